"""Safe reads from a puzzle folder: inside it, regular files only, bounded in size, finite numbers.

A reader refuses a file that resolves outside the folder, a FIFO or a device (asked before
anything is opened), a file over :data:`MAX_FILE_BYTES`, and a folder with a link out of it
or a special file anywhere in it (:func:`require_no_escapes`).
"""

from __future__ import annotations

import json
import math
import os
import stat
from collections.abc import Iterable
from pathlib import Path

from .errors import PuzzleFormatError, one_line, os_reason
from .folder_ownership import large_file_allowed

MAX_FILE_BYTES = 16 * 2**20
"""The largest file a puzzle folder may hand to a reader (``puzzle.json``, URDF, OBJ mesh, solution):
16 MiB, some five hundred times the largest file of the paper's puzzles, checked before the file is read."""


def read_folder_file(path: str | Path, root: str | Path, label: str | None = None,
                     limit: int = MAX_FILE_BYTES, *, real_root: str | None = None) -> bytes:
    """The bytes of the file ``path``, a file of the puzzle folder ``root``.

    The one rule for every file a reader takes from a puzzle folder: after
    resolving symbolic links it lies inside ``root``; it is a regular file
    (``os.stat`` is asked before anything is opened, so a FIFO or a device
    is refused instead of blocking or streaming forever); it holds at most
    ``limit`` bytes. Raises :class:`PuzzleFormatError` ``"<label>: <what is
    wrong>"``; ``label`` defaults to the path. ``real_root``: ``root``'s real path, when the caller
    reads several files of one folder and has resolved it once (:func:`real_folder`).
    """
    path = Path(path)
    label = str(path) if label is None else label
    real = require_folder_file(path, root, label, limit, real_root=real_root)
    try:
        # O_NONBLOCK: should the entry be swapped for a FIFO after the stat, opening it still returns at once.
        descriptor = os.open(real, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0)
                             | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise PuzzleFormatError(f"{label} cannot be read: {os_reason(exc)}") from None
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
        raise PuzzleFormatError(f"{label} cannot be read: {os_reason(exc)}") from None
    finally:
        os.close(descriptor)
    if size > limit:
        raise PuzzleFormatError(f"{label} grew past {_size(limit)} while being read")
    return b"".join(chunks)


def require_folder_file(path: str | Path, root: str | Path, label: str | None = None,
                        limit: int = MAX_FILE_BYTES, what: str = "puzzle folder", *,
                        real_root: str | None = None) -> Path:
    """:func:`read_folder_file`'s rule, asked of the file system only (nothing is opened): ``path``
    resolves to a regular file of at most ``limit`` bytes inside ``root`` (a ``what``; ``real_root``
    its real path, if known). Returns the resolved path; raises :class:`PuzzleFormatError`
    ``"<label>: <what is wrong>"``."""
    text = os.fspath(path)
    label = str(Path(text)) if label is None else label
    try:
        real_root = real_folder(root) if real_root is None else real_root
        real = real_path_under(text, os.fspath(root), real_root)
    except (OSError, ValueError) as exc:
        raise PuzzleFormatError(f"{label} cannot be resolved: {os_reason(exc)}") from None
    # Both are real paths (absolute, normalised): inside is a matter of their text.
    if not (real == real_root or real.startswith(real_root if real_root.endswith("/") else real_root + "/")):
        raise PuzzleFormatError(f"{label} resolves to {real}, outside the {what} {real_root}; "
                                f"a {what} must be self-contained")
    try:
        info = os.stat(real)
    except FileNotFoundError:
        raise PuzzleFormatError(f"{label} is missing") from None
    except (OSError, ValueError) as exc:
        raise PuzzleFormatError(f"{label} cannot be read: {os_reason(exc)}") from None
    _require_regular(info, label, limit)
    return real


def real_folder(root: str | Path) -> str:
    """The real path of the folder ``root`` (``os.path.realpath``), for :func:`real_path_under`."""
    return os.path.realpath(root)


def real_path_under(path: str, root: str, real_root: str) -> str:
    """``os.path.realpath(path)`` for a ``path`` written under the folder ``root``, whose real path
    ``real_root`` is known: the same answer, asking the file system only about the entries below
    ``root`` (realpath asks about every entry of the path, the folders above the puzzle's included:
    a Lockbox Random puzzle's read-back resolved its 41 files' paths in 3 ms). A link among those
    entries, a ``..`` above ``root`` or a path not written under it is left to ``os.path.realpath``."""
    prefix = root if root.endswith("/") else root + "/"
    if os.sep != "/" or not path.startswith(prefix) or not real_root.startswith("/"):
        return os.path.realpath(path)
    parts: list[str] = []
    for part in path[len(prefix):].split("/"):
        if part in ("", "."):
            continue
        if part == "..":  # the entry before it was asked, and is a folder or nothing, never a link
            if not parts:
                return os.path.realpath(path)
            parts.pop()
            continue
        parts.append(part)
        try:
            if stat.S_ISLNK(os.lstat(_joined(real_root, parts)).st_mode):
                return os.path.realpath(path)
        except OSError:  # missing, or not a folder: realpath says what it makes of that
            return os.path.realpath(path)
    return _joined(real_root, parts)


def _joined(real_root: str, parts: list[str]) -> str:
    if not parts:
        return real_root
    return ("" if real_root == "/" else real_root) + "/" + "/".join(parts)


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
            raise PuzzleFormatError(f"{path} cannot be read: {os_reason(exc)}") from None


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
        raise PuzzleFormatError(f"{root} cannot be resolved: {os_reason(exc)}") from None
    pending, walked = [root], 0
    while pending:
        folder = pending.pop()
        try:
            with os.scandir(folder) as scan:
                entries = sorted(scan, key=lambda entry: entry.name)
        except OSError as exc:
            raise PuzzleFormatError(f"{folder} cannot be read: {os_reason(exc)}") from None
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
                raise PuzzleFormatError(f"{path} cannot be read: {os_reason(exc)}") from None


def read_folder_json(path: str | Path, root: str | Path, label: str | None = None, *,
                     real_root: str | None = None) -> object:
    """The JSON data of the file ``path`` of the puzzle folder ``root``: :func:`read_folder_file`'s
    rule, UTF-8 text, and every number in it finite (JSON itself has no NaN or infinity; Python's
    parser accepts ``NaN``, ``Infinity`` and ``1e999``). Raises :class:`PuzzleFormatError` naming
    the file and, for a number, the field (``certificate[3][1]``)."""
    label = str(path) if label is None else label
    raw = read_folder_file(path, root, label, real_root=real_root)
    try:
        data = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise PuzzleFormatError(f"{path}: not UTF-8 text: {one_line(exc)}") from None
    except RecursionError:
        raise PuzzleFormatError(f"{path}: malformed JSON: nested too deeply") from None
    except ValueError as exc:  # json.JSONDecodeError, or an integer of too many digits
        raise PuzzleFormatError(f"{path}: malformed JSON: {one_line(exc)}") from None
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
