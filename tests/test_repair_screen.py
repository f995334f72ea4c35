"""The compiled screen of ``shift_repair`` (:func:`solver.validation._repair_screen.screen`) passes exactly the
offsets for which every screened point is within the limits and collision-free, as a check of every point of
every offset finds, on fresh seeds of Continuous Space and Rooms, offsets of the sizes the repair draws.

Negative control: the screen given the middle point alone passes offsets that a check of every point fails.
"""

from __future__ import annotations

import dataclasses
import random

import numpy as np
import pytest

from phyrogen_core.registry import get_generator
from solver.pipelines.generation import generate_here
from solver.planning.problem import problem_for_chain
from solver.validation._repair_screen import screen
from solver.validation.judge import GOAL_REPAIR_DRAWS, SHIFT_REPAIR_POINTS


def _case(generator: str, seed: int):
    spec = get_generator(generator)
    params = spec.default_params()
    puzzle = generate_here(generator, seed, dataclasses.replace(params))
    problem = problem_for_chain(puzzle.planning_chain, puzzle.goal, shrink=params.interlock_margin)
    rng = np.random.default_rng(seed)
    lower, upper = problem.lower, problem.upper
    # A run of points along a line through the start, as a witness's colliding run lies along its motion.
    end = lower + (upper - lower) * rng.random(len(lower))
    points = problem.start + np.linspace(0.0, 0.05, SHIFT_REPAIR_POINTS)[:, None] * (end - problem.start)
    reach = np.maximum(problem.model.joint_reach(), 1e-9)
    offsets = rng.standard_normal((GOAL_REPAIR_DRAWS, len(lower))) * (0.01 / reach)
    return problem, np.ascontiguousarray(points), offsets


def _every_point(problem, points, offsets):
    states = (points[None] + offsets[:, None]).reshape(-1, points.shape[1])
    inside = np.all((states >= problem.lower) & (states <= problem.upper), axis=1)
    valid = problem.model.check_prepared(np.ascontiguousarray(states)) & inside
    return valid.reshape(len(offsets), len(points)).all(axis=1)


def _screen(problem, points, offsets):
    return screen(points, offsets, problem.lower, problem.upper, *problem.model._arguments)


@pytest.mark.parametrize("generator", ["continuous_space", "rooms"])
def test_the_screen_passes_the_offsets_every_point_passes(generator):
    mixed = 0
    for _ in range(10):  # every seed compared; until one whose offsets both pass and fail
        seed = random.SystemRandom().randrange(1_000_000, 10_000_000)
        problem, points, offsets = _case(generator, seed)
        expected = _every_point(problem, points, offsets)
        where = f"{generator} seed {seed}: {expected.sum()} of {len(expected)} pass"
        assert np.array_equal(_screen(problem, points, offsets), expected), where
        mixed += 0 < expected.sum() < len(expected)
        if mixed:
            return
    raise AssertionError(f"{generator}: 10 seeds, no run with offsets that pass and fail: the test saw nothing")


def test_control_a_screen_of_the_middle_point_passes_more():
    for _ in range(20):  # a seed whose run has offsets failing away from the middle
        seed = random.SystemRandom().randrange(1_000_000, 10_000_000)
        problem, points, offsets = _case("continuous_space", seed)
        middle = np.ascontiguousarray(points[len(points) // 2:len(points) // 2 + 1])
        if not np.array_equal(_screen(problem, middle, offsets), _every_point(problem, points, offsets)):
            return
    raise AssertionError("20 seeds: the middle point alone passed exactly the offsets every point passes")
