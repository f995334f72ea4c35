"""The journal of finished runs (``<out>/runs.jsonl``): each run's key (everything that decides its
result), one JSON line per run, the reader a resumed benchmark uses and the locked appender."""

from __future__ import annotations

import fcntl
import hashlib
import json
import math
import os
import stat
from dataclasses import asdict, dataclass
from pathlib import Path

from phyrogen_core.folder import OutputError, PuzzleFolder, read_folder_file
from solver.benchmark.jobs import RunJob, RunRecord
from solver.benchmark.ompl_log import STATUS_NAMES
from solver.planning.anytime import END_REASONS
from solver.planning.registry import PLANNERS, get_planner

JOURNAL = "runs.jsonl"
"""The journal of finished runs in the output folder: one JSON object a line, ``{"key": ..., "record": ...}``."""
JOURNAL_FORMAT = 2
"""2: keys name the planner's version, the goal seed and the until-first mode (format 1 keys match none)."""


def puzzle_digest(puzzle: PuzzleFolder) -> str:
    """SHA-256 over every file the planners read of ``puzzle``: ``puzzle.json``, the URDF, its meshes.

    Run the strict reader first: this function trusts the URDF to parse.
    """
    import xml.etree.ElementTree as ET

    name = PuzzleFolder.open(puzzle.path).name
    urdf = PuzzleFolder(puzzle.path, name).urdf
    urdf_bytes = read_folder_file(urdf, puzzle.path)
    meshes = sorted({m.get("filename", "") for m in ET.fromstring(urdf_bytes).iter("mesh")})
    digest = hashlib.sha256()
    for path in [puzzle.metadata, urdf] + [urdf.parent / m for m in meshes]:
        label = os.path.relpath(path, puzzle.path).encode()
        data = urdf_bytes if path == urdf else read_folder_file(path, puzzle.path)
        # Lengths first, so that no two different sets of files can hash the same stream.
        digest.update(len(label).to_bytes(8, "little") + label + len(data).to_bytes(8, "little") + data)
    return digest.hexdigest()


def run_key(job: RunJob, digest: str, ompl_version: str) -> str:
    """Everything a run's result depends on, as canonical JSON: equal keys, interchangeable runs.

    The planner's version changes with its code or settings (and the goal sampler's), so a run
    recorded before such a change is not reused under the same planner name."""
    return json.dumps({"planner": job.planner, "planner_version": get_planner(job.planner).version,
                       "puzzle": job.puzzle.name, "puzzle_sha256": digest,
                       "run": job.run, "seed": job.seed, "goal_seed": job.goal_seed, "time_limit": job.time_limit,
                       "progress_interval": job.progress_interval, "until": "first" if job.until_first else "limit",
                       "ompl": ompl_version, "format": JOURNAL_FORMAT,
                       # Only when set, so that the keys of runs without a budget are what they were.
                       **({} if job.budget_checks is None else {"budget_checks": job.budget_checks}),
                       **({} if job.budget_cpu is None else {"budget_cpu": job.budget_cpu})},
                      sort_keys=True)


def _finite_or_none(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None  # strict JSON has no infinity; only progress costs are infinite ("no solution yet")
    if isinstance(value, list | tuple):
        return [_finite_or_none(v) for v in value]
    return value


_RECORD_TYPES = {
    "planner": str, "puzzle": str, "run": int, "seed": int, "time_limit": float, "solved": bool, "status": str,
    "time": float, "first_solution_time": float | None, "action_cost": int | None, "length": float | None,
    "iterations": int, "rejected": int, "wall": float, "error": str | None, "best_solution_time": float | None,
    "checks": int | None, "cpu_time": float | None, "first_solution_checks": int | None, "end": str | None,
}
_ADDED_FIELDS = {"checks", "cpu_time", "first_solution_checks", "end"}
"""RunRecord fields added after journals were first written: a record without them reads as None."""


class JournalFormatError(ValueError):
    """A journal line that is not a run's entry; the message, one line, names the field and why."""


@dataclass(frozen=True)
class JournalEntry:
    """One line of the journal: a finished run's :class:`RunRecord` under its key (:func:`run_key`).

    :meth:`from_line` is the one strict reader of the format: a line is one JSON object
    ``{"key": {...}, "record": {...}}`` (strict JSON: no NaN or Infinity); the key names a registered
    planner whose title, and the puzzle, run and seed, are the record's; the record has every field
    of :class:`RunRecord` (those of :data:`_ADDED_FIELDS` may be missing in older lines: None), each
    of its type, numbers finite, ``status`` one of OMPL's, ``end`` one of the end reasons; a progress
    sample is ``[time, best cost or null (none yet), iterations]``."""

    key: str
    """The run's key as canonical JSON (sorted keys): equal keys, interchangeable runs."""
    record: RunRecord

    def to_line(self) -> bytes:
        """The entry's journal line, newline included (infinite progress costs written as null)."""
        data = {"key": json.loads(self.key),
                "record": {k: _finite_or_none(v) for k, v in asdict(self.record).items()}}
        return (json.dumps(data, sort_keys=True, allow_nan=False) + "\n").encode()

    @classmethod
    def from_line(cls, line: bytes | str) -> JournalEntry:
        """The entry of one journal line; :class:`JournalFormatError` saying what is wrong otherwise."""
        try:
            data = json.loads(line, parse_constant=_refuse_constant)
        except RecursionError:
            raise JournalFormatError("not a journal line: JSON nested too deep") from None
        except ValueError as exc:
            raise JournalFormatError(f"not JSON: {exc}") from None
        if not isinstance(data, dict):
            raise JournalFormatError(f"expected an object with 'key' and 'record', got {_show(data)}")
        for part in ("key", "record"):
            if part not in data:
                raise JournalFormatError(f"no {part!r}: a journal line is {{\"key\": ..., \"record\": ...}}")
            if not isinstance(data[part], dict):
                raise JournalFormatError(f"{part} must be an object, got {_show(data[part])}")
        key, raw = data["key"], data["record"]
        fields = set(RunRecord.__dataclass_fields__)
        missing = sorted(fields - _ADDED_FIELDS - set(raw))
        if missing:
            raise JournalFormatError(f"record has no {missing[0]!r}")
        unknown = sorted(set(raw) - fields)
        if unknown:
            raise JournalFormatError(f"record has unknown field {_show(unknown[0])}")
        raw = {name: None for name in _ADDED_FIELDS} | raw
        for name, kind in _RECORD_TYPES.items():
            _check(f"record.{name}", raw[name], kind)
        if raw["status"] not in STATUS_NAMES:
            raise JournalFormatError(f"record.status {_show(raw['status'])} is none of OMPL's: {list(STATUS_NAMES)}")
        if raw["end"] not in (None, *END_REASONS):
            raise JournalFormatError(f"record.end {_show(raw['end'])} is none of {list(END_REASONS)}")
        record = RunRecord(**{**raw, "progress": _progress(raw["progress"]), "path": _path(raw["path"]),
                              "joint_order": _names(raw["joint_order"])})
        planner = key.get("planner")
        spec = PLANNERS.get(planner) if isinstance(planner, str) else None
        if spec is None:
            raise JournalFormatError(f"key.planner {_show(planner)} is no registered planner")
        if (spec.title, key.get("puzzle"), key.get("run"), key.get("seed")) != (
                record.planner, record.puzzle, record.run, record.seed):
            raise JournalFormatError(f"the record's planner, puzzle, run and seed ({record.planner!r}, "
                                     f"{record.puzzle!r}, {record.run}, {record.seed}) are not its key's")
        return cls(json.dumps(key, sort_keys=True), record)


def _refuse_constant(name: str):
    raise JournalFormatError(f"{name} is not a finite number (strict JSON has none)")


def _show(value: object, width: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."


def _check(where: str, value: object, kind) -> None:
    kinds = (kind,) if isinstance(kind, type) else kind.__args__
    if isinstance(value, bool) or value is None:
        fits = type(value) in kinds
    elif isinstance(value, int):
        fits = int in kinds or float in kinds  # JSON may write a whole float as an integer
    else:
        fits = isinstance(value, kinds)
    if not fits:
        names = " or ".join("null" if k is type(None) else k.__name__ for k in kinds)
        raise JournalFormatError(f"{where} = {_show(value)} must be {names}")
    if isinstance(value, float) and not math.isfinite(value):  # 1e400 reads as infinity
        raise JournalFormatError(f"{where} = {value!r} is not a finite number")


def _number(where: str, value: object) -> float:
    _check(where, value, float)
    return float(value)


def _progress(samples: object) -> tuple[tuple[float, float, int], ...]:
    if not isinstance(samples, list):
        raise JournalFormatError(f"record.progress = {_show(samples)} must be a list")
    out = []
    for i, sample in enumerate(samples):
        where = f"record.progress[{i}]"
        if not isinstance(sample, list) or len(sample) != 3:
            raise JournalFormatError(f"{where} = {_show(sample)} must be [time, best cost or null, iterations]")
        _check(where + "[2]", sample[2], int)
        out.append((_number(where + "[0]", sample[0]),
                    math.inf if sample[1] is None else _number(where + "[1]", sample[1]), sample[2]))
    return tuple(out)


def _path(states: object) -> tuple[tuple[float, ...], ...]:
    if not isinstance(states, list) or not all(isinstance(state, list) for state in states):
        raise JournalFormatError(f"record.path = {_show(states)} must be a list of states (lists of numbers)")
    return tuple(tuple(_number(f"record.path[{i}][{j}]", v) for j, v in enumerate(state))
                 for i, state in enumerate(states))


def _names(names: object) -> tuple[str, ...]:
    if not isinstance(names, list) or not all(isinstance(name, str) for name in names):
        raise JournalFormatError(f"record.joint_order = {_show(names)} must be a list of joint names")
    return tuple(names)


def journal_line(key: str, record: RunRecord) -> bytes:
    """The journal line of ``record`` under ``key`` (:meth:`JournalEntry.to_line`)."""
    return JournalEntry(key, record).to_line()


def parse_journal_line(line: bytes) -> tuple[str, RunRecord] | None:
    """(key, record) of one journal line, or None when the line is torn, foreign or malformed
    (:meth:`JournalEntry.from_line` says why)."""
    try:
        entry = JournalEntry.from_line(line)
    except JournalFormatError:
        return None
    return entry.key, entry.record


def read_journal(path: Path, strict: bool = False) -> dict[str, RunRecord]:
    """The runs recorded in a journal, by key (the last one of a key wins); {} when there is none.

    Every line is read by :meth:`JournalEntry.from_line`. A last line without its newline is torn
    (a process killed mid-write) and skipped. Another line that is no entry is skipped too when a
    benchmark resumes (it costs that one run, run again), and with ``strict`` (a report or a merge
    of finished benchmarks, which would otherwise silently count fewer runs) raises
    :class:`JournalFormatError` ``"<path>: line <n>: ..."``.
    """
    path = Path(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return {}
    except OSError as exc:
        raise OutputError(f"journal {path} cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise OutputError(f"journal {path} is not a regular file; remove it or choose another output folder")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise OutputError(f"journal {path} cannot be read: {exc.strerror or exc}") from None
    runs: dict[str, RunRecord] = {}
    lines = raw.split(b"\n")
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            entry = JournalEntry.from_line(line)
        except JournalFormatError as exc:
            if strict and number < len(lines):  # the last piece has no newline: torn, not malformed
                raise JournalFormatError(f"{path}: line {number}: {exc}") from None
            continue
        runs[entry.key] = entry.record
    return runs


class Journal:
    """The output folder's journal, open for appending and locked against a second benchmark."""

    def __init__(self, path: Path):
        self.path = Path(path)
        # O_NOFOLLOW: a link there would take the journal outside the folder (refused up front as well).
        self._fd = os.open(self.path, os.O_RDWR | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o644)
        try:
            try:
                fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise OutputError(f"{self.path.parent} is in use by another benchmark (its {JOURNAL} is "
                                  "locked); wait for it or choose another output folder") from None
            self._cut_torn_tail()
            os.fsync(self._fd)
            _fsync_dir(self.path.parent)
        except BaseException:
            os.close(self._fd)
            raise

    def _cut_torn_tail(self) -> None:
        # Appending after a torn line would glue the next record onto it; cut the torn part off.
        size = os.fstat(self._fd).st_size
        end = size
        while end > 0:
            start = max(0, end - 65536)
            chunk = os.pread(self._fd, end - start, start)
            newline = chunk.rfind(b"\n")
            if newline >= 0:
                end = start + newline + 1
                break
            end = start
        if end != size:
            os.ftruncate(self._fd, end)

    def append(self, key: str, record: RunRecord) -> None:
        data = memoryview(journal_line(key, record))
        while data:
            data = data[os.write(self._fd, data):]
        os.fsync(self._fd)

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)  # releases the lock
            self._fd = -1

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)

