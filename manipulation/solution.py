"""The solutions the robot may execute, in the order they are tried.

The preferred input is the lowest-cost LA-RRT solution stored beside the
puzzle (``solutions/la_rrt_best.json``: ``joint_order`` and ``path``); a
puzzle without one falls back to its certificate from ``puzzle.json``
(:func:`load_solution`). The cheapest path is not always executable (the
robot may find no grasp or no motion where it leaves an object), so
:func:`candidate_solutions` lists every solution of the least action cost the
benchmark found (the best-solution file and every LA-RRT run of the
benchmark's journal on the same puzzle that reached that cost), then the
clean certificate. Before any of them reaches physics, :func:`solution_problems` checks it as
``phyrogen check`` checks a certificate (start, limits, collisions at 2 mm, goal): the robot never
executes a path our own model refutes. Any path is split into single-object actions by
:func:`phyrogen_core.actions.split_actions`, the rule the planners count actions by:
a segment that moves several objects becomes one move per object (in factor
order), and consecutive moves of the same object form one action.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from phyrogen_core.actions import count_actions
from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.export import LoadedPuzzle
from phyrogen_core.folder_layout import BEST_SOLUTION
from phyrogen_core.solution_file import SolutionFile, read_solution_file

CERTIFICATE = "certificate"


@dataclass(frozen=True)
class Solution:
    path: np.ndarray
    source: str
    """Where the path came from: the solution file's path, or ``certificate``."""
    label: str = CERTIFICATE
    """What a report calls it: ``certificate``, ``benchmark best: <planner> run <n>`` (the
    solution file) or ``benchmark: <planner> run <n>`` (a run of the benchmark's journal)."""


@dataclass(frozen=True)
class BenchmarkRun:
    """A solved LA-RRT run of the benchmark on this very puzzle: what is needed to execute its path.

    The caller reads them from the benchmark's journal and matches them to the puzzle (its name and
    the digest of its files: a run on an earlier version of the puzzle is no solution of this one);
    the solver's journal reader imports OMPL, which this layer leaves to the reaching planner."""

    planner: str
    """The planner's title, as the benchmark's reports print it."""
    run: int
    joint_order: tuple[str, ...]
    path: tuple[tuple[float, ...], ...]


def candidate_solutions(folder: Path, loaded: LoadedPuzzle,
                        runs: Iterable[BenchmarkRun] = ()) -> list[Solution]:
    """The solutions to try on the puzzle in ``folder``, in order.

    First every benchmark solution of the least action cost: the best-solution
    file (when it is one of them), then the benchmark's ``runs`` on this puzzle,
    shortest first. Then the certificate (when it has a path). A path equal to
    one listed earlier is not listed again. Raises
    :class:`~phyrogen_core.folder.PuzzleFormatError` as :func:`load_solution`.
    """
    folder = Path(folder)
    factors = {name: cols for name, cols in loaded.chain.factors.items() if name != "goal"}
    best = load_solution(folder, loaded.joint_order, loaded.certificate)
    benchmark: list[Solution] = [] if best.source == CERTIFICATE else [best]
    ordered = sorted(runs, key=lambda r: (_length(r.path), r.planner, r.run))
    benchmark += [_from_run(r, loaded.joint_order) for r in ordered]
    if benchmark:
        least = min(count_actions(s.path, factors) for s in benchmark)
        benchmark = [s for s in benchmark if count_actions(s.path, factors) == least]
    if not benchmark or len(loaded.certificate) >= 2:
        benchmark.append(_certificate(folder, loaded.certificate))
    out: list[Solution] = []
    for solution in benchmark:
        if not any(np.array_equal(solution.path, other.path) for other in out):
            out.append(solution)
    return out


def solution_problems(loaded: LoadedPuzzle, solution: Solution) -> list[str]:
    """What is wrong with ``solution`` as a path of the puzzle (empty when nothing is): the check
    ``phyrogen check`` applies to a certificate (:func:`solver.planning.problem.verify_certificate`:
    it starts at the puzzle's start, stays within the limits and free of collisions at
    :data:`~solver.planning.problem.FINE_RESOLUTION`, 2 mm, and ends in the goal), its problems
    worded for a solution rather than a certificate."""
    from solver.planning.problem import FINE_RESOLUTION, verify_certificate

    problems = verify_certificate(loaded.chain, solution.path, loaded.goal, FINE_RESOLUTION, start=loaded.start)
    return [problem.replace("certificate", "path") for problem in problems]


def load_solution(folder: Path, joint_order: Sequence[str], certificate: Sequence[Sequence[float]]) -> Solution:
    """The LA-RRT best solution of the puzzle in ``folder`` if there is one, else its certificate.

    The solution file is read by its one strict reader
    (:func:`phyrogen_core.solution_file.read_solution_file`: the puzzle folder's rule, then the
    format's: a path of 2 to :data:`~phyrogen_core.sizes.MAX_CERTIFICATE_STATES` states of finite
    joint values within ``MAX_MAGNITUDE``), and its joints must be the puzzle's. Raises
    :class:`~phyrogen_core.errors.PuzzleFormatError` naming the file and the field.
    """
    folder = Path(folder)
    file = folder / BEST_SOLUTION
    if not os.path.lexists(file):
        return _certificate(folder, certificate)
    solution = read_solution_file(file, folder)
    return Solution(solution.path_in(joint_order, str(file)), str(file), "benchmark best: " + solution.run_name)


def _certificate(folder: Path, certificate: Sequence[Sequence[float]]) -> Solution:
    if len(certificate) < 2:
        raise ValueError(f"{folder}: no {BEST_SOLUTION} and the certificate has {len(certificate)} states; "
                         "a path needs at least 2")
    path = np.asarray(certificate, dtype=float)
    if not np.isfinite(path).all():
        raise PuzzleFormatError(f"{folder}: the certificate holds a value that is not a finite number")
    return Solution(path, CERTIFICATE, CERTIFICATE)


def _from_run(run: BenchmarkRun, joint_order: Sequence[str]) -> Solution:
    label = f"benchmark: {run.planner} run {run.run}"
    where = f"journal run ({label})"
    data = {"joint_order": list(run.joint_order), "path": [list(state) for state in run.path]}
    return Solution(SolutionFile.from_data(data, where).path_in(joint_order, where), "journal", label)


def _length(path: Sequence[Sequence[float]]) -> float:
    return float(np.linalg.norm(np.diff(np.asarray(path, dtype=float), axis=0), axis=1).sum())
