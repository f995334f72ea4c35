"""Where the executed solution comes from by default: the lowest-cost LA-RRT solution.

The paper executes the benchmark's lowest-cost LA-RRT solution. A puzzle folder that holds none
(``solutions/la_rrt_best.json``, which ``phyrogen benchmark`` writes) gets its paths here from the
solve stage (:func:`solver.planning.solve.solve`), in memory: the paper's LA-RRT, a few seeded runs,
each ended by a budget of collision checks (not seconds), so the same puzzle gets the same paths on
any machine; each run is seeded as the benchmark's run of the same index, so it finds the path that
run would. Nothing is written into the puzzle folder (``solutions/`` is the benchmark's alone). The
solved runs are tried as a benchmark's runs are (:func:`~manipulation.solution.candidate_solutions`:
those of the least action cost, shortest first, then the certificate), each checked at 2 mm before
physics (:func:`~manipulation.solution.solution_problems`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from phyrogen_core.export import LoadedPuzzle
from phyrogen_core.folder_layout import BEST_SOLUTION

from .solution import BenchmarkRun


@dataclass(frozen=True)
class ShortBenchmark:
    planners: tuple[str, ...] = ("la_rrt",)
    """The paper's LA-RRT (``la_rrt_push``, ours, may be added)."""
    runs: int = 3
    budget_checks: int = 2_000_000
    """Collision checks per run, a motion charged by its length in resolution steps (the benchmark's
    unit): LA-RRT's anytime search stops there, after about a CPU second. The default was 20,000 while a
    motion counted once; in states that left the paper's LA-RRT without a solution or with a costly one
    on most paper puzzles (seeds 1-2 of the six generators: 12 of 36 runs unsolved, costs up to 31
    actions), where 2,000,000 solves every run but Lockbox Random's at the least cost found before."""


def solved_runs(folder: Path, loaded: LoadedPuzzle, benchmark: ShortBenchmark) -> tuple[BenchmarkRun, ...]:
    """The solved runs of ``benchmark`` on ``loaded`` (the puzzle in ``folder``), run by run in this
    process; none when the folder holds a best solution already (the benchmark's, which is tried)."""
    from solver.planning.solve import solve

    if os.path.lexists(Path(folder) / BEST_SOLUTION):
        return ()
    solved = (solve(loaded, planner, benchmark.budget_checks, run)
              for run in range(benchmark.runs) for planner in benchmark.planners)
    return tuple(BenchmarkRun(s.title, s.run, s.joint_order, s.path) for s in solved if s.solved)
