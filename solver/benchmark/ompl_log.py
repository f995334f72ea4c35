"""OMPL's benchmark log (one per puzzle, an *experiment*) and the SQLite database OMPL's own reader
builds from the logs (Planner Arena's format)."""

from __future__ import annotations

import contextlib
import io
import math
import os
import platform
from collections.abc import Iterable, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path

from solver.benchmark.jobs import RunRecord
from solver.planning.anytime import END_REASONS

STATUS_NAMES = ("Unknown status", "Invalid start", "Invalid goal", "Unrecognized goal type", "Timeout",
                "Approximate solution", "Exact solution", "Crash", "Abort")
"""OMPL's PlannerStatus values, in enum order (the log stores the index)."""

RUN_PROPERTIES = (
    ("time", "REAL"),
    ("solved", "BOOLEAN"),
    ("status", "ENUM"),
    ("solution length", "REAL"),
    ("action cost", "INTEGER"),
    ("time to first solution", "REAL"),
    ("iterations", "INTEGER"),
    ("seed", "INTEGER"),
    ("rejected paths", "INTEGER"),
    ("collision checks", "INTEGER"),
    ("cpu time", "REAL"),
    ("checks to first solution", "INTEGER"),
    ("end reason", "ENUM"),
)
PROGRESS_PROPERTIES = (("time", "REAL"), ("best cost", "REAL"), ("iterations", "INTEGER"))
ENUMS = (("status", STATUS_NAMES), ("end reason", END_REASONS))
"""The logs' enum types: OMPL's status, and why a run ended (:data:`~solver.planning.anytime.END_REASONS`)."""

def _value(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "inf" if isinstance(v, float) and math.isinf(v) else ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def write_log(path: Path, experiment: str, records: Sequence[RunRecord], planner_titles: Sequence[str],
              time_limit: float, runs: int, base_seed: int, total_seconds: float, setup: str,
              until_first: bool = False, versions: Mapping[str, str] | None = None,
              budget_checks: int | None = None, budget_cpu: float | None = None) -> None:
    """Write OMPL's benchmark log for one experiment (one puzzle, several planners). Each planner's
    common properties hold the time limit, whether runs stopped at their first solution
    (``until_first``) and, when given, its version (``versions``: title -> version) and the runs'
    budget (``budget_checks``, or ``budget_cpu`` with ``machine_dependent``); each run's ``end reason``
    says what ended it."""
    if any(c.isspace() for c in experiment):
        raise ValueError(f"experiment name {experiment!r} must not contain white space (OMPL logs split on it)")
    from importlib.metadata import version

    lines = [
        f"OMPL version {version('ompl')}",
        f"Experiment {experiment}",
        f"Running on {platform.node() or 'unknown'}",
        f"Starting at {datetime.now(UTC).strftime('%Y-%b-%d %H:%M:%S')}",
        "<<<|", setup.rstrip("\n"), "|>>>",
        "<<<|", f"{platform.machine()} {platform.processor() or ''} {os.cpu_count()} cores".strip(), "|>>>",
        f"{base_seed} is the random seed",
        f"{time_limit:g} seconds per run",
        "0 MB per run",
        f"{runs} runs per planner",
        f"{total_seconds:.3f} seconds spent to collect the data",
        f"{len(ENUMS)} enum types",
        *("|".join((name, *values)) for name, values in ENUMS),
        f"{len(planner_titles)} planners",
    ]
    for title in planner_titles:
        mine = sorted((r for r in records if r.planner == title), key=lambda r: r.run)
        common = [f"time_limit REAL = {time_limit:g}", f"until_first BOOLEAN = {int(bool(until_first))}"]
        if versions and title in versions:
            common.append(f"version STRING = {versions[title]}")
        if budget_checks is not None:
            common.append(f"budget_checks INTEGER = {budget_checks}")
        if budget_cpu is not None:
            common += [f"budget_cpu REAL = {budget_cpu!r}", "machine_dependent BOOLEAN = 1"]
        lines += [title, f"{len(common)} common properties", *common, f"{len(RUN_PROPERTIES)} properties for each run"]
        lines += [f"{name} {kind}" for name, kind in RUN_PROPERTIES]
        lines.append(f"{len(mine)} runs")
        for r in mine:
            values = [r.time, r.solved, STATUS_NAMES.index(r.status), r.length, r.action_cost,
                      r.first_solution_time, r.iterations, r.seed, r.rejected, r.checks, r.cpu_time,
                      r.first_solution_checks, None if r.end is None else END_REASONS.index(r.end)]
            lines.append("".join(_value(v) + "; " for v in values))
        lines.append(f"{len(PROGRESS_PROPERTIES)} progress properties for each run")
        lines += [f"{name} {kind}" for name, kind in PROGRESS_PROPERTIES]
        lines.append(f"{len(mine)} runs")
        for r in mine:
            lines.append("".join(",".join(_value(v) for v in sample) + ",;" for sample in r.progress))
        lines.append(".")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def build_database(db_path: Path, logs: Iterable[Path]) -> None:
    """The SQLite database of the logs, built by OMPL's own reader (Planner Arena's format)."""
    from ompl.tools import computeViews, readBenchmarkLog

    with contextlib.redirect_stdout(io.StringIO()):  # the reader prints a line per log and planner
        readBenchmarkLog(str(db_path), [str(p) for p in logs], False)
        computeViews(str(db_path), False)


def is_benchmark_log(path: Path) -> bool:
    """Whether ``path`` is a log a benchmark wrote: a regular file ``<name>.log`` that opens as
    :func:`write_log` opens it (``OMPL version ...``, then ``Experiment <name>``). A user's
    ``my_analysis.log`` in ``logs/``, or a benchmark log they copied under another name, is not one."""
    path = Path(path)
    if path.suffix != ".log" or path.is_symlink() or not path.is_file():
        return False
    try:
        with open(path, "rb") as file:
            head = file.read(4096).split(b"\n")
    except OSError:
        return False
    return len(head) > 2 and head[0].startswith(b"OMPL version ") and \
        head[1] == f"Experiment {path.stem}".encode()
