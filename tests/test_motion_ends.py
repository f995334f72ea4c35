"""The skipping move (``CollisionModel.motion_ends``) against the plain every-sample one (``motion_stops``).

Random motions of fresh puzzles of every generator, as the env makes them (bounded steps from
valid states) and longer ones, must end in the same states bit for bit and agree on whether they
collided; so must motions built to collide at exactly one sample. A negative control shrinks the
bound on how far a turning shape moves, so the kernel skips samples it has not proven free, and the
same comparison must catch it.
"""

from __future__ import annotations

import numpy as np
import pytest

import phyrogen
from phyrogen.env import PuzzleVectorEnv
from solver.collision import skipping_move

# Fresh seeds no other test uses, one per generator; Move N Times at a small n.
PUZZLES = (("simple_slider", 5113, {"n_objects": 4}), ("continuous_space", 5127, {}), ("grid_world", 5131, {}),
           ("lockbox_random", 5149, {"n_objects": 3}), ("move_n_times", 5153, {"n": 2}), ("rooms", 5167, {}))


@pytest.fixture(scope="module")
def tasks():
    out = {}
    for name, seed, params in PUZZLES:
        env = PuzzleVectorEnv(1, phyrogen.generate(name, seed, **params))
        out[name] = env._catalog.task(0)
    return out


def _sample_states(a, b, count):
    """The states a move checks: a + (b - a) * (k / count), k = 1 .. count (the kernels' formula)."""
    t = np.arange(1, count + 1) / count
    return a + (b - a) * t[:, None]


def _motions(task, rng, n, scale):
    """``n`` moves from valid states reached by earlier moves, each joint by up to ``scale`` max steps."""
    model, d = task.model, task.d
    state = np.array(task.start, dtype=np.float64)
    starts, ends = [], []
    while len(starts) < n:
        target = np.clip(state + rng.uniform(-scale, scale, d) * task.max_step, task.lower, task.upper)
        starts.append(state.copy())
        ends.append(target)
        reached, _ = model.motion_stops(state[None, :], target[None, :], task.steps, True)
        state = reached[0]
    return np.array(starts), np.array(ends)


def _agree(model, starts, ends, steps, stop):
    old_out, old_hit = model.motion_stops(starts, ends, steps, stop)
    new_out, new_hit = model.motion_ends(starts, ends, steps, stop)
    same_out = old_out.view(np.int64) == new_out.view(np.int64)
    return same_out.all(axis=1) & ((old_hit >= 0) == (new_hit >= 0)), old_hit


@pytest.mark.parametrize("name", [p[0] for p in PUZZLES])
def test_random_moves_end_where_the_every_sample_check_ends_them(tasks, name):
    task = tasks[name]
    rng = np.random.default_rng(5200 + len(name))
    for scale, n in ((1.0, 600), (4.0, 300)):  # the env's moves, and longer ones with more samples
        starts, ends = _motions(task, rng, n, scale)
        for stop in (True, False):
            agree, hit = _agree(task.model, starts, ends, task.steps, stop)
            assert agree.all(), f"{name}: {np.count_nonzero(~agree)} of {n} moves differ"
        if name in ("grid_world", "continuous_space", "lockbox_random", "rooms"):
            assert 0.05 < np.mean(hit >= 0) < 0.95  # both kinds of move are exercised


def _one_sample_collisions(task, rng, wanted):
    """Moves whose every-sample check finds exactly one colliding sample: a colliding move cut at its
    first colliding sample, kept when the cut move's samples confirm it."""
    model = task.model
    found_a, found_b = [], []
    for _ in range(40):
        starts, ends = _motions(task, rng, 200, 3.0)
        for a, b in zip(starts, ends, strict=True):
            count = int(max(1, np.ceil(np.max(np.abs(b - a) / task.steps))))
            bad = np.flatnonzero(~model.check(_sample_states(a, b, count)))
            if bad.size == 0:
                continue
            cut = a + (b - a) * ((bad[0] + 1) / count)
            cut_count = int(max(1, np.ceil(np.max(np.abs(cut - a) / task.steps))))
            if np.count_nonzero(~model.check(_sample_states(a, cut, cut_count))) == 1:
                found_a.append(a)
                found_b.append(cut)
        if len(found_a) >= wanted:
            break
    return np.array(found_a), np.array(found_b)


@pytest.mark.parametrize("name", ["grid_world", "continuous_space", "rooms"])
def test_moves_that_collide_at_exactly_one_sample(tasks, name):
    task = tasks[name]
    starts, ends = _one_sample_collisions(task, np.random.default_rng(5300 + len(name)), 30)
    assert len(starts) >= 30
    agree, hit = _agree(task.model, starts, ends, task.steps, True)
    assert agree.all()
    assert (hit >= 0).all()


def test_negative_control_an_unproven_skip_is_caught(tasks):
    """With the turning shapes' reach taken as zero, turns are assumed to move nothing: samples are
    skipped that collide, and moves end elsewhere than the every-sample check ends them."""
    task = tasks["grid_world"]  # prismatic boxes and turning bars
    model = task.model
    starts, ends = _motions(task, np.random.default_rng(5401), 600, 4.0)
    old_out, old_hit = model.motion_stops(starts, ends, task.steps, True)
    out, hits = np.empty_like(starts), np.empty(len(starts))
    skipping_move.motion_ends(starts, ends, task.steps, True, out, hits, *model._arguments, model._pair_columns,
                              np.zeros_like(model._shape_rho))
    differ = (old_out != out).any(axis=1) | ((old_hit >= 0) != (hits >= 0))
    assert differ.any()
    # The true bound gives no difference on the same moves.
    agree, _ = _agree(model, starts, ends, task.steps, True)
    assert agree.all()
