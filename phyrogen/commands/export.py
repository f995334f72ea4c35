"""``phyrogen export``: other formats written into puzzle folders (MJCF)."""

from __future__ import annotations

from phyrogen.options import path_option
from phyrogen.stages import export
from phyrogen_core.stage_records.export import ExportRequest


def add_parser(sub) -> None:
    parser = sub.add_parser("export", help="write other formats into puzzle folders: mjcf -> <folder>/mjcf/<name>.xml")
    parser.add_argument("puzzle_dirs", type=path_option, nargs="+", metavar="PUZZLE_DIR",
                        help="puzzle folder(s), or a folder of generated puzzles (all of them)")
    parser.add_argument("--format", required=True, choices=("mjcf",), help="mjcf: MuJoCo (docs/interop.md)")
    parser.set_defaults(func=run)


def run(args) -> int:
    return export.run(ExportRequest(tuple(args.puzzle_dirs), args.format), on_file=print).exit_code
