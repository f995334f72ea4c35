"""The solve stage: a seeded planner run on a puzzle, its path in memory; manipulation takes its paths
from it and writes nothing into the puzzle folder (``solutions/`` is the benchmark's alone)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.folder_layout import BEST_SOLUTION

BUDGET = 300_000
"""Collision checks a run: LA-RRT solves the two-object slider below in every run well within it."""


@pytest.fixture(scope="module")
def slider():
    from solver.pipelines.generation import generate_puzzle

    return generate_puzzle("simple_slider", 863, {"n_objects": 2})


@pytest.fixture
def folder(slider, tmp_path):
    """The slider's folder, written afresh for each test (a test may add files to it)."""
    from phyrogen_core.export import write_puzzle

    return write_puzzle(slider, tmp_path)


def _tree(root):
    return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_a_solve_run_is_a_valid_path_the_same_for_the_same_run(folder):
    from solver.planning.problem import FINE_RESOLUTION, verify_certificate
    from solver.planning.solve import solve

    loaded = read_puzzle_dir(folder)
    first, again, other = (solve(loaded, "la_rrt", BUDGET, run) for run in (0, 0, 1))
    assert first.solved and first.end == "budget" and first.checks >= BUDGET
    assert first.joint_order == loaded.joint_order and first.title == "LA-RRT"
    assert verify_certificate(loaded.chain, first.path, loaded.goal, FINE_RESOLUTION, start=loaded.start) == []
    assert again == first  # deterministic for a seed: the same record, every float
    assert other.solved and other.seed != first.seed and other.path != first.path  # another run, another draw


def test_a_budget_too_small_solves_nothing_and_no_budget_is_refused(folder):
    """The negative control: one check finds no path (an empty one, not a made-up one)."""
    from solver.planning.solve import solve

    loaded = read_puzzle_dir(folder)
    starved = solve(loaded, "la_rrt", 1)
    assert not starved.solved and starved.path == () and starved.action_cost is None and starved.end == "budget"
    for budget in (None, 0, 1.5, True):
        with pytest.raises(ValueError, match="budget"):
            solve(loaded, "la_rrt", budget)
    with pytest.raises(ValueError, match="unknown planner 'nope'"):
        solve(loaded, "nope", BUDGET)


@pytest.mark.slow
def test_a_solve_run_finds_the_path_of_the_benchmark_run_of_the_same_index(folder, tmp_path):
    """Seeded as the benchmark seeds its run (in a fresh worker process), the in-memory run finds the
    very path that run journals."""
    from phyrogen_core.folder import PuzzleFolder
    from solver.benchmark.profiles import get_profile
    from solver.benchmark.runner import run_benchmark
    from solver.planning.solve import solve

    records = []
    run_benchmark([PuzzleFolder.open(folder)], ["la_rrt"], get_profile("quick", runs=2, time_limit=600.0),
                  tmp_path / "bench", workers=1, save_solutions=False, plots=False, progress=False,
                  on_done=records.append, budget_checks=BUDGET)
    loaded = read_puzzle_dir(folder)
    by_run = {record.run: record for record in records}
    assert sorted(by_run) == [0, 1]
    for run, record in by_run.items():
        solved = solve(loaded, "la_rrt", BUDGET, run)
        assert record.solved and solved.seed == record.seed and solved.checks == record.checks
        assert np.array_equal(solved.path, record.path) and solved.action_cost == record.action_cost
    assert not np.array_equal(solve(loaded, "la_rrt", BUDGET, 0).path, by_run[1].path)  # runs tell apart


def _fake_execution(monkeypatch, tried):
    import manipulation.execution as execution

    def fake(loaded, solution, settings, gui=False, progress=None):
        tried.append((solution.label, solution.path))
        attempt = execution.AttemptReport(solution.label, 0.5, 2, 0, 1.0, 2.0, 3.0, False, False, 0.0, "no grasp")
        return attempt, execution.Recording(), None

    monkeypatch.setattr(execution, "execute_solution", fake)
    return execution


def test_manipulation_executes_the_solve_runs_and_writes_nothing_into_the_puzzle_folder(folder, monkeypatch):
    from manipulation.source import ShortBenchmark
    from solver.planning.solve import solve

    tried = []
    execution = _fake_execution(monkeypatch, tried)
    before = _tree(folder)
    settings = execution.ExecutionSettings(short_benchmark=ShortBenchmark(runs=2, budget_checks=BUDGET))
    report, _, _ = execution.execute_puzzle(folder, settings)
    assert _tree(folder) == before and not (folder / BEST_SOLUTION).parent.exists()
    loaded = read_puzzle_dir(folder)
    runs = [solve(loaded, "la_rrt", BUDGET, run) for run in (0, 1)]
    labels = [label for label, _ in tried]
    assert labels[-1] == "certificate" and all(label.startswith("benchmark: LA-RRT run ") for label in labels[:-1])
    first = runs[int(labels[0][-1])]
    assert np.array_equal(tried[0][1], first.path)  # the solve stage's path, as it found it
    assert report.solutions_tried == len(tried)


def test_a_folder_with_the_benchmarks_best_solution_runs_no_solve(folder, monkeypatch):
    """The control: a best solution in the folder (the benchmark's) is executed, and nothing is solved."""
    import solver.planning.solve as solve_stage
    from manipulation.source import ShortBenchmark
    from solver.planning.solve import solve

    loaded = read_puzzle_dir(folder)
    best = solve(loaded, "la_rrt", BUDGET, 0)
    (folder / BEST_SOLUTION).parent.mkdir()
    (folder / BEST_SOLUTION).write_text(json.dumps({"planner": "LA-RRT", "run": 0, "joint_order": best.joint_order,
                                                    "path": best.path}))

    def refused(*args, **kwargs):
        raise AssertionError("the solve stage ran")

    monkeypatch.setattr(solve_stage, "solve", refused)
    tried = []
    execution = _fake_execution(monkeypatch, tried)
    execution.execute_puzzle(folder, execution.ExecutionSettings(short_benchmark=ShortBenchmark(budget_checks=BUDGET)))
    assert [label for label, _ in tried] == ["benchmark best: LA-RRT run 0", "certificate"]


def test_a_solve_path_our_model_refutes_is_refused_before_physics(folder, monkeypatch):
    """The 2 mm check applies to the solve stage's paths too: one straight through the blockers never
    reaches physics, a valid one (the control) does."""
    import manipulation.execution as execution
    from manipulation.solution import BenchmarkRun

    loaded = read_puzzle_dir(folder)
    start = np.asarray(loaded.certificate[0], dtype=float)
    through = start.copy()
    for name, value in loaded.goal.values.items():
        through[loaded.joint_order.index(name)] = value
    bad = BenchmarkRun("LA-RRT", 0, loaded.joint_order, (tuple(start), tuple(through)))
    good = BenchmarkRun("LA-RRT", 1, loaded.joint_order, tuple(map(tuple, loaded.certificate)))
    tried = []
    _fake_execution(monkeypatch, tried)
    monkeypatch.setattr(execution, "solved_runs", lambda *args: (bad,))
    report, _, _ = execution.execute_puzzle(folder)
    assert [label for label, _ in tried] == ["certificate"]
    assert report.attempts[0].solution == "benchmark: LA-RRT run 0"
    assert "refused before simulation" in report.attempts[0].message and "collides" in report.attempts[0].message
    tried.clear()
    monkeypatch.setattr(execution, "solved_runs", lambda *args: (good,))
    execution.execute_puzzle(folder)
    assert [label for label, _ in tried] == ["benchmark: LA-RRT run 1"]  # the certificate's path, listed once
