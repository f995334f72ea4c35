"""The replan stage: a new certificate for a puzzle folder as it is now (RRT-Connect, else LA-RRT)."""

from __future__ import annotations

from pathlib import Path

from phyrogen.options import MAX_BENCHMARK_SEED
from phyrogen.stage_checks import check_within
from phyrogen_core.stage_records.replan import ReplanRequest, ReplanResult

PLANNER_TITLES = {"rrt_connect": "RRT-Connect", "la_rrt_push": "LA-RRT+push"}


def run(request: ReplanRequest) -> ReplanResult:
    """Find a new certificate and store it in the folder's puzzle.json; not solved within the budget, the
    folder is left as it was."""
    from phyrogen_core.export import read_puzzle_dir
    from solver.pipelines.replanning import (
        MAX_REPLAN_BUDGET,
        REPLAN_BUDGET,
        check_replan_folder,
        replan,
        write_replanned,
    )

    check_within("budget", request.budget, 1, MAX_REPLAN_BUDGET, " collision queries")
    check_within("seed", request.seed, 0, MAX_BENCHMARK_SEED)
    folder = Path(request.folder)
    loaded = read_puzzle_dir(folder)  # bad input is found before any work
    check_replan_folder(folder, loaded.name)
    found = replan(loaded, REPLAN_BUDGET if request.budget is None else request.budget, request.seed)
    if not found.solved:
        return ReplanResult(puzzle=loaded.name, folder=str(folder), solved=False, budget=found.budget,
                            seed=request.seed, planner=None, queries=None, states=None, dependencies=None, notices=())
    notices: list[str] = []
    write_replanned(folder, loaded, found, notices)
    return ReplanResult(puzzle=loaded.name, folder=str(folder), solved=True, budget=found.budget, seed=request.seed,
                        planner=PLANNER_TITLES[found.planner], queries=found.queries, states=len(found.certificate),
                        dependencies=len(found.dependencies), notices=tuple(notices))
