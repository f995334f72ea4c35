"""Check budgets: a run given a number of collision checks gives the same result (path, cost,
checks) for the same seed whatever else the machine is doing, for every registered planner."""

from __future__ import annotations

import subprocess
import sys

import pytest

from solver.planning.registry import PLANNERS, default_planners

BUDGET = 6_000
"""Enough for LA-RRT to solve Simple Slider 2 and for every planner to make many iterations."""
BACKSTOP = 300.0
"""Seconds: only against a hang; a budgeted run here takes well under a second."""


@pytest.fixture(scope="module")
def slider_folder(tmp_path_factory):
    from phyrogen_core.export import write_puzzle
    from phyrogen_core.folder import find_puzzle_folders
    from solver.pipelines.generation import generate_puzzle, versions

    root = tmp_path_factory.mktemp("puzzles")
    write_puzzle(generate_puzzle("simple_slider", 2), root, versions())
    return find_puzzle_folders(root)


def _outcomes(folders) -> dict[str, tuple]:
    from solver.benchmark.jobs import make_jobs, run_all
    from solver.benchmark.profiles import get_profile

    jobs = make_jobs(folders, list(default_planners()), get_profile("quick", runs=1, time_limit=BACKSTOP),
                     base_seed=3, budget_checks=BUDGET)
    records = list(run_all(jobs, workers=1))
    assert all(r.error is None for r in records), [r.error for r in records if r.error]
    return {r.planner: (r.solved, r.action_cost, r.path, r.checks, r.iterations, r.rejected) for r in records}


def test_the_same_seed_and_budget_give_the_same_result_under_load(slider_folder):
    quiet = _outcomes(slider_folder)
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        loaded = _outcomes(slider_folder)
    finally:
        for process in busy:
            process.kill()
            process.wait()
    assert set(quiet) == {PLANNERS[name].title for name in default_planners()}
    for title, outcome in quiet.items():
        assert loaded[title] == outcome, title
        assert outcome[3] >= BUDGET or outcome[0], (title, outcome)  # ended by its budget, not the backstop
    assert quiet["LA-RRT+push (ours)"][0]


def test_a_budget_ends_a_run_by_checks_not_seconds(slider_folder):
    from phyrogen_core.export import read_puzzle_dir
    from solver.planning.problem import problem_for_chain

    loaded = read_puzzle_dir(slider_folder[0].path)
    problem = problem_for_chain(loaded.chain, loaded.goal)
    small, large = (PLANNERS["lbt_rrt"].plan(problem, BACKSTOP, 5, budget_checks=b) for b in (500, 5_000))
    assert 500 <= small.checks < 600 and 5_000 <= large.checks < 5_100
    assert small.iterations < large.iterations and small.time < BACKSTOP and small.cpu_time > 0


@pytest.mark.parametrize("bad", [0, -1, 2.5, True, 10**9 + 1])
def test_a_bad_budget_is_refused(slider_folder, bad):
    from phyrogen_core.export import read_puzzle_dir
    from solver.planning.problem import problem_for_chain

    loaded = read_puzzle_dir(slider_folder[0].path)
    problem = problem_for_chain(loaded.chain, loaded.goal)
    with pytest.raises(ValueError, match="check budget"):
        PLANNERS["la_rrt"].plan(problem, 1.0, 0, budget_checks=bad)


@pytest.mark.parametrize("bad", ["0", "-5", "1.5", "lots", "1000000001"])
def test_the_command_line_refuses_a_bad_budget_with_one_line(tmp_path, capsys, bad):
    from phyrogen.cli import main

    code = main(["benchmark", "--puzzles", str(tmp_path), "--budget-checks", bad, "--dry-run"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--budget-checks" in err[0] and "1000000000" in err[0], err
