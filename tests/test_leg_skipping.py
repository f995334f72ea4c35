"""The routed re-plan's motion checks by skipping (solver/planning/_leg_connect.py): the legs' RRT-Connect and
the shortcut of their paths ask :func:`~solver.collision.skipping_move.motion_ends` whether a motion is free,
where they asked every sample (``_motion_free``, ``CollisionModel.check_motion``). The verdicts must be the
same, or the legs' random numbers, and so the puzzles, change. Checked on Move N Times seeds drawn fresh each
run (printed in every assertion message), on motions from each leg's start to uniform draws in its window
(many free, many through a wall: the controls that each verdict occurs), and on the legs' own paths.
"""

from __future__ import annotations

import random
from dataclasses import replace

import numpy as np
import pytest

import phyrogen_core.generators.move_n_times as move_n_times
import solver.validation.validator as validator_module
from phyrogen_core.registry import get_generator
from solver.pipelines.generation import generate_here
from solver.planning._leg_connect import (
    _extension_free,
    _motion_free,
    _skipping_free,
    _unpacked,
    first_colliding_motion,
    rrt_connect_leg,
    shortcut,
)
from solver.planning.problem import FINE_RESOLUTION


def fresh_seed() -> int:
    return random.SystemRandom().randrange(10**6, 10**9)


@pytest.fixture(scope="module")
def legs():
    seed = fresh_seed()
    found = []

    def capture(problem, budget, rng, resolution, held=()):
        result = rrt_connect_leg(problem, budget, rng, resolution, held)
        found.append((problem, resolution, tuple(held), result))
        return result

    params = replace(get_generator("move_n_times").default_params(), n=3)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(validator_module, "rrt_connect_leg", capture)
        generate_here("move_n_times", seed, params)
    return seed, found


def _scratch(d: int):
    return np.empty((1, d)), np.empty((1, d)), np.empty((1, d)), np.empty(1)


def test_skipping_verdicts_are_every_samples_verdicts(legs):
    seed, found = legs
    rng = np.random.default_rng(seed)
    verdicts = {True: 0, False: 0}
    for problem, resolution, held, _ in found:
        model = problem.model
        ints, floats, pair_columns = model.packed
        unpacked = _unpacked(ints, floats)
        steps = model.motion_steps(resolution)
        lower, upper = problem.lower.copy(), problem.upper.copy()
        lower[list(held)] = upper[list(held)] = problem.start[list(held)]
        scratch = _scratch(len(problem.start))
        for _ in range(20):
            end = lower + (upper - lower) * rng.random(len(lower))
            every = _motion_free(problem.start, end, steps, unpacked, ints[0], pair_columns)
            skipping = _skipping_free(problem.start, end, steps, unpacked, ints[0], pair_columns, model._shape_rho,
                                      scratch)
            assert skipping == every, f"seed {seed}: {problem.start} -> {end}"
            # What the search asks: the end state (unless known valid), the middle sample, then skipping.
            extension = _extension_free(problem.start, end, False, steps, unpacked, ints[0], pair_columns,
                                        np.empty((2, ints[2])), model._shape_rho, scratch)
            assert extension == every, f"seed {seed}: {problem.start} -> {end}"
            if model.is_valid(end):  # from a valid end back to the (valid) start, as the goal tree asks
                back = _motion_free(end, problem.start, steps, unpacked, ints[0], pair_columns)
                assert _extension_free(end, problem.start, True, steps, unpacked, ints[0], pair_columns,
                                       np.empty((2, ints[2])), model._shape_rho, scratch) == back, f"seed {seed}"
            verdicts[every] += 1
    # The controls: both verdicts occur often, so a check that always answered one of them would fail above.
    assert verdicts[True] >= 50 and verdicts[False] >= 50, f"seed {seed}: {verdicts}"


def _shortcut_reference(model, states, steps):
    """The shortcut as written before, one ``check_motion`` per motion tried."""
    kept, i, checks = [0], 0, 0
    while i < len(states) - 1:
        j = len(states) - 1
        while j > i + 1:
            checks += 1
            if model.check_motion(states[i], states[j], steps):
                break
            j -= 1
        kept.append(j)
        i = j
    return states[kept], checks


def test_the_compiled_shortcut_keeps_what_the_reference_keeps(legs):
    seed, found = legs
    dropped = 0
    for problem, resolution, _, result in found:
        if not result.solved:
            continue
        model = problem.model
        states = np.ascontiguousarray(result.path, dtype=np.float64)
        steps = model.motion_steps(resolution)
        expected, expected_checks = _shortcut_reference(model, states, steps)
        kept, checks = shortcut(model, states, steps)
        assert np.array_equal(kept, expected) and checks == expected_checks, f"seed {seed}"
        dropped += len(states) - len(kept)
        # Each kept motion is free at 2 mm (the legs are planned at that resolution).
        assert resolution == FINE_RESOLUTION
        assert all(model.check_motion(a, b, steps) for a, b in zip(kept[:-1], kept[1:], strict=True)), f"seed {seed}"
    # The control: the shortcut had states to drop, so keeping every state would fail the comparison above.
    assert dropped > 0, f"seed {seed}"


def test_the_first_colliding_motion_by_skipping_is_the_models(legs):
    seed, found = legs
    rng = np.random.default_rng(seed)
    answers = {"free": 0, "colliding": 0}
    for problem, resolution, held, _ in found:
        model = problem.model
        steps = model.motion_steps(resolution)
        lower, upper = problem.lower.copy(), problem.upper.copy()
        lower[list(held)] = upper[list(held)] = problem.start[list(held)]
        # Short random walks from the leg's start: free, or stopped by a wall somewhere along them.
        for _ in range(5):
            states = [problem.start]
            for _ in range(4):
                states.append(states[-1] + (lower + (upper - lower) * rng.random(len(lower)) - states[-1]) * 0.3)
            states = np.ascontiguousarray(states, dtype=np.float64)
            expected = model.first_colliding_motion(states, steps)
            assert first_colliding_motion(model, states, steps) == expected, f"seed {seed}"
            answers["free" if expected < 0 else "colliding"] += 1
    # The controls: walks that collide (at some motion) and walks that do not both occur.
    assert answers["free"] >= 10 and answers["colliding"] >= 10, f"seed {seed}: {answers}"


def test_a_puzzle_is_the_same_whatever_the_process_made_before():
    """What a process keeps across puzzles: Move N Times' objects (move_n_times._made, so the chains and collision
    models kept by identity serve every puzzle) and the route's free cells (validator._walls_clear). The same
    puzzle and the same query count with them kept as without (the controls: the second generation did share
    the first one's objects and use its free cells, and a different seed gives a different puzzle)."""
    seed = fresh_seed()
    params = replace(get_generator("move_n_times").default_params(), n=3)
    move_n_times._MADE.clear()
    validator_module._WALLS_CLEAR.clear()
    cold_stats: dict = {}
    cold = generate_here("move_n_times", seed, params, stats=cold_stats)
    assert len(validator_module._WALLS_CLEAR) > 0, f"seed {seed}"
    other = generate_here("move_n_times", seed + 1, params)
    assert other.certificate != cold.certificate, f"seed {seed}"
    calls = []
    original = validator_module._walls_clear

    def counting(*args):
        calls.append(any(key[1] == args[1] for key in validator_module._WALLS_CLEAR))
        return original(*args)

    warm_stats: dict = {}
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(validator_module, "_walls_clear", counting)
        warm = generate_here("move_n_times", seed, params, stats=warm_stats)
    assert calls and all(calls), f"seed {seed}: free cells computed again"
    assert all(a is b for a, b in zip(warm.objects, cold.objects, strict=True)), f"seed {seed}: objects made again"
    assert warm == cold and warm_stats == cold_stats, f"seed {seed}"
