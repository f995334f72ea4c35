"""A certificate keyframed on the puzzle's link armatures: play it and the puzzle is solved (bpy wheel)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from blender_support import every_shape_puzzle, private_blender_home

private_blender_home()
bpy = pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")

from blender_addon.animation import clear_solution, keyframe_solution, planner_solution  # noqa: E402
from blender_addon.scene import build_chain, build_puzzle, read_chain  # noqa: E402
from phyrogen_core.actions import count_actions  # noqa: E402
from phyrogen_core.errors import PuzzleFormatError  # noqa: E402
from phyrogen_core.export import write_puzzle  # noqa: E402
from phyrogen_core.registry import all_generators  # noqa: E402

pytestmark = pytest.mark.blender
FRAMES_PER_ACTION = 10
POSE_TOLERANCE = 1e-5  # Blender keeps transforms in single precision


@pytest.fixture(autouse=True)
def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    yield


@pytest.fixture(scope="module")
def generated():
    """One certified puzzle per registered generator (seed 2), generated on first use."""
    from solver.pipelines.generation import generate_puzzle

    cache = {}

    def get(generator):
        if generator not in cache:
            cache[generator] = generate_puzzle(generator, 2)
        return cache[generator]

    return get


def link_poses(built) -> dict[str, np.ndarray]:
    bpy.context.view_layer.update()
    return {name: np.array(obj.matrix_world) for name, obj in built.links.items()}


def assert_scene_shows(built, chain, state, frame) -> None:
    """At ``frame``, every link of the scene stands where ``chain`` puts it at ``state``."""
    bpy.context.scene.frame_set(frame)
    expected = chain.link_transforms(np.asarray(state, dtype=float))
    for name, pose in link_poses(built).items():
        assert pose == pytest.approx(expected[name], abs=POSE_TOLERANCE), f"link {name} at frame {frame}"


def action_ends(path, chain) -> list[int]:
    """Indices of the path's states where an action ends (a different object moves next)."""
    moved = [frozenset(np.flatnonzero(np.abs(b - a) > 1e-6)) for a, b in zip(path, path[1:], strict=False)]
    objects = [frozenset(chain.object_of_joint(chain.joint_order[j]) for j in m) for m in moved]
    return [i + 1 for i in range(len(objects)) if i + 1 == len(objects) or objects[i + 1] != objects[i]]


@pytest.mark.parametrize("generator", list(all_generators()))
def test_playing_the_certificate_solves_the_puzzle(generator, generated):
    puzzle = generated(generator)
    path = np.asarray(puzzle.certificate, dtype=float)
    chain = puzzle.chain
    built = build_puzzle(puzzle)
    keyframe_solution(built, path, chain, frames_per_action=FRAMES_PER_ACTION, frame_start=1)
    scene = bpy.context.scene
    actions = count_actions(path, chain.factors)
    # Every action takes the same time; the scene's range is the solution.
    assert (scene.frame_start, scene.frame_end) == (1, 1 + actions * FRAMES_PER_ACTION)
    assert scene.frame_current == scene.frame_start
    assert_scene_shows(built, chain, path[0], scene.frame_start)
    # The end of the k-th action is reached at frame 1 + k * FRAMES_PER_ACTION.
    for k, index in enumerate(action_ends(path, chain), start=1):
        assert_scene_shows(built, chain, path[index], 1 + k * FRAMES_PER_ACTION)
    # Halfway through an action of one segment, the object is halfway (linear keyframes).
    ends = [0, *action_ends(path, chain)]
    for k, (first, last) in enumerate(zip(ends, ends[1:], strict=False)):
        if last == first + 1:
            middle = 1 + k * FRAMES_PER_ACTION + FRAMES_PER_ACTION / 2
            if middle.is_integer():
                assert_scene_shows(built, chain, (path[first] + path[last]) / 2, int(middle))
    # At the last frame the target covers its goal marker (the translucent copy at the goal).
    scene.frame_set(scene.frame_end)
    poses = link_poses(built)
    assert poses[puzzle.goal.target] == pytest.approx(poses["goal"], abs=5e-3)
    assert puzzle.goal.is_reached(chain.state_dict(path[-1]))


def test_the_scene_reads_back_as_the_puzzle_at_every_frame(generated):
    puzzle = generated("move_n_times")
    built = build_puzzle(puzzle)
    keyframe_solution(built, puzzle.certificate, puzzle.chain)
    scene = bpy.context.scene
    for frame in (scene.frame_start, (scene.frame_start + scene.frame_end) // 2, scene.frame_end):
        scene.frame_set(frame)
        assert read_chain(built.collection) == puzzle.chain
    # Clearing the solution puts every link back at its joint origin.
    scene.frame_set(scene.frame_end)
    clear_solution(built)
    assert_scene_shows(built, puzzle.chain, np.zeros(len(puzzle.joint_order)), scene.frame_end)


def test_any_joint_axis_and_a_path_that_moves_two_objects_at_once():
    puzzle = every_shape_puzzle()
    chain = puzzle.chain
    # Tilt the revolute joint's axis: no Euler angle is linear in its value any more.
    tilted = tuple(dataclasses.replace(j, axis=(0.36, 0.48, 0.8)) if j.name == "obj_01" else j for j in chain.joints)
    chain = dataclasses.replace(chain, joints=tilted)
    built = build_chain(chain)
    start = np.zeros(len(chain.joint_order))
    both = start.copy()
    both[chain.joint_order.index("obj_00")] = 0.8  # the prismatic joint along (0.6, 0.8, 0)
    both[chain.joint_order.index("obj_01")] = 2.0
    timing = keyframe_solution(built, [start, both], chain, frames_per_action=8)
    # One segment moving two objects plays as two actions, one object after the other.
    assert timing.actions == 2 and bpy.context.scene.frame_end == 17
    first = start.copy()
    first[chain.joint_order.index("obj_00")] = 0.8
    assert_scene_shows(built, chain, first, 9)
    assert_scene_shows(built, chain, both, 17)
    halfway = first.copy()
    halfway[chain.joint_order.index("obj_01")] = 1.0
    assert_scene_shows(built, chain, halfway, 13)


def test_a_path_of_the_wrong_width_is_refused():
    puzzle = every_shape_puzzle()
    built = build_puzzle(puzzle)
    with pytest.raises(ValueError, match="obj_00, obj_01"):
        keyframe_solution(built, [[0.0, 0.0]], puzzle.chain)


def test_a_planner_solution_plays_in_the_puzzles_joint_order(generated, tmp_path):
    import json

    puzzle = generated("rooms")
    folder = write_puzzle(puzzle, tmp_path)
    assert planner_solution(folder, puzzle.joint_order) is None
    order = list(reversed(puzzle.joint_order))  # a solution file may list the joints in another order
    path = np.asarray(puzzle.certificate)[:, ::-1]
    (folder / "solutions").mkdir()
    file = folder / "solutions" / "la_rrt_best.json"
    file.write_text(json.dumps({"joint_order": order, "path": path.tolist()}))
    solution = planner_solution(folder, puzzle.joint_order)
    built = build_puzzle(puzzle)
    keyframe_solution(built, solution, puzzle.chain)
    assert_scene_shows(built, puzzle.chain, puzzle.certificate[-1], bpy.context.scene.frame_end)
    file.write_text(json.dumps({"joint_order": order[1:], "path": path[:, 1:].tolist()}))
    with pytest.raises(PuzzleFormatError, match="joint_order"):
        planner_solution(folder, puzzle.joint_order)
    file.write_text(json.dumps({"joint_order": order[1:], "path": path.tolist()}))  # a state wider than the joints
    with pytest.raises(PuzzleFormatError, match=r"la_rrt_best\.json: path\[0\]"):
        planner_solution(folder, puzzle.joint_order)
