"""Writes that readers never see half-done: whole folders and files swapped in by a rename,
and the checks that an output folder can be written at all, made before any work."""

from __future__ import annotations

import errno
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from .errors import os_reason


class OutputError(ValueError):
    """An output path that cannot be written (a file, a missing permission): bad input, found up front."""


SWAP_ATTEMPTS = 1000
"""How often a writer moves another writer's folder aside before giving up: only writers that bypass
the swap lock (another file system's semantics, an old version) can make it retry at all."""


@contextmanager
def atomic_directory(final: str | Path, prepare: Callable[[Path], None] | None = None) -> Iterator[Path]:
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

    ``prepare(temporary)``, when given, runs just before the swap, under the swap lock, so that
    it sees the ``final`` the swap replaces (:func:`~phyrogen_core.stage_writes.stage_directory`
    carries the files the stage does not own from there).
    """
    final = Path(final)
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
        raise OutputError(f"output folder {final} cannot be made: {os_reason(exc)}") from None
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
        raise OutputError(f"{label} {path}: cannot write in {probe}: {os_reason(exc)}") from None
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
