"""Manipulation tries a puzzle's solutions in order: every least-cost benchmark solution, then the certificate."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from bad_paths_support import straight_through, swapped

from manipulation.solution import BenchmarkRun, candidate_solutions
from phyrogen_core.actions import count_actions
from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.folder_layout import BEST_SOLUTION


@pytest.fixture(scope="module")
def slider_folder(tmp_path_factory):
    from phyrogen_core.export import write_puzzle
    from solver.pipelines.generation import generate_puzzle

    return write_puzzle(generate_puzzle("simple_slider", 741, {"n_objects": 2}), tmp_path_factory.mktemp("solutions"))


@pytest.fixture
def folder(slider_folder, tmp_path):
    return shutil.copytree(slider_folder, tmp_path / slider_folder.name)


def _factors(loaded):
    return {name: cols for name, cols in loaded.chain.factors.items() if name != "goal"}


def _variants(loaded):
    """Paths of the puzzle: the certificate, one as costly but longer (the last mover overshoots and
    comes back, in the same action), and one costlier (the last mover nudged and put back first)."""
    certificate = np.asarray(loaded.certificate, dtype=float)
    factors = _factors(loaded)

    def mover(a, b):
        return next(cols for cols in factors.values() if not np.allclose(a[cols], b[cols]))

    before, last = certificate[-2], certificate[-1]
    cols = mover(before, last)
    assert np.allclose(certificate[1][cols], certificate[0][cols]), "the last mover must not move first"
    overshoot = last.copy()
    overshoot[cols] += 0.1 * (last[cols] - before[cols])
    longer = np.vstack([certificate[:-1], overshoot, last])
    nudge = certificate[0].copy()
    nudge[cols] += 0.1 * (last[cols] - before[cols])
    costly = np.vstack([certificate[0], nudge, certificate[0], *certificate[1:]])
    assert count_actions(longer, factors) == count_actions(certificate, factors)
    assert count_actions(costly, factors) > count_actions(certificate, factors)
    return certificate, longer, costly


def _run(loaded, path, run: int, planner: str = "LA-RRT") -> BenchmarkRun:
    order = tuple(reversed(loaded.joint_order))  # the journal's order need not be the puzzle's
    columns = [loaded.joint_order.index(name) for name in order]
    return BenchmarkRun(planner, run, order, tuple(tuple(float(v) for v in np.asarray(s)[columns]) for s in path))


def _digest(folder, loaded):
    from solver.benchmark.journal import puzzle_digest

    return puzzle_digest(PuzzleFolder(folder, loaded.name))


def test_without_a_benchmark_the_certificate_is_the_only_solution(folder):
    loaded = read_puzzle_dir(folder)
    (only,) = candidate_solutions(folder, loaded)
    assert only.label == "certificate" and np.array_equal(only.path, np.asarray(loaded.certificate))


def test_least_cost_benchmark_solutions_come_first_shortest_first_then_the_certificate(folder):
    loaded = read_puzzle_dir(folder)
    certificate, longer, costly = _variants(loaded)
    file = folder / BEST_SOLUTION
    file.parent.mkdir()
    file.write_text(json.dumps({"planner": "LA-RRT+push (ours)", "run": 7, "joint_order": list(loaded.joint_order),
                                "path": longer.tolist()}))
    runs = [_run(loaded, costly, 1),                      # costlier: not tried
            _run(loaded, longer, 7, "LA-RRT+push (ours)"),  # the best file's own run: listed once
            _run(loaded, certificate, 3)]
    solutions = candidate_solutions(folder, loaded, runs)
    assert [s.label for s in solutions] == ["benchmark best: LA-RRT+push (ours) run 7", "benchmark: LA-RRT run 3"]
    # The certificate equals run 3's path: tried once, under the benchmark's name.
    assert np.allclose(solutions[1].path, certificate)
    assert np.allclose(solutions[0].path, longer)


def test_a_costlier_best_file_gives_way_to_cheaper_journal_runs(folder):
    loaded = read_puzzle_dir(folder)
    certificate, longer, costly = _variants(loaded)
    file = folder / BEST_SOLUTION
    file.parent.mkdir()
    file.write_text(json.dumps({"joint_order": list(loaded.joint_order), "path": costly.tolist()}))
    solutions = candidate_solutions(folder, loaded, [_run(loaded, longer, 5)])
    assert [s.label for s in solutions] == ["benchmark: LA-RRT run 5", "certificate"]


def test_the_command_line_takes_solved_la_rrt_runs_of_this_very_puzzle_from_the_journal(folder, tmp_path):
    from phyrogen.cli import benchmark_runs
    from phyrogen_core.atomic_writes import OutputError
    from solver.benchmark.jobs import RunRecord
    from solver.benchmark.journal import journal_line

    loaded = read_puzzle_dir(folder)
    name, digest = loaded.name, _digest(folder, loaded)
    path = tuple(tuple(s) for s in loaded.certificate)

    def line(planner: str, title: str, run: int, solved: bool = True, puzzle_digest: str = digest) -> bytes:
        key = {"planner": planner, "puzzle": name, "run": run, "seed": 10 + run, "puzzle_sha256": puzzle_digest}
        record = RunRecord(title, name, run, 10 + run, 1.0, solved, "Exact solution" if solved else "Timeout",
                           0.5, 0.5, 2 if solved else None, 1.0, 10, 0, (), path if solved else (),
                           loaded.joint_order)
        return journal_line(json.dumps(key, sort_keys=True), record)

    benchmark = tmp_path / "benchmark"
    benchmark.mkdir()
    (benchmark / "runs.jsonl").write_bytes(
        line("la_rrt", "LA-RRT", 0) + line("la_rrt_push", "LA-RRT+push (ours)", 1, solved=False)
        + line("rrt_star", "RRT*", 2) + line("la_rrt", "LA-RRT", 3, puzzle_digest="an earlier version")
        + b'{"torn": ')
    runs = benchmark_runs(benchmark, [folder])
    assert runs == {folder: [BenchmarkRun("LA-RRT", 0, loaded.joint_order, path)]}
    with pytest.raises(OutputError, match="has no runs.jsonl"):
        benchmark_runs(tmp_path, [folder])


def test_the_next_solution_runs_when_one_fails_and_the_report_says_which(folder, monkeypatch):
    import manipulation.execution as execution
    from manipulation.outputs import report_json, summary_table

    loaded = read_puzzle_dir(folder)
    certificate, _, _ = _variants(loaded)
    runs = [_run(loaded, _with_midpoint(certificate), 1)]  # a valid path (the overshoot leaves the limits)
    tried = []

    def fake(loaded, solution, settings, gui=False, progress=None):
        tried.append(solution.label)
        ok = solution.label == "certificate"
        attempt = execution.AttemptReport(solution.label, 0.5, 2, 0, 1.0, 2.0, 3.0, ok, ok, 0.0,
                                          "ok" if ok else "action 2/2 (obj_00): no grasp")
        return attempt, execution.Recording(), None

    monkeypatch.setattr(execution, "execute_solution", fake)
    report, _, _ = execution.execute_puzzle(folder, runs=runs)
    assert tried == ["benchmark: LA-RRT run 1", "certificate"]
    assert report.success and report.solution == "certificate" and report.solutions_tried == 2
    assert [a.success for a in report.attempts] == [False, True]
    assert report.planning_seconds == 2.0 and report.execution_seconds == 4.0  # summed over the attempts
    data = json.loads(report_json(report))
    assert data["solution"] == "certificate" and data["solutions_tried"] == 2
    assert "| certificate (2 tried) |" in summary_table([report])

    # Every solution failing: the last one's outcome, and the count.
    monkeypatch.setattr(execution, "execute_solution",
                        lambda loaded, solution, *args, **kwargs: _failing(execution, solution))
    report, _, _ = execution.execute_puzzle(folder, runs=runs)
    assert not report.success and report.solutions_tried == 2
    assert report.message.startswith("none of 2 solutions executed; the last, certificate: ")


def _failing(execution, solution):
    attempt = execution.AttemptReport(solution.label, 0.5, 2, 0, 1.0, 2.0, 3.0, False, False, 0.0, "no grasp")
    return attempt, execution.Recording(), None


def _with_midpoint(path):
    """The same motion with one more state, halfway along the first segment."""
    path = np.asarray(path, dtype=float)
    return np.vstack([path[:1], (path[0] + path[1]) / 2, path[1:]])


def _write_best(folder, loaded, path):
    (folder / BEST_SOLUTION).parent.mkdir(exist_ok=True)
    data = {"planner": "LA-RRT", "run": 3, "joint_order": list(loaded.joint_order), "path": np.asarray(path).tolist()}
    (folder / BEST_SOLUTION).write_text(json.dumps(data))


@pytest.mark.parametrize(("bad", "reason"), [
    (straight_through, "path collides at"),
    (swapped, "path collides at"),
    (lambda loaded: np.asarray(loaded.certificate)[1:], "path does not begin at the start state"),
    (lambda loaded: np.asarray(loaded.certificate)[:-1], "path does not end in the goal"),
])
def test_a_bad_solution_file_is_refused_before_physics_with_its_reason(folder, monkeypatch, bad, reason):
    """Every solution is checked as ``phyrogen check`` checks a certificate (2 mm) before the robot
    tries it: a refuted one never reaches physics, its attempt names why, and the next one runs."""
    import manipulation.execution as execution

    loaded = read_puzzle_dir(folder)
    _write_best(folder, loaded, bad(loaded))
    tried = []

    def fake(loaded, solution, settings, gui=False, progress=None):
        tried.append(solution.label)
        attempt = execution.AttemptReport(solution.label, 0.5, 2, 0, 1.0, 2.0, 3.0, True, True, 0.0, "ok")
        return attempt, execution.Recording(), None

    monkeypatch.setattr(execution, "execute_solution", fake)
    monkeypatch.setattr(execution, "solved_runs", lambda *args: ())
    report, _, _ = execution.execute_puzzle(folder)
    assert tried == ["certificate"]  # the bad file never reached physics
    refused = report.attempts[0]
    assert refused.solution == "benchmark best: LA-RRT run 3" and not refused.success
    assert refused.message.startswith(f"refused before simulation: {folder / BEST_SOLUTION}: ")
    assert reason in refused.message, refused.message
    assert report.success and report.solutions_tried == 2


def test_a_good_solution_file_passes_the_check_and_reaches_physics(folder, monkeypatch):
    """The control: the same file holding a valid path (the certificate with one more state) is tried."""
    import manipulation.execution as execution
    from manipulation.solution import load_solution, solution_problems

    loaded = read_puzzle_dir(folder)
    _write_best(folder, loaded, _with_midpoint(loaded.certificate))
    assert solution_problems(loaded, load_solution(folder, loaded.joint_order, loaded.certificate)) == []
    for bad in (straight_through, swapped):  # and the bad paths are refuted by the check itself
        _write_best(folder, loaded, bad(loaded))
        assert solution_problems(loaded, load_solution(folder, loaded.joint_order, loaded.certificate))
    _write_best(folder, loaded, _with_midpoint(loaded.certificate))
    tried = []
    monkeypatch.setattr(execution, "execute_solution",
                        lambda loaded, solution, *args, **kwargs: (tried.append(solution.label),
                                                                   _failing(execution, solution))[1])
    monkeypatch.setattr(execution, "solved_runs", lambda *args: ())
    execution.execute_puzzle(folder)
    assert tried == ["benchmark best: LA-RRT run 3", "certificate"]
