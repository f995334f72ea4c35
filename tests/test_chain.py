"""The chain model: structure checks, state order, kinematics."""

import math

import numpy as np
import pytest

from phyrogen_core import Box, Geometry, Goal, Motion, Pose, Puzzle, PuzzleObject, Role, build_chain
from phyrogen_core.chain import Joint, JointType, KinematicChain, Link


def box_object(name, motion, x=0.0, y=0.0, yaw=0.0, limits=None, size=(1.0, 1.0, 1.0)):
    geometry = (Geometry(Box(size)),)
    default = {Motion.FIXED: (), Motion.PRISMATIC: ((0.0, 1.0),), Motion.REVOLUTE: ((-1.0, 1.0),),
               Motion.SE2: ((-1.0, 1.0),) * 3, Motion.R2: ((-1.0, 1.0),) * 2}[motion]
    return PuzzleObject(name, motion, Pose.planar(x, y, size[2] / 2, yaw), geometry, geometry,
                        Role.BLOCKER, limits if limits is not None else default)


def test_joint_order_is_by_name_even_past_ten_objects():
    objects = [box_object(f"obj_{i:02d}", Motion.PRISMATIC, x=3.0 * i) for i in range(12)]
    chain = build_chain(list(reversed(objects)))
    assert chain.joint_order == tuple(f"obj_{i:02d}" for i in range(12))
    assert list(chain.factors) == [f"obj_{i:02d}" for i in range(12)]


def test_se2_object_is_three_joints_of_one_factor():
    chain = build_chain([box_object("obj_00", Motion.SE2), box_object("obj_01", Motion.PRISMATIC, x=3)])
    assert chain.joint_order == ("obj_00_x", "obj_00_y", "obj_00_yaw", "obj_01")
    assert chain.factors == {"obj_00": (0, 1, 2), "obj_01": (3,)}


def test_forward_kinematics_of_prismatic_and_revolute_joints():
    slider = box_object("obj_00", Motion.PRISMATIC, x=1.0, yaw=math.pi / 2)
    bar = box_object("obj_01", Motion.REVOLUTE, x=5.0)
    chain = build_chain([slider, bar])
    poses = chain.link_transforms([0.5, math.pi / 2])
    # The slider moves along its local x, which points along world y.
    np.testing.assert_allclose(poses["obj_00"][:3, 3], [1.0, 0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(poses["obj_01"][:2, 0], [0.0, 1.0], atol=1e-12)


def test_bad_structures_are_rejected_with_names():
    base = Link("base_link")
    with pytest.raises(ValueError, match="duplicate link names"):
        KinematicChain((base, Link("a"), Link("a")), ())
    with pytest.raises(ValueError, match="unknown link 'ghost'"):
        KinematicChain((base, Link("a")), (Joint("j", JointType.FIXED, "base_link", "ghost"),))
    with pytest.raises(ValueError, match="not connected"):
        KinematicChain((base, Link("a")), ())
    with pytest.raises(ValueError, match="lower limit"):
        Joint("j", JointType.PRISMATIC, "base_link", "a", lower=1.0, upper=0.0)


def test_objects_must_be_planar_and_limits_complete():
    with pytest.raises(ValueError, match="planar"):
        PuzzleObject("obj_00", Motion.FIXED, Pose((0, 0, 0), (0.1, 0, 0)))
    with pytest.raises(ValueError, match="limit pairs"):
        PuzzleObject("obj_00", Motion.SE2, Pose(), limits=((0, 1),))


def test_goal_marker_is_a_visual_only_copy_at_the_goal():
    target = box_object("obj_00", Motion.PRISMATIC, limits=((0.0, 2.0),))
    puzzle = Puzzle((target,), Goal("obj_00", {"obj_00": 2.0}), "test", 1)
    chain = puzzle.chain
    marker = chain.link("goal")
    assert marker.role is Role.GOAL_MARKER and not marker.collisions and marker.visuals
    assert all(v.color[3] < 1.0 for v in marker.visuals)
    np.testing.assert_allclose(chain.link_transforms([0.0])["goal"][:3, 3], [2.0, 0.0, 0.5])
    assert "goal" not in puzzle.planning_chain.joint_order
