"""The puzzle folder: its layout, which stage owns which entry, finding folders, writing a stage's files.

A puzzle lives in one folder, ``<out>/<generator>/<name>/``::

    urdf/<name>.urdf, srdf/<name>.srdf, meshes/, puzzle.json     export (generate, the panel's Export)
    solutions/                                                    benchmark (planner solutions)
    images/, <name>.blend                                         render

Every stage writes only the entries it owns and keeps every other entry,
another stage's or a user's file, as it was (:func:`stage_directory`). This
module is the one place that knows the layout: other layers ask a
:class:`PuzzleFolder` for paths and :func:`find_puzzle_folders` for folders.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import stat
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

METADATA_FILE = "puzzle.json"
BEST_SOLUTION = Path("solutions") / "la_rrt_best.json"
"""The benchmark's lowest-cost solution, the one the manipulation stage executes (inside a puzzle folder)."""
MAX_FILE_BYTES = 16 * 2**20
"""The largest file a puzzle folder may hand to a reader (``puzzle.json``, URDF, OBJ mesh, solution):
16 MiB, some five hundred times the largest file of the paper's puzzles, checked before the file is read."""
MAX_NAME_LENGTH = 200
"""The longest puzzle or generator name: ``<name>.blend`` and friends stay within file-name limits."""


class OutputError(ValueError):
    """An output path that cannot be written (a file, a missing permission): bad input, found up front."""


class PuzzleFormatError(ValueError):
    """A puzzle folder, its ``puzzle.json``, its URDF or a mesh is missing or malformed."""


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
    try:
        real_root = Path(os.path.realpath(root))
        real = Path(os.path.realpath(path))
    except (OSError, ValueError) as exc:
        raise PuzzleFormatError(f"{label} cannot be resolved: {_reason(exc)}") from None
    if not real.is_relative_to(real_root):
        raise PuzzleFormatError(f"{label} resolves to {real}, outside the puzzle folder {real_root}; "
                                "a puzzle folder must be self-contained")
    try:
        info = os.stat(real)
    except FileNotFoundError:
        raise PuzzleFormatError(f"{label} is missing") from None
    except (OSError, ValueError) as exc:
        raise PuzzleFormatError(f"{label} cannot be read: {_reason(exc)}") from None
    _require_regular(info, label, limit)
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


def stage_entries(stage: Stage, name: str) -> tuple[str, ...]:
    """The top-level entries of puzzle ``name``'s folder that ``stage`` owns."""
    return {
        Stage.EXPORT: ("urdf", "srdf", "meshes", METADATA_FILE),
        Stage.BENCHMARK: ("solutions",),
        Stage.RENDER: ("images", f"{name}.blend"),
    }[stage]


@dataclass(frozen=True)
class PuzzleFolder:
    """Where everything of one puzzle lives; ``name`` names the files inside."""

    path: Path
    name: str
    generator: str = ""

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
        name = data.get("name", path.name)
        problem = name_problem(name)
        if problem is not None:
            raise PuzzleFormatError(f"{metadata_file}: name {name!r} {problem}")
        return cls(path, name, str(data.get("generator", path.parent.name)))

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

    @property
    def seed(self) -> int:
        """The seed in a generated puzzle's name (``<generator>_<seed>``), else 0."""
        tail = self.name.rsplit("_", 1)[-1]
        return int(tail) if tail.isdigit() else 0


def find_puzzle_folders(root: str | Path, generators: Iterable[str] | None = None) -> list[PuzzleFolder]:
    """The puzzle folders ``root`` stands for, in a stable order.

    ``root`` is either one puzzle folder (it holds ``puzzle.json``) or a
    folder of generated puzzles (``<root>/<generator>/<name>/puzzle.json``);
    folders being written (dot-prefixed temporary names) are skipped. The
    order is the registry's generator order, then seed, then name. Raises
    FileNotFoundError when ``root`` is missing or holds no puzzle (of
    ``generators``, when given).
    """
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: no such folder of puzzles (make one with `phyrogen generate --out {root}`)")
    if (root / METADATA_FILE).is_file():
        found = [PuzzleFolder.open(root)]
    else:
        found = [PuzzleFolder.open(meta.parent) for meta in sorted(root.glob(f"*/*/{METADATA_FILE}"))
                 if not meta.parent.name.startswith(".") and not meta.parent.parent.name.startswith(".")]
    wanted = None if generators is None else set(generators)
    found = [f for f in found if wanted is None or f.generator in wanted]
    if not found:
        raise FileNotFoundError(f"{root}: no puzzle folders (*/*/{METADATA_FILE})"
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
def stage_directory(final: str | Path, owned: Sequence[str]) -> Iterator[Path]:
    """Yield an empty temporary folder for one stage's entries of the folder ``final``.

    When the block succeeds, ``final`` becomes the temporary folder's entries
    plus every entry of the old ``final`` that is not in ``owned`` (another
    stage's files or a user's, hard-linked or copied over), swapped in
    atomically. The stage's own old entries are replaced as a whole. If the
    block raises or is interrupted, ``final`` is left as it was.
    """
    final = Path(final)
    owned_set = set(owned)
    with atomic_directory(final) as temporary:
        yield temporary
        if final.is_dir():
            for entry in sorted(final.iterdir()):
                if entry.name in owned_set or (temporary / entry.name).exists():
                    continue
                _link_or_copy(entry, temporary / entry.name)


def _link_or_copy(source: Path, target: Path) -> None:
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
        shutil.copy2(source, target)


@contextmanager
def atomic_directory(final: str | Path) -> Iterator[Path]:
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


def require_writable_dir(path: str | Path, label: str = "output folder") -> Path:
    """Check, before any work, that ``path`` is (or can be created as) a folder we may write in.

    Raises :class:`OutputError` (one line naming the path) when it is a file, lies under a file,
    or is not writable. Creates nothing: a refused command leaves no output behind.
    """
    path = Path(path)
    probe = path
    while not probe.exists():
        if probe.is_symlink():  # a dangling link: writing through it would create its target elsewhere
            raise OutputError(f"{label} {path}: {probe} is a broken symbolic link")
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        what = "is a file" if probe == path else f"lies under {probe}, which is not a folder"
        raise OutputError(f"{label} {path} {what}; choose another path")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"{label} {path}: no permission to write in {probe}")
    return path


def write_file_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary sibling and a rename: readers see the old
    file or the new one, never a part."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile("wb", dir=path.parent, prefix=f".{path.name}.", suffix=".tmp",
                                     delete=False) as handle:
        handle.write(data)
        temporary = Path(handle.name)
    try:
        os.chmod(temporary, 0o644)
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return path
