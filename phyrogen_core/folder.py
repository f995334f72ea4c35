"""The puzzle folder: its layout, which stage owns which entry, finding folders, writing a stage's files.

A puzzle lives in one folder, ``<out>/<generator>/<name>/``::

    urdf/<name>.urdf, srdf/<name>.srdf, meshes/, puzzle.json     export (generate, the panel's Export)
    solutions/                                                    benchmark (planner solutions)
    images/, <name>.blend                                         render
    mjcf/, phobos/                                                interop (MJCF; the add-on's Export with Phobos)
    stale/<n>/                                                    export, when the puzzle changed

Every stage writes only the files it owns, by exact name (:func:`stage_owns`),
and keeps every other entry, another stage's or a user's file, even one inside
a folder the stage writes, as it was (:func:`stage_directory`,
:func:`owned_directory`); only renders and solutions of a puzzle that was
regenerated differently move, into ``stale/<n>/`` beside it, with the puzzle
they were made for. No stage writes through a symbolic link
(:func:`require_stage_folder`) or copies a file that is not a regular file
inside the folder (:func:`require_self_contained`), and a reader refuses a folder
with a link out of it or a FIFO or device anywhere in it (:func:`require_no_escapes`). This
module is the one place that knows the layout: other layers ask a
:class:`PuzzleFolder` for paths and :func:`find_puzzle_folders` for folders.
"""

from __future__ import annotations

import errno
import json
import math
import os
import re
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from .errors import PuzzleFormatError
from .record import PuzzleRecord, folder_identity

METADATA_FILE = "puzzle.json"
BEST_SOLUTION = Path("solutions") / "la_rrt_best.json"
"""The benchmark's lowest-cost solution, the one the manipulation stage executes (inside a puzzle folder)."""
MAX_FILE_BYTES = 16 * 2**20
"""The largest file a puzzle folder may hand to a reader (``puzzle.json``, URDF, OBJ mesh, solution):
16 MiB, some five hundred times the largest file of the paper's puzzles, checked before the file is read."""
MAX_NAME_LENGTH = 200
"""The longest puzzle or generator name: ``<name>.blend`` and friends stay within file-name limits."""
DATASET_FILE = "dataset.json"
"""Marks a dataset root (``phyrogen dataset``): its puzzles lie in shard folders,
``<root>/shard-<nnnnn>/<generator>/<name>/``, each shard an output root of its own."""
SHARD_PREFIX = "shard-"


def shard_name(index: int) -> str:
    """The folder of shard ``index`` (0-based) of a dataset: ``shard-00000``, ``shard-00001``, ..."""
    return f"{SHARD_PREFIX}{index:05d}"


class OutputError(ValueError):
    """An output path that cannot be written (a file, a missing permission): bad input, found up front."""


def name_problem(name: object) -> str | None:
    """Why ``name`` cannot name a puzzle (or a generator's folder), or None when it can.

    The one rule for names that build paths: a non-empty string of at most
    :data:`MAX_NAME_LENGTH` printable characters, without ``/`` or ``\\``, not
    starting with ``.`` (which also excludes ``.`` and ``..``, and the
    temporary folders of :func:`atomic_directory`). Such a name stays one
    entry inside the folder it is joined to.
    """
    if not isinstance(name, str) or not name:
        return "must be a non-empty string"
    if len(name) > MAX_NAME_LENGTH:
        return f"is {len(name)} characters long; valid names have at most {MAX_NAME_LENGTH}"
    if "/" in name or "\\" in name or name.startswith(".") or not name.isprintable():
        return ("cannot name an entry inside a folder; valid names have no slashes, no control characters "
                "and do not start with '.'")
    return None


def read_folder_file(path: str | Path, root: str | Path, label: str | None = None,
                     limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of the file ``path``, a file of the puzzle folder ``root``.

    The one rule for every file a reader takes from a puzzle folder: after
    resolving symbolic links it lies inside ``root``; it is a regular file
    (``os.stat`` is asked before anything is opened, so a FIFO or a device
    is refused instead of blocking or streaming forever); it holds at most
    ``limit`` bytes. Raises :class:`PuzzleFormatError` ``"<label>: <what is
    wrong>"``; ``label`` defaults to the path.
    """
    path = Path(path)
    label = str(path) if label is None else label
    real = require_folder_file(path, root, label, limit)
    try:
        # O_NONBLOCK: should the entry be swapped for a FIFO after the stat, opening it still returns at once.
        descriptor = os.open(real, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0)
                             | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise PuzzleFormatError(f"{label} cannot be read: {_reason(exc)}") from None
    try:
        _require_regular(os.fstat(descriptor), label, limit)
        chunks: list[bytes] = []
        size = 0
        while size <= limit:
            chunk = os.read(descriptor, min(1 << 20, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        raise PuzzleFormatError(f"{label} cannot be read: {_reason(exc)}") from None
    finally:
        os.close(descriptor)
    if size > limit:
        raise PuzzleFormatError(f"{label} grew past {_size(limit)} while being read")
    return b"".join(chunks)


def require_folder_file(path: str | Path, root: str | Path, label: str | None = None,
                        limit: int = MAX_FILE_BYTES, what: str = "puzzle folder") -> Path:
    """:func:`read_folder_file`'s rule, asked of the file system only (nothing is opened): ``path``
    resolves to a regular file of at most ``limit`` bytes inside ``root`` (a ``what``). Returns the
    resolved path; raises :class:`PuzzleFormatError` ``"<label>: <what is wrong>"``."""
    path = Path(path)
    label = str(path) if label is None else label
    try:
        real_root = Path(os.path.realpath(root))
        real = Path(os.path.realpath(path))
    except (OSError, ValueError) as exc:
        raise PuzzleFormatError(f"{label} cannot be resolved: {_reason(exc)}") from None
    if not real.is_relative_to(real_root):
        raise PuzzleFormatError(f"{label} resolves to {real}, outside the {what} {real_root}; "
                                f"a {what} must be self-contained")
    try:
        info = os.stat(real)
    except FileNotFoundError:
        raise PuzzleFormatError(f"{label} is missing") from None
    except (OSError, ValueError) as exc:
        raise PuzzleFormatError(f"{label} cannot be read: {_reason(exc)}") from None
    _require_regular(info, label, limit)
    return real


def require_self_contained(root: str | Path, entries: Iterable[str], what: str = "puzzle folder") -> None:
    """Every file under the entries ``entries`` of the folder ``root`` keeps :func:`require_folder_file`'s
    rule (its folders too, which must lie inside ``root``): for a stage that copies whole entries, so
    that a link to a file elsewhere, a FIFO or a device among them is bad input found before any work,
    not read, blocked on or streamed. Missing entries are fine. Raises :class:`PuzzleFormatError`."""
    root = Path(root)
    pending = [root / entry for entry in entries if os.path.lexists(root / entry)]
    seen: set[Path] = set()
    while pending:
        path = pending.pop()
        try:
            is_folder = path.is_dir()
        except OSError:
            is_folder = False
        if not is_folder:
            require_folder_file(path, root, what=what)
            continue
        real = Path(os.path.realpath(path))
        if real in seen:  # a link back to a folder already walked
            continue
        seen.add(real)
        if not real.is_relative_to(Path(os.path.realpath(root))):
            raise PuzzleFormatError(f"{path} resolves to {real}, outside the {what} {os.path.realpath(root)}; "
                                    f"a {what} must be self-contained")
        try:
            pending += sorted(path.iterdir())
        except OSError as exc:
            raise PuzzleFormatError(f"{path} cannot be read: {_reason(exc)}") from None


MAX_FOLDER_ENTRIES = 100_000
"""The most entries :func:`require_no_escapes` walks in one folder (a puzzle folder holds tens);
a folder with more is refused, not walked."""


def require_no_escapes(root: str | Path, what: str = "puzzle folder", name: str | None = None) -> None:
    """No entry of the folder ``root``, at any depth and referenced or not, leads out of it, is
    a special file or is too large: every symbolic link resolves inside ``root``, nothing is a
    FIFO, a device or a socket, and no file holds more than :data:`MAX_FILE_BYTES` but the
    renders of puzzle ``name`` (:func:`large_file_allowed`; ``name`` defaults to the folder's).
    A path that leaves a puzzle folder is bad input wherever it appears: a stage that
    reads, copies or carries the folder over would read what lies elsewhere, block on a FIFO or
    stream a device; and a file beyond the bound would be copied (where a hard link cannot be
    made) at a cost that no stated size bounds. Asked of the file system only (one ``stat`` per
    file, nothing opened); links are not followed (a linked folder inside ``root`` is walked where
    it really is). Raises :class:`PuzzleFormatError`, one line naming the entry."""
    root = Path(root)
    name = root.name if name is None else name
    try:
        real_root = Path(os.path.realpath(root))
    except (OSError, ValueError) as exc:
        raise PuzzleFormatError(f"{root} cannot be resolved: {_reason(exc)}") from None
    pending, walked = [root], 0
    while pending:
        folder = pending.pop()
        try:
            with os.scandir(folder) as scan:
                entries = sorted(scan, key=lambda entry: entry.name)
        except OSError as exc:
            raise PuzzleFormatError(f"{folder} cannot be read: {_reason(exc)}") from None
        walked += len(entries)
        if walked > MAX_FOLDER_ENTRIES:
            raise PuzzleFormatError(f"{root} holds more than {MAX_FOLDER_ENTRIES} entries; a {what} holds tens "
                                    "(move the others out)")
        for entry in entries:
            path = Path(entry.path)
            try:
                if entry.is_symlink():
                    real = Path(os.path.realpath(path))
                    if not real.is_relative_to(real_root):
                        raise PuzzleFormatError(f"{path} is a symbolic link to {real}, outside the {what} "
                                                f"{real_root}; a {what} must be self-contained (move the link out)")
                elif entry.is_dir(follow_symlinks=False):
                    pending.append(path)
                elif entry.is_file(follow_symlinks=False):
                    size = entry.stat(follow_symlinks=False).st_size
                    if size > MAX_FILE_BYTES and not large_file_allowed(path.relative_to(root).as_posix(), name):
                        raise PuzzleFormatError(f"{path} is {size} bytes, more than the {_size(MAX_FILE_BYTES)} a "
                                                f"file in a {what} may have (move it out)")
                else:
                    mode = entry.stat(follow_symlinks=False).st_mode
                    kinds = ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                             (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
                    kind = next((name for test, name in kinds if test(mode)), "a special file")
                    raise PuzzleFormatError(f"{path} is {kind}, not a regular file or folder; a {what} holds "
                                            "only files and folders (move it out)")
            except OSError as exc:
                raise PuzzleFormatError(f"{path} cannot be read: {_reason(exc)}") from None


def large_file_allowed(relative: str, name: str) -> bool:
    """Whether ``relative`` (a POSIX path inside puzzle ``name``'s folder) may hold more than
    :data:`MAX_FILE_BYTES`: the render stage's own images, animation and ``.blend``, in the folder
    or in a ``stale/<n>/`` snapshot of it, which no reader reads and whose size the render's
    ``--size`` bounds (an 8192 x 8192 image is tens of MiB)."""
    inner = re.sub(rf"^{STALE_FOLDER}(?:/\d+|-\d+)/", "", relative, count=1)  # (:func:`_stale_slot`)
    return stage_owns(Stage.RENDER, name, inner)


def read_folder_json(path: str | Path, root: str | Path, label: str | None = None) -> object:
    """The JSON data of the file ``path`` of the puzzle folder ``root``: :func:`read_folder_file`'s
    rule, UTF-8 text, and every number in it finite (JSON itself has no NaN or infinity; Python's
    parser accepts ``NaN``, ``Infinity`` and ``1e999``). Raises :class:`PuzzleFormatError` naming
    the file and, for a number, the field (``certificate[3][1]``)."""
    label = str(path) if label is None else label
    raw = read_folder_file(path, root, label)
    try:
        data = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise PuzzleFormatError(f"{path}: not UTF-8 text: {_one_line(exc)}") from None
    except RecursionError:
        raise PuzzleFormatError(f"{path}: malformed JSON: nested too deeply") from None
    except ValueError as exc:  # json.JSONDecodeError, or an integer of too many digits
        raise PuzzleFormatError(f"{path}: malformed JSON: {_one_line(exc)}") from None
    bad = _non_finite_number(data)
    if bad is not None:
        field, value = bad
        raise PuzzleFormatError(f"{path}: {field} is {value}; every number in the file must be finite")
    return data


def _non_finite_number(data: object) -> tuple[str, str] | None:
    """(field, value) of the first number in JSON ``data`` that is not a finite float, else None."""
    stack: list[tuple[object, str]] = [(data, "")]
    while stack:
        value, field = stack.pop()
        if isinstance(value, dict):
            stack += [(item, _member(field, key)) for key, item in reversed(value.items())]
        elif isinstance(value, list):
            stack += [(item, f"{field}[{i}]") for i, item in reversed(list(enumerate(value)))]
        elif isinstance(value, float) and not math.isfinite(value):
            return field or "the value", repr(value)
        elif isinstance(value, int) and not isinstance(value, bool):
            try:
                float(value)
            except OverflowError:
                return field or "the value", f"an integer of {len(str(abs(value)))} digits, beyond any float"
    return None


def _member(field: str, key: str) -> str:
    plain = key.isidentifier() or (key.replace("_", "").replace("-", "").isalnum() and key.isascii())
    name = key if plain else repr(key)
    return f"{field}.{name}" if field else name


def _require_regular(info: os.stat_result, label: str, limit: int) -> None:
    mode = info.st_mode
    if not stat.S_ISREG(mode):
        kinds = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                 (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
        kind = next((name for test, name in kinds if test(mode)), "not a file")
        raise PuzzleFormatError(f"{label} is {kind}, not a regular file")
    if info.st_size > limit:
        raise PuzzleFormatError(f"{label} is {info.st_size} bytes, more than the {_size(limit)} "
                                "a puzzle-folder file may have")


def _size(limit: int) -> str:
    return f"{limit // 2**20} MiB" if limit % 2**20 == 0 else f"{limit} bytes"


def _reason(exc: BaseException) -> str:
    return exc.strerror if isinstance(exc, OSError) and exc.strerror else _one_line(exc)


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


class Stage(StrEnum):
    """A stage that writes into puzzle folders."""

    EXPORT = "export"
    BENCHMARK = "benchmark"
    RENDER = "render"
    INTEROP = "interop"  # files for other tools (MJCF; Phobos's URDF from the Blender add-on), made from the export


def stage_entries(stage: Stage, name: str) -> tuple[str, ...]:
    """The top-level entries of puzzle ``name``'s folder that ``stage`` owns."""
    return {
        Stage.EXPORT: ("urdf", "srdf", "meshes", METADATA_FILE),
        Stage.BENCHMARK: ("solutions",),
        Stage.RENDER: ("images", f"{name}.blend"),
        Stage.INTEROP: ("mjcf", "phobos"),
    }[stage]


MESH_FILE = re.compile(r"[^/]+_(?:visual|collision)_\d+_\d+\.obj")
"""The name of a mesh file the export stage writes (``<link>_<visual|collision>_<geometry>_<piece>.obj``)."""


PHOBOS_FILE = re.compile(r"phobos/(?:urdf/[^/]+\.urdf|meshes/obj/[^/]+)")
"""A file the Blender add-on's Export with Phobos writes (``blender_addon.phobos``): Phobos's URDF
and its OBJ meshes; anything else in ``phobos/`` is a user's."""


def phobos_owns(relative: str) -> bool:
    """Whether ``relative`` (a POSIX path inside a folder Export with Phobos writes) is Phobos's own
    file (:data:`PHOBOS_FILE`): what :func:`owned_directory` replaces there, keeping the rest."""
    return PHOBOS_FILE.fullmatch(f"phobos/{relative}") is not None


def stage_owns(stage: Stage, name: str, relative: str) -> bool:
    """Whether ``relative`` (a POSIX path inside puzzle ``name``'s folder) is a file ``stage`` writes.

    Ownership is by file, not by folder: a stage replaces, and moves into ``stale/``, only files
    of its own exact names; any other file, even one inside a folder the stage writes (a user's
    ``urdf/my_robot.urdf`` or ``images/notes.txt``), is a user's and stays where it is.
    """
    parts = relative.split("/")
    inner = parts[1] if len(parts) == 2 else None
    if stage is Stage.EXPORT:
        return (relative in (METADATA_FILE, f"urdf/{name}.urdf", f"srdf/{name}.srdf")
                or (parts[0] == "meshes" and inner is not None and MESH_FILE.fullmatch(inner) is not None))
    if stage is Stage.BENCHMARK:
        return relative == BEST_SOLUTION.as_posix()
    if stage is Stage.RENDER:
        # blender_addon.views.image_name and animation_name
        return relative == f"{name}.blend" or (
            parts[0] == "images" and inner is not None
            and re.fullmatch(rf"{re.escape(name)}_(?:\d{{2,}}\.png|solution\.webp)", inner) is not None)
    return relative == f"mjcf/{name}.xml" or PHOBOS_FILE.fullmatch(relative) is not None


def owned_files(folder: str | Path, stage: Stage, name: str) -> list[str]:
    """The files of ``stage`` (:func:`stage_owns`) present in ``folder``, as POSIX paths inside it, sorted.
    A symbolic link stands for itself: a linked folder is not walked."""
    folder = Path(folder)
    found = []
    pending = [entry for entry in stage_entries(stage, name) if os.path.lexists(folder / entry)]
    while pending:
        relative = pending.pop()
        path = folder / relative
        is_folder = path.is_dir() and not path.is_symlink()
        if stage_owns(stage, name, relative) and (not is_folder or "/" not in relative):
            found.append(relative)
        elif is_folder:
            try:
                pending += [f"{relative}/{child}" for child in os.listdir(path)]
            except OSError:
                continue
    return sorted(found)


def _carry(old: Path, new: Path, leave: Callable[[str], bool], walk: Callable[[str], bool],
           relative: str = "") -> None:
    """Hard-link (or copy) into ``new`` every entry of the folder ``old`` that ``leave`` does not
    claim and ``new`` does not hold yet, at the same place: what a user (or another stage) made
    stays. Folders that ``walk`` names are entered, so that single files in them can be left; an
    entered folder that ends up empty is not made, unless it was empty already."""
    try:
        names = sorted(os.listdir(old / relative) if relative else os.listdir(old))
    except OSError:
        return
    if not names and relative:
        (new / relative).mkdir(parents=True, exist_ok=True)
    for child in names:
        path = f"{relative}/{child}" if relative else child
        source = old / path
        if leave(path):
            continue
        if source.is_dir() and not source.is_symlink() and walk(path):
            _carry(old, new, leave, walk, path)
        elif not os.path.lexists(new / path):
            _link_or_copy(source, new / path)


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


@contextmanager
def stage_directory(final: str | Path, stage: Stage, name: str,
                    notices: list[str] | None = None) -> Iterator[Path]:
    """Yield an empty temporary folder for ``stage``'s entries of puzzle ``name``'s folder ``final``.

    When the block succeeds, ``final`` becomes the temporary folder's entries
    plus every file of the old ``final`` that ``stage`` does not own
    (:func:`stage_owns`: another stage's files or a user's, even inside
    ``urdf/``, hard-linked or copied over to the same place), swapped in
    atomically (:func:`atomic_directory`). The stage's own old files are
    replaced. If the block raises or is interrupted, ``final`` is left as it was.

    Files of the stages computed from ``stage``'s (:func:`derived_stages`:
    an exported puzzle's renders and solutions) are kept only while they still
    belong to it: when the new files describe another puzzle
    (:func:`same_stage_entries` is false), they move into ``stale/<n>/`` of the
    new folder together with the old files they were made from, a complete
    puzzle folder of its own, and a one-line notice saying where is appended
    to ``notices``; a user's files stay where they were. Nothing but the
    stage's own old files is ever deleted. Raises :class:`OutputError` when
    ``final`` is a symbolic link.
    """
    final = Path(final)
    owned = stage_entries(stage, name)
    derived = derived_stages(stage)
    # Folders holding single files of some stage: entered file by file, so a user's file in them stays.
    shared = {entry for other in Stage for entry in stage_entries(other, name) if not stage_owns(other, name, entry)}

    def merge(temporary: Path) -> None:
        # Runs while this writer holds the swap lock, so ``final`` is the folder the swap replaces.
        if not final.is_dir():
            return
        own = owned_files(final, stage, name)
        made_from_it = [path for other in derived for path in owned_files(final, other, name)]
        moving = bool(made_from_it) and not same_stage_entries(
            final, temporary, owned, owns=lambda path: stage_owns(stage, name, path))
        leave = set(own) | (set(made_from_it) if moving else set())
        _carry(final, temporary, leave.__contains__, lambda path: path.split("/")[0] in shared)
        if moving:
            slot = _stale_slot(temporary)
            (temporary / slot).mkdir(parents=True)
            for path in own + made_from_it:
                _link_or_copy(final / path, temporary / slot / path)
            if notices is not None:
                moved = sorted({path.split("/")[0] for path in made_from_it})
                notices.append(f"{final}: puzzle changed; its previous {', '.join(moved)} moved to {final / slot}, "
                               "with the puzzle they were made for")

    with _atomic_directory(final, merge) as temporary:
        yield temporary


@contextmanager
def owned_directory(final: str | Path, owns: Callable[[str], bool]) -> Iterator[Path]:
    """:func:`atomic_directory` for a folder a stage shares with its user (``images/``, ``mjcf/``,
    a puzzle's manipulation outputs): when the block succeeds, the old folder's files that ``owns``
    names (POSIX paths inside ``final``) are replaced by the temporary folder's, and every other
    entry of it is carried into the new folder where it was. Raises :class:`OutputError` when
    ``final`` is a symbolic link."""
    final = Path(final)

    def keep(temporary: Path) -> None:
        if final.is_dir():
            _carry(final, temporary, owns, lambda path: True)

    with _atomic_directory(final, keep) as temporary:
        yield temporary


def carry_others(old: str | Path, new: str | Path, owns: Callable[[str], bool]) -> None:
    """Hard-link (or copy) into the folder ``new`` every file of the folder ``old`` that ``owns``
    does not name (POSIX paths inside ``old``) and ``new`` does not hold, at the same place: for a
    stage that swaps in a whole folder of its own files (the benchmark's ``logs/``), so that a
    user's file in the old one is kept. Nothing when ``old`` is missing or a symbolic link."""
    old = Path(old)
    if old.is_dir() and not old.is_symlink():
        _carry(old, Path(new), owns, lambda path: True)


STALE_FOLDER = "stale"
"""Where :func:`stage_directory` keeps the renders and solutions of a puzzle that was regenerated differently."""


def derived_stages(stage: Stage) -> tuple[Stage, ...]:
    """The stages whose entries are computed from ``stage``'s, and go stale when those change."""
    return (Stage.BENCHMARK, Stage.RENDER, Stage.INTEROP) if stage is Stage.EXPORT else ()


def same_stage_entries(old: str | Path, new: str | Path, names: Iterable[str],
                       owns: Callable[[str], bool] | None = None) -> bool:
    """Whether the entries ``names`` of the folders ``old`` and ``new`` describe the same puzzle.

    With ``owns`` (a stage's :func:`stage_owns`), only the files it names count inside a folder
    entry: a user's file dropped into ``urdf/`` changes no puzzle.

    The same files with the same bytes, except that ``puzzle.json`` is compared
    as a record without its package versions (:meth:`PuzzleRecord.same_puzzle`: a
    puzzle regenerated by newer packages into the same files is the same puzzle
    and keeps its renders and solutions). Anything unreadable, oversized
    or neither a regular file nor a folder counts as different: when in doubt,
    :func:`stage_directory` moves the old renders aside rather than keep them
    beside a puzzle they may not show.
    """
    old, new = Path(old), Path(new)
    if owns is None:
        return all(_same_metadata(old / n, new / n) if n == METADATA_FILE else _same_tree(old / n, new / n)
                   for n in names)
    for n in names:
        if n == METADATA_FILE:
            if not _same_metadata(old / n, new / n):
                return False
            continue
        before, after = _owned_in(old, n, owns), _owned_in(new, n, owns)
        if before != after or not all(_same_tree(old / path, new / path) for path in before):
            return False
    return True


def _owned_in(folder: Path, entry: str, owns: Callable[[str], bool]) -> list[str]:
    path = folder / entry
    if path.is_dir() and not path.is_symlink():
        try:
            return sorted(p for p in (f"{entry}/{child}" for child in os.listdir(path)) if owns(p))
        except OSError:
            return [entry]  # unreadable: differs from any readable folder
    return [entry] if os.path.lexists(path) else []


def _same_metadata(old: Path, new: Path) -> bool:
    def record(path: Path) -> PuzzleRecord | None:
        try:
            info = os.lstat(path)
            if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_FILE_BYTES:
                return None
            return PuzzleRecord.from_json(path.read_bytes(), str(path))
        except (OSError, ValueError, RecursionError):  # PuzzleFormatError is a ValueError
            return None

    before, after = record(old), record(new)
    return before is not None and after is not None and before.same_puzzle(after)


def _same_tree(old: Path, new: Path) -> bool:
    try:
        a, b = os.lstat(old), os.lstat(new)
    except FileNotFoundError:
        return not os.path.lexists(old) and not os.path.lexists(new)
    except OSError:
        return False
    try:
        if stat.S_ISDIR(a.st_mode) and stat.S_ISDIR(b.st_mode):
            names = sorted(os.listdir(old))
            return names == sorted(os.listdir(new)) and all(_same_tree(old / n, new / n) for n in names)
        if not (stat.S_ISREG(a.st_mode) and stat.S_ISREG(b.st_mode)) or a.st_size != b.st_size:
            return False
        with open(old, "rb") as first, open(new, "rb") as second:
            while True:
                chunk = first.read(1 << 20)
                if chunk != second.read(1 << 20):
                    return False
                if not chunk:
                    return True
    except OSError:
        return False


def _stale_slot(folder: Path) -> Path:
    """A new ``stale/<n>`` inside ``folder``, numbered after the ones already there."""
    root = folder / STALE_FOLDER
    if os.path.lexists(root) and (root.is_symlink() or not root.is_dir()):
        # A user's own file is called "stale": leave it alone and number the snapshots beside it.
        n = 1
        while os.path.lexists(folder / f"{STALE_FOLDER}-{n}"):
            n += 1
        return Path(f"{STALE_FOLDER}-{n}")
    taken = [int(p.name) for p in root.iterdir() if p.name.isdigit()] if root.is_dir() else []
    return Path(STALE_FOLDER) / str(max(taken, default=0) + 1)


def _link_or_copy(source: Path, target: Path) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    if source.is_symlink():
        os.symlink(os.readlink(source), target)
    elif source.is_dir():
        shutil.copytree(source, target, symlinks=True, copy_function=_link_file)
    else:
        _link_file(source, target)


def _link_file(source: str | Path, target: str | Path) -> None:
    try:
        os.link(source, target)
    except OSError:
        # No hard link here (another owner's file under protected_hardlinks, a file system without
        # them): a regular file is copied; a FIFO is made anew, for opening it to copy would block.
        mode = os.lstat(source).st_mode
        if stat.S_ISFIFO(mode):
            os.mkfifo(target, stat.S_IMODE(mode))
        elif stat.S_ISREG(mode):
            shutil.copy2(source, target)
        else:
            # Copying a device would stream it (/dev/zero forever); leaving it behind would delete it.
            raise OutputError(f"{source} is a special file that cannot be hard-linked into the new folder; "
                              "move it out of the folder") from None


@contextmanager
def atomic_directory(final: str | Path) -> Iterator[Path]:
    """Yield an empty temporary folder that becomes ``final`` when the block succeeds.

    The temporary folder is a dot-prefixed sibling of ``final`` (same file
    system, so the rename is atomic). An existing ``final`` folder is first
    renamed aside, then deleted once the new one is in place. If the block
    raises (or is interrupted), the temporary folder is removed and ``final``
    is left as it was. Missing parent folders are created and kept, even on
    failure: removing them could race with another writer using the same parent.

    Writers finishing the same ``final`` at once (threads or processes) take
    turns at the swap, and a writer that finds another's folder in place moves
    it aside and tries again: the last writer to finish wins, and ``final`` is
    always one writer's complete folder. Raises :class:`OutputError` when
    ``final`` or one of its parents is a file.
    """
    with _atomic_directory(Path(final)) as temporary:
        yield temporary


SWAP_ATTEMPTS = 1000
"""How often a writer moves another writer's folder aside before giving up: only writers that bypass
the swap lock (another file system's semantics, an old version) can make it retry at all."""


@contextmanager
def _atomic_directory(final: Path, prepare: Callable[[Path], None] | None = None) -> Iterator[Path]:
    """:func:`atomic_directory`; ``prepare(temporary)`` runs just before the swap, under the swap lock."""
    if final.is_symlink():
        # Swapping would replace the link itself, and writing through it would write elsewhere.
        raise OutputError(f"output folder {final} is a symbolic link; a stage writes only into real folders "
                          "(put the folder itself there)")
    if os.path.lexists(final) and not final.is_dir():
        raise OutputError(f"output folder {final} exists and is not a folder; remove it or choose another path")
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        temporary = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent))
    except OSError as exc:
        raise OutputError(f"output folder {final} cannot be made: {_reason(exc)}") from None
    try:
        # mkdtemp makes the folder private (0700); the result should be as readable as its parent.
        os.chmod(temporary, final.parent.stat().st_mode & 0o777)
        yield temporary
        with _swap_lock(final.parent):
            if prepare is not None:
                prepare(temporary)
            _swap_in(temporary, final)
    except BaseException:
        shutil.rmtree(temporary, ignore_errors=True)
        raise


@contextmanager
def _swap_lock(folder: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``folder`` (the parent of the folders being swapped) for the block.

    A lock on the folder itself, not on a lock file: nothing is left behind.
    Where locks are not available the block runs unlocked and the retries of
    :func:`_swap_in` still keep each result whole.
    """
    try:
        import fcntl
    except ImportError:  # not on POSIX
        yield
        return
    try:
        descriptor = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        yield
        return
    try:
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX)
        except OSError:  # a file system without flock
            pass
        yield
    finally:
        os.close(descriptor)  # releases the lock


def _swap_in(temporary: Path, final: Path) -> None:
    """Rename ``temporary`` to ``final``, moving whatever folder is at ``final`` aside first.

    The rename only succeeds onto a missing (or empty) ``final``, so another
    writer's folder that appears in between is moved aside in its turn, never
    merged with this one. The folders moved aside are deleted once this one is
    in place; if the rename fails for another reason, the latest of them goes back.
    """
    asides: list[Path] = []
    try:
        for attempt in range(SWAP_ATTEMPTS):
            try:
                os.rename(temporary, final)
                break
            except OSError as exc:
                if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST):
                    raise
            aside = temporary.with_name(f"{temporary.name}.old{attempt}")
            try:
                os.rename(final, aside)
            except FileNotFoundError:  # another writer moved it aside first
                continue
            asides.append(aside)
        else:
            raise OSError(errno.EBUSY, f"{final} kept being replaced by other writers; gave up after "
                                       f"{SWAP_ATTEMPTS} attempts")
    except BaseException:
        if asides and not os.path.lexists(final):
            os.rename(asides.pop(), final)
        for aside in asides:
            shutil.rmtree(aside, ignore_errors=True)
        raise
    for aside in asides:
        # The new folder is in place: failing to delete an old copy must not undo that.
        shutil.rmtree(aside, ignore_errors=True)


def require_writable_dir(path: str | Path, label: str = "output folder") -> Path:
    """Check, before any work, that ``path`` is (or can be created as) a folder we may write in.

    Raises :class:`OutputError` (one line naming the path) when it is a file, lies under a file,
    is a broken symbolic link, or cannot be written. Besides the permission bits, the nearest
    existing folder is tried with a folder made and removed at once: root passes every
    permission check, yet cannot write on a read-only mount or in ``/proc`` or ``/sys``.
    Creates nothing: a refused command leaves no output behind.
    """
    path = Path(path)
    probe = path
    try:
        while not os.path.lexists(probe):
            if probe.parent == probe:
                break
            probe = probe.parent
        if probe.is_symlink() and not probe.exists():
            # Writing through a dangling link would create its target somewhere else.
            raise OutputError(f"{label} {path}: {probe} is a broken symbolic link")
        if not probe.is_dir():
            what = "is a file" if probe == path else f"lies under {probe}, which is not a folder"
            raise OutputError(f"{label} {path} {what}; choose another path")
        if not os.access(probe, os.W_OK | os.X_OK):
            raise OutputError(f"{label} {path}: no permission to write in {probe}")
        os.rmdir(tempfile.mkdtemp(prefix=".phyrogen-probe-", dir=probe))
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(f"{label} {path}: cannot write in {probe}: {_reason(exc)}") from None
    return path


def require_stage_folder(path: str | Path, label: str, root: str | Path | None = None) -> Path:
    """A folder a stage replaces or writes its files into (a puzzle folder; its ``images/``,
    ``solutions/`` or ``mjcf/``; a puzzle's manipulation outputs), checked before any work:
    :func:`require_writable_dir`, and neither it nor a folder between ``root`` and it is a
    symbolic link, which would send the stage's files outside (or be swapped away for a folder).
    Raises :class:`OutputError`, one line naming the path."""
    path = Path(path)
    stop = None if root is None else Path(root)
    probe = path
    while True:
        if probe.is_symlink():
            where = "is" if probe == path else f"lies in {probe}, which is"
            raise OutputError(f"{label} {path} {where} a symbolic link; a stage writes only into real folders "
                              "(put the folder itself there)")
        if stop is None or probe == stop or probe.parent == probe:
            break
        probe = probe.parent
    return require_writable_dir(path, label)


TEMPORARY_NAME = re.compile(r"\.(?P<entry>.+)\.[a-z0-9_]{6,12}(?:\.[A-Za-z0-9]+)?\.tmp(?:\.[a-z]+)?(?:\.old\d+)?")
"""The names of this module's temporary entries: ``.<entry>.<random characters><suffix>`` as
:func:`tempfile.mkstemp` and :func:`tempfile.mkdtemp` make them (eight today; six to twelve are
taken), the suffix ``.tmp``, ``.<format>.tmp`` or ``.tmp.<format>``, and the ``.old<n>`` asides
of :func:`_swap_in`."""


def temporary_entry(name: str) -> str | None:
    """The entry the temporary name ``name`` of an atomic write stands for (``.manifest.parquet.k3j_x9ab.tmp``
    -> ``manifest.parquet``), else None. A caller that removes leftovers removes only those of its own
    entries, by this exact pattern: a user's ``.notes.tmp`` is no temporary of ours."""
    match = TEMPORARY_NAME.fullmatch(name)
    return None if match is None else match.group("entry")


@contextmanager
def atomic_file(path: str | Path, suffix: str = ".tmp") -> Iterator[Path]:
    """A temporary sibling of ``path`` to write (by any writer that takes a path), renamed onto
    ``path`` when the block ends: readers see the old file or the new one, never a part. An
    exception (or a signal) in the block removes the temporary file instead."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(handle)
    temporary = Path(name)
    try:
        yield temporary
        os.chmod(temporary, 0o644)
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def write_file_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary sibling and a rename (:func:`atomic_file`)."""
    with atomic_file(path) as temporary:
        temporary.write_bytes(data)
    return Path(path)
