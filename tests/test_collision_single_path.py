"""The collision model's single-state entry points (one compiled call each) against the batch check.

``is_valid``'s direct path, ``motion_stop`` and ``joint_step`` (the Gymnasium env's step) must give
what the batch kernel gives on the same states: the reference here samples every motion with
``check`` and takes the last free sample before the first colliding one.

Puzzles: grid_world 28501, lockbox_random 28502 (revolute joints), rooms 28503 (seeds 28500-28599
are this file's; no other test uses them).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver.collision.model import CollisionModel
from solver.pipelines.generation import generate_here

PUZZLES = (("grid_world", 28501), ("lockbox_random", 28502), ("rooms", 28503))


@pytest.fixture(scope="module", params=PUZZLES, ids=[g for g, _ in PUZZLES])
def model(request):
    generator, seed = request.param
    puzzle = generate_here(generator, seed)
    return CollisionModel(puzzle.planning_chain), np.asarray(puzzle.certificate[0], dtype=np.float64)


def _limits(model):
    chain = model.chain
    lower = np.array([chain.joint(n).lower for n in model.joint_order])
    upper = np.array([chain.joint(n).upper for n in model.joint_order])
    return lower, upper


def _reference_move(model, a, b, steps, stop):
    """Where a move a -> b ends, from the batch check of all its samples."""
    count = max(1, math.ceil(float(np.max(np.abs(b - a) / steps))))
    points = a + (b - a) * (np.arange(1, count + 1) / count)[:, None]
    valid = model.check(points)
    if valid.all():
        return b, False
    first_bad = int(np.argmin(valid))
    if not stop or first_bad == 0:
        return a, True
    return points[first_bad - 1], True


def test_is_valid_agrees_with_the_batch_check_on_any_input_form(model):
    model, start = model
    lower, upper = _limits(model)
    rng = np.random.default_rng(28510)
    # Uniform states (mostly colliding in a crowded puzzle) and small moves from the start (mostly free).
    states = np.concatenate([rng.uniform(lower, upper, (200, len(lower))),
                             np.clip(start + rng.normal(0, 0.05, (200, len(lower))) * (upper - lower), lower, upper)])
    batch = model.check(states)
    assert 0 < batch.sum() < len(batch)  # both verdicts occur: the comparison can fail
    assert [model.is_valid(s) for s in states] == batch.tolist()  # the direct path (float64 rows)
    assert [model.is_valid(list(s)) for s in states[:40]] == batch[:40].tolist()
    assert [model.is_valid(s.astype(np.float32).astype(np.float64)[None]) for s in states[:5]] \
        == model.check(states[:5].astype(np.float32).astype(np.float64)).tolist()
    strided = np.repeat(states[:40], 2, axis=1)[:, ::2]  # not contiguous: the converting path
    assert [model.is_valid(s) for s in strided] == batch[:40].tolist()


@pytest.mark.parametrize("stop", [True, False])
def test_motion_stop_ends_where_the_batch_check_says(model, stop):
    model, start = model
    lower, upper = _limits(model)
    steps = model.motion_steps(0.02)
    rng = np.random.default_rng(28520 + stop)
    out = np.empty_like(start)
    collided = moved = 0
    a = start.copy()
    for _ in range(300):
        b = np.clip(a + rng.uniform(-1, 1, len(a)) * 0.6 * (upper - lower), lower, upper)
        want, hit = _reference_move(model, a, b, steps, stop)
        fraction = model.motion_stop(a, b, steps, stop, out)
        assert (fraction >= 0) == hit
        assert np.array_equal(out, want)
        collided += hit
        moved += hit and not np.array_equal(out, a)
        a = out.copy()  # walk on from where the move ended (always valid)
        assert model.is_valid(a)
    assert collided > 20 and (moved > 5 if stop else moved == 0)


def test_joint_step_is_the_clipped_target_and_its_move(model):
    model, start = model
    lower, upper = _limits(model)
    steps = model.motion_steps(0.02)
    max_step = model.motion_steps(0.25)
    center, scale = (lower + upper) / 2, 2.0 / (upper - lower)
    table = CollisionModel.step_table(max_step, lower, upper, steps, center, scale)
    rng = np.random.default_rng(28530)
    d = len(start)
    out, position = np.empty(d), np.empty(d)
    a = start.copy()
    for k in range(300):
        action = rng.uniform(-1.6, 1.6, d + 2)  # beyond [-1, 1] (clipped) and two padding values
        action = action.astype(np.float32) if k % 2 else action
        target = np.minimum(np.maximum(np.minimum(np.maximum(action[:d].astype(np.float64), -1.0), 1.0)
                                       * max_step + a, lower), upper)
        want, hit = _reference_move(model, a, target, steps, True)
        fraction = model.joint_step(a, action, table, True, out, position)
        assert (fraction >= 0) == hit and np.array_equal(out, want)
        assert np.array_equal(position, (want - center) * scale)
        if not hit:
            free_step = (a, action, want)
        a = out.copy()
    # A value that is not finite, even in the padding, is refused with nothing written.
    out[:] = position[:] = 7.0
    for bad in (np.nan, np.inf):
        action = np.zeros(d + 2)
        action[-1] = bad
        assert model.joint_step(a, action, table, True, out, position) == -2.0
        assert (out == 7.0).all() and (position == 7.0).all()
    # Control: with the step halved, a free step ends elsewhere, so the comparison above can tell.
    a, action, want = free_step
    half = CollisionModel.step_table(max_step / 2, lower, upper, steps, center, scale)
    model.joint_step(a, action, half, True, out, position)
    assert not np.array_equal(out, want)
