"""The export stage of a puzzle folder (:mod:`phyrogen_core.folder`), written atomically.

The export entries are filled under a temporary, dot-prefixed folder beside
the final place and swapped in only when complete: a reader never sees a
half-written puzzle, and an interrupted run leaves nothing behind.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from ..chain import KinematicChain
from ..folder import PuzzleFolder
from ..folder_ownership import Stage
from ..puzzle import Puzzle
from ..stage_writes import stage_directory
from .metadata import metadata_json
from .srdf import chain_to_srdf
from .urdf import chain_to_urdf


def puzzle_folder(out_root: Path, puzzle: Puzzle) -> Path:
    """Where :func:`write_puzzle` puts ``puzzle``: ``<out_root>/<generator>/<generator>_<seed>``."""
    return PuzzleFolder.at(out_root, puzzle.generator, puzzle.name).path


def write_puzzle(puzzle: Puzzle, out_root: Path, versions: Mapping[str, str] | None = None,
                 notices: list[str] | None = None) -> Path:
    """Write the puzzle's export entries into its folder and return the folder's path.

    The export stage owns ``urdf/<name>.urdf``, ``srdf/<name>.srdf``,
    ``meshes/*.obj`` (only when the chain has prisms) and ``puzzle.json``;
    they are replaced as a whole, atomically. Every other entry of an
    existing folder (renders, solutions, a user's files) is kept, except that
    renders and solutions of a different earlier puzzle move into
    ``stale/<n>/`` with it, and a line saying so is appended to ``notices``
    (:func:`~phyrogen_core.folder.stage_directory`).
    """
    place = PuzzleFolder.at(out_root, puzzle.generator, puzzle.name)
    with stage_directory(place.path, Stage.EXPORT, puzzle.name, notices) as folder:
        chain = puzzle.chain  # built once for both
        write_export_files(PuzzleFolder(folder, puzzle.name), chain, metadata_json(puzzle, versions, chain=chain))
    return place.path


def write_export_files(folder: PuzzleFolder, chain: KinematicChain, metadata: str) -> None:
    """The export stage's files of ``chain`` into ``folder`` (a fresh temporary folder)."""
    urdf_text, meshes = chain_to_urdf(chain)
    _write_file(folder.urdf, urdf_text.encode("utf-8"))
    if meshes:  # one folder for them all, made once (Lockbox Random: 18 meshes a puzzle)
        folder.meshes.mkdir(parents=True, exist_ok=True)
        for file_name, text in meshes.items():
            (folder.meshes / file_name).write_bytes(text.encode("utf-8"))
    _write_file(folder.srdf, chain_to_srdf(chain).encode("utf-8"))
    _write_file(folder.metadata, metadata.encode("utf-8"))


def _write_file(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
