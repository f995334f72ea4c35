"""Building a dataset: shards of puzzle folders, resumable after any interruption.

Layout of a dataset root::

    dataset.json                      the request (a re-run with another request is refused)
    shard-00000/<generator>/<name>/   puzzle folders, exactly as ``phyrogen generate`` writes them
    shard-00001/...                   (each shard folder is an output root of its own)
    parts/shard-00000.parquet         a shard's manifest rows, written when the shard is complete
    manifest.parquet                  every row, written when every shard is complete

**Safe at any moment, even ``kill -9``.** A worker writes its puzzle's
generation record (``shard-<n>/.records/<name>.json``: status, error, cost)
and then its folder, each atomically (a temporary name, then a rename),
without reacting to SIGINT or SIGTERM in between. A part file and the
manifest are written the same way. So after any interruption every folder,
record, part and manifest present is complete, and what is missing is
redone on the next run: a complete shard (its part file holds all its
rows) is skipped; inside an incomplete one, a puzzle whose folder is valid
and matches the request is kept, a seed whose recorded failure is
generation's own verdict is kept as failed, and everything else is
generated. Temporary leftovers of a killed writer are removed on the way.

**Backends.** Puzzles are made by a backend: a function that runs
:func:`make_entry` for each task and yields the outcomes in any order.
Every puzzle seeds its own random sources, so where and after what it runs
does not matter. :func:`local_backend` runs batches of cheap entries in
fresh processes of :mod:`solver.parallel.pool`; :func:`ray_backend` runs the same
batches as Ray tasks (:mod:`solver.parallel.ray_pool`). Tasks name their shard
folder, which every worker must be able to write (a shared file system).
"""

from __future__ import annotations

import contextlib
import itertools
import json
import math
import os
import re
import time
import traceback
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from phyrogen_core.folder import (
    DATASET_FILE,
    PuzzleFormatError,
    read_folder_json,
    require_no_escapes,
    require_stage_folder,
    require_writable_dir,
    shard_name,
    temporary_entry,
    write_file_atomic,
)
from phyrogen_core.maker import GenerationError
from phyrogen_core.registry import ParameterError, get_generator
from solver.parallel.pool import deferred_signals
from solver.parallel.ray_pool import LOCAL
from solver.parallel.tasks import task_pool
from solver.pipelines.dataset.manifest import (
    MANIFEST_FILE,
    PARTS_FOLDER,
    failed_row,
    part_is_complete,
    part_path,
    puzzle_row,
    read_parquet,
    write_manifest,
    write_part,
)
from solver.pipelines.dataset.manifest_row import ManifestRow
from solver.pipelines.dataset.request import DatasetError, DatasetRequest, Entry, request_difference
from solver.pipelines.dataset.shard_files import (
    RECORDS_FOLDER,
    exclusive,
    read_record,
    remove_records,
    remove_temporary_files,
)
from solver.pipelines.generation import _PRELOAD as GENERATION_PRELOAD
from solver.pipelines.generation import LOOKAHEAD, generate_here, versions, warm_hint

if TYPE_CHECKING:
    from solver.benchmark.difficulty import DifficultySettings

PRELOAD = [*(m for m in GENERATION_PRELOAD if m != "solver.benchmark.difficulty"), "solver.pipelines.dataset.build"]
"""What the workers' server imports: generation's stack but the difficulty measure, which only a request with
``--difficulty`` runs (its tasks bring it along: about 0.015 CPU s a worker, beside seconds a puzzle)."""


@dataclass(frozen=True)
class EntryTask:
    """What a worker needs to make one entry: the entry and the shard folder to write it into."""

    index: int
    generator: str
    seed: int
    params: Any
    shard_dir: str
    mjcf: bool = False  # also write the puzzle's MJCF
    difficulty: DifficultySettings | None = None  # measure it into puzzle.json
    shard: int | None = None  # the shard's number: the worker then sends the puzzle's manifest row back
    generators: tuple[str, ...] = ()  # the request's: the workers' server prepares for them all (_server_hint)
    entries: int = 0  # the request's: a large one's server generates the hint's puzzle even with a record

    @property
    def name(self) -> str:
        return f"{self.generator}_{self.seed}"


@dataclass(frozen=True)
class EntryOutcome:
    """What a worker reports: ``ok`` (its folder is written), or the error. ``lost``: the worker died
    without reporting (the error says how)."""

    index: int
    ok: bool
    error: str | None = None
    seconds: float | None = None
    validation_checks: int | None = None
    lost: bool = False
    row: ManifestRow | None = None  # the written folder's manifest row, read back by the worker (see make_entry)

    @property
    def record(self) -> dict[str, Any]:
        """The generation record's cost columns of a manifest row."""
        return {"seconds": self.seconds, "validation_checks": self.validation_checks}


Backend = Callable[[Iterable[EntryTask], int, Callable[[list[EntryTask]], None] | None], Iterator[EntryOutcome]]
"""``backend(tasks, workers, on_running)``: :func:`make_entry` for every task, each in a fresh process,
outcomes yielded as they come (any order); ``on_running`` gets the running tasks now and then."""


# -- the worker side -----------------------------------------------------------------
def make_entry(task: EntryTask) -> EntryOutcome:
    """Generate one puzzle and write its record, then its folder (runs in a fresh worker process)."""
    started = time.perf_counter()
    stats: dict[str, Any] = {}
    puzzle = None
    error = None
    try:
        puzzle = generate_here(task.generator, task.seed, task.params, stats=stats)
        if task.difficulty is not None:
            from solver.benchmark.difficulty import measure_difficulty

            puzzle = replace(puzzle, difficulty=measure_difficulty(puzzle.chain, puzzle.goal, puzzle.name,
                                                                   task.difficulty))
    except (ParameterError, GenerationError) as exc:
        error = str(exc)
    except Exception as exc:  # a bug: keep the traceback in the manifest
        if asked_to_stop(exc):
            raise  # not the puzzle's failure: no record, so that a resume makes it
        error = f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}"
    outcome = EntryOutcome(task.index, error is None, error, time.perf_counter() - started,
                           stats.get("validation_checks"))
    from phyrogen_core.export import write_mjcf, write_puzzle

    shard_dir = Path(task.shard_dir)
    with deferred_signals():  # stopped now, a worker finishes every file first
        write_record(shard_dir, task, outcome)
        if puzzle is not None:
            folder = write_puzzle(puzzle, shard_dir, versions())
            if task.mjcf:
                write_mjcf(folder, puzzle.chain, puzzle.name, puzzle.certificate)
    if puzzle is not None and task.shard is not None:
        outcome = replace(outcome, row=_written_row(task, outcome))
    return outcome


def _written_row(task: EntryTask, outcome: EntryOutcome) -> ManifestRow | None:
    """The manifest row of the folder this worker has just written, read back from the folder as the
    command's process reads any folder (:func:`~solver.pipelines.dataset.manifest.puzzle_row`), so the
    row is the same by construction; that process then needs neither the reader nor its imports.
    None when the folder cannot be read: the command's process reads it again and reports why."""
    from solver.pipelines.dataset.request import Entry

    shard_dir = Path(task.shard_dir)
    entry = Entry(task.index, task.generator, task.seed, task.params)
    try:
        return puzzle_row(entry, task.shard, shard_dir.parent, shard_dir / task.generator / task.name, outcome.record)
    except Exception as exc:
        if asked_to_stop(exc):
            raise
        return None


def asked_to_stop(exc: BaseException) -> bool:
    """Whether ``exc`` is, or comes from, a request to stop the worker (SystemExit, KeyboardInterrupt).

    Compiled code reports one that a signal handler raised inside it as a SystemError: Ray's SIGTERM
    to a worker whose owner died (the killed command's) arrived in the compiled judge, and the
    worker recorded its puzzle as failed, which the resumed dataset then counted as done."""
    seen: BaseException | None = exc
    while seen is not None:
        if isinstance(seen, (SystemExit, KeyboardInterrupt)):
            return True
        seen = seen.__cause__ or seen.__context__
    return False


def write_record(shard_dir: Path, task: EntryTask, outcome: EntryOutcome) -> Path:
    from solver.pipelines.dataset.request import parameters_json

    record = {"index": task.index, "generator": task.generator, "seed": task.seed,
              "parameters": parameters_json(task.params), "ok": outcome.ok, "error": outcome.error,
              "seconds": outcome.seconds, "validation_checks": outcome.validation_checks}
    data = json.dumps(record, sort_keys=True, allow_nan=False).encode()
    return write_file_atomic(shard_dir / RECORDS_FOLDER / f"{task.name}.json", data)


# -- backends ------------------------------------------------------------------------
BATCH_SIZE = 32
"""Entries of Lockbox Random's size (:data:`REFERENCE_OBJECTS`) that one worker process makes in a row.
Every puzzle seeds its random sources itself (OMPL's included, :func:`solver.planning.ompl_setup.seed_ompl`),
so a batch gives the puzzles single processes give. A fresh worker costs about 0.02-0.03 CPU s (the
server's fork, about 0.008, and the pages of the server's the worker then touches and so copies, about
0.013, before it has made its first puzzle: 2-core dev machine), a Simple Slider or Grid World puzzle
0.009-0.014. A request of fewer than 32 entries per worker is cut into four batches per worker instead, so
that every worker gets a share. Smaller puzzles run in longer batches, larger ones in shorter
(:func:`_batch_length`), so that no batch holds more work than a full one of the reference size and no
worker is left with a long queue at the end."""
REFERENCE_OBJECTS = 7
"""The objects of a puzzle of a full batch: the largest default size of the bundled generators (Lockbox
Random's seven parts, 0.05-0.07 CPU s a puzzle in a whole run: 32 of them are no long queue)."""
LONGEST_BATCH = 2 * BATCH_SIZE
"""The most entries a batch holds, however small its puzzles (four objects: Simple Slider's and Rooms'
benchmark sizes, 0.009-0.07 CPU s a puzzle)."""


def make_batch(batch: list[EntryTask]) -> list[EntryOutcome]:
    """:func:`make_entry` for each task of ``batch``, in one worker process."""
    return [make_entry(task) for task in batch]


def local_backend(tasks: Iterable[EntryTask], workers: int,
                  on_running: Callable[[list[EntryTask]], None] | None = None, *,
                  batch_size: int = BATCH_SIZE) -> Iterator[EntryOutcome]:
    """Tasks on this machine, in batches, each in a fresh process forked from a server (:mod:`solver.parallel.pool`)."""
    yield from _run_batches(task_pool(workers, workers, PRELOAD, server_hint=_server_hint), tasks, on_running,
                            batch_size, workers)


def ray_backend(address: str = LOCAL, *, batch_size: int = BATCH_SIZE) -> Backend:
    """A backend running the same batches as Ray tasks (:mod:`solver.parallel.ray_pool`): on a local Ray
    instance with ``workers`` CPUs (``address`` :data:`~solver.parallel.ray_pool.LOCAL`) or on the cluster
    at ``address``. Its workers are reused: every puzzle seeds its own random sources."""

    def backend(tasks: Iterable[EntryTask], workers: int,
                on_running: Callable[[list[EntryTask]], None] | None = None) -> Iterator[EntryOutcome]:
        yield from _run_batches(task_pool(workers, workers, PRELOAD, address, fresh=False), tasks, on_running,
                                batch_size, workers)

    return backend


def _run_batches(pool, tasks: Iterable[EntryTask], on_running: Callable[[list[EntryTask]], None] | None,
                 batch_size: int, workers: int) -> Iterator[EntryOutcome]:
    def heartbeat(batches: list[list[EntryTask]]) -> None:
        on_running([task for batch in batches for task in batch])

    with pool:
        for outcomes in pool.imap_unordered(make_batch, _batches(tasks, batch_size, workers),
                                            lookahead=max(1, LOOKAHEAD // batch_size),
                                            priority=_batch_cost,
                                            on_lost=_lost, heartbeat=heartbeat if on_running else None):
            yield from outcomes


def _batches(tasks: Iterable[EntryTask], size: int, workers: int = 1) -> Iterator[list[EntryTask]]:
    """``tasks`` cut into batches of entries of one cost (:func:`_cost_hint`), each in the order read."""
    tasks = iter(tasks)
    head = list(itertools.islice(tasks, size * workers))
    short = None
    if len(head) < size * workers:  # a small request: four batches a worker (see BATCH_SIZE)
        short = min(size, max(1, math.ceil(len(head) / (4 * workers))))
    open_batches: dict[tuple[float, int], list[EntryTask]] = {}
    for task in itertools.chain(head, tasks):
        scale, objects = _cost_hint(task)
        length = _batch_length(size, objects)
        key = (scale, length if short is None else min(short, length))
        batch = open_batches.setdefault(key, [])
        batch.append(task)
        if len(batch) == key[1]:
            yield open_batches.pop(key)
    yield from open_batches.values()


def _batch_length(size: int, objects: int) -> int:
    """How many entries of ``objects`` objects a batch holds: ``size`` at :data:`REFERENCE_OBJECTS`, more
    for smaller puzzles (up to twice ``size``: :data:`LONGEST_BATCH`) and fewer for larger ones, whose
    cost grows with the square of their objects (Move N Times, n = 2..5, 3..6 objects: 5.0-5.3 ms x
    objects^2 a puzzle, 2-core dev machine), so that a batch holds no more work than a full one of the
    largest default size; the largest puzzles run alone."""
    return max(1, min(2 * size, size * REFERENCE_OBJECTS ** 2 // max(1, objects) ** 2))


RECORD_ONLY_ENTRIES = 4 * LONGEST_BATCH
"""The most entries of a request whose server prepares from a record alone (:func:`_server_hint`): at most a
few batches per worker (each a few ms dearer than after a server that generated a puzzle), fewer than a
puzzle costs."""


def _server_hint(batch: list[EntryTask]) -> str | None:
    """What the workers' server prepares for (:func:`~solver.pipelines.generation.warm_hint`): the request's
    generators, whose records it loads (:mod:`solver.pipelines._warm_record`), and the first batch's first
    puzzle, generated there once when its generator has no record and it costs less than the server's
    warm-up of every kernel (about 0.45 CPU s); a larger puzzle (more than :data:`REFERENCE_OBJECTS`
    objects, whose cost grows with their square) leaves the server to that warm-up. A request of more than
    :data:`RECORD_ONLY_ENTRIES` entries has the puzzle generated even when its generator has a record: what the
    puzzle warms beyond the signatures saves each worker about 3 ms, worth a puzzle (0.01-0.05 CPU s) at
    that many batches."""
    task = batch[0]
    try:
        return warm_hint(task.generator, task.seed, task.params, also=task.generators,
                         generate=_cost_hint(task)[1] <= REFERENCE_OBJECTS, always=task.entries > RECORD_ONLY_ENTRIES)
    except Exception:  # (parameters that do not pickle: the workers get them otherwise, or report it)
        return None


def _batch_cost(batch: list[EntryTask]) -> float:
    return _cost_hint(batch[0])[0]  # (a batch holds entries of one cost)


def _cost_hint(task: EntryTask) -> tuple[float, int]:
    """The generator's validation budget scale for the task (the costliest puzzles start first) and the
    puzzle's objects (the Maker's iterations)."""
    try:
        made = get_generator(task.generator).build(task.seed, task.params)
        return float(made.budget_scale), int(made.n_objects)
    except Exception:  # the worker runs the task and reports what is wrong with it
        return 1.0, REFERENCE_OBJECTS


def _lost(batch: list[EntryTask], how: str) -> list[EntryOutcome]:
    """Outcomes of a batch whose worker died: what it finished (its records say), the rest lost."""
    return [_finished_outcome(task) or EntryOutcome(task.index, False, f"the worker process ended ({how}) before "
                                                    "it reported", lost=True) for task in batch]


def _finished_outcome(task: EntryTask) -> EntryOutcome | None:
    """The outcome a worker wrote for ``task`` before it died: its record, and its folder if ok."""
    try:
        record = json.loads((Path(task.shard_dir) / RECORDS_FOLDER / f"{task.name}.json").read_text("utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("index") != task.index:
        return None
    ok = record.get("ok") is True
    if ok and not (Path(task.shard_dir) / task.generator / task.name).is_dir():
        return None  # killed between its record and its folder
    return EntryOutcome(task.index, ok, record.get("error"), record.get("seconds"), record.get("validation_checks"))


# -- the parent side -----------------------------------------------------------------
@dataclass
class BuildResult:
    root: Path
    entries: int = 0
    ok: int = 0
    failed: int = 0
    generated: int = 0  # entries made by this run (the rest were found done)
    seconds: float = 0.0
    manifest: Path | None = None

    @property
    def reused(self) -> int:
        return self.entries - self.generated

    @property
    def puzzles_per_hour(self) -> float:
        return 3600.0 * self.generated / self.seconds if self.seconds > 0 else 0.0


@dataclass
class _Shard:
    index: int
    rows: dict[int, ManifestRow] = field(default_factory=dict)
    waiting: set[int] = field(default_factory=set)


def check_dataset_root(request: DatasetRequest, root: str | Path) -> Path:
    """Refuse, before anything is written, a root that cannot hold this dataset: unwritable, a
    dataset of another request, or a non-empty folder that is no dataset. Returns the root."""
    root = Path(root)
    require_writable_dir(root, "dataset folder")
    stored_file = root / DATASET_FILE
    if os.path.lexists(stored_file):
        try:
            stored = read_folder_json(stored_file, root)
        except ValueError as exc:
            raise DatasetError(f"{stored_file}: unreadable ({exc}); move the folder aside or choose another --out") \
                from None
        if not isinstance(stored, dict):
            raise DatasetError(f"{stored_file}: not a dataset request; choose another --out")
        difference = request_difference(stored, request)
        if difference is not None:
            raise DatasetError(f"{root} holds a dataset of another request ({difference}); run the same "
                               "command as before to resume it, or choose another --out")
        _check_puzzle_folders(request, root)
    elif root.is_dir() and any(not _root_temporary(name) for name in os.listdir(root)):
        raise DatasetError(f"{root} is not empty and holds no {DATASET_FILE}; choose an empty or new folder for "
                           "the dataset")
    return root


def _check_puzzle_folders(request: DatasetRequest, root: Path) -> None:
    """The puzzle folders already in the incomplete shards of the dataset ``root``, checked as
    their writers and readers will meet them, before any work: no link on the way (the puzzle would
    be written elsewhere), no link out of a folder nor a FIFO or device in it (its reader would refuse
    it only after the puzzle was made again), and with ``--mjcf`` no file of a user's at
    ``mjcf/<name>.xml`` (refused, as by ``generate --mjcf``). Only folders that exist are visited: a
    new dataset costs nothing."""
    from phyrogen_core.export.mjcf import check_mjcf_target

    for shard in range(request.shard_count):
        shard_dir = root / shard_name(shard)
        if not os.path.lexists(shard_dir) or part_is_complete(part_path(root, shard), request.shard_entries(shard)):
            continue
        for generator in request.generators:
            parent = shard_dir / generator
            if not os.path.lexists(parent):
                continue
            require_stage_folder(parent, "dataset shard folder", root=root)
            entry = re.compile(rf"{re.escape(generator)}_\d+").fullmatch
            for name in sorted(n for n in os.listdir(parent) if entry(n)):
                folder = require_stage_folder(parent / name, "puzzle folder", root=root)
                if folder.is_dir():
                    require_no_escapes(folder)
                    if request.mjcf:
                        check_mjcf_target(folder, name)


def build_dataset(request: DatasetRequest, root: str | Path, workers: int = 2, *,
                  backend: Backend = local_backend,
                  on_row: Callable[[ManifestRow, bool], None] | None = None,
                  on_skip: Callable[[int], None] | None = None,
                  on_shard: Callable[[int, list[ManifestRow]], None] | None = None,
                  on_running: Callable[[list[EntryTask]], None] | None = None) -> BuildResult:
    """Make (or finish) the dataset ``request`` in ``root`` and return what was done.

    ``on_row(row, made_now)`` gets every entry's manifest row as it is known (``made_now`` False
    for an entry found done in an incomplete shard); ``on_skip(count)`` the number of entries of
    each complete shard, which is skipped; ``on_shard(shard, rows)`` every shard completed by this
    run. Interrupted (an exception, Ctrl-C), it stops the workers; everything finished so far
    stays, and a later call resumes.
    """
    try:
        import pyarrow  # noqa: F401  (found missing before anything is written)
    except ImportError:
        raise DatasetError("datasets need pyarrow: pip install 'phyrogen[datasets]'") from None
    started = time.perf_counter()
    root = check_dataset_root(request, root)
    result = BuildResult(root, entries=request.size)
    root.mkdir(parents=True, exist_ok=True)
    with exclusive(root):
        check_dataset_root(request, root)  # again, now that no other run can write it
        if not (root / DATASET_FILE).is_file():
            stored = json.dumps({**request.to_json(), "versions": versions()}, sort_keys=True, indent=2) + "\n"
            write_file_atomic(root / DATASET_FILE, stored.encode())
        remove_temporary_files(root, _ROOT_FILES.__contains__)
        remove_temporary_files(root / PARTS_FOLDER, _PART_FILE.fullmatch)
        pending = []
        for shard in range(request.shard_count):
            if part_is_complete(part_path(root, shard), request.shard_entries(shard)):
                remove_records(request, _clean_shard(request, root, shard), shard)
                if on_skip is not None:
                    on_skip(len(request.shard_entries(shard)))
            else:
                pending.append(shard)
        shards: dict[int, _Shard] = {}

        def tasks() -> Iterator[EntryTask]:
            for shard in pending:
                state, todo = _scan_shard(request, root, shard, on_row)
                shards[shard] = state
                yield from todo

        def finish_ready() -> None:
            for shard in sorted(shards):
                state = shards[shard]
                if state.waiting:
                    continue
                rows = [state.rows[i] for i in request.shard_entries(shard)]
                write_part(part_path(root, shard), rows)
                remove_records(request, root / shard_name(shard), shard)
                del shards[shard]
                if on_shard is not None:
                    on_shard(shard, rows)

        with contextlib.closing(backend(tasks(), workers, on_running)) as outcomes:
            for outcome in outcomes:
                shard = request.shard_of(outcome.index)
                state = shards[shard]
                entry = request.entry(outcome.index)
                if outcome.ok:
                    row = outcome.row
                    if row is None or (row.index, row.shard) != (outcome.index, shard):  # none sent: read here
                        row = puzzle_row(entry, shard, root, _folder(root, shard, entry), outcome.record)
                else:
                    row = failed_row(entry, shard, outcome.error or "failed", outcome.record)
                state.rows[outcome.index] = row
                state.waiting.discard(outcome.index)
                result.generated += 1
                if on_row is not None:
                    on_row(row, True)
                finish_ready()
        finish_ready()  # shards found complete after the last outcome
        if shards:
            raise RuntimeError(f"shards {sorted(shards)} still wait for entries the backend did not return")
        result.manifest = write_manifest(root, [part_path(root, s) for s in range(request.shard_count)])
    _count(result)
    result.seconds = time.perf_counter() - started
    return result


def _count(result: BuildResult) -> None:
    status = read_parquet(result.manifest, ["status"]).column("status").to_pylist()
    result.ok = status.count("ok")
    result.failed = len(status) - result.ok


def _folder(root: Path, shard: int, entry: Entry) -> Path:
    return root / shard_name(shard) / entry.generator / entry.name


def _scan_shard(request: DatasetRequest, root: Path, shard: int,
                on_row: Callable[[ManifestRow, bool], None] | None) -> tuple[_Shard, list[EntryTask]]:
    """What of an incomplete shard is done (rows) and what is left to do (tasks)."""
    shard_dir = _clean_shard(request, root, shard)
    state = _Shard(shard)
    todo: list[EntryTask] = []
    for entry in request.entries(request.shard_entries(shard)):
        record = read_record(shard_dir, entry)
        row = None
        folder = _folder(root, shard, entry)
        if folder.is_dir() and not (request.mjcf and not _has_mjcf(folder, entry.name)):
            # (A folder killed between its URDF and its MJCF is made again: the same puzzle, so
            # only the MJCF is new.)
            try:
                row = puzzle_row(entry, shard, root, folder, record if record and record.get("ok") else None)
            except (PuzzleFormatError, FileNotFoundError):
                row = None  # torn by hand, or of another request: made again
        elif record is not None and not record.get("ok"):
            row = failed_row(entry, shard, str(record.get("error") or "failed"), record)
        if row is not None:
            state.rows[entry.index] = row
            if on_row is not None:
                on_row(row, False)
        else:
            state.waiting.add(entry.index)
            todo.append(EntryTask(entry.index, entry.generator, entry.seed, entry.params, str(shard_dir),
                                  request.mjcf, request.difficulty, shard, tuple(request.generators), request.size))
    return state, todo


def _has_mjcf(folder: Path, name: str) -> bool:
    from phyrogen_core.export.mjcf import mjcf_path

    return mjcf_path(folder, name).is_file()


def _clean_shard(request: DatasetRequest, root: Path, shard: int) -> Path:
    """Remove what killed writers left in a shard's folder; returns the folder."""
    shard_dir = root / shard_name(shard)
    for generator in request.generators:
        remove_temporary_files(shard_dir / generator, re.compile(rf"{re.escape(generator)}_\d+").fullmatch)
    remove_temporary_files(shard_dir / RECORDS_FOLDER, lambda entry: entry.endswith(".json"))
    return shard_dir


_ROOT_FILES = (DATASET_FILE, MANIFEST_FILE)
_PART_FILE = re.compile(r"shard-\d{5,}\.parquet")


def _root_temporary(name: str) -> bool:
    """Whether ``name`` in a dataset root is a temporary entry of this stage's own files."""
    return temporary_entry(name) in _ROOT_FILES
