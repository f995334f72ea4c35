"""Why a run ended, recorded everywhere; budgets in checks that charge every planner's motions by
their length; budgets in CPU seconds; and the same command twice giving the same journal.

A run ends for one stated reason (``solved``, ``budget``, ``clock``, ``stopped``), in ``runs.jsonl``,
the OMPL log (run property ``end reason``), ``summary.json``, ``summary.md`` and the results page. A
run the wall-clock backstop ended before its budget is no result of the budget: the summary counts
it apart and marks its cell incomplete (a deliberately tiny ``--time-limit`` makes such runs; the
derived backstop of the same budget is the negative control, where the budget ends every run).
"""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from phyrogen.cli import main
from solver.benchmark.journal import JOURNAL

PLANNERS = "la_rrt,la_rrt_push,rrt_star,lbt_rrt,bit_star"
BUDGET = "60000"
"""Checks per run (motions by their length): a few tenths of a CPU second for each planner, so the
whole file stays cheap; the runs on a Move N Times of n = 3 end on it (it is not solved by every run)."""
TIME_COLUMNS = ("time", "first_solution_time", "best_solution_time", "wall", "cpu_time")
"""Record fields measured by the clock; progress samples' first element (their time) too."""


@pytest.fixture(scope="module")
def puzzles(tmp_path_factory) -> Path:
    from phyrogen_core.export import write_puzzle
    from solver.pipelines.generation import generate_puzzle, versions

    root = tmp_path_factory.mktemp("puzzles")
    # Fresh seeds: not the paper's puzzles.
    for generator, seed, params in (("move_n_times", 7103, {"n": 3}), ("simple_slider", 7109, {"n_objects": 3})):
        write_puzzle(generate_puzzle(generator, seed, params), root, versions())
    return root


def bench(puzzles: Path, out: Path, *extra: str, runs: str = "2") -> int:
    return main(["benchmark", "--puzzles", str(puzzles), "--out", str(out), "--planners", PLANNERS, "--runs", runs,
                 "--workers", "2", "--quiet", "--no-solutions", *extra])


def journal_without_time(out: Path) -> list[dict]:
    lines = []
    for line in (out / JOURNAL).read_text().splitlines():
        data = json.loads(line)
        record = data["record"]
        for name in TIME_COLUMNS:
            record.pop(name)
        record["progress"] = [sample[1:] for sample in record["progress"]]
        lines.append(data)
    return sorted(lines, key=lambda d: json.dumps(d["key"], sort_keys=True))


@pytest.fixture(scope="module")
def twice(puzzles, tmp_path_factory) -> tuple[Path, Path]:
    """The same command twice, the second time beside a busy loop on each core."""
    root = tmp_path_factory.mktemp("twice")
    assert bench(puzzles, root / "quiet", "--budget-checks", BUDGET) == 0
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        assert bench(puzzles, root / "loaded", "--budget-checks", BUDGET) == 0
    finally:
        for process in busy:
            process.kill()
            process.wait()
    return root / "quiet", root / "loaded"


@pytest.mark.slow
def test_the_same_command_twice_gives_the_same_journal_apart_from_the_clock(twice):
    quiet, loaded = twice
    first, second = journal_without_time(quiet), journal_without_time(loaded)
    assert len(first) == 2 * 2 * 5
    assert first == second
    # Every run ended on its budget (the derived backstop is far away), and the budget was spent.
    records = [line["record"] for line in first]
    assert {r["end"] for r in records} == {"budget"}
    assert all(r["checks"] >= int(BUDGET) for r in records)
    # Negative control: the time columns do differ, so the comparison above could have failed.
    times = [json.loads(line)["record"]["time"] for line in (quiet / JOURNAL).read_text().splitlines()]
    again = [json.loads(line)["record"]["time"] for line in (loaded / JOURNAL).read_text().splitlines()]
    assert times != again


@pytest.mark.slow
def test_end_reasons_reach_every_output_and_a_complete_summary_says_so(twice):
    quiet, _ = twice
    summary = json.loads((quiet / "summary.json").read_text())
    assert summary["version"] == 2 and summary["complete"] is True and summary["machine_dependent"] is False
    assert all(c["ends"] == {"budget": 2} and c["clock_ended"] == 0 and c["runs"] == 2 for c in summary["cells"])
    log = (quiet / "logs" / "move_n_times_7103.log").read_text()
    assert "end reason|solved|budget|clock|stopped" in log and "end reason ENUM" in log
    with sqlite3.connect(quiet / "benchmark.db") as db:
        assert {row[0] for row in db.execute("SELECT end_reason FROM runs")} == {1}  # "budget"
    assert "Runs by end reason: budget 20" in (quiet / "summary.md").read_text()
    assert "Incomplete" not in (quiet / "summary.md").read_text()


@pytest.mark.slow
def test_a_tiny_backstop_records_the_clock_and_marks_the_cell_incomplete(puzzles, tmp_path):
    out = tmp_path / "clock"
    # A budget no run can spend in 0.01 s: the explicit, tight backstop ends every run.
    assert bench(puzzles, out, "--budget-checks", "100000000", "--time-limit", "0.01", runs="1") == 0
    records = [json.loads(line)["record"] for line in (out / JOURNAL).read_text().splitlines()]
    assert len(records) == 2 * 5 and {r["end"] for r in records} == {"clock"}
    assert all(r["checks"] < 100_000_000 for r in records)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is False
    for cell in summary["cells"]:  # reported apart, not as a budget result
        assert cell["clock_ended"] == 1 and cell["runs"] == 0 and cell["complete"] is False
        assert cell["rate"] is None and cell["successes"] == 0  # of 0 runs of the budget
    text = (out / "summary.md").read_text()
    assert "**Incomplete: 10 of 10 cells**" in text and "(+1 clock-ended: incomplete)" in text
    assert "Incomplete: 10 cells" in (out / "results.html").read_text()
    with sqlite3.connect(out / "benchmark.db") as db:
        assert {row[0] for row in db.execute("SELECT end_reason FROM runs")} == {2}  # "clock"


@pytest.mark.slow
def test_a_cpu_budget_ends_runs_on_cpu_seconds_and_is_marked_machine_dependent(puzzles, tmp_path):
    out = tmp_path / "cpu"
    assert bench(puzzles, out, "--budget-cpu", "0.2", runs="1") == 0
    records = [json.loads(line) for line in (out / JOURNAL).read_text().splitlines()]
    assert {r["key"]["budget_cpu"] for r in records} == {0.2} and all("budget_checks" not in r["key"] for r in records)
    assert {r["record"]["end"] for r in records} == {"budget"}
    assert all(r["record"]["cpu_time"] >= 0.2 for r in records)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["machine_dependent"] is True and all(c["machine_dependent"] for c in summary["cells"])
    assert "machine_dependent BOOLEAN = 1" in (out / "logs" / "simple_slider_7109.log").read_text()
    assert "depend on the machine" in (out / "summary.md").read_text()


@pytest.mark.parametrize("extra", [["--budget-cpu", "0"], ["--budget-cpu", "nan"], ["--budget-cpu", "inf"],
                                   ["--budget-cpu", "1", "--budget-checks", "5000"],
                                   ["--budget-cpu", "1", "--budget-from-paper"]])
def test_a_bad_cpu_budget_is_refused_with_one_line(puzzles, tmp_path, capsys, extra):
    capsys.readouterr()
    try:
        code = bench(puzzles, tmp_path / "bench", *extra, "--dry-run")
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "budget" in err[0], err
    assert not (tmp_path / "bench").exists()


def test_the_backstop_of_a_budget_is_derived_from_it_unless_a_time_limit_is_given():
    from solver.benchmark.difficulty import BACKSTOP_SECONDS, backstop_seconds, cpu_backstop_seconds
    from solver.benchmark.paper_budgets import paper_budgets
    from solver.benchmark.profiles import backstop_profile, get_profile

    quick = get_profile("quick")
    by_checks = backstop_profile(quick, 10**8)
    assert set(by_checks.time_limits.values()) == {backstop_seconds(10**8)} == {10**6}
    paper = backstop_profile(quick, paper_budgets())
    assert all(paper.time_limit(g) == backstop_seconds(b) >= BACKSTOP_SECONDS for g, b in paper_budgets().items())
    assert set(backstop_profile(quick, budget_cpu=100.0).time_limits.values()) == {cpu_backstop_seconds(100.0)}
    assert backstop_profile(quick) is quick  # control: no budget, the profile's own limits


# -- the charge of a motion --------------------------------------------------------------------
@pytest.fixture(scope="module")
def _slider():
    from solver.pipelines.generation import generate_puzzle

    return generate_puzzle("simple_slider", 7127, {"n_objects": 3})


@pytest.fixture()
def slider(_slider):
    return lambda: _slider


def test_a_motion_is_charged_its_length_for_every_benchmark_planner_and_once_for_the_judges(slider):
    from solver.planning.anytime import CheckCounter, count_checks, motion_length, planning_steps
    from solver.planning.problem import problem_for_chain

    puzzle = slider()
    problem = problem_for_chain(puzzle.planning_chain, puzzle.goal)
    steps = planning_steps(problem)
    start = problem.start
    far = start.copy()
    far[0] += 40 * steps[0]
    near = start.copy()
    near[0] += 2.5 * steps[0]
    assert motion_length(start, far, steps) == 40 and motion_length(start, near, steps) == 3
    assert motion_length(start, start, steps) == 1  # a motion that goes nowhere tests its end state
    benchmark, judge = CheckCounter(problem.model, by_length=True), CheckCounter(problem.model)
    for counter in (benchmark, judge):
        counter.check_motion(start, far, steps)
        counter.motion_collision(start, near, steps)
        counter.is_valid(start)
    assert benchmark.checks == 40 + 3 + 1
    assert judge.checks == 1 + 1 + 1  # the Maker's unit, which generated puzzles depend on, is unchanged
    assert isinstance(count_checks(problem, by_length=True).model, CheckCounter)
    assert count_checks(problem, by_length=True).model.by_length and not count_checks(problem).model.by_length


def test_the_registry_charges_motions_by_length_whatever_the_planner(slider):
    """Every registered planner gets its problem counted by length from the registry, even one whose
    own code would count otherwise (the first to count decides)."""
    from solver.planning.anytime import PlanResult
    from solver.planning.problem import problem_for_chain
    from solver.planning.registry import Planner, planner, registry_copy

    seen = []

    class Probe(Planner):
        name, title, version = "probe", "Probe", "1"

        def plan(self, problem, time_limit, seed, progress_interval, until_first, goal_seed, budget_checks=None):
            seen.append(problem.model.by_length)
            return PlanResult("probe", False, (), None, None, 0.0, 0, (), "Timeout")

    puzzle = slider()
    with registry_copy():
        spec = planner(Probe).spec
        result = spec.plan(problem_for_chain(puzzle.planning_chain, puzzle.goal), 1.0, 0, budget_checks=10)
        with pytest.raises(TypeError):  # a plan function without budget_cpu cannot take a CPU budget
            spec.plan(problem_for_chain(puzzle.planning_chain, puzzle.goal), 1.0, 0, budget_cpu=1.0)
    assert seen == [True] and result.end == "stopped"


def test_until_first_scores_every_planners_first_path_as_found(monkeypatch, slider):
    """LA-RRT's first path is not defragmented before it is scored with ``--until first`` (RRT*'s,
    BIT*'s and LBT-RRT's never are); anytime, it is (the control)."""
    from phyrogen_core.actions import count_actions
    from solver.planning import defragment
    from solver.planning.problem import problem_factors, problem_for_chain
    from solver.planning.registry import get_planner

    calls = []
    original = defragment.Defragmenter.run

    def counting(self, *args, **kwargs):
        calls.append(1)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(defragment.Defragmenter, "run", counting)
    puzzle = slider()
    problem = problem_for_chain(puzzle.planning_chain, puzzle.goal)
    first = get_planner("la_rrt").plan(problem, 1e4, 3, 1.0, True, 5, 2_000_000)
    assert first.solved and first.end == "solved" and calls == []
    assert first.action_cost == count_actions(np.asarray(first.path), problem_factors(problem))
    anytime = get_planner("la_rrt").plan(problem, 1e4, 3, 1.0, False, 5, 200_000)
    assert anytime.solved and anytime.end == "budget" and calls  # control: anytime runs defragment
    assert np.asarray(first.path).shape[1] == len(problem.start)
