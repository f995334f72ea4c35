"""``phyrogen export``: other formats written into puzzle folders (MJCF)."""

from __future__ import annotations

from pathlib import Path

from phyrogen.options import path_option
from phyrogen_core.folder import PuzzleFolder, find_in_paths


def add_parser(sub) -> None:
    export = sub.add_parser("export", help="write other formats into puzzle folders: mjcf -> <folder>/mjcf/<name>.xml")
    export.add_argument("puzzle_dirs", type=path_option, nargs="+", metavar="PUZZLE_DIR",
                        help="puzzle folder(s), or a folder of generated puzzles (all of them)")
    export.add_argument("--format", required=True, choices=("mjcf",), help="mjcf: MuJoCo (docs/interop.md)")
    export.set_defaults(func=run)


def run(args) -> int:
    from phyrogen_core.export import chain_to_mjcf, read_puzzle_dir, write_mjcf
    from phyrogen_core.export.mjcf import check_mjcf_target

    # Every folder is read, converted and checked writable before the first file is written:
    # bad input (a missing folder, a malformed puzzle) leaves every folder as it was.
    folders = [f.path if isinstance(f, PuzzleFolder) else Path(f) for f in find_in_paths(args.puzzle_dirs)]
    puzzles = []
    for folder in folders:
        loaded = read_puzzle_dir(folder)
        chain_to_mjcf(loaded.chain, loaded.certificate)
        check_mjcf_target(folder, loaded.name)  # a link, or a user's file of the name, is refused
        puzzles.append((folder, loaded))
    for folder, loaded in puzzles:
        print(write_mjcf(folder, loaded.chain, loaded.name, loaded.certificate))
    return 0
