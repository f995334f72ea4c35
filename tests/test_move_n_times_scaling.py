"""Move N Times at its largest sizes: generated and certified on seeds drawn fresh each run.

The seeds are new every run (printed in each assertion message), so these tests keep sampling
seeds nobody measured; a failure names the seed that reproduces it.
"""

from __future__ import annotations

import random
from dataclasses import replace

import numpy as np
import pytest

from phyrogen_core.generators.move_n_times import MAX_N
from phyrogen_core.puzzle import Puzzle
from phyrogen_core.registry import get_generator
from solver.pipelines.generation import generate_here
from solver.planning.problem import verify_certificate


def fresh_seed() -> int:
    return random.SystemRandom().randrange(10**6, 10**9)


def generate(n: int, seed: int) -> tuple[Puzzle, int]:
    """The puzzle and the collision queries its validation spent."""
    stats: dict[str, int] = {}
    params = replace(get_generator("move_n_times").default_params(), n=n)
    return generate_here("move_n_times", seed, params, stats=stats), stats["validation_checks"]


def door_moves(puzzle: Puzzle) -> int:
    """How many separate times the certificate slides the door: its monotone runs of motion (a
    plan may move the door and the target together, so a run of door motion can hold two moves)."""
    door = next(o for o in puzzle.objects if o.is_movable and o.name != puzzle.goal.target)
    column = puzzle.chain.joint_order.index(door.joint_names[0])
    steps = np.diff(np.asarray(puzzle.certificate)[:, column])
    signs = np.sign(steps[np.abs(steps) > 1e-9])
    return int(len(signs) > 0) + int(np.count_nonzero(signs[1:] != signs[:-1]))


def test_n_8_validates_at_a_cost_that_grows_gently():
    seed = fresh_seed()
    small, small_queries = generate(4, seed)
    large, large_queries = generate(8, seed)
    for n, puzzle in ((4, small), (8, large)):
        assert verify_certificate(puzzle.chain, puzzle.certificate, puzzle.goal) == [], f"n = {n}, seed {seed}"
        assert door_moves(puzzle) >= n, f"n = {n}, seed {seed}"
    # Planning each level from the start costs about 4x per move (256x from n = 4 to 8).
    assert large_queries < 6 * small_queries, f"seed {seed}: {small_queries} queries at n = 4, {large_queries} at 8"


@pytest.mark.slow
def test_the_largest_accepted_n_generates_certified():
    seed = fresh_seed()
    spec = get_generator("move_n_times")
    spec.check(seed, replace(spec.default_params(), n=MAX_N))
    puzzle, _ = generate(MAX_N, seed)
    assert verify_certificate(puzzle.chain, puzzle.certificate, puzzle.goal) == [], f"seed {seed}"
    assert door_moves(puzzle) >= MAX_N, f"seed {seed}"
