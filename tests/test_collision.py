"""The planar collision model: exact contact semantics, agreement with PyBullet."""

import math

import numpy as np
import pytest
from pybullet_scene import PENETRATION, PyBulletScene

from phyrogen_core import Box, Cylinder, Geometry, Motion, Pose, PuzzleObject, Role, build_chain
from phyrogen_core.geometry import slot_disc
from solver.collision.model import CollisionModel, UnsupportedGeometryError


def obj(name, motion, x, y, yaw=0.0, size=(1.0, 1.0, 1.0), limits=None, shape=None, z=None):
    shape = shape or Box(size)
    height = size[2] if isinstance(shape, Box) else getattr(shape, "height", getattr(shape, "length", 1.0))
    geometry = (Geometry(shape),)
    default = {Motion.FIXED: (), Motion.PRISMATIC: ((0.0, 3.0),), Motion.REVOLUTE: ((-math.pi, math.pi),),
               Motion.SE2: ((-3.0, 3.0), (-3.0, 3.0), (-math.pi, math.pi))}[motion]
    return PuzzleObject(name, motion, Pose.planar(x, y, height / 2 if z is None else z, yaw), geometry, geometry,
                        Role.BLOCKER, default if limits is None else limits)


def test_touching_faces_are_not_collisions_but_overlaps_are():
    slider = obj("obj_00", Motion.PRISMATIC, 0.0, 0.0)
    wall = obj("fixed_00_wall", Motion.FIXED, 2.0, 0.0)
    model = CollisionModel(build_chain([slider, wall]))
    valid = model.check(np.array([[0.0], [1.0], [1.0 + 1e-4], [1.5], [3.0]]))
    assert valid.tolist() == [True, True, False, False, True]


def test_shapes_at_different_heights_never_collide():
    low = obj("obj_00", Motion.PRISMATIC, 0.0, 0.0)
    high = obj("fixed_00_shelf", Motion.FIXED, 1.0, 0.0, z=1.5)
    model = CollisionModel(build_chain([low, high]))
    assert model.pair_count == 0
    assert model.check(np.array([[1.0]])).all()


def test_rotated_bar_sweeps_into_a_neighbour():
    bar = obj("obj_00", Motion.REVOLUTE, 0.0, 0.0, size=(3.0, 1.0, 1.0))
    block = obj("fixed_00_block", Motion.FIXED, 0.0, 1.8)
    model = CollisionModel(build_chain([bar, block]))
    assert model.is_valid([0.0])
    assert not model.is_valid([math.pi / 2])
    assert not model.check_motion([0.0], [math.pi / 2], model.motion_steps(0.01))


def test_circle_against_polygon_and_circle():
    disc = obj("obj_00", Motion.PRISMATIC, 0.0, 0.0, shape=Cylinder(0.5, 1.0))
    box = obj("fixed_00_box", Motion.FIXED, 2.0, 0.0)
    other = obj("fixed_01_disc", Motion.FIXED, 0.0, 2.0, shape=Cylinder(0.5, 1.0))
    model = CollisionModel(build_chain([disc, box, other]))
    # Moving along +x: touches the box face at q = 1.0 (centre 1.0, radius 0.5, face at 1.5).
    assert model.check(np.array([[0.99], [1.0], [1.01]])).tolist() == [True, True, False]


def test_locked_joints_hold_their_value():
    slider = obj("obj_00", Motion.PRISMATIC, 0.0, 0.0)
    blocker = obj("obj_01", Motion.PRISMATIC, 2.0, 0.0)
    model = CollisionModel(build_chain([slider, blocker]), locked={"obj_01": 1.0})
    assert model.joint_order == ("obj_00",)
    assert model.is_valid([2.0]) and not model.is_valid([2.2])


def test_tilted_geometry_is_rejected():
    tilted = PuzzleObject("obj_00", Motion.FIXED, Pose.planar(0, 0, 0.5),
                          (), (Geometry(Box((1, 1, 1)), Pose((0, 0, 0), (0.3, 0, 0))),))
    with pytest.raises(UnsupportedGeometryError):
        CollisionModel(build_chain([tilted, obj("obj_01", Motion.PRISMATIC, 3, 0)]))


def test_agrees_with_pybullet_on_random_states():
    """Independent referee: PyBullet on the exported URDF (slot disc, rotated boxes, SE(2))."""
    objects = [
        obj("obj_00", Motion.SE2, 0.0, 0.0, size=(0.8, 0.4, 0.6)),
        obj("obj_01", Motion.REVOLUTE, 3.0, 0.5, 0.3, size=(2.5, 0.5, 0.8)),
        obj("obj_02", Motion.REVOLUTE, -2.5, 2.0, shape=slot_disc(1.2, 1.0)),
        obj("obj_03", Motion.PRISMATIC, -1.0, -2.5, 0.7, size=(1.4, 0.2, 1.0), limits=((-1.0, 1.0),)),
        obj("fixed_00_wall", Motion.FIXED, 0.5, 3.6, size=(3.0, 0.2, 0.5)),
    ]
    chain = build_chain(objects)
    model = CollisionModel(chain)
    scene = PyBulletScene(chain)
    rng = np.random.default_rng(7)
    states = rng.uniform(chain.lower_limits, chain.upper_limits, size=(300, len(chain.joint_order)))
    ours = model.check(states)
    disagreements = 0
    try:
        for state, valid in zip(states, ours, strict=True):
            depth = scene.deepest_penetration(state)
            # Ours counts penetration beyond 1e-6 m; PyBullet's margins blur contact by ~1 mm.
            if (valid and depth > PENETRATION) or (not valid and depth < 1e-9):
                disagreements += 1
    finally:
        scene.close()
    assert 0.2 < ours.mean() < 0.9, "the sample should contain both valid and colliding states"
    assert disagreements == 0


@pytest.mark.parametrize("generator", ["lockbox_random", "rooms", "grid_world"])
def test_one_states_colliding_pairs_are_those_of_the_batch_test(generator):
    """``colliding_objects`` of one state takes the packed single-state kernel; a batch of several
    takes the batched one; ``colliding_objects_each`` a row's pairs for every row at once. On random
    states of a fresh puzzle, with a joint locked and a shrink too, each state alone names the pairs
    that the same state in a batch of two names, and that its row names."""
    from solver.pipelines.generation import generate_here

    chain = generate_here(generator, 7407).planning_chain
    rng = np.random.default_rng(7407)
    colliding = 0
    for locked, tolerance in (({}, 1e-6), ({chain.joint_order[-1]: 0.0}, 0.02)):
        model = CollisionModel(chain, locked, tolerance)
        lower = np.array([chain.joint(j).lower for j in model.joint_order])
        upper = np.array([chain.joint(j).upper for j in model.joint_order])
        states = rng.uniform(lower, upper, size=(150, len(lower)))
        each = model.colliding_objects_each(states)  # (all rows in one call, as a goal sampler's repair asks)
        for state, in_rows in zip(states, each, strict=True):
            alone = model.colliding_objects(state[None, :])
            assert alone == model.colliding_objects(np.stack([state, state])) == in_rows
            colliding += bool(alone)
        assert len({frozenset(pairs) for pairs in each}) > 1  # rows differ: each row is its own state's
    assert colliding >= 20  # the states do collide: the comparison is not of empty sets alone
