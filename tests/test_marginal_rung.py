"""The judge's verdict at the required margin (the marginal rung): slivers superfluous, real blockers necessary.

A puzzle made for the purpose, on fresh seeds: the target (a box that moves in x and y) must pass a slot
between two static walls, and the object under test, a slider, reaches into the slot. With the slider
fixed, the target gets through only by overlapping it and a wall; with every shape shrunk by ``s`` a
pair may overlap by ``2 s``, so the target passes when the slider reaches in by at most ``4 s`` beyond the
slot's clearance. A slider that reaches in by 3.0-3.6 cm blocks the exact puzzle but not the one shrunk by
the 1 cm margin (4-10 mm of slack: a sliver blocker, superfluous); one that reaches in by 4.6-6 cm blocks at
1 cm and not at 2 cm (a real blocker, necessary with a measured margin of 1 cm). Both are solved at the rung
above, so both verdicts are the marginal rung's. Work is bounded by the judges' query and check budgets,
never seconds. Seeds 52001-52012 are used by no other test.
"""

from __future__ import annotations

import numpy as np
import pytest

from phyrogen_core.chain import Geometry, Role
from phyrogen_core.geometry import Box, Pose
from phyrogen_core.objects import Motion, PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal
from phyrogen_core.seeding import stable_rng
from solver.planning.problem import FINE_RESOLUTION, in_goal, path_is_valid, problem_for_chain
from solver.validation.judge import (
    JUDGE_BUDGET,
    SECOND_JUDGE_BUDGET,
    WARM_JUDGE,
    goal_repair,
    judge,
    witness_nodes,
)

MARGIN = 0.01
CLEARANCE = 0.02  # the slot's width beyond the target's
SEEDS = range(52001, 52009)


def _box(sx: float, sy: float) -> tuple[Geometry, ...]:
    return (Geometry(Box((sx, sy, 1.0))),)


def _slot(seed: int, intrusion: float):
    """The slot puzzle of ``seed``: the target's width, the slot's place and the target's start drawn from it;
    the slider (obj_03) reaches into the slot by ``intrusion`` metres beyond its clearance and slides out in +y."""
    rng = stable_rng("marginal rung slot", seed)
    width, slot_y, start_y = rng.uniform(0.4, 0.8), rng.uniform(-0.3, 0.3), rng.uniform(-0.5, 0.5)
    half = (width + CLEARANCE) / 2
    walls = [PuzzleObject(f"obj_0{i}", Motion.FIXED, Pose.planar(0.0, slot_y + side * (half + 1.5), 0.5),
                          _box(0.2, 3.0), _box(0.2, 3.0), Role.STATIC) for i, side in ((1, 1), (2, -1))]
    reach_in = slot_y + half - CLEARANCE - intrusion  # the slider's lower face
    slider = PuzzleObject("obj_03", Motion.PRISMATIC, Pose.planar(-0.2, reach_in + 0.25, 0.5),
                          _box(0.15, 0.5), _box(0.15, 0.5), limits=((0.0, 0.6),), axis=(0.0, 1.0, 0.0))
    target = PuzzleObject("obj_00", Motion.R2, Pose.planar(-1.0, slot_y + start_y, 0.5), _box(0.4, width),
                          _box(0.4, width), Role.TARGET, limits=((0.0, 2.0), (-1.0 - start_y, 1.0 - start_y)))
    return build_chain([target, *walls, slider]), Goal("obj_00", {target.joint_names[0]: 2.0})


def _verdict(seed: int, intrusion: float):
    chain, goal = _slot(seed, intrusion)
    verdict = judge(chain, goal, ["obj_03"], MARGIN, JUDGE_BUDGET, np.random.default_rng(seed),
                    second_budget=SECOND_JUDGE_BUDGET)
    return chain, goal, verdict


def _intrusion(seed: int, low: float, high: float) -> float:
    return float(stable_rng("marginal rung intrusion", seed).uniform(low, high))


def _holds(chain, goal, path, shrink: float) -> bool:
    problem = problem_for_chain(chain, goal, fixed=["obj_03"], shrink=shrink)
    columns = [chain.joint_order.index(name) for name in problem.model.joint_order]
    states = np.ascontiguousarray(np.asarray(path, dtype=np.float64)[:, columns])
    return bool(problem.model.check(states[:1])[0]) and in_goal(problem, states[-1]) \
        and path_is_valid(problem.model, states, problem.model.motion_steps(FINE_RESOLUTION))


@pytest.mark.parametrize("seed", SEEDS)
def test_a_sliver_blocker_is_superfluous_and_a_real_blocker_necessary(seed):
    chain, goal, sliver = _verdict(seed, _intrusion(seed, 0.030, 0.036))
    assert not sliver.necessary, sliver.describe()
    assert any(a.shrink == 2 * MARGIN and a.solved for a in sliver.attempts)  # the verdict is the marginal rung's
    path = sliver.witness.path
    assert _holds(chain, goal, path, MARGIN)
    assert not _holds(chain, goal, path, 0.0)  # control: it blocks the exact puzzle; the path needs the margin

    chain, goal, real = _verdict(seed, _intrusion(seed, 0.046, 0.060))
    assert real.necessary and real.margin == MARGIN, real.describe()
    marginal = [a for a in real.attempts if a.shrink == MARGIN]
    assert any(a.judge == WARM_JUDGE for a in marginal)  # the warm start ran, and failed as it must
    assert not any(a.solved for a in marginal)


@pytest.mark.parametrize("seed", range(52009, 52013))
def test_warm_start_nodes_are_valid_and_rooted(seed):
    """The rung above's witness, cut where it collides at the required margin: every node valid, every
    motion from its parent free, the goal tree's roots goal states; a witness that holds gives no nodes."""
    chain, goal = _slot(seed, _intrusion(seed, 0.046, 0.060))
    above = judge(chain, goal, ["obj_03"], 2 * MARGIN, JUDGE_BUDGET, np.random.default_rng(seed),
                  second_budget=SECOND_JUDGE_BUDGET)
    assert not above.necessary  # solved with shapes shrunk by 2 cm ...
    problem = problem_for_chain(chain, goal, fixed=["obj_03"], shrink=MARGIN)
    nodes, spent = witness_nodes(problem, chain, above.witness.path, MARGIN, np.random.default_rng(seed))
    assert isinstance(nodes, tuple) and spent >= 1  # ... and that path collides at 1 cm, by more than a shift mends
    steps = problem.model.motion_steps(FINE_RESOLUTION)
    for tree, (states, parents) in enumerate(nodes):
        assert problem.model.check(states).all()
        everything = np.vstack([problem.start[None], states]) if tree == 0 else states  # the start: node 0
        for state, parent in zip(states, parents, strict=True):
            if parent < 0:
                assert tree == 1 and in_goal(problem, state)
            else:
                assert path_is_valid(problem.model, np.vstack([everything[parent], state]), steps)
    shrunk_more = problem_for_chain(chain, goal, fixed=["obj_03"], shrink=2 * MARGIN)
    held = witness_nodes(shrunk_more, chain, above.witness.path, 2 * MARGIN, np.random.default_rng(seed))[0]
    assert isinstance(held, np.ndarray) and _holds(chain, goal, above.witness.path, 2 * MARGIN)  # as it stands


def _two_boxes(slider_limits: tuple[float, float]):
    """A target sliding in x to a goal where a free slider (moving in y) overlaps it by 1.5 cm at its start."""
    target = PuzzleObject("obj_00", Motion.PRISMATIC, Pose.planar(0.0, 0.0, 0.5), _box(1.0, 1.0), _box(1.0, 1.0),
                          Role.TARGET, limits=((0.0, 1.0),))
    slider = PuzzleObject("obj_01", Motion.PRISMATIC, Pose.planar(1.0, 0.985, 0.5), _box(1.0, 1.0), _box(1.0, 1.0),
                          limits=(slider_limits,), axis=(0.0, 1.0, 0.0))
    chain = build_chain([target, slider])
    return chain, Goal("obj_00", {target.joint_names[0]: 1.0})


def test_goal_repair_finds_near_goal_states_only_where_they_exist():
    chain, goal = _two_boxes((-0.5, 0.5))
    problem = problem_for_chain(chain, goal, shrink=0.002)
    state = np.array([1.0, 0.0])  # problem order: target x at its goal, the slider at rest: 1.5 cm overlap
    assert not problem.model.check(state[None])[0]
    roots, batches = goal_repair(problem, state, 0.002, np.random.default_rng(52013))
    assert len(roots) and batches >= 1
    assert problem.model.check(roots).all() and all(in_goal(problem, root) for root in roots)
    assert np.all(roots[:, 1] > 0.01)  # the slider moved out by more than the overlap less the tolerance
    # control: a slider that cannot move up leaves no valid goal state near the rest pose
    chain, goal = _two_boxes((-0.5, 0.0))
    problem = problem_for_chain(chain, goal, shrink=0.002)
    roots, _ = goal_repair(problem, state, 0.002, np.random.default_rng(52013))
    assert len(roots) == 0
