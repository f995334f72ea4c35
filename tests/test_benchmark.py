"""Benchmark output: OMPL log -> SQLite database (OMPL's reader) -> queries, summary, plots, solutions."""

from __future__ import annotations

import json
import math
import sqlite3
from pathlib import Path

import pytest

from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.folder_layout import BEST_SOLUTION
from solver.benchmark.jobs import RunRecord, make_jobs
from solver.benchmark.journal import journal_line, parse_journal_line, run_key
from solver.benchmark.ompl_log import build_database, write_log
from solver.benchmark.plots import (
    COLORS,
    PLANNER_ORDER,
    curves,
    planner_color,
    plot_fig4,
    summary_markdown,
    summary_rows,
)
from solver.benchmark.profiles import PAPER_TIME_LIMITS, get_profile
from solver.benchmark.runner import estimate_seconds
from solver.planning.registry import PLANNERS, default_planners


def _record(planner: str, run: int, solved: bool, first: float | None, cost: int | None) -> RunRecord:
    progress = ((0.0, math.inf, 0), (0.5, float(cost + 2) if solved else math.inf, 10),
                (1.0, float(cost) if solved else math.inf, 20))
    return RunRecord(planner, "toy_1", run, 100 + run, 1.0, solved, "Exact solution" if solved else "Timeout",
                     1.0, first, cost, 2.5 if solved else None, 20, 0, progress)


@pytest.fixture()
def database(tmp_path):
    records = [_record("LA-RRT", 0, True, 0.1, 2), _record("LA-RRT", 1, True, 0.3, 4),
               _record("RRT*", 0, True, 0.6, 9), _record("RRT*", 1, False, None, None)]
    log = tmp_path / "toy_1.log"
    write_log(log, "toy_1", records, ["LA-RRT", "RRT*"], 1.0, 2, 7, 4.2, "toy setup")
    db = tmp_path / "bench.db"
    build_database(db, [log])
    return db


def test_log_round_trips_through_ompl_database(database):
    with sqlite3.connect(database) as db:
        (name, limit, runcount, seed), = db.execute("SELECT name, timelimit, runcount, seed FROM experiments")
        assert (name, limit, runcount, seed) == ("toy_1", 1.0, 2, "7")
        planners = {n for (n,) in db.execute("SELECT name FROM plannerConfigs")}
        assert planners == {"LA-RRT", "RRT*"}
        rows = db.execute("""SELECT plannerConfigs.name, solved, status, action_cost, time_to_first_solution, seed
                             FROM runs JOIN plannerConfigs ON runs.plannerid = plannerConfigs.id
                             ORDER BY plannerConfigs.name, seed""").fetchall()
        assert rows == [("LA-RRT", 1, 6, 2, 0.1, 100), ("LA-RRT", 1, 6, 4, 0.3, 101),
                        ("RRT*", 1, 6, 9, 0.6, 100), ("RRT*", 0, 4, None, None, 101)]
        statuses = dict(db.execute("SELECT value, description FROM enums WHERE name = 'status'").fetchall())
        assert statuses[6] == "Exact solution" and statuses[4] == "Timeout"
        progress = db.execute("SELECT time, best_cost, iterations FROM progress ORDER BY runid, time").fetchall()
        assert len(progress) == 12
        assert progress[:3] == [(0.0, None, 0), (0.5, 4.0, 10), (1.0, 2.0, 20)]  # inf is stored as NULL
        # computeViews ran: Planner Arena's views exist
        views = {n for (n,) in db.execute("SELECT name FROM sqlite_master WHERE type = 'view'")}
        assert {"bestPlannerConfigs", "bestPlannerConfigsPerExperiment"} <= views


def test_summary_and_curves_from_the_database(database, tmp_path):
    rows = {r.planner: r for r in summary_rows(database)}
    assert rows["LA-RRT"].success == 1.0 and rows["LA-RRT"].median_first_solution == pytest.approx(0.2)
    assert rows["LA-RRT"].median_action_cost == 3
    assert rows["RRT*"].success == 0.5 and rows["RRT*"].median_action_cost == 9
    text = summary_markdown(list(rows.values()))
    assert "| toy_1 | 1 | 2/2 / 0.20 / 3 | 1/2 / 0.60 / 9 |" in text
    times, success, cost = curves(database, "toy_1", "LA-RRT", points=11)
    assert success[0] == 0 and success[-1] == 1.0
    assert cost[-1] == 3 and cost[6] == 5 and math.isnan(cost[0])  # medians of (2, 4) and (4, 6)
    figure = plot_fig4(database, tmp_path / "fig.png")
    assert figure.stat().st_size > 1000


def test_until_first_and_planner_versions_reach_the_database_and_the_summary(tmp_path):
    records = [_record("LA-RRT", 0, True, 0.1, 2), _record("LA-RRT+push (ours)", 0, True, 0.05, 2)]
    log = tmp_path / "toy_1.log"
    titles = ["LA-RRT", "LA-RRT+push (ours)"]
    versions = {title: PLANNERS[name].version for title, name in zip(titles, ["la_rrt", "la_rrt_push"], strict=True)}
    write_log(log, "toy_1", records, titles, 1.0, 1, 7, 1.0, "toy setup", until_first=True, versions=versions)
    db = tmp_path / "bench.db"
    build_database(db, [log])
    with sqlite3.connect(db) as connection:
        settings = dict(connection.execute("SELECT name, settings FROM plannerConfigs"))
    assert set(settings) == set(titles)
    for title in titles:
        assert "until_first BOOLEAN = 1" in settings[title] and versions[title] in settings[title]
    rows = summary_rows(db)
    text = summary_markdown(rows, until_first=True)
    assert "--until first" in text and "action cost of the first solution" in text
    assert "| toy_1 | 1 | 1/1 / 0.10 / 2 | 1/1 / 0.05 / 2 |" in text
    assert plot_fig4(db, tmp_path / "fig.png", until_first=True).stat().st_size > 1000


def test_every_registered_planner_has_its_own_colour_in_the_registry_order():
    assert PLANNER_ORDER == tuple(spec.title for spec in PLANNERS.values())
    assert set(PLANNER_ORDER) <= set(COLORS)
    assert len({planner_color(title) for title in PLANNER_ORDER}) == len(PLANNER_ORDER)
    assert planner_color("Someone's planner") == planner_color("Someone's planner")


def test_log_rejects_experiment_names_with_spaces(tmp_path):
    with pytest.raises(ValueError, match="white space"):
        write_log(tmp_path / "x.log", "two words", [], ["LA-RRT"], 1.0, 1, 0, 0.0, "")


def test_profiles_and_jobs():
    paper = get_profile("paper")
    assert paper.runs == 100 and dict(paper.time_limits) == dict(PAPER_TIME_LIMITS)
    assert PAPER_TIME_LIMITS["lockbox_random"] == 600 and PAPER_TIME_LIMITS["continuous_space"] == 20
    with pytest.raises(ValueError, match="quick"):
        get_profile("huge")
    quick = get_profile("quick", runs=2, time_limit=0.5)
    puzzles = [PuzzleFolder(Path("/nowhere"), "rooms_1", "rooms"),
               PuzzleFolder(Path("/nowhere"), "grid_world_2", "grid_world")]
    jobs = make_jobs(puzzles, ["la_rrt", "bit_star"], quick, base_seed=3)
    assert len(jobs) == 8 and {j.time_limit for j in jobs} == {0.5}
    assert len({j.seed for j in jobs}) == 8
    assert [j.seed for j in make_jobs(puzzles, ["la_rrt", "bit_star"], quick, base_seed=3)] == [j.seed for j in jobs]
    # 100 runs x 4 planners x (40 + 1) s on two workers for one Simple Slider puzzle
    one = [PuzzleFolder(Path("/nowhere"), "simple_slider_1", "simple_slider")]
    assert estimate_seconds(one, ["la_rrt", "rrt_star", "lbt_rrt", "bit_star"], paper, 2, 1.0) == 8200


def test_every_planner_of_a_run_gets_the_same_goal_seed_and_the_mode_is_in_the_key():
    quick = get_profile("quick", runs=3, time_limit=0.5)
    puzzles = [PuzzleFolder(Path("/nowhere"), "rooms_1", "rooms")]
    jobs = make_jobs(puzzles, list(default_planners()), quick, base_seed=3)
    by_run = {}
    for job in jobs:
        by_run.setdefault(job.run, set()).add(job.goal_seed)
    assert all(len(seeds) == 1 for seeds in by_run.values())  # one goal seed per run, whatever the planner
    assert len({next(iter(seeds)) for seeds in by_run.values()}) == 3  # and another one per run
    assert not any(job.until_first for job in jobs)
    first = make_jobs(puzzles, list(default_planners()), quick, base_seed=3, until_first=True)
    assert all(job.until_first for job in first)
    keys = {run_key(job, "digest", "2.0.1") for job in jobs}
    first_keys = {run_key(job, "digest", "2.0.1") for job in first}
    assert len(keys) == len(jobs) and not keys & first_keys  # a mode's runs are never the other's
    key = json.loads(run_key(first[0], "digest", "2.0.1"))
    assert key["until"] == "first" and key["planner_version"] == PLANNERS[first[0].planner].version
    assert key["goal_seed"] == first[0].goal_seed


def test_a_changed_planner_version_changes_the_journal_key(monkeypatch):
    from dataclasses import replace

    import solver.planning.registry as planners

    job = make_jobs([PuzzleFolder(Path("/nowhere"), "rooms_1", "rooms")], ["la_rrt"], get_profile("quick"))[0]
    before = run_key(job, "digest", "2.0.1")
    monkeypatch.setitem(planners.PLANNERS, "la_rrt", replace(planners.PLANNERS["la_rrt"], code_version="paper-99"))
    assert run_key(job, "digest", "2.0.1") != before


def test_journal_lines_round_trip_and_refuse_what_does_not_fit():
    from dataclasses import replace

    record = replace(_record("LA-RRT", 0, True, 0.1, 2), path=((0.0, 1.0), (1.0, 1.0)), joint_order=("a", "b"))
    key = json.dumps({"planner": "la_rrt", "puzzle": "toy_1", "run": 0, "seed": 100, "time_limit": 1.0},
                     sort_keys=True)
    line = journal_line(key, record)
    assert line.endswith(b"\n") and line.count(b"\n") == 1
    assert b"Infinity" not in line  # strict JSON: "no solution yet" is null
    assert parse_journal_line(line) == (key, record)
    assert parse_journal_line(line[:-20]) is None  # torn mid-write
    for change in ({"solved": "yes"}, {"status": "Great"}, {"run": 5}, {"seed": 1.5}, {"path": [["x"]]}):
        data = json.loads(line)
        data["record"].update(change)
        assert parse_journal_line(json.dumps(data).encode()) is None, change


# The end-to-end runs below end on check budgets, so a loaded machine runs the same searches as an
# idle one; the time limit is only a backstop against a hang.
BACKSTOP = 300.0
END_TO_END_CHECKS = 5_000
"""Simple Slider 1, base seed 0: LA-RRT's runs 0 and 1 first hold an action-cost-2 solution after 375 and
197 checks, LA-RRT+push's after 2 and 73 (the least budgets that solve them); 5,000 is 13 times the most.
A run to its budget takes about 0.2 s idle; the 1 s limit this replaced spent 20,000-40,000 checks."""
UNTIL_FIRST_CHECKS = 20_000
"""Move N Times 1, base seed 0, until first: the five planners' first solutions take 127 (LA-RRT+push),
154 (LA-RRT), 363 (BIT*), 1,334 (LBT-RRT) and 1,428 (RRT*) checks; 20,000 is 14 times the most."""


@pytest.mark.slow
def test_benchmark_end_to_end(tmp_path):
    from phyrogen_core.export import write_puzzle
    from phyrogen_core.folder import find_puzzle_folders
    from solver.benchmark.runner import run_benchmark
    from solver.pipelines.generation import generate_puzzle, versions
    from solver.planning.problem import verify_certificate

    puzzle = generate_puzzle("simple_slider", 1)
    folder = write_puzzle(puzzle, tmp_path / "puzzles", versions())
    puzzles = find_puzzle_folders(tmp_path / "puzzles")
    assert [p.name for p in puzzles] == ["simple_slider_1"]
    out = run_benchmark(puzzles, ["la_rrt", "la_rrt_push", "rrt_star"],
                        get_profile("quick", runs=2, time_limit=BACKSTOP), tmp_path / "bench", workers=2,
                        progress=False, budget_checks=END_TO_END_CHECKS)
    assert (tmp_path / "bench" / "logs" / "simple_slider_1.log").is_file()
    assert (tmp_path / "bench" / "fig4.png").is_file() and (tmp_path / "bench" / "summary.md").is_file()
    assert (tmp_path / "bench" / "results.html").is_file()
    rows = summary_rows(out.database)
    # summary.json (what the Blender panel and scripts read) holds the database's counts, cell by cell
    cells = json.loads((tmp_path / "bench" / "summary.json").read_text())["cells"]
    assert [(c["puzzle"], c["planner"], c["successes"], c["runs"]) for c in cells] == [
        (r.experiment, r.planner, round(r.success * r.runs), r.runs) for r in rows]
    assert {r.planner for r in rows} == {"LA-RRT", "LA-RRT+push (ours)", "RRT*"} and all(r.runs == 2 for r in rows)
    assert all(r.success == 1.0 for r in rows if r.planner.startswith("LA-RRT"))
    saved = json.loads((folder / BEST_SOLUTION).read_text())
    assert saved["planner"] in ("LA-RRT", "LA-RRT+push (ours)") and saved["action_cost"] == 2
    assert saved["joint_order"] == list(puzzle.joint_order)
    assert verify_certificate(puzzle.planning_chain, saved["path"], puzzle.goal) == []


@pytest.mark.slow
def test_a_benchmark_until_first_stops_every_run_at_its_first_solution(tmp_path):
    from phyrogen_core.export import write_puzzle
    from phyrogen_core.folder import find_puzzle_folders
    from solver.benchmark.journal import JOURNAL, read_journal
    from solver.benchmark.runner import run_benchmark
    from solver.pipelines.generation import generate_puzzle, versions

    write_puzzle(generate_puzzle("move_n_times", 1), tmp_path / "puzzles", versions())
    puzzles = find_puzzle_folders(tmp_path / "puzzles")
    profile = get_profile("quick", runs=1, time_limit=BACKSTOP)
    out = run_benchmark(puzzles, list(default_planners()), profile, tmp_path / "bench", workers=2, progress=False,
                        save_solutions=False, until_first=True, budget_checks=UNTIL_FIRST_CHECKS)
    assert len(out.records) == len(default_planners())
    for record in out.records:
        if record.solved:  # stopped right at its first solution, which is the result
            assert record.first_solution_time == record.best_solution_time
            assert record.checks < UNTIL_FIRST_CHECKS, record
        else:  # possible for RRT* and BIT*: a best path that clips a corner at fine resolution
            assert record.checks >= UNTIL_FIRST_CHECKS, record  # it searched on to its budget
    assert all(r.solved for r in out.records if r.planner.startswith("LA-RRT"))
    assert "--until first" in (tmp_path / "bench" / "summary.md").read_text()
    log = (tmp_path / "bench" / "logs" / "move_n_times_1.log").read_text()
    assert log.count("until_first BOOLEAN = 1") == len(default_planners())
    keys = [json.loads(k) for k in read_journal(tmp_path / "bench" / JOURNAL)]
    assert {k["until"] for k in keys} == {"first"} and len({k["goal_seed"] for k in keys}) == 1
    # The same benchmark until the limit reuses none of them.
    again = run_benchmark(puzzles, ["la_rrt"], profile, tmp_path / "bench", workers=1, progress=False,
                          save_solutions=False, plots=False, budget_checks=UNTIL_FIRST_CHECKS)
    assert again.reused == 0
