"""The files a dataset's writers keep beside its puzzle folders, and the lock on its root.

A worker writes a generation record (``shard-<n>/.records/<name>.json``) before its puzzle's folder;
the records of a shard go once its part file holds their rows. Killed writers leave temporary entries
(:func:`~phyrogen_core.folder.temporary_entry`), removed on the next run. See
:mod:`solver.pipelines.dataset.build` for the whole protocol.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from phyrogen_core.folder import temporary_entry
from solver.pipelines.dataset.request import DatasetError

if TYPE_CHECKING:
    from solver.pipelines.dataset.request import DatasetRequest, Entry

RECORDS_FOLDER = ".records"
"""Inside a shard folder: one generation record per finished puzzle, until the shard's part is written."""


def remove_records(request: DatasetRequest, shard_dir: Path, shard: int) -> None:
    """Remove the generation records of a complete shard (its part file holds their rows now):
    the records of its own entries, by their exact names, then the folder if that left it empty.
    Anything else in it, a user's file, stays, and so does the folder holding it."""
    folder = shard_dir / RECORDS_FOLDER
    if folder.is_symlink() or not folder.is_dir():
        return
    own = {f"{entry.name}.json" for entry in request.entries(request.shard_entries(shard))}
    try:
        names = os.listdir(folder)
    except OSError:
        return
    for name in names:
        if name in own:
            with contextlib.suppress(OSError):
                (folder / name).unlink()
    with contextlib.suppress(OSError):  # not empty: a user's file is in it
        folder.rmdir()


def read_record(shard_dir: Path, entry: Entry) -> dict[str, Any] | None:
    """The generation record of ``entry`` when there is one and it belongs to exactly this entry."""
    path = shard_dir / RECORDS_FOLDER / f"{entry.name}.json"
    if not path.is_file():
        return None
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict):
        return None
    same = (record.get("index") == entry.index and record.get("generator") == entry.generator
            and record.get("seed") == entry.seed and record.get("parameters") == entry.parameters_json)
    return record if same and _record_values_hold(record) else None


def _record_values_hold(record: dict[str, Any]) -> bool:
    """Whether a generation record's values are of the kinds
    :func:`~solver.pipelines.dataset.build.write_record` writes (a manifest row is made of them): one
    that is not is made again, as a torn record is."""
    seconds, checks, error = record.get("seconds"), record.get("validation_checks"), record.get("error")
    return (isinstance(record.get("ok"), bool) and (error is None or isinstance(error, str))
            and (seconds is None or type(seconds) in (int, float) and math.isfinite(seconds) and seconds >= 0)
            and (checks is None or type(checks) is int and checks >= 0))


def remove_temporary_files(folder: Path, own: Callable[[str], object]) -> None:
    """Remove what killed writers left in ``folder``: the temporary entries of atomic writes
    (:func:`~phyrogen_core.folder.temporary_entry`: ``.<entry>.<8 random characters>.tmp`` and
    their ``.old<n>`` asides) of the entries ``own`` names, this stage's own. Nothing else is
    touched: a user's ``.notes.tmp`` or ``.draft.tmp.tex`` is no temporary of ours."""
    try:
        names = os.listdir(folder)
    except OSError:
        return
    for name in names:
        entry = temporary_entry(name)
        if entry is None or not own(entry):
            continue
        path = folder / name
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                path.unlink()


@contextlib.contextmanager
def exclusive(root: Path) -> Iterator[None]:
    """Hold a lock on the dataset root for the block: two runs never write one dataset at once.

    A lock on the folder itself: nothing is left behind, and the lock ends with its process, even
    one killed by SIGKILL."""
    try:
        import fcntl
    except ImportError:  # not on POSIX: no lock
        yield
        return
    descriptor = os.open(root, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_CLOEXEC", 0))
    try:
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise DatasetError(f"{root}: another `phyrogen dataset` is writing this dataset; wait for it "
                               "or stop it") from None
        except OSError:  # a file system without flock
            pass
        yield
    finally:
        os.close(descriptor)
