"""The compiled RRT-Connect of a routed re-plan's legs (solver/planning/_leg_connect.py), on Move N Times
seeds drawn fresh each run (printed in every assertion message).

Every leg a generation plans is captured and re-checked here at 2 mm; the same leg planned twice from the
same random numbers is the same path; and the controls: a leg whose goal lies inside a wall, or past the
door the leg may not move, is given up within its budget, and a motion through a wall is refused.

The certificate's length: the legs' raw certificate of n = 3 defragments to 2n actions at 2 mm (the
control: undefragmented it has more); the stored one of seed 6120348 kept 17 because the defragmenter
checks its motions at 2 cm and the certificate check at 2 mm rejects the whole result (xfail until
solver/planning/defragment.py retries at 2 mm).
"""

from __future__ import annotations

import random
from dataclasses import replace

import numpy as np
import pytest

import solver.planning.defragment as defragment_module
import solver.validation.validator as validator_module
from phyrogen_core.actions import count_actions
from phyrogen_core.registry import get_generator
from solver.pipelines.generation import generate_here
from solver.planning._leg_connect import _motion_free, _unpacked, rrt_connect_leg
from solver.planning.problem import FINE_RESOLUTION, verify_certificate


def fresh_seed() -> int:
    return random.SystemRandom().randrange(10**6, 10**9)


def generate_capturing_legs(seed: int, n: int = 3):
    """The puzzle of ``seed`` and every leg its validation planned: (problem, budget, resolution, held, result)."""
    legs = []

    def capture(problem, budget, rng, resolution, held=()):
        result = rrt_connect_leg(problem, budget, rng, resolution, held)
        legs.append((problem, budget, resolution, tuple(held), result))
        return result

    params = replace(get_generator("move_n_times").default_params(), n=n)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(validator_module, "rrt_connect_leg", capture)
        puzzle = generate_here("move_n_times", seed, params)
    return puzzle, legs


@pytest.fixture(scope="module")
def generated():
    seed = fresh_seed()
    puzzle, legs = generate_capturing_legs(seed)
    return seed, puzzle, legs


def test_every_leg_found_holds_at_2_mm_and_ends_in_its_goal(generated):
    seed, puzzle, legs = generated
    assert verify_certificate(puzzle.chain, puzzle.certificate, puzzle.goal) == [], f"seed {seed}"
    solved = [leg for leg in legs if leg[4].solved]
    assert len(solved) >= 3, f"seed {seed}: {len(solved)} of {len(legs)} legs solved"
    for problem, budget, resolution, held, result in solved:
        path = np.array(result.path)
        model = problem.model
        assert resolution == FINE_RESOLUTION, f"seed {seed}"
        assert np.array_equal(path[0], problem.start), f"seed {seed}"
        assert all(path[-1, c] == v for c, v in problem.goal_columns.items()), f"seed {seed}"
        assert (path >= problem.lower - 1e-12).all() and (path <= problem.upper + 1e-12).all(), f"seed {seed}"
        assert (path[:, list(held)] == problem.start[list(held)]).all(), f"seed {seed}: a held joint moved"
        assert model.path_free(np.ascontiguousarray(path), model.motion_steps(FINE_RESOLUTION)), f"seed {seed}"
        assert 0 < result.checks <= budget + 10, f"seed {seed}: {result.checks} queries of {budget}"


def test_the_same_leg_from_the_same_numbers_is_the_same_path(generated):
    seed, _, legs = generated
    problem, budget, resolution, held, _ = next(leg for leg in legs if leg[4].solved)
    first = rrt_connect_leg(problem, budget, np.random.default_rng(seed), resolution, held)
    second = rrt_connect_leg(problem, budget, np.random.default_rng(seed), resolution, held)
    assert first == second, f"seed {seed}"
    other = rrt_connect_leg(problem, budget, np.random.default_rng(seed + 1), resolution, held)
    assert other.solved, f"seed {seed}"


def test_a_generation_is_the_same_twice():
    seed = fresh_seed()
    first, _ = generate_capturing_legs(seed)
    second, _ = generate_capturing_legs(seed)
    assert first.certificate == second.certificate, f"seed {seed}"


def _inside_a_wall(puzzle, problem, columns):
    """(x, y) of a wall's centre where the target (its ``columns``: x, y, yaw) collides at every yaw."""
    for wall in (o for o in puzzle.objects if not o.is_movable):
        state = problem.start.copy()
        state[columns[0]], state[columns[1]] = wall.pose.xyz[:2]
        blocked = True
        for yaw in np.linspace(-np.pi, np.pi, 16):
            state[columns[2]] = yaw
            blocked = blocked and not problem.model.is_valid(state)
        if blocked:
            return float(state[columns[0]]), float(state[columns[1]])
    return None


def test_a_leg_whose_goal_is_walled_off_is_given_up_within_its_budget(generated):
    seed, puzzle, legs = generated
    problem, _, resolution, held, _ = next(leg for leg in legs if leg[4].solved and leg[3])
    columns = [i for i in range(len(problem.start)) if i not in held]
    inside = _inside_a_wall(puzzle, problem, columns)
    assert inside is not None, f"seed {seed}"
    lower, upper = problem.lower.copy(), problem.upper.copy()
    lower[columns[:2]] = np.minimum(lower[columns[:2]], inside)
    upper[columns[:2]] = np.maximum(upper[columns[:2]], inside)
    walled = replace(problem, goal_columns={columns[0]: inside[0], columns[1]: inside[1]}, lower=lower, upper=upper)
    result = rrt_connect_leg(walled, 300, np.random.default_rng(seed), resolution, held)
    assert not result.solved and result.checks == 300, f"seed {seed}: {result}"
    # The control's control: the same leg with its own goal is found.
    assert rrt_connect_leg(problem, 300, np.random.default_rng(seed), resolution, held).solved, f"seed {seed}"


def test_a_leg_past_the_held_door_fails_and_the_whole_leg_then_succeeds(generated):
    seed, _, legs = generated
    failed = [leg for leg in legs if not leg[4].solved and leg[3]]
    assert failed, f"seed {seed}: every leg went through with the door held"
    for problem, budget, resolution, held, result in failed:
        assert result.checks <= budget + 10, f"seed {seed}: {result.checks} queries of {budget}"
        again = rrt_connect_leg(problem, 4 * budget, np.random.default_rng(seed), resolution, held)
        assert not again.solved, f"seed {seed}: a leg through the held door was found"


def test_a_motion_through_a_wall_is_refused(generated):
    seed, puzzle, legs = generated
    problem, _, resolution, held, result = next(leg for leg in legs if leg[4].solved and leg[3])
    columns = [i for i in range(len(problem.start)) if i not in held]
    inside = _inside_a_wall(puzzle, problem, columns)
    assert inside is not None, f"seed {seed}"
    model = problem.model
    ints, floats, pair_columns = model.packed
    steps = model.motion_steps(resolution)
    through = problem.start.copy()
    through[columns[0]], through[columns[1]] = inside
    beyond = through + (through - problem.start)  # on through the wall to the far side
    unpacked = _unpacked(ints, floats)
    assert not _motion_free(problem.start, beyond, steps, unpacked, ints[0], pair_columns), f"seed {seed}"
    # The control: the leg's own first motion is free.
    path = np.array(result.path)
    assert _motion_free(path[0], path[1], steps, unpacked, ints[0], pair_columns), f"seed {seed}"


def _raw_certificate(seed: int, n: int = 3):
    """The puzzle of ``seed`` with its certificate as validation left it (not defragmented)."""
    params = replace(get_generator("move_n_times").default_params(), n=n)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(defragment_module, "defragment_certificate",
                      lambda chain, goal, path, *_: tuple(map(tuple, path)))
        return generate_here("move_n_times", seed, params)


@pytest.mark.parametrize("draw", range(3))
def test_the_legs_certificate_defragments_to_two_actions_a_level(draw):
    """Each of the n levels needs the door opened and the target moved: 2n actions. 1750128 and 6de768f
    reach that at 2 mm on every n = 3 seed tried (120 fresh seeds, 20 at n = 5); a leg that moved the
    door back and forth where the defragmenter cannot undo it would fail here."""
    seed, n = fresh_seed(), 3
    puzzle = _raw_certificate(seed, n)
    raw = puzzle.certificate
    # The control: undefragmented, the legs' certificate moves door and target together (10-23 actions).
    assert count_actions(raw, puzzle.chain.factors) > 2 * n, f"seed {seed}"
    clean = defragment_module.defragment_certificate(puzzle.chain, puzzle.goal, raw, FINE_RESOLUTION)
    assert verify_certificate(puzzle.chain, clean, puzzle.goal) == [], f"seed {seed}"
    assert count_actions(clean, puzzle.chain.factors) <= 2 * n, f"seed {seed}"


@pytest.mark.xfail(strict=True, reason="defragment_certificate checks motions at 2 cm and, when its result then "
                   "fails the 2 mm certificate check, keeps the raw certificate (about 2 % of n = 3 seeds, at "
                   "1750128 too); it needs a retry at 2 mm (solver/planning/defragment.py)")
def test_a_stored_certificate_of_n_3_has_two_actions_a_level():
    seed, n = 6120348, 3  # one of the seeds whose coarse defragmentation clips at 2 mm
    params = replace(get_generator("move_n_times").default_params(), n=n)
    puzzle = generate_here("move_n_times", seed, params)
    assert count_actions(puzzle.certificate, puzzle.chain.factors) <= 2 * n, f"seed {seed}"
