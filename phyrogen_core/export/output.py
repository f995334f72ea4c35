"""Puzzle folders, written atomically.

A folder is filled under a temporary, dot-prefixed name beside its final
place and renamed into place only when complete: a reader never sees a
half-written puzzle, and an interrupted run leaves nothing behind.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path, PurePosixPath

from ..puzzle import Puzzle
from .metadata import metadata_json
from .srdf import chain_to_srdf
from .urdf import chain_to_urdf


@contextmanager
def atomic_directory(final: Path) -> Iterator[Path]:
    """Yield an empty temporary folder that becomes ``final`` when the block succeeds.

    The temporary folder is a dot-prefixed sibling of ``final`` (same file
    system, so the rename is atomic). An existing ``final`` folder is first
    renamed aside, then deleted once the new one is in place. If the block
    raises (or is interrupted), the temporary folder is removed and ``final``
    is left as it was. Missing parent folders are created and kept, even on
    failure: removing them could race with another writer using the same parent.
    """
    final = Path(final)
    if final.exists() and not final.is_dir():
        raise FileExistsError(f"{final} exists and is not a folder; remove it or choose another output path")
    final.parent.mkdir(parents=True, exist_ok=True)
    temporary = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent))
    try:
        # mkdtemp makes the folder private (0700); the result should be as readable as its parent.
        os.chmod(temporary, final.parent.stat().st_mode & 0o777)
        yield temporary
        aside = temporary.with_name(temporary.name + ".old")
        moved_aside = False
        if final.exists():
            os.replace(final, aside)
            moved_aside = True
        try:
            os.replace(temporary, final)
        except BaseException:
            if moved_aside:
                os.replace(aside, final)
            raise
        if moved_aside:
            # The new folder is in place: failing to delete the old copy must not undo that.
            shutil.rmtree(aside, ignore_errors=True)
    except BaseException:
        shutil.rmtree(temporary, ignore_errors=True)
        raise


def puzzle_folder(out_root: Path, puzzle: Puzzle) -> Path:
    """Where :func:`write_puzzle` puts ``puzzle``: ``<out_root>/<generator>/<generator>_<seed>``."""
    for part in (puzzle.generator, puzzle.name):
        if not part or part in (".", "..") or "/" in part or "\\" in part or part.startswith("."):
            raise ValueError(f"{part!r} cannot name an output folder; valid names have no slashes "
                             "and do not start with '.'")
    return Path(out_root) / puzzle.generator / puzzle.name


def write_puzzle(puzzle: Puzzle, out_root: Path, versions: Mapping[str, str] | None = None,
                 extra_files: Mapping[str, bytes] | None = None) -> Path:
    """Write the puzzle folder and return its path.

    The folder holds ``urdf/<name>.urdf``, ``srdf/<name>.srdf``,
    ``meshes/*.obj`` (only when the chain has prisms), ``puzzle.json`` and
    ``extra_files`` (relative POSIX path -> bytes, e.g. renders). An existing
    folder for the same puzzle is replaced, atomically.
    """
    final = puzzle_folder(out_root, puzzle)
    extras = {_relative_path(name): data for name, data in (extra_files or {}).items()}
    chain = puzzle.chain
    with atomic_directory(final) as folder:
        urdf_text, meshes = chain_to_urdf(chain)
        _write_file(folder / "urdf" / f"{puzzle.name}.urdf", urdf_text.encode("utf-8"))
        for file_name, text in meshes.items():
            _write_file(folder / "meshes" / file_name, text.encode("utf-8"))
        _write_file(folder / "srdf" / f"{puzzle.name}.srdf", chain_to_srdf(chain).encode("utf-8"))
        _write_file(folder / "puzzle.json", metadata_json(puzzle, versions).encode("utf-8"))
        for relative, data in sorted(extras.items()):
            _write_file(folder / relative, data)
    return final


_RESERVED = ("urdf", "srdf", "meshes", "puzzle.json")


def _relative_path(name: str) -> PurePosixPath:
    path = PurePosixPath(name)
    if not path.parts or path.is_absolute() or ".." in path.parts:
        raise ValueError(f"extra file name {name!r} must be a relative path inside the puzzle folder, "
                         "e.g. 'images/puzzle_00.png'")
    if path.parts[0] in _RESERVED:
        raise ValueError(f"extra file name {name!r} would overwrite the puzzle's own files; "
                         f"valid names start with anything but {', '.join(_RESERVED)}")
    return path


def _write_file(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
