"""``phyrogen check``: a puzzle folder's certificate checked again at fine resolution."""

from __future__ import annotations

from pathlib import Path

from phyrogen.options import path_option
from phyrogen.stage_checks import certificate_problems


def add_parser(sub) -> None:
    check = sub.add_parser("check", help="re-validate an exported puzzle folder")
    check.add_argument("puzzle_dir", type=path_option)
    check.set_defaults(func=run)


def run(args) -> int:
    from phyrogen_core.export import read_puzzle_dir

    loaded = read_puzzle_dir(Path(args.puzzle_dir))
    problems = certificate_problems(loaded)
    name = loaded.name
    # An edited puzzle (the Blender panel's Export) keeps its old certificate, marked as not verified for it.
    edited = not loaded.record.certificate_verified
    note = " (found for the puzzle before it was edited)" if edited else ""
    if problems:
        print(f"{name}: INVALID{note}: " + "; ".join(problems))
        return 1
    print(f"{name}: certificate valid{note} ({len(loaded.certificate)} states, checked at fine resolution)")
    return 0
