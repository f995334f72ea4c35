"""``phyrogen import``: a planar puzzle from a URDF file, certified by LA-RRT, as a puzzle folder (docs/import.md)."""

from __future__ import annotations

import argparse
import math
import sys

from phyrogen.options import benchmark_seed_option, path_option, whole_number
from phyrogen.stages import import_urdf
from phyrogen_core.stage_records.import_urdf import ImportRequest


def add_parser(sub) -> None:
    imp = sub.add_parser("import", help="import a planar puzzle from a URDF file as a certified puzzle folder "
                                        "(docs/import.md)")
    imp.add_argument("urdf", type=path_option, metavar="URDF",
                     help="the URDF file; meshes: STL (binary or ASCII) or OBJ")
    imp.add_argument("--out", type=path_option, default="output",
                     help="output folder; the puzzle goes to OUT/imported/NAME (default: output)")
    imp.add_argument("--name", help="the puzzle's name (default: the URDF's robot name)")
    imp.add_argument("--target", help="the target: a URDF joint or link (default: the object that fits the link "
                                      "named 'goal')")
    imp.add_argument("--goal", type=goal_values_option, metavar="VALUE[,VALUE...]",
                     help="the target's goal in URDF joint values: one for a joint, one per joint (from the world "
                          "outwards) for a link; needs --target (default: read from the link named 'goal')")
    imp.add_argument("--budget", type=import_budget_option,
                     help="collision queries LA-RRT may spend to certify the puzzle (default 100000)")
    imp.add_argument("--seed", type=benchmark_seed_option, default=0, help="seed of the certifying search (default 0)")
    imp.set_defaults(func=run)


def run(args) -> int:
    request = ImportRequest(args.urdf, args.out, args.name, args.target,
                            None if args.goal is None else tuple(args.goal), args.budget, args.seed)
    result = import_urdf.run(request, on_note=lambda note: print(f"phyrogen: note: {note}", file=sys.stderr))
    if not result.solved:
        print(f"phyrogen: error: {result.puzzle}: not solved by LA-RRT within {result.budget} collision queries "
              f"(seed {result.seed}); nothing written (a larger --budget may solve it, or the goal is wrong)",
              file=sys.stderr)
        return result.exit_code
    for notice in result.notices:
        print(f"phyrogen: note: {notice}", file=sys.stderr)
    print(f"{result.folder}: {result.movable} movable and {result.static} static objects, {result.joints} joints, "
          f"goal from the {result.goal_source} (target {result.target}); certified by LA-RRT in "
          f"{result.queries} collision queries: {result.states} states, {result.actions} actions")
    return result.exit_code


def goal_values_option(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"must be comma-separated finite numbers (joint values), got {text!r}")
    return values


def import_budget_option(text: str) -> int:
    from solver.pipelines.importing import MAX_IMPORT_BUDGET

    return whole_number(text, 1, MAX_IMPORT_BUDGET, " collision queries")
