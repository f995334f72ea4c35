"""LA-RRT's compiled isolated step makes exactly the run of the Python step: the second judge's verdicts,
paths and checks, and the benchmark's LA-RRT runs (checks charged by length, anytime, defragmented), for
every generator, blocked (an object fixed) and free, in the random and the fixed factor order.

Seeds are drawn afresh for every run (they are in the failure messages). Work is bounded by checks.
"""

from __future__ import annotations

import dataclasses
import random

import numpy as np
import pytest

from phyrogen_core.registry import get_generator, paper_generators
from solver.pipelines.generation import generate_here
from solver.planning.la_rrt import FIXED_ORDER_SETTINGS, PAPER_SETTINGS, LaRrt, plan_la_rrt
from solver.planning.problem import problem_for_chain
from solver.validation.judge import SECOND_JUDGE_BUDGET, attempt_second

SIZES = {"simple_slider": {"n_objects": 4}, "move_n_times": {"n": 3}}  # sizes the paper ties to the seed


def _python_steps(monkeypatch) -> None:
    monkeypatch.setattr(LaRrt, "_compiled_step_arguments", lambda self: None)


def _second_judge_runs(puzzle, margin, seed):
    blockers = [name for name in puzzle.chain.object_names if name != puzzle.goal.target]
    cases = [((), margin)] + [((name,), shrink) for name in blockers[:2] for shrink in (margin, 4 * margin)]
    return [attempt_second(puzzle.planning_chain, puzzle.goal, fixed, shrink, SECOND_JUDGE_BUDGET, seed)
            for fixed, shrink in cases]


def _benchmark_runs(puzzle, seed):
    problem = problem_for_chain(puzzle.planning_chain, puzzle.goal)
    return [plan_la_rrt(problem, 1e9, seed, settings=settings, budget_checks=6000, progress_interval=1e9)
            for settings in (PAPER_SETTINGS, FIXED_ORDER_SETTINGS)]


def _summary(result):
    return (result.solved, result.checks, result.iterations, result.action_cost, result.rejected,
            result.goal_states, np.asarray(result.path).tolist())


@pytest.mark.parametrize("generator", paper_generators())
def test_the_compiled_isolated_step_makes_the_python_run(generator, monkeypatch):
    seed = random.SystemRandom().randrange(100_000, 10_000_000)
    spec = get_generator(generator)
    params = dataclasses.replace(spec.default_params(), **SIZES.get(generator, {}))
    puzzle = generate_here(generator, seed, params)
    where = f"{generator} seed {seed}"
    compiled = (_second_judge_runs(puzzle, params.interlock_margin, seed), _benchmark_runs(puzzle, seed))
    other_seed = (_second_judge_runs(puzzle, params.interlock_margin, seed + 1), _benchmark_runs(puzzle, seed + 1))
    _python_steps(monkeypatch)
    python = (_second_judge_runs(puzzle, params.interlock_margin, seed), _benchmark_runs(puzzle, seed))
    assert compiled[0] == python[0], where  # attempts: verdict, path, checks, goal accounting
    assert [_summary(r) for r in compiled[1]] == [_summary(r) for r in python[1]], where
    # Control: the comparison sees a different run (another seed draws other numbers).
    assert (compiled[0], [_summary(r) for r in compiled[1]]) != \
        (other_seed[0], [_summary(r) for r in other_seed[1]]), where
