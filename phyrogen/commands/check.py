"""``phyrogen check``: a puzzle folder's certificate checked again at fine resolution."""

from __future__ import annotations

from phyrogen.options import path_option
from phyrogen.stages import check
from phyrogen_core.stage_records.check import CheckRequest


def add_parser(sub) -> None:
    parser = sub.add_parser("check", help="re-validate an exported puzzle folder")
    parser.add_argument("puzzle_dir", type=path_option)
    parser.set_defaults(func=run)


def run(args) -> int:
    result = check.run(CheckRequest(args.puzzle_dir))
    note = " (found for the puzzle before it was edited)" if result.edited else ""
    if result.problems:
        print(f"{result.puzzle}: INVALID{note}: " + "; ".join(result.problems))
    else:
        print(f"{result.puzzle}: certificate valid{note} ({result.states} states, checked at fine resolution)")
    return result.exit_code
