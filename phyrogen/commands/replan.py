"""``phyrogen replan``: a new certificate for a puzzle folder as it is now (RRT-Connect, else LA-RRT)."""

from __future__ import annotations

import sys
from pathlib import Path

from phyrogen.json_output import add_json_option
from phyrogen.options import benchmark_seed_option, path_option, whole_number


def add_parser(sub) -> None:
    replan = sub.add_parser("replan", help="find a new certificate for a puzzle folder as it is now (e.g. edited "
                                           "in Blender) with OMPL's RRT-Connect (else LA-RRT) and store it in "
                                           "puzzle.json")
    replan.add_argument("puzzle_dir", type=path_option)
    replan.add_argument("--budget", type=replan_budget_option,
                        help="collision queries each planner may spend (default 100000)")
    replan.add_argument("--seed", type=benchmark_seed_option, default=0, help="seed of the search (default 0)")
    add_json_option(replan, "solved, planner, queries, states, dependencies")
    replan.set_defaults(func=run)


def run(args) -> int:
    from phyrogen_core.export import read_puzzle_dir
    from solver.pipelines.replanning import REPLAN_BUDGET, check_replan_folder, replan, write_replanned

    folder = Path(args.puzzle_dir)
    loaded = read_puzzle_dir(folder)  # bad input is found before any work
    check_replan_folder(folder, loaded.name)
    name = loaded.name
    result = replan(loaded, REPLAN_BUDGET if args.budget is None else args.budget, args.seed)
    args.json_result = {"command": "replan", "puzzle": name, "folder": str(folder), "solved": result.solved,
                        "budget": result.budget, "seed": args.seed}
    if not result.solved:
        print(f"phyrogen: error: {name}: not solved by RRT-Connect nor LA-RRT within {result.budget} collision "
              f"queries each (seed {args.seed}); the folder is unchanged (a larger --budget may solve it)",
              file=sys.stderr)
        return 1
    notices: list[str] = []
    write_replanned(folder, loaded, result, notices)
    for notice in notices:
        print(f"phyrogen: note: {notice}", file=sys.stderr)
    planner = {"rrt_connect": "RRT-Connect", "la_rrt_push": "LA-RRT+push"}[result.planner]
    args.json_result.update(planner=planner, queries=result.queries, states=len(result.certificate),
                            dependencies=len(result.dependencies), notices=notices)
    print(f"{name}: new certificate by {planner} in {result.queries} collision queries: "
          f"{len(result.certificate)} states, {len(result.dependencies)} dependencies")
    return 0


def replan_budget_option(text: str) -> int:
    from solver.pipelines.replanning import MAX_REPLAN_BUDGET

    return whole_number(text, 1, MAX_REPLAN_BUDGET, " collision queries")
