"""Benchmark statistics (intervals against known values, each with a control that a wrong method fails),
the summary table built on them, and the results page, read by headless Chromium."""

from __future__ import annotations

import math
import re
import shutil
import sqlite3
import subprocess

import numpy as np
import pytest

from phyrogen.cli import main
from phyrogen_core.seeding import stable_rng
from solver.benchmark.database import BenchmarkDataError, parse_settings, read_benchmark
from solver.benchmark.jobs import RunRecord
from solver.benchmark.ompl_log import build_database, write_log
from solver.benchmark.plots import benchmark_statistics, summary_markdown, summary_rows
from solver.benchmark.results_page import RESULTS_PAGE, write_results_page
from solver.benchmark.statistics import (
    Proportion,
    beta_quantile,
    bootstrap_median,
    clopper_pearson_interval,
    median,
    normal_quantile,
    planner_totals,
    regularized_incomplete_beta,
    success_interval,
    wilson_interval,
)

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


# -- intervals: known values, and a wrong method that the same checks reject ----------------------
def wald_interval(successes: int, runs: int) -> Proportion:
    """The textbook normal approximation: the control every interval check here must reject."""
    p = successes / runs
    half = 1.959964 * math.sqrt(p * (1 - p) / runs)
    return Proportion(successes, runs, max(0.0, p - half), min(1.0, p + half), "wald")


WILSON_KNOWN = {(10, 10): (0.7225, 1.0), (0, 10): (0.0, 0.2775), (5, 10): (0.2366, 0.7634),
                (1, 2): (0.0945, 0.9055)}
"""Wilson score 95 % intervals (Agresti and Coull 1998's formula; e.g. R's ``prop.test(correct=FALSE)``)."""
CLOPPER_PEARSON_KNOWN = {(10, 10): (0.6915, 1.0), (0, 10): (0.0, 0.3085), (5, 10): (0.1871, 0.8129),
                         (1, 2): (0.0126, 0.9874)}
"""Clopper-Pearson 95 % intervals (R's ``binom.test``): 10/10's lower end is 0.025 ** (1 / 10)."""


def matches(interval, known) -> bool:
    return all(abs(interval(k, n).low - low) < 5e-5 and abs(interval(k, n).high - high) < 5e-5
               for (k, n), (low, high) in known.items())


def test_wilson_and_clopper_pearson_give_the_known_intervals():
    assert matches(wilson_interval, WILSON_KNOWN)
    assert matches(clopper_pearson_interval, CLOPPER_PEARSON_KNOWN)
    assert clopper_pearson_interval(10, 10).low == pytest.approx(0.025 ** 0.1, abs=1e-12)
    # Ten clean runs bound the failure rate below about 28 % (Wilson), 31 % (Clopper-Pearson).
    assert 1 - wilson_interval(10, 10).low == pytest.approx(0.2775, abs=1e-4)
    assert success_interval(3, 4, "clopper-pearson") == clopper_pearson_interval(3, 4)
    # Negative controls: the normal approximation (a point at 10/10 and 0/10) and each method in
    # the other's place fail the same checks.
    assert not matches(wald_interval, WILSON_KNOWN) and not matches(wald_interval, CLOPPER_PEARSON_KNOWN)
    assert not matches(clopper_pearson_interval, WILSON_KNOWN)
    assert not matches(wilson_interval, CLOPPER_PEARSON_KNOWN)


def coverage(interval, runs: int, rates) -> list[float]:
    """For each rate p, the exact probability that ``interval`` covers p in ``runs`` Bernoulli(p) trials."""
    intervals = [interval(k, runs) for k in range(runs + 1)]
    return [sum(math.comb(runs, k) * p ** k * (1 - p) ** (runs - k)
                for k, ci in enumerate(intervals) if ci.low <= p <= ci.high) for p in rates]


def test_intervals_cover_the_true_rate_as_stated_and_the_normal_approximation_does_not():
    grid = np.linspace(0.02, 0.98, 49)
    for runs in (5, 10, 30):
        exact = coverage(clopper_pearson_interval, runs, grid)
        assert min(exact) >= 0.95 - 1e-9  # Clopper-Pearson: at least the stated coverage, always
        wilson = coverage(wilson_interval, runs, grid)
        assert 0.93 <= float(np.mean(wilson)) <= 0.97  # Wilson: about the stated coverage on average
        wald = coverage(wald_interval, runs, grid)
        assert float(np.mean(wald)) < 0.92  # the control: far below it at these run counts


def test_beta_and_normal_quantiles_match_closed_forms():
    assert normal_quantile(0.975) == pytest.approx(1.959963984540054, abs=1e-12)
    assert normal_quantile(0.5) == pytest.approx(0.0, abs=1e-12)
    for b in (1, 3, 10):  # I_x(1, b) = 1 - (1 - x)^b
        for x in (0.01, 0.3, 0.9):
            assert regularized_incomplete_beta(1, b, x) == pytest.approx(1 - (1 - x) ** b, abs=1e-12)
    for k in (1, 4, 10):  # the beta(k, 1) quantile is p^(1/k)
        assert beta_quantile(0.025, k, 1) == pytest.approx(0.025 ** (1 / k), abs=1e-12)
    assert regularized_incomplete_beta(2.5, 7.0, 0.3) + regularized_incomplete_beta(7.0, 2.5, 0.7) \
        == pytest.approx(1.0, abs=1e-12)  # symmetry, through both branches of the continued fraction
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(11, 10)
    with pytest.raises(ValueError, match="method"):
        success_interval(1, 2, "wald")


# -- medians and their bootstrap intervals -------------------------------------------------------
def test_bootstrap_median_is_seeded_honest_about_failures_and_covers_a_known_median():
    values = [0.3, 0.1, 0.7, 0.2, 0.5, 0.4, 0.9, 0.6, 0.8]
    a = bootstrap_median(values, stable_rng("t", 1))
    assert a == bootstrap_median(values, stable_rng("t", 1))  # the same seed, the same interval
    # Control: the seed is what fixes it; other seeds give other intervals (coarse ones, 50 resamples).
    assert len({bootstrap_median(values, stable_rng("t", seed), resamples=50) for seed in range(20)}) > 1
    assert a.value == 0.5 and a.low <= 0.5 <= a.high and a.low < a.high and a.samples == 9
    assert bootstrap_median([3, 3, 3], stable_rng("t")).low == bootstrap_median([3, 3, 3], stable_rng("t")).high == 3
    # Failures count as infinite: 2 of 4 failed, so the median itself is not within the budget.
    assert median([1.0, 2.0, math.inf, math.inf]) == math.inf and median([1.0, 2.0, 3.0, math.inf]) == 2.5
    failing = bootstrap_median([0.1, 0.2, 0.3, math.inf, math.inf], stable_rng("t"))
    assert failing.value == 0.3 and failing.high == math.inf and not math.isnan(failing.low)
    # Coverage of the true median of an exponential distribution (ln 2), 200 samples of 30: the
    # percentile bootstrap's 95 % interval holds it in roughly 95 % of them, a point estimate never.
    rng = np.random.default_rng(7)
    held = sum(e.low <= math.log(2) <= e.high for e in
               (bootstrap_median(rng.exponential(size=30), stable_rng("cover", i), resamples=500) for i in range(200)))
    assert 0.88 * 200 <= held <= 0.99 * 200
    assert sum(median(rng.exponential(size=30)) == math.log(2) for _ in range(200)) == 0


# -- the database, the summary table, the results page -------------------------------------------
PLANNERS = ("LA-RRT", "LA-RRT+push (ours)", "RRT*")
OUTCOMES = {  # puzzle -> planner -> per run: (first solution's time, checks, cost) or None (failed)
    "toy_1": {"LA-RRT": [(0.1, 120, 2), (0.3, 310, 4), (0.2, 200, 2), None, (0.25, 260, 3)],
              "LA-RRT+push (ours)": [(0.05, 40, 2)] * 5,
              "RRT*": [None, None, (0.9, 1500, 9), None, None]},
    "toy_2": {"LA-RRT": [None] * 5,
              "LA-RRT+push (ours)": [(0.4, 800, 3), (0.6, 900, 3), (0.5, 700, 4), (0.45, 820, 3), (0.7, 1000, 5)],
              "RRT*": [(1.2, 2400, 12), (1.5, 2900, 10), None, (1.1, 2100, 11), (1.9, 3600, 14)]},
}
BUDGET = 5000


def write_toy_benchmark(folder, until_first: bool = True):
    folder.mkdir(parents=True, exist_ok=True)
    logs = []
    for puzzle, planners in OUTCOMES.items():
        records = []
        for planner, runs in planners.items():
            for run, outcome in enumerate(runs):
                solved = outcome is not None
                first, checks, cost = outcome if solved else (None, BUDGET, None)
                progress = ((0.0, math.inf, 0), (2.0, float(cost) if solved else math.inf, 10))
                records.append(RunRecord(planner, puzzle, run, 100 + run, 2.0, solved,
                                         "Exact solution" if solved else "Timeout", 2.0 if not solved else first,
                                         first, cost, 1.5 if solved else None, 10, 0, progress, checks=checks,
                                         cpu_time=0.1))
        log = folder / "logs" / f"{puzzle}.log"
        log.parent.mkdir(exist_ok=True)
        write_log(log, puzzle, records, list(PLANNERS), 2.0, 5, 0, 1.0, "toy setup", until_first=until_first,
                  budget_checks=BUDGET)
        logs.append(log)
    build_database(folder / "benchmark.db", logs)
    return folder


@pytest.fixture()
def toy(tmp_path):
    return write_toy_benchmark(tmp_path / "bench")


def test_statistics_from_the_database_agree_with_its_runs(toy):
    data = read_benchmark(toy / "benchmark.db")
    assert data.experiments == ("toy_1", "toy_2") and data.planners == PLANNERS
    assert parse_settings("time_limit REAL = 2\n;until_first BOOLEAN = 1\n;") == {"time_limit": "2",
                                                                                  "until_first": "1"}
    cells = {(c.experiment, c.planner): c for c in benchmark_statistics(data)}
    la = cells[("toy_1", "LA-RRT")]
    assert (la.success.successes, la.runs, la.solved_all, la.solved_any) == (4, 5, False, True)
    # The failed run counts as infinite: the median of (0.1, 0.2, 0.25, 0.3, inf), not of the solved four.
    assert la.time_to_first.value == 0.25 and la.checks_to_first.value == 260 and la.final_cost.value == 2.5
    rrt = cells[("toy_1", "RRT*")]
    # 1 of 5: the median time is not within the limit, whatever the one solved run took.
    assert rrt.time_to_first.value == math.inf and rrt.final_cost.value == 9
    assert cells[("toy_2", "LA-RRT")].final_cost is None and not cells[("toy_2", "LA-RRT")].solved_any
    assert benchmark_statistics(data) == benchmark_statistics(read_benchmark(toy / "benchmark.db"))  # seeded
    totals = {t.planner: t for t in planner_totals(list(cells.values()))}
    assert (totals["LA-RRT"].solved_all, totals["LA-RRT"].solved_any, totals["LA-RRT"].pooled.successes) == (0, 1, 4)
    assert (totals["LA-RRT+push (ours)"].solved_all, totals["RRT*"].solved_any) == (2, 2)
    # Each count, recounted straight from the database, is the one reported (the control: one
    # run's verdict flipped in the database changes it).
    with sqlite3.connect(toy / "benchmark.db") as db:
        counted = dict(((e, p), int(n)) for e, p, n in db.execute(
            """SELECT experiments.name, plannerConfigs.name, SUM(runs.solved) FROM runs
               JOIN experiments ON runs.experimentid = experiments.id
               JOIN plannerConfigs ON runs.plannerid = plannerConfigs.id GROUP BY 1, 2"""))
        assert {k: c.success.successes for k, c in cells.items()} == counted
        db.execute("UPDATE runs SET solved = 0 WHERE id = (SELECT MIN(id) FROM runs WHERE solved = 1)")
    flipped = {(c.experiment, c.planner): c.success.successes
               for c in benchmark_statistics(read_benchmark(toy / "benchmark.db"))}
    assert flipped != counted


def test_summary_table_shows_counts_intervals_solved_all_and_any_and_medians(toy):
    text = summary_markdown(summary_rows(toy / "benchmark.db"), until_first=True)
    assert "| toy_1 | 2 | 4/5 / 0.23 / 2.5 | 5/5 / 0.05 / 2 | 1/5 / 0.90 / 9 |" in text  # the overview
    line = next(t for t in text.splitlines() if t.startswith("| toy_1 | LA-RRT |"))
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[2:5] == ["4/5", "80 % [38, 96]", "no / yes"]
    assert cells[5] == "0.25 [0.1, ∞]" and cells[6] == "260 [120, ∞]" and cells[7] == "2.5 [2, 4]"
    assert "| toy_2 | LA-RRT | 0/5 | 0 % [0, 43] | no / no | ∞ [∞, ∞] | ∞ [∞, ∞] | - |" in text
    assert "| LA-RRT+push (ours) | 2/2 | 2/2 | 10/10 | 100 % [72, 100] |" in text
    assert "| LA-RRT | 0/2 | 1/2 | 4/10 | 40 % [17, 69] |" in text
    # Runs that went on past their first solution, without the run property "checks to first
    # solution", did not count the checks to it: '-', not a guess (a cell with no solved run: all ∞).
    limit = write_toy_benchmark(toy.parent / "limit", until_first=False)
    unknown = benchmark_statistics(read_benchmark(limit / "benchmark.db"))
    assert all((c.checks_to_first is None) == c.solved_any for c in unknown)
    # Control: with the property recorded (here filled in by hand) the same runs have their counts.
    with sqlite3.connect(limit / "benchmark.db") as db:
        if "checks_to_first_solution" not in {row[1] for row in db.execute("PRAGMA table_info(runs)")}:
            db.execute("ALTER TABLE runs ADD COLUMN checks_to_first_solution INTEGER")
        db.execute("UPDATE runs SET checks_to_first_solution = collision_checks - 7 WHERE solved = 1")
    known = {(c.experiment, c.planner): c for c in benchmark_statistics(read_benchmark(limit / "benchmark.db"))}
    assert all(c.checks_to_first is not None for c in known.values())
    assert known[("toy_1", "LA-RRT")].checks_to_first.value == 253  # 260 - 7: the property, not the total
    # A database from before runs counted their checks (no such column) reads, with '-' too.
    assert all(c.checks_to_first is not None for c in benchmark_statistics(read_benchmark(toy / "benchmark.db")))
    with sqlite3.connect(toy / "benchmark.db") as db:
        db.execute("ALTER TABLE runs DROP COLUMN collision_checks")
    older = benchmark_statistics(read_benchmark(toy / "benchmark.db"))
    assert len(older) == 6 and all((c.checks_to_first is None) == c.solved_any for c in older)


def bars_of(page: str) -> dict[tuple[str, str], tuple[int, int]]:
    return {(m["puzzle"], m["planner"]): (int(m["k"]), int(m["n"])) for m in re.finditer(
        r'<rect class="bar"[^>]*data-puzzle="(?P<puzzle>[^"]+)" data-planner="(?P<planner>[^"]+)" '
        r'data-successes="(?P<k>\d+)" data-runs="(?P<n>\d+)"', page)}


def database_counts(db_path) -> dict[tuple[str, str], tuple[int, int]]:
    import html

    with sqlite3.connect(db_path) as db:
        return {(html.escape(e), html.escape(p)): (int(k), int(n)) for e, p, k, n in db.execute(
            """SELECT experiments.name, plannerConfigs.name, SUM(runs.solved), COUNT(*) FROM runs
               JOIN experiments ON runs.experimentid = experiments.id
               JOIN plannerConfigs ON runs.plannerid = plannerConfigs.id GROUP BY 1, 2""")}


def test_results_page_has_one_bar_per_planner_and_puzzle_with_the_databases_numbers(toy):
    page = write_results_page(toy)
    assert page == toy / RESULTS_PAGE
    text = page.read_text(encoding="utf-8")
    assert bars_of(text) == database_counts(toy / "benchmark.db") and len(bars_of(text)) == 6
    assert "http://" not in text.replace("http://www.w3.org/2000/svg", "") and "https://" not in text
    assert 'class="ecdf-time"' in text and 'class="ecdf-checks"' in text and text.count('class="cost-median"') == 5
    assert page.read_bytes() == write_results_page(toy).read_bytes()  # deterministic
    # Control: a page with one bar missing, or one count changed, fails the same comparison.
    assert bars_of(text.replace('<rect class="bar"', '<rect class="gone"', 1)) != database_counts(toy / "benchmark.db")
    assert bars_of(text.replace('data-successes="4"', 'data-successes="5"', 1)) != database_counts(
        toy / "benchmark.db")


def test_a_missing_or_broken_database_is_refused_with_one_line_and_nothing_written(tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(BenchmarkDataError, match="no benchmark database"):
        write_results_page(empty)
    (empty / "benchmark.db").write_bytes(b"this is not SQLite, just some bytes long enough to be read" * 20)
    with pytest.raises(BenchmarkDataError, match="not a readable benchmark database"):
        write_results_page(empty)
    with sqlite3.connect(tmp_path / "other.db") as db:
        db.execute("CREATE TABLE runs (id INTEGER)")
    with pytest.raises(BenchmarkDataError, match="lacks"):
        read_benchmark(tmp_path / "other.db")
    assert sorted(p.name for p in empty.iterdir()) == ["benchmark.db"]
    for folder in (empty, tmp_path / "nowhere"):
        capsys.readouterr()
        assert main(["benchmark", "--report", str(folder)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and str(folder) in err, err
    assert sorted(p.name for p in empty.iterdir()) == ["benchmark.db"] and not (tmp_path / "nowhere").exists()
    # A folder of the user's named results.html is not replaced (control: a file of ours is).
    occupied = write_toy_benchmark(tmp_path / "occupied")
    (occupied / RESULTS_PAGE).mkdir()
    (occupied / RESULTS_PAGE / "mine.txt").write_text("keep me")
    capsys.readouterr()
    assert main(["benchmark", "--report", str(occupied)]) == 2
    assert (occupied / RESULTS_PAGE / "mine.txt").read_text() == "keep me"
    assert main(["benchmark", "--report", str(write_toy_benchmark(tmp_path / "free"))]) == 0


def test_report_makes_the_page_again_from_a_finished_benchmark(toy, capsys):
    assert main(["benchmark", "--report", str(toy)]) == 0
    assert str(toy / RESULTS_PAGE) in capsys.readouterr().out
    assert bars_of((toy / RESULTS_PAGE).read_text(encoding="utf-8")) == database_counts(toy / "benchmark.db")


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (apt-get install chromium)")
def test_results_page_renders_in_headless_chromium(toy, tmp_path):
    from PIL import Image

    page = write_results_page(toy)
    browser = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
               "--allow-file-access-from-files", "--virtual-time-budget=2000"]
    dom = subprocess.run([*browser, "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=120,
                         check=True).stdout
    # The browser parsed every bar as an SVG element (the page's script counted them).
    assert 'data-bars="6"' in dom and 'data-bars-rendered="6"' in dom
    screenshot = tmp_path / "page.png"
    subprocess.run([*browser, f"--screenshot={screenshot}", "--window-size=1200,900", page.as_uri()],
                   capture_output=True, timeout=120, check=True)
    r, g, b = np.asarray(Image.open(screenshot).convert("RGB"), dtype=int).transpose(2, 0, 1)
    purple = (abs(r - 0x94) < 20) & (abs(g - 0x67) < 20) & (abs(b - 0xBD) < 20)  # LA-RRT+push's bars
    assert purple.sum() > 500
    # Control: the same screenshot of a page without the figures has none of that colour.
    bare = tmp_path / "bare.html"
    stripped = re.sub(r"<svg.*?</svg>", "", page.read_text(encoding="utf-8"), flags=re.S)
    bare.write_text(re.sub(r'<span class="swatch"[^>]*></span>', "", stripped), encoding="utf-8")
    subprocess.run([*browser, f"--screenshot={screenshot}", "--window-size=1200,900", bare.as_uri()],
                   capture_output=True, timeout=120, check=True)
    r, g, b = np.asarray(Image.open(screenshot).convert("RGB"), dtype=int).transpose(2, 0, 1)
    assert ((abs(r - 0x94) < 20) & (abs(g - 0x67) < 20) & (abs(b - 0xBD) < 20)).sum() < 50
