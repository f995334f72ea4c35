"""The paper's Fig. 4 and the summary table, read back from the benchmark database.

Everything here reads the SQLite database that OMPL's tools built from our
logs, so the figure shows exactly what Planner Arena would show.
Per puzzle: success rate over time (share of runs with a solution by time t)
and action cost over time (median best cost over the runs solved by t).
Planners appear in the registry's order (:data:`solver.planning.registry.PLANNERS`),
each in its own colour. For a benchmark whose runs stopped at their first
solution (``until_first``) the cost is that of the first solution, and the
table and figure say so.

A run the wall-clock backstop ended before its budget (end reason ``clock``) is no result of that
budget: every statistic here counts only the other runs, and the table, ``summary.json`` and the
results page report the clock-ended ones apart and mark their cell incomplete.
"""

from __future__ import annotations

import json
import math
import sqlite3
import statistics
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from phyrogen_core.seeding import stable_rng
from solver.benchmark.database import BenchmarkData, DatabaseRun, planner_key, read_benchmark
from solver.benchmark.statistics import (
    BOOTSTRAP_RESAMPLES,
    CONFIDENCE,
    CellStatistics,
    Estimate,
    Proportion,
    cell_statistics,
    planner_totals,
)
from solver.planning.registry import PLANNERS

PLANNER_ORDER = tuple(spec.title for spec in PLANNERS.values())
"""Planner titles in the registry's order: the paper's LA-RRT, ours, RRT*, LBT-RRT, BIT*."""
COLORS = {"LA-RRT": "tab:green", "LA-RRT+push (ours)": "tab:purple", "RRT*": "tab:blue", "LBT-RRT": "tab:orange",
          "BIT*": "tab:red", "LA-RRT, original segment check": "tab:olive", "LA-RRT, fixed factor order": "tab:cyan"}
"""The paper's colours for its four planners, ours and the paper LA-RRT's two ablations (green's
neighbours); any other planner gets one of :data:`SPARE_COLORS`."""
SPARE_COLORS = ("tab:brown", "tab:pink", "tab:gray", "tab:olive", "tab:cyan")


def planner_color(title: str) -> str:
    """The colour of a planner in every plot: its own, else a spare one picked by its name (stable)."""
    if title in COLORS:
        return COLORS[title]
    return SPARE_COLORS[sum(map(ord, title)) % len(SPARE_COLORS)]


@dataclass(frozen=True)
class SummaryRow:
    experiment: str
    planner: str
    runs: int
    time_limit: float
    success: float  # share of runs solved, 0..1
    median_first_solution: float | None  # seconds, over solved runs
    median_action_cost: float | None  # final best cost, over solved runs
    statistics: CellStatistics | None = None  # intervals, solved all / any, medians over the counted runs
    clock_ended: int = 0  # runs the wall-clock backstop ended before their budget: not counted in ``runs``
    ends: tuple[tuple[str, int], ...] = ()  # (end reason, runs) of every run of the cell; ("unknown", n) for old ones
    machine_dependent: bool = False  # its runs had a budget in CPU seconds

    @property
    def complete(self) -> bool:
        """Every run of the cell is a result of its budget (none ended on the clock)."""
        return self.clock_ended == 0


def _connect(db_path: Path) -> sqlite3.Connection:
    if not Path(db_path).is_file():
        raise FileNotFoundError(f"{db_path}: no benchmark database")
    return sqlite3.connect(str(db_path))


def _planner_key(name: str) -> tuple[int, str]:
    return planner_key(name)


def checks_to_first(runs: Sequence[DatabaseRun]) -> list[int | None] | None:
    """Each run's collision checks up to its first solution (None for a run without one), or None
    when a solved run's count is unknown (:attr:`~solver.benchmark.database.DatabaseRun.checks_to_first_solution`)."""
    if not runs or any(r.solved and r.checks_to_first_solution is None for r in runs):
        return None
    return [r.checks_to_first_solution for r in runs]


def counted_runs(data: BenchmarkData, experiment: str, planner: str) -> list[DatabaseRun]:
    """The runs of a cell that are results of their budget: all but those the clock ended."""
    return [r for r in data.cell(experiment, planner) if not r.clock_ended]


def benchmark_statistics(data: BenchmarkData, method: str = "wilson") -> list[CellStatistics]:
    """Per puzzle (in the database's order) and planner (the registry's), the statistics of its counted
    runs (:func:`counted_runs`; a cell with none has none); each bootstrap seeded from (puzzle, planner,
    quantity), so the numbers are the same on every machine."""
    out = []
    for experiment in data.experiments:
        for planner in data.planners:
            runs = counted_runs(data, experiment, planner)
            if not runs:
                continue
            out.append(cell_statistics(
                experiment, planner, [r.solved for r in runs], [r.first_solution_time for r in runs],
                [r.action_cost for r in runs], checks_to_first(runs),
                lambda quantity, e=experiment, p=planner: stable_rng("benchmark-bootstrap", e, p, quantity),
                method))
    return out


def summary_rows(db_path: Path, method: str = "wilson") -> list[SummaryRow]:
    """Per puzzle and planner: success rate, median time to first solution and median final action
    cost over the solved runs, and the full :class:`~solver.benchmark.statistics.CellStatistics`."""
    data = read_benchmark(db_path)
    cells = {(c.experiment, c.planner): c for c in benchmark_statistics(data, method)}
    out = []
    for experiment in data.experiments:
        for planner in data.planners:
            every = data.cell(experiment, planner)
            if not every:
                continue
            runs = [r for r in every if not r.clock_ended]
            solved = [r for r in runs if r.solved]
            ends: dict[str, int] = {}
            for r in every:
                ends[r.end or "unknown"] = ends.get(r.end or "unknown", 0) + 1
            out.append(SummaryRow(
                experiment, planner, len(runs), data.time_limits[experiment],
                len(solved) / len(runs) if runs else 0.0,
                statistics.median(r.first_solution_time for r in solved) if solved else None,
                statistics.median(r.action_cost for r in solved) if solved else None,
                cells.get((experiment, planner)), len(every) - len(runs), tuple(sorted(ends.items())),
                any(r.budget_cpu is not None for r in every)))
    return out


def format_number(value: float, digits: int = 3) -> str:
    """A number for a table: ``digits`` significant digits, ``∞`` for "not within the budget"."""
    return "∞" if math.isinf(value) else f"{value:.{digits}g}"


def format_estimate(estimate: Estimate | None, digits: int = 3) -> str:
    """``median [low, high]``, or ``-`` when there is nothing to estimate."""
    if estimate is None:
        return "-"
    return (f"{format_number(estimate.value, digits)} "
            f"[{format_number(estimate.low, digits)}, {format_number(estimate.high, digits)}]")


def format_rate(proportion: Proportion) -> str:
    """``100 % [72, 100]``: the rate and its interval, in percent."""
    return (f"{100 * proportion.rate:.0f} % [{100 * proportion.low:.0f}, {100 * proportion.high:.0f}]")


def _estimate_json(estimate: Estimate | None) -> dict | None:
    # JSON has no infinity: a median "not within the budget" is null, with its interval's finite ends kept.
    if estimate is None:
        return None
    finite = lambda v: None if math.isinf(v) else v  # noqa: E731
    return {"median": finite(estimate.value), "low": finite(estimate.low), "high": finite(estimate.high),
            "samples": estimate.samples}


def summary_json(rows: Sequence[SummaryRow]) -> str:
    """The summary for programs (the Blender panel, scripts): one object per puzzle and planner with
    the success count, rate and interval, and the medians with their intervals (null: not within the
    budget, or nothing to estimate). ``summary.md`` is the same numbers for people."""
    cells = []
    for row in rows:
        cell = row.statistics
        common = {"puzzle": row.experiment, "planner": row.planner, "runs": row.runs,
                  "clock_ended": row.clock_ended, "complete": row.complete, "ends": dict(row.ends),
                  "machine_dependent": row.machine_dependent}
        if cell is None:  # every run ended on the clock: nothing of the budget to report
            cells.append(common | {"successes": 0, "rate": None, "rate_low": None, "rate_high": None,
                                   "interval": None, "solved_all": None, "solved_any": None, "time_to_first": None,
                                   "checks_to_first": None, "final_cost": None})
            continue
        cells.append(common | {
            "successes": cell.success.successes, "rate": cell.success.rate,
            "rate_low": cell.success.low, "rate_high": cell.success.high, "interval": cell.success.method,
            "solved_all": cell.solved_all, "solved_any": cell.solved_any,
            "time_to_first": _estimate_json(cell.time_to_first),
            "checks_to_first": _estimate_json(cell.checks_to_first),
            "final_cost": _estimate_json(cell.final_cost)})
    # Version 2: "runs" counts the budget's runs only; the clock-ended ones are "clock_ended" beside.
    return json.dumps({"format": "phyrogen-benchmark-summary", "version": 2,
                       "complete": all(row.complete for row in rows),
                       "machine_dependent": any(row.machine_dependent for row in rows), "cells": cells},
                      indent=2) + "\n"


INTERVAL_NAMES = {"wilson": "Wilson score", "clopper-pearson": "Clopper-Pearson"}


def statistics_legend(method: str = "wilson") -> str:
    """What the intervals and medians of the tables and the results page are, in one paragraph."""
    return (f"Success rate: successes of runs with a {100 * CONFIDENCE:.0f} % {INTERVAL_NAMES[method]} interval. "
            "Solved: in all runs (the paper's criterion) / in at least one run. Times and checks to the first "
            "solution: median over all runs, a run without a solution counting as ∞ (not within its limit or "
            f"budget); final action cost: median over the solved runs; each with a seeded percentile-bootstrap "
            f"{100 * CONFIDENCE:.0f} % interval ({BOOTSTRAP_RESAMPLES} resamples). Checks to the first solution: "
            "the run property `checks to first solution`, or in runs without it all the checks of a run that "
            "stopped there (`--until first`); '-' where a solved run's count is unknown.")


def summary_markdown(rows: Sequence[SummaryRow], profile=None, wall_seconds: float | None = None,
                     workers: int | None = None, reused: int = 0, until_first: bool = False,
                     method: str = "wilson") -> str:
    """The summary as Markdown: an overview (one line per puzzle, a column per planner), then per
    planner and puzzle the statistics with their intervals, then per planner the totals.

    ``reused``: runs of a resumed benchmark that an earlier session did (``wall_seconds`` is
    then this session's time only). ``until_first``: the runs stopped at their first solution,
    so the cost is the first solution's."""
    planners = sorted({r.planner for r in rows}, key=_planner_key)
    experiments = list(dict.fromkeys(r.experiment for r in rows))
    table = {(r.experiment, r.planner): r for r in rows}
    cells = [r.statistics for r in rows if r.statistics is not None]
    lines = []
    if profile is not None:
        session = f" in this session; {reused} runs resumed from an earlier one" if reused else ""
        lines.append(f"Profile `{profile.name}`: {profile.runs} runs per planner and puzzle"
                     + (f", {wall_seconds:.0f} s wall time on {workers} workers{session}" if wall_seconds else "")
                     + ".")
        lines.append("")
    if until_first:
        lines.append("Runs stopped at their first solution (`--until first`). Overview cells: runs solved within "
                     "the limit / median time to first solution [s] / median action cost of the first solution "
                     "(medians over solved runs).")
    else:
        lines.append("Overview cells: runs solved / median time to first solution [s] / median final action cost "
                     "(medians over solved runs).")
    lines.append("")
    lines.append("| puzzle | limit [s] | " + " | ".join(planners) + " |")
    lines.append("|---|---:|" + "---:|" * len(planners))

    def cell(r: SummaryRow | None) -> str:
        if r is None:
            return "-"
        first = "-" if r.median_first_solution is None else f"{r.median_first_solution:.2f}"
        cost = "-" if r.median_action_cost is None else f"{r.median_action_cost:g}"
        clock = f" (+{r.clock_ended} clock-ended: incomplete)" if r.clock_ended else ""
        return f"{round(r.success * r.runs)}/{r.runs} / {first} / {cost}{clock}"

    for experiment in experiments:
        limit = next(r.time_limit for r in rows if r.experiment == experiment)
        lines.append(f"| {experiment} | {limit:g} | "
                     + " | ".join(cell(table.get((experiment, p))) for p in planners) + " |")
    incomplete = [r for r in rows if not r.complete]
    ends: dict[str, int] = {}
    for r in rows:
        for reason, count in r.ends:
            ends[reason] = ends.get(reason, 0) + count
    lines += ["", "Runs by end reason: " + ", ".join(f"{reason} {count}" for reason, count in sorted(ends.items()))
              + " (budget: its budget spent; solved: stopped at its first solution; clock: the wall-clock "
              "backstop ended it before its budget; stopped: the planner ended by itself)."]
    if incomplete:
        lines += ["", f"**Incomplete: {len(incomplete)} of {len(rows)} cells** had runs that the wall-clock backstop "
                  "ended before their budget (" + ", ".join(f"{r.planner} on {r.experiment}: {r.clock_ended}"
                                                              for r in incomplete)
                  + "). They are no results of the budget: every number here counts the other runs only; rerun "
                  "those cells with a longer backstop (or none: no --time-limit)."]
    if any(r.machine_dependent for r in rows):
        lines += ["", "Budgets in CPU seconds (`--budget-cpu`): these results depend on the machine."]
    if cells:
        cost_name = "first solution's action cost" if until_first else "final action cost"
        lines += ["", f"Per planner and puzzle, with {100 * CONFIDENCE:.0f} % intervals. {statistics_legend(method)}",
                  "",
                  f"| puzzle | planner | runs solved | success rate [{100 * CONFIDENCE:.0f} % CI] | solved: all / any "
                  f"| time to first solution [s] | checks to first solution | {cost_name} |",
                  "|---|---|---:|---:|:-:|---:|---:|---:|"]
        for c in cells:
            lines.append(f"| {c.experiment} | {c.planner} | {c.success.successes}/{c.runs} | {format_rate(c.success)} "
                         f"| {'yes' if c.solved_all else 'no'} / {'yes' if c.solved_any else 'no'} "
                         f"| {format_estimate(c.time_to_first)} | {format_estimate(c.checks_to_first, 7)} "
                         f"| {format_estimate(c.final_cost)} |")
        lines += ["", "Per planner, over all puzzles (runs pooled; the puzzles differ, so the pooled rate is a "
                  "summary, not one distribution):", "",
                  "| planner | puzzles solved in all runs | in at least one run | runs solved | pooled success rate "
                  f"[{100 * CONFIDENCE:.0f} % CI] | median of per-puzzle median times to first solution [s] |",
                  "|---|---:|---:|---:|---:|---:|"]
        for t in planner_totals(cells, method):
            median_time = "-" if t.median_time_to_first is None else format_number(t.median_time_to_first)
            lines.append(f"| {t.planner} | {t.solved_all}/{t.puzzles} | {t.solved_any}/{t.puzzles} "
                         f"| {t.pooled.successes}/{t.pooled.runs} | {format_rate(t.pooled)} | {median_time} |")
    return "\n".join(lines) + "\n"


def curves(db_path: Path, experiment: str, planner: str, points: int = 100
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, success rate and median best action cost (nan where no run has a solution) over time."""
    with _connect(db_path) as db:
        limit, = db.execute("SELECT timelimit FROM experiments WHERE name = ?", (experiment,)).fetchone()
        runs = db.execute(
            """SELECT runs.id, runs.solved, runs.time_to_first_solution FROM runs
               JOIN experiments ON runs.experimentid = experiments.id
               JOIN plannerConfigs ON runs.plannerid = plannerConfigs.id
               WHERE experiments.name = ? AND plannerConfigs.name = ?""", (experiment, planner)).fetchall()
        progress = {run_id: db.execute("SELECT time, best_cost FROM progress WHERE runid = ? ORDER BY time",
                                       (run_id,)).fetchall() for run_id, _, _ in runs}
    times = np.linspace(0.0, limit, points)
    firsts = np.array([first if solved and first is not None else math.inf for _, solved, first in runs])
    success = (firsts[None, :] <= times[:, None]).mean(axis=1) if len(runs) else np.zeros(points)
    costs = np.full((points, len(runs)), np.nan)
    for k, (run_id, _, _) in enumerate(runs):
        samples = [(t, c) for t, c in progress[run_id] if c is not None]
        for t, c in samples:
            costs[times >= t, k] = c  # later samples overwrite: the best cost known at each time
    with np.errstate(all="ignore"):
        median = np.array([np.nanmedian(row) if np.any(~np.isnan(row)) else np.nan for row in costs])
    return times, success, median


def plot_fig4(db_path: Path, out_path: Path, columns: int = 4, until_first: bool = False) -> Path:
    """Fig. 4: per puzzle, success rate (upper panel) and action cost (lower panel) over time;
    ``until_first``: the runs stopped at their first solution (the cost is the first solution's)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with _connect(db_path) as db:
        experiments = [name for (name,) in db.execute("SELECT name FROM experiments ORDER BY id")]
        planners = sorted({name for (name,) in db.execute("SELECT name FROM plannerConfigs")}, key=_planner_key)
    rows = math.ceil(len(experiments) / columns)
    figure, axes = plt.subplots(2 * rows, columns, figsize=(4 * columns, 4.2 * rows), squeeze=False)
    for index, experiment in enumerate(experiments):
        top = axes[2 * (index // columns)][index % columns]
        bottom = axes[2 * (index // columns) + 1][index % columns]
        for planner in planners:
            times, success, cost = curves(db_path, experiment, planner)
            color = planner_color(planner)
            top.plot(times, 100 * success, color=color, label=planner)
            bottom.plot(times, cost, color=color, label=planner)
        top.set_title(experiment, fontsize=10)
        top.set_ylim(-5, 105)
        top.set_ylabel("success [%]", fontsize=8)
        bottom.set_ylabel("first solution's action cost" if until_first else "action cost", fontsize=8)
        bottom.set_xlabel("time [s]", fontsize=8)
        bottom.set_yscale("log")
        for axis in (top, bottom):
            axis.tick_params(labelsize=7)
            axis.grid(alpha=0.3)
    for index in range(len(experiments), rows * columns):
        axes[2 * (index // columns)][index % columns].axis("off")
        axes[2 * (index // columns) + 1][index % columns].axis("off")
    # One legend entry per planner, from whichever panel drew it (a planner may lack some puzzles).
    legend: dict[str, object] = {}
    for axis in axes.flat:
        for handle, label in zip(*axis.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    ordered = sorted(legend, key=_planner_key)
    figure.legend([legend[label] for label in ordered], ordered, loc="lower center", ncol=max(1, len(ordered)),
                  fontsize=10)
    height = figure.get_figheight()
    if until_first:
        figure.suptitle("Runs stopped at their first solution (--until first)", fontsize=11)
    # Room for the legend (about half an inch) and the title, whatever the number of rows.
    figure.tight_layout(rect=(0, min(0.5 / height, 0.2), 1, 1 - (0.35 / height if until_first else 0)))
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(out_path, dpi=70)
    plt.close(figure)
    return out_path
