"""A stage's files swapped into a puzzle folder, keeping everything the stage does not own.

Only renders and solutions of a puzzle that was regenerated differently move, into ``stale/<n>/``
beside it, with the puzzle they were made for; nothing but the stage's own old files is deleted.
"""

from __future__ import annotations

import os
import shutil
import stat
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from .atomic_writes import OutputError, atomic_directory
from .folder_layout import METADATA_FILE, STALE_FOLDER
from .folder_ownership import Stage, derived_stages, owned_files, stage_entries, stage_owns
from .folder_reads import MAX_FILE_BYTES
from .record import PuzzleRecord


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

    with atomic_directory(final, merge) as temporary:
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

    with atomic_directory(final, keep) as temporary:
        yield temporary


def carry_others(old: str | Path, new: str | Path, owns: Callable[[str], bool]) -> None:
    """Hard-link (or copy) into the folder ``new`` every file of the folder ``old`` that ``owns``
    does not name (POSIX paths inside ``old``) and ``new`` does not hold, at the same place: for a
    stage that swaps in a whole folder of its own files (the benchmark's ``logs/``), so that a
    user's file in the old one is kept. Nothing when ``old`` is missing or a symbolic link."""
    old = Path(old)
    if old.is_dir() and not old.is_symlink():
        _carry(old, Path(new), owns, lambda path: True)


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
