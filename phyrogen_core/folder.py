"""The puzzle folder: its layout, which stage owns which entry, finding folders, writing a stage's files.

A puzzle lives in one folder, ``<out>/<generator>/<name>/``::

    urdf/<name>.urdf, srdf/<name>.srdf, meshes/, puzzle.json     export (generate, the panel's Export)
    solutions/                                                    benchmark (planner solutions)
    images/, <name>.blend                                         render
    mjcf/, phobos/                                                interop (MJCF; the add-on's Export with Phobos)
    stale/<n>/                                                    export, when the puzzle changed

Every stage writes only the files it owns, by exact name
(:mod:`~phyrogen_core.folder_ownership`), and keeps every other entry, another stage's or a
user's file, even one inside a folder the stage writes, as it was; only renders and solutions
of a puzzle that was regenerated differently move, into ``stale/<n>/`` beside it, with the
puzzle they were made for (:mod:`~phyrogen_core.stage_writes`). No stage writes through a
symbolic link, and every write is swapped in whole (:mod:`~phyrogen_core.atomic_writes`); a
reader refuses a file outside the folder, a FIFO or device, or an oversized file
(:mod:`~phyrogen_core.folder_reads`). The fixed names live in :mod:`~phyrogen_core.folder_layout`.

This module is the folder itself: other layers ask a :class:`PuzzleFolder` for paths and
:func:`find_puzzle_folders` for folders. It also re-exports the names of the modules above, where
they were imported from before they had modules of their own.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from .atomic_writes import (
    OutputError,
    atomic_directory,
    atomic_file,
    require_stage_folder,
    require_writable_dir,
    temporary_entry,
    write_file_atomic,
)
from .errors import PuzzleFormatError
from .folder_layout import (
    BEST_SOLUTION,
    DATASET_FILE,
    MAX_NAME_LENGTH,
    METADATA_FILE,
    SHARD_PREFIX,
    STALE_FOLDER,
    name_problem,
    shard_name,
)
from .folder_ownership import Stage, derived_stages, owned_files, phobos_owns, stage_entries, stage_owns
from .folder_reads import (
    MAX_FILE_BYTES,
    read_folder_file,
    read_folder_json,
    require_folder_file,
    require_no_escapes,
    require_self_contained,
)
from .record import folder_identity
from .stage_writes import carry_others, owned_directory, same_stage_entries, stage_directory

__all__ = [
    "BEST_SOLUTION", "DATASET_FILE", "MAX_FILE_BYTES", "MAX_NAME_LENGTH", "METADATA_FILE", "SHARD_PREFIX",
    "STALE_FOLDER", "OutputError", "PuzzleFolder", "PuzzleFormatError", "Stage", "atomic_directory",
    "atomic_file", "carry_others", "derived_stages", "find_in_paths", "find_puzzle_folders", "name_problem",
    "owned_directory", "owned_files", "phobos_owns", "read_folder_file", "read_folder_json",
    "require_folder_file", "require_no_escapes", "require_self_contained", "require_stage_folder",
    "require_writable_dir", "same_stage_entries", "shard_name", "stage_directory", "stage_entries", "stage_owns",
    "temporary_entry", "write_file_atomic",
]
"""The folder's names where they have always been imported from; each lives in the module named for it."""


@dataclass(frozen=True)
class PuzzleFolder:
    """Where everything of one puzzle lives; ``name`` names the files inside."""

    path: Path
    name: str
    generator: str = ""
    seed: int = 0
    """The seed its ``puzzle.json`` states (:meth:`open`), for ordering folders; 0 when not read yet."""

    @classmethod
    def at(cls, out_root: str | Path, generator: str, name: str) -> PuzzleFolder:
        """The folder of puzzle ``name`` under an output root: ``<out_root>/<generator>/<name>``."""
        for part in (generator, name):
            problem = name_problem(part)
            if problem is not None:
                raise ValueError(f"{part!r} cannot name a puzzle folder: it {problem}")
        return cls(Path(out_root) / generator / name, name, generator)

    @classmethod
    def open(cls, path: str | Path) -> PuzzleFolder:
        """An existing puzzle folder; its name and generator come from its ``puzzle.json``.

        Raises FileNotFoundError when ``path`` holds no ``puzzle.json`` and
        :class:`PuzzleFormatError` (a ValueError) when that file breaks
        :func:`read_folder_json`'s rule or is not a JSON object whose ``name``
        keeps :func:`name_problem`'s rule.
        """
        path = Path(path)
        metadata_file = path / METADATA_FILE
        if not os.path.lexists(metadata_file):
            raise FileNotFoundError(f"{path}: not a puzzle folder (no {METADATA_FILE})")
        data = read_folder_json(metadata_file, path, f"{metadata_file}: {METADATA_FILE}")
        if not isinstance(data, dict):
            raise PuzzleFormatError(f"{metadata_file}: expected a JSON object with a string 'name'")
        name, generator, seed = folder_identity(data, path.name, path.parent.name)
        problem = name_problem(name)
        if problem is not None:
            raise PuzzleFormatError(f"{metadata_file}: name {name!r} {problem}")
        require_no_escapes(path, name=name)
        return cls(path, name, str(generator), seed if isinstance(seed, int) and not isinstance(seed, bool) else 0)

    @property
    def metadata(self) -> Path:
        return self.path / METADATA_FILE

    @property
    def urdf(self) -> Path:
        return self.path / "urdf" / f"{self.name}.urdf"

    @property
    def srdf(self) -> Path:
        return self.path / "srdf" / f"{self.name}.srdf"

    @property
    def meshes(self) -> Path:
        return self.path / "meshes"

    @property
    def solutions(self) -> Path:
        return self.path / "solutions"

    @property
    def best_solution(self) -> Path:
        return self.path / BEST_SOLUTION

    @property
    def images(self) -> Path:
        return self.path / "images"

    @property
    def blend(self) -> Path:
        return self.path / f"{self.name}.blend"


def find_puzzle_folders(root: str | Path, generators: Iterable[str] | None = None) -> list[PuzzleFolder]:
    """The puzzle folders ``root`` stands for, in a stable order.

    ``root`` is either one puzzle folder (it holds ``puzzle.json``), a
    folder of generated puzzles (``<root>/<generator>/<name>/puzzle.json``)
    or a dataset root (it holds :data:`DATASET_FILE`; its puzzles are
    ``<root>/shard-<n>/<generator>/<name>/puzzle.json``);
    folders being written (dot-prefixed temporary names) are skipped. The
    order is the registry's generator order, then seed, then name. Raises
    FileNotFoundError when ``root`` is missing or holds no puzzle (of
    ``generators``, when given).
    """
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: no such folder of puzzles (make one with `phyrogen generate --out {root}`)")
    pattern = f"{SHARD_PREFIX}*/*/*/{METADATA_FILE}" if (root / DATASET_FILE).is_file() else f"*/*/{METADATA_FILE}"
    if (root / METADATA_FILE).is_file():
        found = [PuzzleFolder.open(root)]
    else:
        found = [PuzzleFolder.open(meta.parent) for meta in sorted(root.glob(pattern))
                 if not meta.parent.name.startswith(".") and not meta.parent.parent.name.startswith(".")]
    wanted = None if generators is None else set(generators)
    found = [f for f in found if wanted is None or f.generator in wanted]
    if not found:
        raise FileNotFoundError(f"{root}: no puzzle folders ({pattern})"
                                + (f" of generators {sorted(wanted)}" if wanted else ""))
    from .registry import all_generators

    order = {name: i for i, name in enumerate(all_generators())}
    return sorted(found, key=lambda f: (order.get(f.generator, len(order)), f.generator, f.seed, f.name))


def find_in_paths(paths: Sequence[str | Path]) -> list[PuzzleFolder | Path]:
    """Every puzzle folder named: each path is a puzzle folder or a folder of generated puzzles.

    A path that is neither is passed through as it is, for the caller to
    report with its own reader's message.
    """
    out: list[PuzzleFolder | Path] = []
    for given in map(Path, paths):
        if given.is_dir():
            out += find_puzzle_folders(given)
        else:
            out.append(given)
    return out
