"""Long work of the panel in a subprocess: start it, watch its progress, cancel it, read its result.

No bpy here (the operators of :mod:`.job_control` poll a :class:`Job` from a modal
timer, so Blender's UI never waits for it). A job is one command of
``phyrogen`` run in the project's Python (:func:`.environment.worker_python`)
in a process group of its own; its stdout and stderr go to files in a
temporary folder that is removed when the job is done. Cancelling sends
SIGTERM to the whole group, the signal the command line answers by stopping
its workers and leaving no half-written file (README, "One contract for every
command"), and SIGKILL to what is left after :data:`KILL_AFTER` seconds.
"""

from __future__ import annotations

import atexit
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from phyrogen_core.command_result import (
    BenchmarkResult,
    GenerateResult,
    ManipulationOutcome,
    ReplanResult,
)

from .environment import worker_python

KILL_AFTER = 5.0
"""Seconds a cancelled job's processes have to stop on SIGTERM before they are killed."""
_TAIL_BYTES = 8192
_COUNT = re.compile(r"(\d+)/(\d+) \[")  # tqdm's "47/50 [00:03<00:00, ...]"


@dataclass(frozen=True)
class JobResult:
    """How a finished job ended: its exit code, its whole stdout, and the last line of its output that
    names an error (else stderr's and stdout's last line)."""

    returncode: int
    stdout: str
    last_line: str
    cancelled: bool

    @property
    def ok(self) -> bool:
        return self.returncode == 0 and not self.cancelled


def phyrogen_command(*arguments: str) -> list[str]:
    """``phyrogen ARGUMENTS --json`` in the project's Python: the result comes as JSON on stdout, read by the
    command's reader in :mod:`phyrogen_core.command_result`."""
    return [worker_python(), "-m", "phyrogen", *arguments, "--json"]


class Job:
    """A command running in its own process group; :meth:`poll` it until it returns a :class:`JobResult`."""

    def __init__(self, label: str, command: Sequence[str], cwd: str | Path | None = None, note: str = ""):
        self.label = label
        self.note = note
        """What the job does before it shows progress, e.g. that it compiles the collision kernels first."""
        self.command = list(command)
        self.started = time.monotonic()
        self._folder = Path(tempfile.mkdtemp(prefix="phyrogen-job-"))
        self._stdout_path, self._stderr_path = self._folder / "stdout.txt", self._folder / "stderr.txt"
        self._cancelled_at: float | None = None
        self._result: JobResult | None = None
        try:
            with open(self._stdout_path, "wb") as stdout, open(self._stderr_path, "wb") as stderr:
                self.process = subprocess.Popen(self.command, stdin=subprocess.DEVNULL, stdout=stdout,
                                                stderr=stderr, cwd=cwd, start_new_session=True)
        except OSError:
            shutil.rmtree(self._folder, ignore_errors=True)
            raise
        _live.append(self)

    @property
    def pid(self) -> int:
        """The process id, which is also the id of the job's process group."""
        return self.process.pid

    @property
    def cancelling(self) -> bool:
        return self._cancelled_at is not None

    def elapsed(self) -> float:
        return time.monotonic() - self.started

    def progress(self) -> tuple[float | None, str]:
        """The latest progress: the fraction done (from a progress bar's ``n/total``; None when the
        command shows none) and the last line the command wrote on stderr."""
        line = _last_line(_tail(self._stderr_path))
        counts = _COUNT.findall(line)
        fraction = None
        if counts:
            done, total = (int(v) for v in counts[-1])
            fraction = done / total if total else None
        return fraction, line

    def status_text(self) -> str:
        """One line for the status bar: what runs, how far it is, how long it has run."""
        fraction, line = self.progress()
        if self.cancelling:
            return f"{self.label}: cancelling..."
        shown = f"{fraction:.0%}" if fraction is not None else "running"
        if (fraction is None or fraction == 0) and self.note:
            shown = self.note
        detail = line.split("]", 1)[-1].strip(" ,") if fraction is not None else ""
        detail = detail if len(detail) <= 60 else detail[:57] + "..."
        return (f"{self.label}: {shown}, {self.elapsed():.0f} s" + (f" ({detail})" if detail else "")
                + "  (Esc or right-click cancels)")

    def cancel(self) -> None:
        """Ask the job's whole process group to stop (SIGTERM); :meth:`poll` kills it if it lingers."""
        if self._cancelled_at is None and self._result is None:
            self._cancelled_at = time.monotonic()
            _signal_group(self.pid, signal.SIGTERM)

    def poll(self) -> JobResult | None:
        """The result once the process has ended (its group then gets no second chance), else None."""
        if self._result is not None:
            return self._result
        returncode = self.process.poll()
        if returncode is None:
            if self._cancelled_at is not None and time.monotonic() - self._cancelled_at > KILL_AFTER:
                _signal_group(self.pid, signal.SIGKILL)
            return None
        if self._cancelled_at is not None:  # workers that outlived the leader: killed, and gone (briefly waited for)
            _signal_group(self.pid, signal.SIGKILL)
            deadline = time.monotonic() + 2.0
            while group_alive(self.pid) and time.monotonic() < deadline:
                time.sleep(0.01)
        stdout = self._stdout_path.read_text(encoding="utf-8", errors="replace")
        # A --json result on stdout is no error line (its rows have "error" keys): stderr says what failed.
        last = _error_line(_tail(self._stderr_path) + ("" if stdout.lstrip().startswith("{") else "\n" + stdout))
        self._result = JobResult(returncode, stdout, last, self._cancelled_at is not None)
        shutil.rmtree(self._folder, ignore_errors=True)
        if self in _live:
            _live.remove(self)
        return self._result

    def wait(self, interval: float = 0.2) -> JobResult:
        """Block until the job ends (scripts and background mode; the panel polls instead)."""
        while True:
            result = self.poll()
            if result is not None:
                return result
            time.sleep(interval)


_live: list[Job] = []


@atexit.register
def _stop_live_jobs() -> None:
    """Blender quits: jobs still running would outlive it in their own process groups; stop them."""
    for job in list(_live):
        job.cancel()


def group_alive(pgid: int) -> bool:
    """Whether any process of process group ``pgid`` is left (zombies of this process aside)."""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return _group_has_live_member(pgid)


def _group_has_live_member(pgid: int) -> bool:
    proc = Path("/proc")
    if not proc.is_dir():
        return True
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            return True
    return False


def _signal_group(pgid: int, signum: int) -> None:
    try:
        os.killpg(pgid, signum)
    except (ProcessLookupError, PermissionError):
        pass


def _tail(path: Path) -> str:
    try:
        with open(path, "rb") as stream:
            stream.seek(0, os.SEEK_END)
            stream.seek(max(0, stream.tell() - _TAIL_BYTES))
            return stream.read().decode("utf-8", errors="replace")
    except OSError:
        return ""


def _last_line(text: str) -> str:
    """The last non-empty line, where a progress bar's carriage returns also end lines."""
    for line in reversed(re.split(r"[\r\n]", text)):
        if line.strip():
            return line.strip()
    return ""


def _error_line(text: str) -> str:
    """The last line that names an error or a failure (the command line's contract), else the last line."""
    lines = [line.strip() for line in re.split(r"[\r\n]", text) if line.strip()]
    named = [line for line in lines if "error" in line.lower() or "FAILED" in line]
    return (named or lines or [""])[-1]


def one_line_error(result: JobResult, label: str) -> str:
    """What a failed or cancelled job says, in one line."""
    if result.cancelled:
        return f"{label} cancelled"
    why = result.last_line
    return f"{label} failed (exit code {result.returncode})" + (f": {why}" if why else "")

# -- what the panel shows of each command's result (its --json object) ----------------------------


@dataclass(frozen=True)
class ResultTable:
    """A job's result as the panel's table: column titles and rows of cells (text)."""

    columns: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


def _seconds(value) -> str:
    return "-" if value is None else f"{value:.2g} s" if value < 10 else f"{value:.0f} s"


def generate_table(result: GenerateResult) -> ResultTable:
    """``phyrogen generate --json`` of one puzzle: what was made, one quantity a row."""
    (puzzle,) = result.puzzles
    return ResultTable(("Puzzle", f"{puzzle.generator}_{puzzle.seed}"),
                       (("Objects", str(puzzle.objects)), ("Actions", str(puzzle.actions)),
                        ("Time", _seconds(puzzle.seconds))))


def replan_table(result: ReplanResult) -> ResultTable:
    """``phyrogen replan --json``: the new certificate, one quantity a row."""
    return ResultTable(("Certificate", "new"),
                       (("Planner", str(result.planner)), ("Queries", str(result.queries)),
                        ("States", str(result.states)), ("Dependencies", str(result.dependencies))))


def benchmark_table(result: BenchmarkResult) -> ResultTable:
    """``phyrogen benchmark --json`` (``summary.json`` under ``summary``): per planner the solved runs of all
    runs and the median time to a first solution (over all runs; "none" when at most half solved)."""
    return ResultTable(("Planner", "Solved", "Time"),
                       tuple((cell.planner.removesuffix(" (ours)"), f"{cell.successes}/{cell.runs}",
                              "none" if cell.time_to_first is None else _seconds(cell.time_to_first))
                             for cell in result.cells))


def manipulation_table(report: ManipulationOutcome) -> ResultTable:
    """One ``phyrogen manipulate --json`` report: how the execution went, one quantity a row."""
    return ResultTable(("Execution", "succeeded" if report.success else "failed"),
                       (("Actions", str(report.actions)), ("Regrasps", str(report.regrasps)),
                        ("Planning", _seconds(report.planning_seconds)),
                        ("Execution", _seconds(report.execution_seconds))))


def manipulation_summary(report: ManipulationOutcome) -> str:
    """The outcome in a ``phyrogen manipulate`` report (``report.json``), in one line."""
    outcome = "succeeded" if report.success else f"failed: {report.message}"
    return f"{report.puzzle}: execution {outcome} with {report.solution}"
