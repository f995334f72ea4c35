"""The judge loop's motion check (:func:`solver.planning._judge_motion.motion_hit`) answers what
:func:`solver.collision.kernels.motion_collision` answers, the same sample of every motion, on fresh seeds
of the generators the judge serves, long motions and short ones, shapes shrunk as the judge shrinks them.

Negative control: with every shape's farthest point taken at its joint (``shape_rho`` zero, a motion
bound that is wrong for a turning joint: Continuous Space's bars turn), pairs are skipped where they
collide, and some answers differ.
"""

from __future__ import annotations

import dataclasses
import random

import numpy as np
import pytest

from phyrogen_core.registry import get_generator
from solver.collision.kernels import motion_collision
from solver.pipelines.generation import generate_here
from solver.planning._judge_motion import motion_hit
from solver.planning.problem import problem_for_chain
from solver.validation.judge import JUDGE_SETTINGS

SIZES = {"simple_slider": {"n_objects": 4}}
MOTIONS = 400


def _case(generator: str, seed: int):
    spec = get_generator(generator)
    params = dataclasses.replace(spec.default_params(), **SIZES.get(generator, {}))
    puzzle = generate_here(generator, seed, params)
    problem = problem_for_chain(puzzle.planning_chain, puzzle.goal, shrink=params.interlock_margin)
    rng = np.random.default_rng(seed)
    lower, upper = problem.lower, problem.upper
    # Valid starts: uniform draws and, where those are rarely valid (a lockbox), the start moved a little.
    uniform = lower + (upper - lower) * rng.random((20 * MOTIONS, len(lower)))
    near = np.clip(problem.start + 0.05 * (upper - lower) * rng.standard_normal(uniform.shape), lower, upper)
    starts = np.ascontiguousarray(np.vstack([uniform[:10 * MOTIONS], near[:10 * MOTIONS]]))
    starts = starts[problem.model.check_prepared(starts)]
    starts = starts[rng.permutation(len(starts))[:MOTIONS]]
    ends = lower + (upper - lower) * rng.random(starts.shape)
    # Half the motions short, along one joint, as a staircase step moves one factor.
    for i in range(0, len(starts), 2):
        ends[i] = starts[i]
        j = rng.integers(len(lower))
        ends[i, j] = np.clip(starts[i, j] + 0.1 * (upper[j] - lower[j]) * rng.standard_normal(), lower[j], upper[j])
    return problem.model, problem.model.motion_steps(JUDGE_SETTINGS.resolution), starts, ends


def _answers(model, steps, starts, ends, rho):
    arguments = (*model._arguments, model._pair_columns)
    return (np.array([motion_collision(a, b, steps, *arguments) for a, b in zip(starts, ends, strict=True)]),
            np.array([motion_hit(a, b, steps, *arguments, rho) for a, b in zip(starts, ends, strict=True)]))


@pytest.mark.parametrize("generator", ["continuous_space", "rooms", "lockbox_random", "simple_slider"])
def test_the_motion_check_answers_as_motion_collision(generator):
    seed = random.SystemRandom().randrange(1_000_000, 10_000_000)
    model, steps, starts, ends = _case(generator, seed)
    expected, answers = _answers(model, steps, starts, ends, model._shape_rho)
    where = f"{generator} seed {seed}"
    assert len(starts) >= MOTIONS // 2, where
    assert (expected >= 0).sum() >= 10 and (expected < 0).sum() >= 10, f"{where}: too few of one kind"
    differ = np.flatnonzero(expected != answers)
    assert not len(differ), f"{where}: motions {differ[:5]}: {expected[differ[:5]]} != {answers[differ[:5]]}"


def test_control_a_wrong_motion_bound_changes_answers():
    seed = random.SystemRandom().randrange(1_000_000, 10_000_000)
    model, steps, starts, ends = _case("continuous_space", seed)
    expected, answers = _answers(model, steps, starts, ends, np.zeros_like(model._shape_rho))
    assert (expected != answers).any(), f"continuous_space seed {seed}: the control found nothing"
