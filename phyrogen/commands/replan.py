"""``phyrogen replan``: a new certificate for a puzzle folder as it is now (RRT-Connect, else LA-RRT)."""

from __future__ import annotations

import sys

from phyrogen.json_output import add_json_option
from phyrogen.options import benchmark_seed_option, path_option, whole_number
from phyrogen.stages import replan
from phyrogen_core.stage_records.replan import ReplanRequest


def add_parser(sub) -> None:
    parser = sub.add_parser("replan", help="find a new certificate for a puzzle folder as it is now (e.g. edited "
                                           "in Blender) with OMPL's RRT-Connect (else LA-RRT) and store it in "
                                           "puzzle.json")
    parser.add_argument("puzzle_dir", type=path_option)
    parser.add_argument("--budget", type=replan_budget_option,
                        help="collision queries each planner may spend (default 100000)")
    parser.add_argument("--seed", type=benchmark_seed_option, default=0, help="seed of the search (default 0)")
    add_json_option(parser, "solved, planner, queries, states, dependencies")
    parser.set_defaults(func=run)


def run(args) -> int:
    result = replan.run(ReplanRequest(args.puzzle_dir, args.budget, args.seed))
    args.json_result = result
    if not result.solved:
        print(f"phyrogen: error: {result.puzzle}: not solved by RRT-Connect nor LA-RRT within {result.budget} "
              f"collision queries each (seed {result.seed}); the folder is unchanged (a larger --budget may solve "
              "it)", file=sys.stderr)
        return result.exit_code
    for notice in result.notices:
        print(f"phyrogen: note: {notice}", file=sys.stderr)
    print(f"{result.puzzle}: new certificate by {result.planner} in {result.queries} collision queries: "
          f"{result.states} states, {result.dependencies} dependencies")
    return result.exit_code


def replan_budget_option(text: str) -> int:
    from solver.pipelines.replanning import MAX_REPLAN_BUDGET

    return whole_number(text, 1, MAX_REPLAN_BUDGET, " collision queries")
