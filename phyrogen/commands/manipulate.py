"""``phyrogen manipulate``: puzzles' solutions executed by a mobile KUKA iiwa in PyBullet."""

from __future__ import annotations

import argparse
import math

from phyrogen.json_output import add_json_option
from phyrogen.options import add_quiet_option, path_option
from phyrogen.stages import manipulate
from phyrogen.stages.manipulate import MAX_SCENE_SCALE, MIN_SCENE_SCALE
from phyrogen_core.stage_records.manipulate import ManipulateRequest


def add_parser(sub) -> None:
    manipulate = sub.add_parser("manipulate", help="execute puzzles' solutions with a mobile KUKA iiwa in PyBullet")
    manipulate.add_argument("puzzle_dirs", type=path_option, nargs="+", metavar="PUZZLE_DIR",
                            help="puzzle folder(s), or a folder of generated puzzles (all of them)")
    manipulate.add_argument("--out", type=path_option, default="output/manipulation",
                            help="output folder (default: output/manipulation)")
    manipulate.add_argument("--no-video", action="store_true", help="frames and report only")
    manipulate.add_argument("--table", type=path_option, metavar="FILE",
                            help="also write a Markdown summary table here")
    manipulate.add_argument("--scale", type=scene_scale_option,
                            help="scene metres per puzzle metre, 0.05..2, for every puzzle (default: each generator's "
                                 "physical scale, docs/manipulation/README.md#physical-scale)")
    manipulate.add_argument("--gui", action="store_true", help="show the simulation in a PyBullet window")
    add_quiet_option(manipulate)
    manipulate.add_argument("--benchmark", type=path_option, metavar="DIR",
                            help="a benchmark's output folder: every least-cost LA-RRT solution in its journal is "
                                 "tried, then the certificate (default: the puzzle's best solution, then the "
                                 "certificate)")
    add_json_option(manipulate, "each puzzle's report.json and its output folder")
    manipulate.set_defaults(func=run)


def run(args) -> int:
    request = ManipulateRequest(tuple(args.puzzle_dirs), args.out, not args.no_video, args.table, args.scale, args.gui,
                                not args.quiet, args.benchmark)
    args.json_result = manipulate.run(request)
    return args.json_result.exit_code




def scene_scale_option(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and MIN_SCENE_SCALE <= value <= MAX_SCENE_SCALE):
        raise argparse.ArgumentTypeError(f"must be a number from {MIN_SCENE_SCALE:g} to {MAX_SCENE_SCALE:g} (scene "
                                         f"metres per puzzle metre), got {text!r}")
    return value
