"""The results page of a benchmark: one static, self-contained HTML file, ``<out>/results.html``.

In the manner of Planner Arena, read back from the benchmark database: success rates with their
95 % intervals as bars (one per planner and puzzle), empirical CDFs of the time and the collision
checks to the first solution per planner, the final action cost per puzzle with its interval, and
a table per puzzle. Figures are inline SVG drawn here (no matplotlib, no script or font from the
network), so the page opens offline and is the same, byte for byte, for the same database.
The numbers are those of the summary table (:func:`solver.benchmark.plots.benchmark_statistics`).

``phyrogen benchmark`` writes it beside ``summary.md``; ``phyrogen benchmark --report DIR``
(:func:`write_results_page`) makes it again from a finished benchmark folder.
"""

from __future__ import annotations

import html
import math
import os
import re
from collections.abc import Sequence
from pathlib import Path

from phyrogen_core.folder import OutputError, require_writable_dir, write_file_atomic
from solver.benchmark.database import DATABASE, BenchmarkData, BenchmarkDataError, read_benchmark
from solver.benchmark.plots import (
    INTERVAL_NAMES,
    benchmark_statistics,
    checks_to_first,
    counted_runs,
    format_estimate,
    format_number,
    format_rate,
    planner_color,
    statistics_legend,
)
from solver.benchmark.statistics import CONFIDENCE, CellStatistics, planner_totals

RESULTS_PAGE = "results.html"
"""The page's name in a benchmark's output folder."""

TAB_COLORS = {"tab:blue": "#1f77b4", "tab:orange": "#ff7f0e", "tab:green": "#2ca02c", "tab:red": "#d62728",
              "tab:purple": "#9467bd", "tab:brown": "#8c564b", "tab:pink": "#e377c2", "tab:gray": "#7f7f7f",
              "tab:olive": "#bcbd22", "tab:cyan": "#17becf"}
"""matplotlib's tab colours as hex, so the page's planners wear the colours of Fig. 4."""

# The gallery's look (blender_addon/gallery.py), restated here: the solver does not import the add-on.
_STYLE = """
body { font-family: sans-serif; margin: 1em; background: #fff; color: #222; max-width: 1400px; }
h1 { margin-bottom: 0.2em; }
h2 { margin-top: 1.4em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; }
th { font-weight: 600; padding: 4px 6px; text-align: left; border-bottom: 1px solid #ccc; }
td { padding: 3px 6px; vertical-align: top; }
td.n { text-align: right; font-variant-numeric: tabular-nums; }
tr:nth-child(even) td { background: #f6f6f6; }
.note { font-size: 13px; color: #444; max-width: 1000px; }
.swatch { display: inline-block; width: 12px; height: 12px; margin-right: 5px; vertical-align: -1px;
          border: 1px solid #0003; }
.legend span { margin-right: 16px; font-size: 13px; white-space: nowrap; }
.figures { display: flex; flex-wrap: wrap; gap: 16px; }
figure { margin: 0; }
figcaption { font-size: 12px; margin-top: 2px; color: #444; max-width: 520px; }
.cards { display: flex; flex-wrap: wrap; gap: 14px; }
.card { border: 1px solid #ccc; padding: 8px; }
.card h3 { margin: 0 0 4px 0; font-size: 15px; }
.card table { font-size: 12px; }
svg text { font-family: sans-serif; fill: #222; }
svg .axis { stroke: #888; stroke-width: 1; }
svg .grid { stroke: #ddd; stroke-width: 1; }
svg .whisker { stroke: #222; stroke-width: 1.5; }
"""


def _color(planner: str) -> str:
    return TAB_COLORS.get(planner_color(planner), "#555555")


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def _code(text: str) -> str:
    # The legend is written for Markdown; `x` becomes <code>x</code> here.
    return re.sub(r"`([^`]+)`", r"<code>\1</code>", _e(text))


def _f(value: float) -> str:
    # SVG coordinates: one decimal, the same text for the same number on every machine.
    return f"{value:.1f}"


def _success_figure(data: BenchmarkData, cells: Sequence[CellStatistics]) -> str:
    """One bar per planner and puzzle: the success rate, with its interval as a whisker."""
    by_cell = {(c.experiment, c.planner): c for c in cells}
    label_width, column, row, top = 190.0, 150.0, 22.0, 44.0
    bar = column - 44.0  # room for the "k/n" text
    width = label_width + column * len(data.planners) + 10
    height = top + row * len(data.experiments) + 8
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" class="success" width="{_f(width)}" height="{_f(height)}" '
             f'viewBox="0 0 {_f(width)} {_f(height)}" role="img" aria-label="success rate per planner and puzzle">']
    for j, planner in enumerate(data.planners):
        x = label_width + j * column
        parts.append(f'<text x="{_f(x)}" y="14" font-size="12" font-weight="600">{_e(planner)}</text>')
        for share in (0.0, 0.5, 1.0):
            gx = x + share * bar
            parts.append(f'<line class="grid" x1="{_f(gx)}" y1="{_f(top - 4)}" x2="{_f(gx)}" '
                         f'y2="{_f(height - 6)}"/>')
            parts.append(f'<text x="{_f(gx)}" y="{_f(top - 8)}" font-size="9" text-anchor="middle" fill="#666">'
                         f'{100 * share:.0f}%</text>')
    for i, experiment in enumerate(data.experiments):
        y = top + i * row
        parts.append(f'<text x="4" y="{_f(y + 14)}" font-size="12">{_e(experiment)}</text>')
        for j, planner in enumerate(data.planners):
            cell = by_cell.get((experiment, planner))
            if cell is None:
                continue
            x = label_width + j * column
            s = cell.success
            parts.append(
                f'<rect class="bar" x="{_f(x)}" y="{_f(y + 4)}" width="{_f(s.rate * bar)}" height="{_f(row - 8)}" '
                f'fill="{_color(planner)}" data-puzzle="{_e(experiment)}" data-planner="{_e(planner)}" '
                f'data-successes="{s.successes}" data-runs="{s.runs}" data-low="{s.low:.4f}" data-high="{s.high:.4f}">'
                f'<title>{_e(planner)} on {_e(experiment)}: {s.successes}/{s.runs} runs solved, '
                f'{_e(format_rate(s))}</title></rect>')
            low, high, middle = x + s.low * bar, x + s.high * bar, y + row / 2
            parts.append(f'<line class="whisker" x1="{_f(low)}" y1="{_f(middle)}" x2="{_f(high)}" y2="{_f(middle)}"/>')
            for end in (low, high):
                parts.append(f'<line class="whisker" x1="{_f(end)}" y1="{_f(middle - 4)}" x2="{_f(end)}" '
                             f'y2="{_f(middle + 4)}"/>')
            parts.append(f'<text x="{_f(x + bar + 6)}" y="{_f(y + 14)}" font-size="11">{s.successes}/{s.runs}</text>')
    parts.append("</svg>")
    return "".join(parts)


def _decades(low: float, high: float) -> list[float]:
    return [10.0 ** k for k in range(math.floor(math.log10(low)), math.ceil(math.log10(high)) + 1)]


def _ecdf_figure(title: str, unit: str, series: dict[str, list[float]], css_class: str) -> str:
    """Empirical CDFs on a log axis: per planner, the share of its runs with a solution by x (inf: none)."""
    finite = [v for values in series.values() for v in values if math.isfinite(v)]
    width, height, left, right, top, bottom = 520.0, 300.0, 48.0, 28.0, 12.0, 40.0
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" class="{css_class}" width="{_f(width)}" height="{_f(height)}" '
             f'viewBox="0 0 {_f(width)} {_f(height)}" role="img" aria-label="{_e(title)}">']
    plot_w, plot_h = width - left - right, height - top - bottom
    if not finite:
        parts.append(f'<text x="{_f(width / 2)}" y="{_f(height / 2)}" text-anchor="middle" font-size="13">'
                     'no run found a solution</text></svg>')
        return "".join(parts)
    positive = [v for v in finite if v > 0] or [1.0]  # a log axis: a solution at 0 sits at its left end
    ticks = _decades(min(positive), max(positive))
    lo, hi = math.log10(ticks[0]), math.log10(ticks[-1])
    hi = hi if hi > lo else lo + 1

    def x_of(v: float) -> float:
        return left + (math.log10(v) - lo) / (hi - lo) * plot_w

    def y_of(share: float) -> float:
        return top + (1 - share) * plot_h

    for tick in ticks:
        parts.append(f'<line class="grid" x1="{_f(x_of(tick))}" y1="{_f(top)}" x2="{_f(x_of(tick))}" '
                     f'y2="{_f(top + plot_h)}"/>')
        parts.append(f'<text x="{_f(x_of(tick))}" y="{_f(top + plot_h + 14)}" font-size="10" text-anchor="middle">'
                     f'{tick:g}</text>')
    for share in (0.0, 0.25, 0.5, 0.75, 1.0):
        parts.append(f'<line class="grid" x1="{_f(left)}" y1="{_f(y_of(share))}" x2="{_f(left + plot_w)}" '
                     f'y2="{_f(y_of(share))}"/>')
        parts.append(f'<text x="{_f(left - 4)}" y="{_f(y_of(share) + 4)}" font-size="10" text-anchor="end">'
                     f'{100 * share:.0f}%</text>')
    parts.append(f'<rect class="axis" x="{_f(left)}" y="{_f(top)}" width="{_f(plot_w)}" height="{_f(plot_h)}" '
                 'fill="none"/>')
    parts.append(f'<text x="{_f(left + plot_w / 2)}" y="{_f(height - 6)}" font-size="11" text-anchor="middle">'
                 f'{_e(unit)} (log scale)</text>')
    for planner, values in series.items():
        if not values:
            continue
        solved = sorted(v for v in values if math.isfinite(v))
        points = [(x_of(ticks[0]), y_of(0.0))]
        for k, v in enumerate(solved):
            x = x_of(max(v, ticks[0]))
            points += [(x, y_of(k / len(values))), (x, y_of((k + 1) / len(values)))]
        points.append((x_of(ticks[-1]), y_of(len(solved) / len(values))))
        path = " ".join(f"{_f(px)},{_f(py)}" for px, py in points)
        parts.append(f'<polyline class="ecdf" points="{path}" fill="none" stroke="{_color(planner)}" '
                     f'stroke-width="2" data-planner="{_e(planner)}" data-solved="{len(solved)}" '
                     f'data-runs="{len(values)}"><title>{_e(planner)}: {len(solved)}/{len(values)} runs solved'
                     '</title></polyline>')
    parts.append("</svg>")
    return "".join(parts)


def _cost_figure(experiment: str, planners: Sequence[str], cells: dict[str, CellStatistics]) -> str:
    """Per planner, the median final action cost of the solved runs with its interval (a dot and a whisker)."""
    costs = [c.final_cost for c in cells.values() if c.final_cost is not None]
    row, label_width, width, top = 18.0, 150.0, 420.0, 8.0
    height = top + row * len(planners) + 26
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" class="cost" width="{_f(width)}" height="{_f(height)}" '
             f'viewBox="0 0 {_f(width)} {_f(height)}" role="img" aria-label="action cost on {_e(experiment)}">']
    high = max((max(e.high, e.value) for e in costs), default=1.0)
    scale_end = max(1.0, high) * 1.05
    plot_w = width - label_width - 14

    def x_of(v: float) -> float:
        return label_width + v / scale_end * plot_w

    step = 10 ** math.floor(math.log10(scale_end)) if scale_end >= 1 else 1
    if scale_end / step < 3:
        step /= 2
    tick = 0.0
    while tick <= scale_end:
        parts.append(f'<line class="grid" x1="{_f(x_of(tick))}" y1="{_f(top)}" x2="{_f(x_of(tick))}" '
                     f'y2="{_f(height - 22)}"/>')
        parts.append(f'<text x="{_f(x_of(tick))}" y="{_f(height - 10)}" font-size="9" text-anchor="middle">'
                     f'{tick:g}</text>')
        tick += step
    for i, planner in enumerate(planners):
        y = top + i * row + row / 2
        parts.append(f'<text x="4" y="{_f(y + 4)}" font-size="11">{_e(planner)}</text>')
        cell = cells.get(planner)
        estimate = None if cell is None else cell.final_cost
        if estimate is None:
            parts.append(f'<text x="{_f(label_width)}" y="{_f(y + 4)}" font-size="10" fill="#888">'
                         'no solved run</text>')
            continue
        parts.append(f'<line class="whisker" x1="{_f(x_of(estimate.low))}" y1="{_f(y)}" x2="{_f(x_of(estimate.high))}" '
                     f'y2="{_f(y)}"/>')
        parts.append(f'<circle class="cost-median" cx="{_f(x_of(estimate.value))}" cy="{_f(y)}" r="4.5" '
                     f'fill="{_color(planner)}" data-planner="{_e(planner)}" data-median="{estimate.value:g}">'
                     f'<title>{_e(planner)}: median cost {_e(format_estimate(estimate))}</title></circle>')
    parts.append("</svg>")
    return "".join(parts)


def _clock_ended(data: BenchmarkData, experiment: str, planner: str) -> int:
    return sum(1 for r in data.cell(experiment, planner) if r.clock_ended)


def _puzzle_card(data: BenchmarkData, experiment: str, cells: dict[str, CellStatistics], cost_name: str) -> str:
    rows = []
    for planner in data.planners:
        c = cells.get(planner)
        clock = _clock_ended(data, experiment, planner)
        mark = f'<td class="n incomplete">{clock} (incomplete)</td>' if clock else '<td class="n">0</td>'
        if c is None:
            if clock:
                rows.append(f'<tr><td><span class="swatch" style="background:{_color(planner)}"></span>'
                            f'{_e(planner)}</td><td class="n">0/0</td><td>-</td><td>-</td><td>-</td><td>-</td>'
                            f'<td>-</td>{mark}</tr>')
            continue
        rows.append(
            f'<tr><td><span class="swatch" style="background:{_color(planner)}"></span>{_e(planner)}</td>'
            f'<td class="n">{c.success.successes}/{c.runs}</td><td class="n">{_e(format_rate(c.success))}</td>'
            f'<td>{"yes" if c.solved_all else "no"} / {"yes" if c.solved_any else "no"}</td>'
            f'<td class="n">{_e(format_estimate(c.time_to_first))}</td>'
            f'<td class="n">{_e(format_estimate(c.checks_to_first, 7))}</td>'
            f'<td class="n">{_e(format_estimate(c.final_cost))}</td>{mark}</tr>')
    return (f'<div class="card" id="puzzle-{_e(experiment)}"><h3>{_e(experiment)} '
            f'<small>(limit {data.time_limits[experiment]:g} s)</small></h3>'
            f'{_cost_figure(experiment, data.planners, cells)}'
            f'<table><tr><th>planner</th><th>solved</th><th>rate [{100 * CONFIDENCE:.0f} % CI]</th>'
            '<th>all / any</th><th>time to first [s]</th><th>checks to first</th>'
            f'<th>{_e(cost_name)}</th><th>clock-ended</th></tr>{"".join(rows)}</table></div>')


def results_page_html(data: BenchmarkData, method: str = "wilson") -> str:
    """The page for ``data`` (see the module docstring)."""
    cells = benchmark_statistics(data, method)
    until_first = all(r.until_first for r in data.runs)
    cost_name = "first solution's action cost" if until_first else "final action cost"
    legend = "".join(f'<span><span class="swatch" style="background:{_color(p)}"></span>{_e(p)}</span>'
                     for p in data.planners)
    totals = "".join(
        f'<tr><td><span class="swatch" style="background:{_color(t.planner)}"></span>{_e(t.planner)}</td>'
        f'<td class="n">{t.solved_all}/{t.puzzles}</td><td class="n">{t.solved_any}/{t.puzzles}</td>'
        f'<td class="n">{t.pooled.successes}/{t.pooled.runs}</td><td class="n">{_e(format_rate(t.pooled))}</td>'
        f'<td class="n">{_e("-" if t.median_time_to_first is None else format_number(t.median_time_to_first))}</td>'
        '</tr>' for t in planner_totals(cells, method))
    times: dict[str, list[float]] = {p: [] for p in data.planners}
    checks: dict[str, list[float]] = {p: [] for p in data.planners}
    checks_missing = []
    for experiment in data.experiments:
        for planner in data.planners:
            runs = counted_runs(data, experiment, planner)
            times[planner] += [r.first_solution_time if r.solved else math.inf for r in runs]
            counted = checks_to_first(runs)
            if counted is None and runs:
                checks_missing.append((experiment, planner))
            elif counted is not None:
                checks[planner] += [math.inf if v is None else float(v) for v in counted]
    if checks_missing:
        checks_figure = ('<p class="note">No figure of the checks to the first solution: in '
                         f'{len(checks_missing)} of {len(cells)} planner-puzzle cells a solved run does not say '
                         'how many checks its first solution took (runs recorded before the run property '
                         '<code>checks to first solution</code> that did not stop there).</p>')
    else:
        figure = _ecdf_figure("checks to first solution", "collision checks", checks, "ecdf-checks")
        checks_figure = (f'<figure>{figure}'
                         '<figcaption>Share of each planner\'s runs (all puzzles pooled) with a solution within x '
                         'collision checks.</figcaption></figure>')
    per_puzzle = {e: {c.planner: c for c in cells if c.experiment == e} for e in data.experiments}
    cards = "".join(_puzzle_card(data, e, per_puzzle[e], cost_name) for e in data.experiments)
    runs_per_cell = sorted({c.runs for c in cells})
    ends: dict[str, int] = {}
    for r in data.runs:
        ends[r.end or "unknown"] = ends.get(r.end or "unknown", 0) + 1
    incomplete = sorted({(r.experiment, r.planner) for r in data.runs if r.clock_ended})
    end_note = ("Runs by end reason: " + ", ".join(f"{k} {v}" for k, v in sorted(ends.items())) + ". ")
    if incomplete:
        end_note += (f"<strong>Incomplete: {len(incomplete)} cells</strong> had runs that the wall-clock backstop "
                     "ended before their budget; they are no results of the budget, and every number here counts "
                     "the other runs only.")
    if any(r.budget_cpu is not None for r in data.runs):
        end_note += " Budgets in CPU seconds: these results depend on the machine."
    runs_text = " or ".join(str(n) for n in runs_per_cell)
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>PhyRoGen benchmark results</title>
<style>{_STYLE}</style>
</head>
<body data-bars="{len(cells)}">
<h1>PhyRoGen benchmark results</h1>
<p class="note">{len(data.experiments)} puzzles x {len(data.planners)} planners, {runs_text} runs per planner and
puzzle ({len(data.runs)} runs), from <code>{_e(data.path.name)}</code>. {_e(data.setup.strip())}</p>
<p class="legend">{legend}</p>
<p class="note">{_code(statistics_legend(method))}</p>
<p class="note" id="end-reasons">{end_note}</p>

<h2>Per planner</h2>
<table><tr><th>planner</th><th>puzzles solved in all runs</th><th>in at least one run</th><th>runs solved</th>
<th>pooled success rate [{100 * CONFIDENCE:.0f} % CI]</th><th>median of per-puzzle median times [s]</th></tr>
{totals}</table>

<h2>Success rate per planner and puzzle</h2>
<figure>{_success_figure(data, cells)}<figcaption>Bar: share of runs solved; whisker: its
{100 * CONFIDENCE:.0f} % {_e(INTERVAL_NAMES[method])} interval.</figcaption></figure>

<h2>Time and collision checks to the first solution</h2>
<div class="figures">
<figure>{_ecdf_figure("time to first solution", "seconds", times, "ecdf-time")}<figcaption>Share of each
planner's runs (all puzzles pooled) with a solution within x seconds; the curve ends at the share solved at
all.</figcaption></figure>
{checks_figure}
</div>

<h2>Per puzzle: {_e(cost_name)} and statistics</h2>
<p class="note">Dot: median {_e(cost_name)} over the solved runs; whisker: its bootstrap interval.</p>
<div class="cards">{cards}</div>
<script>
// Proof for a headless browser that the figures were parsed as SVG, not left as text.
document.body.dataset.barsRendered = document.querySelectorAll("svg rect.bar").length;
</script>
</body>
</html>
"""


def write_results_page(folder: str | Path, method: str = "wilson", database: str | Path | None = None) -> Path:
    """Write ``folder/results.html`` (atomically) from ``folder/benchmark.db`` (or ``database``).

    Raises :class:`~solver.benchmark.database.BenchmarkDataError` (one line naming the file), with
    nothing written, when the folder or its database is missing or is not a benchmark database;
    :class:`~phyrogen_core.folder.OutputError` when the folder cannot be written or ``results.html``
    there is a link or a folder (not ours to replace)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise BenchmarkDataError(f"{folder}: not a benchmark folder (no such directory)")
    require_writable_dir(folder, "benchmark folder")
    page = folder / RESULTS_PAGE
    if os.path.lexists(page) and (page.is_symlink() or not page.is_file()):
        # Not ours to replace: a link or a folder someone put there.
        raise OutputError(f"{page} exists and is not a file; move it away or choose another folder")
    data = read_benchmark(folder / DATABASE if database is None else database)
    return write_file_atomic(page, results_page_html(data, method).encode("utf-8"))
