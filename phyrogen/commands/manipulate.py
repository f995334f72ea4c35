"""``phyrogen manipulate``: puzzles' solutions executed by a mobile KUKA iiwa in PyBullet."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
from pathlib import Path

from phyrogen.json_output import add_json_option
from phyrogen.options import add_quiet_option, path_option
from phyrogen_core.folder import PuzzleFolder, find_in_paths


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
    from manipulation.batch import manipulate_folders

    folders = [f.path if isinstance(f, PuzzleFolder) else f for f in find_in_paths(args.puzzle_dirs)]
    runs = benchmark_runs(Path(args.benchmark), folders) if args.benchmark else None
    from manipulation.execution import ExecutionSettings

    reports = manipulate_folders(folders, Path(args.out), video=not args.no_video,
                                 table=Path(args.table) if args.table else None, gui=args.gui, quiet=args.quiet,
                                 settings=ExecutionSettings(scale=args.scale), runs=runs)
    args.json_result = {"command": "manipulate", "out": str(Path(args.out)),
                        "reports": [{**dataclasses.asdict(r), "folder": str(Path(args.out) / r.puzzle)}
                                    for r in reports]}
    return 0 if all(r.success for r in reports) else 1


MAX_SCENE_SCALE = 2.0
MIN_SCENE_SCALE = 0.05
"""``manipulate --scale``: below it every object's 5 cm knob is under 2.5 mm wide, less than the
gripper closes on (docs/manipulation/README.md#physical-scale); 1e-300 made the physics fail."""


def scene_scale_option(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and MIN_SCENE_SCALE <= value <= MAX_SCENE_SCALE):
        raise argparse.ArgumentTypeError(f"must be a number from {MIN_SCENE_SCALE:g} to {MAX_SCENE_SCALE:g} (scene "
                                         f"metres per puzzle metre), got {text!r}")
    return value


def benchmark_runs(benchmark: Path, folders: list[Path]) -> dict[Path, list]:
    """Per puzzle folder, the solved LA-RRT runs of ``benchmark``'s journal on that very puzzle (its
    name and the digest of its files), for the manipulation stage. Glue here, at the top: the
    journal's reader lives in the solver beside OMPL, which manipulation may not import."""
    from manipulation.solution import BenchmarkRun
    from phyrogen_core.export import read_puzzle_dir
    from phyrogen_core.folder import OutputError
    from solver.benchmark.runner import JOURNAL, puzzle_digest, read_journal
    from solver.planning.registry import LA_RRT_PLANNERS

    journal = benchmark / JOURNAL
    if not os.path.lexists(journal):
        raise OutputError(f"benchmark folder {benchmark} has no {JOURNAL}; name the folder a benchmark wrote "
                          "(its --out)")
    records = [(json.loads(key), record) for key, record in read_journal(journal).items()]
    out: dict[Path, list] = {}
    for folder in folders:
        name = read_puzzle_dir(folder).name
        digest = puzzle_digest(PuzzleFolder(Path(folder), name))
        out[Path(folder)] = [BenchmarkRun(r.planner, r.run, tuple(r.joint_order), tuple(r.path))
                             for key, r in records
                             if key.get("planner") in LA_RRT_PLANNERS and r.solved and len(r.path) >= 2
                             and r.puzzle == name and key.get("puzzle_sha256") == digest]
    return out
