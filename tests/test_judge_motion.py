"""The judge loop's motion check (:func:`solver.planning._judge_motion.motion_hit`) answers what
:func:`solver.collision.kernels.motion_collision` answers, the same sample of every motion, on fresh seeds
of the generators the judge serves, long motions and short ones, shapes shrunk as the judge shrinks them.

The same with one set of buffers for every motion (:func:`motion_hit_in`, as the loops call it), filled with
junk first; its control: the calls did write into those buffers (the reuse is real, not fresh arrays).

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
from solver.planning._judge_motion import count_bound, motion_buffers, motion_hit, motion_hit_in
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


def _dirty_buffers(model, steps, lower, upper, d):
    mf, mi, ml = motion_buffers(count_bound(lower, upper, steps), d, model._arguments[2],
                                len(model._arguments[10]), len(model._arguments[3]))
    mf[:], mi[:], ml[:] = np.nan, 1 << 40, True
    return mf, mi, ml


def test_reused_buffers_answer_as_motion_collision():
    seed = random.SystemRandom().randrange(1_000_000, 10_000_000)
    model, steps, starts, ends = _case("continuous_space", seed)
    problem_lower, problem_upper = np.minimum(starts, ends).min(axis=0), np.maximum(starts, ends).max(axis=0)
    mf, mi, ml = _dirty_buffers(model, steps, problem_lower, problem_upper, starts.shape[1])
    arguments = (*model._arguments, model._pair_columns, model._shape_rho)
    expected, _ = _answers(model, steps, starts, ends, model._shape_rho)
    # the short motions first: later, long ones may outgrow the buffers and get their own
    order = np.argsort([np.max(np.abs(b - a) / steps) for a, b in zip(starts, ends, strict=True)], kind="stable")
    answers = np.empty(len(starts))
    for i in order:
        answers[i] = motion_hit_in(mf, mi, ml, starts[i], ends[i], steps, *arguments)
    differ = np.flatnonzero(expected != answers)
    assert not len(differ), f"continuous_space seed {seed}: motions {differ[:5]} differ with reused buffers"
    # control: the buffers were the ones used (junk overwritten), so the comparison above tested reuse
    assert not np.isnan(mf).all() and (mi != 1 << 40).any(), f"continuous_space seed {seed}: buffers untouched"
