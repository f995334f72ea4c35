"""The export stage: other formats written into puzzle folders (MJCF)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from phyrogen_core.stage_records.export import ExportRequest, ExportResult


def run(request: ExportRequest, *, on_file: Callable[[str], None] | None = None) -> ExportResult:
    """Write each puzzle's ``format`` into its folder; ``on_file`` gets each file as it is written."""
    from phyrogen_core.export import chain_to_mjcf, read_puzzle_dir, write_mjcf
    from phyrogen_core.export.mjcf import check_mjcf_target
    from phyrogen_core.folder import PuzzleFolder, find_in_paths

    # Every folder is read, converted and checked writable before the first file is written:
    # bad input (a missing folder, a malformed puzzle) leaves every folder as it was.
    folders = [f.path if isinstance(f, PuzzleFolder) else Path(f) for f in find_in_paths(list(request.folders))]
    puzzles = []
    for folder in folders:
        loaded = read_puzzle_dir(folder)
        chain_to_mjcf(loaded.chain, loaded.certificate)
        check_mjcf_target(folder, loaded.name)  # a link, or a user's file of the name, is refused
        puzzles.append((folder, loaded))
    files = []
    for folder, loaded in puzzles:
        files.append(str(write_mjcf(folder, loaded.chain, loaded.name, loaded.certificate)))
        if on_file is not None:
            on_file(files[-1])
    return ExportResult(files=tuple(files))
