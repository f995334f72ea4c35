"""The compiled RRT-Connect of a routed re-plan's legs (solver/planning/_leg_connect.py), on Move N Times
seeds drawn fresh each run (printed in every assertion message).

Every leg a generation plans is captured and re-checked here at 2 mm; the same leg planned twice from the
same random numbers is the same path; and the controls: a leg whose goal lies inside a wall is given up
within its budget, a leg that fails with the door held stays within its budget (and whatever a longer run
finds is free), and a motion through a wall is refused.

The certificate's length: the legs' raw certificate of n = 3 defragments to 2n actions at 2 mm (the
control: undefragmented it has more); seed 6120348's kept 17 because the defragmenter checks its
motions at 2 cm and the certificate check at 2 mm rejected the whole result: at 2 mm it reaches 6, which
solver/planning/defragment.py now retries when the 2 cm result fails the check.
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
from solver.planning.problem import FINE_RESOLUTION, densify, verify_certificate


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


def test_a_leg_that_fails_with_the_door_held_is_given_up_within_its_budget(generated):
    seed, _, legs = generated
    failed = [leg for leg in legs if not leg[4].solved and leg[3]]
    assert failed, f"seed {seed}: every leg went through with the door held"
    for problem, budget, resolution, held, result in failed:
        assert result.checks <= budget + 10, f"seed {seed}: {result.checks} queries of {budget}"
        # A leg given up within its budget is not proven blocked by the door: a longer run from other numbers
        # may find a way round it (seed 943038398: one of its 4 such legs, in 149 queries). Whatever a longer
        # run finds must keep the held joints still and be free at every state 0.2 mm apart.
        again = rrt_connect_leg(problem, 4 * budget, np.random.default_rng(seed), resolution, held)
        if again.solved:
            path = np.array(again.path)
            assert (path[:, list(held)] == problem.start[list(held)]).all(), f"seed {seed}: a held joint moved"
            dense = densify(path, problem.model.motion_steps(0.0002))
            assert problem.model.check(dense).all(), f"seed {seed}: a leg through the held door was found"


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


# Seed 6120348 at n = 3 (6de768f): the certificate validation returned, stored as it was because its
# defragmentation failed the 2 mm check (17 actions; joints obj_00_x, obj_00_y, obj_00_yaw, obj_01). Fixed
# here so the defragmenter's test does not depend on the legs' random numbers.
_SEED_6120348_RAW = (
    (0.0, 0.0, 0.0, 0.0),
    (-0.08261028279837346, -0.009401968187588983, 0.09720772297522018, -1.2730172870171228),
    (-0.13728868221830642, -0.2845623095083227, 1.5751373355733922, -1.6830877975160448),
    (-0.022057515826342633, -0.9667896471084365, 2.877500885192755, -1.879026088959924),
    (0.8774693814551738, -1.1245834949015332, 1.4687702037706645, 1.235107090529831),
    (1.091374330569777, -0.616962475817991, 0.9276265769418355, 1.9374098080529898),
    (0.9000000000000035, -0.699999999999998, -2.1804501865191535, 1.8278719032280062),
    (1.0813454621898397, -0.7318629374070533, -0.8572588622061326, 1.8278719032280062),
    (0.9484158701392397, -0.21024202835729383, 0.6652071328248463, 1.8278719032280062),
    (1.600000000000004, -0.1999999999999975, -0.5010132266025717, 1.8278719032280062),
    (1.9867159626725006, -0.5600105717781415, -0.663342450775835, 1.8278719032280062),
    (1.900000000000004, -0.9999999999999982, 1.8643690455197888, 1.8278719032280062),
    (2.0173281765426503, -1.7950379806724417, 0.8507714333941809, 1.8278719032280062),
    (1.600000000000004, -1.799999999999999, 1.0076580843279528, 1.8278719032280062),
    (0.5892063749725881, -2.077295618343966, -2.607140830639534, 1.8278719032280062),
    (0.7000000000000033, -1.899999999999999, -2.9410605748771497, 1.8278719032280062),
    (-0.2999999999999976, -1.899999999999999, -1.0671821444994665, 1.8278719032280062),
    (-1.0537881090325723, -2.1135146622542087, -0.04062666845670915, 1.8278719032280062),
    (-0.8999999999999981, -1.3999999999999986, -1.1536328447390976, 1.8278719032280062),
    (-0.9546484719709517, -1.1366374217493773, -0.2502726223918933, -0.10775092927410901),
    (-1.0999999999999983, -0.4999999999999978, -0.5728851105120571, -1.4827504249871581),
    (-1.1884833558002283, -0.22404505201137842, 0.7226287900699575, -1.4827504249871581),
    (-1.799999999999999, -0.3999999999999977, 2.6643505253494313, -1.4827504249871581),
    (-2.207799257471925, -0.41977924399652566, -2.21635538730187, -1.4827504249871581),
    (-1.899999999999999, -1.2999999999999985, -1.2664039453982836, -1.4827504249871581),
    (-1.899999999999999, -2.1999999999999993, 1.8091746078342048, -1.4827504249871581),
    (-1.9172102920152359, -2.4302131528636433, 0.08156185641914737, -1.4827504249871581),
    (-1.5543117781151858, -3.0, 2.6023969187461615, -1.4827504249871581),
)


def _seed_6120348():
    params = replace(get_generator("move_n_times").default_params(), n=3)
    puzzle = generate_here("move_n_times", 6120348, params)
    assert puzzle.chain.joint_order == ("obj_00_x", "obj_00_y", "obj_00_yaw", "obj_01")
    return puzzle


def test_a_certificate_whose_2_cm_defragmentation_clips_reaches_2n_at_2_mm():
    puzzle = _seed_6120348()
    assert verify_certificate(puzzle.chain, _SEED_6120348_RAW, puzzle.goal) == []
    assert count_actions(_SEED_6120348_RAW, puzzle.chain.factors) == 17
    clean = defragment_module.defragment_certificate(puzzle.chain, puzzle.goal, _SEED_6120348_RAW, FINE_RESOLUTION)
    assert verify_certificate(puzzle.chain, clean, puzzle.goal) == []
    assert count_actions(clean, puzzle.chain.factors) == 6


def test_the_stored_defragmentation_of_a_clipping_certificate_has_2n_actions():
    puzzle = _seed_6120348()
    clean = defragment_module.defragment_certificate(puzzle.chain, puzzle.goal, _SEED_6120348_RAW)
    assert count_actions(clean, puzzle.chain.factors) <= 6
