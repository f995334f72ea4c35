"""The journal of finished runs (``<out>/runs.jsonl``): each run's key (everything that decides its
result), one JSON line per run, the reader a resumed benchmark uses and the locked appender."""

from __future__ import annotations

import fcntl
import hashlib
import json
import math
import os
import stat
from dataclasses import asdict
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


def journal_line(key: str, record: RunRecord) -> bytes:
    data = {"key": json.loads(key), "record": {k: _finite_or_none(v) for k, v in asdict(record).items()}}
    return (json.dumps(data, sort_keys=True, allow_nan=False) + "\n").encode()


_RECORD_TYPES = {
    "planner": str, "puzzle": str, "run": int, "seed": int, "time_limit": float, "solved": bool, "status": str,
    "time": float, "first_solution_time": float | None, "action_cost": int | None, "length": float | None,
    "iterations": int, "rejected": int, "wall": float, "error": str | None, "best_solution_time": float | None,
    "checks": int | None, "cpu_time": float | None, "first_solution_checks": int | None, "end": str | None,
}
_ADDED_FIELDS = {"checks", "cpu_time", "first_solution_checks", "end"}
"""RunRecord fields added after journals were first written: a record without them reads as None."""


def _fits(value: object, kind) -> bool:
    kinds = (kind,) if isinstance(kind, type) else kind.__args__
    if isinstance(value, bool) or value is None:
        return type(value) in kinds
    if isinstance(value, int):
        return int in kinds or float in kinds  # JSON may write a whole float as an integer
    return isinstance(value, kinds)


def parse_journal_line(line: bytes) -> tuple[str, RunRecord] | None:
    """(key, record) of one journal line, or None when the line is torn, foreign or malformed."""
    try:
        data = json.loads(line)
        key, raw = data["key"], data["record"]
        fields = set(RunRecord.__dataclass_fields__)
        if not isinstance(key, dict) or not isinstance(raw, dict) or not fields - _ADDED_FIELDS <= set(raw) <= fields:
            return None
        raw = {name: None for name in _ADDED_FIELDS} | raw
        if not all(_fits(raw[name], kind) for name, kind in _RECORD_TYPES.items()) \
                or raw["status"] not in STATUS_NAMES or raw["end"] not in (None, *END_REASONS):
            return None
        progress = tuple((float(t), math.inf if c is None else float(c), int(i)) for t, c, i in raw["progress"])
        path = tuple(tuple(float(v) for v in state) for state in raw["path"])
        joint_order = tuple(raw["joint_order"])
        if not all(isinstance(n, str) for n in joint_order):
            return None
        record = RunRecord(**{**raw, "progress": progress, "path": path, "joint_order": joint_order})
        spec = PLANNERS.get(key.get("planner"))
        if spec is None or (spec.title, key.get("puzzle"), key.get("run"), key.get("seed")) != (
                record.planner, record.puzzle, record.run, record.seed):
            return None
        return json.dumps(key, sort_keys=True), record
    except (ValueError, TypeError, KeyError, AttributeError, RecursionError):
        return None


def read_journal(path: Path) -> dict[str, RunRecord]:
    """The runs recorded in a journal, by key (the last one of a key wins); {} when there is none.

    Lines that do not parse are skipped: a torn last line, left by a process killed mid-write,
    costs that one run and nothing else.
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
    for line in raw.split(b"\n"):
        parsed = parse_journal_line(line) if line.strip() else None
        if parsed is not None:
            runs[parsed[0]] = parsed[1]
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

