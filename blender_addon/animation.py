"""A solution path as keyframes on the puzzle's link armatures, and its short animation file.

Every link of a built puzzle (:mod:`.scene`) is an Armature object placed at
its joint origin, with the joint described on it. A joint's motion goes into
the object's *delta* transform (``delta_location`` for a prismatic joint,
``delta_rotation_euler`` for a revolute one), so the object's own location and
rotation keep the joint origin: reading the chain back (Export, Phobos's
annotations) sees the puzzle as built at any frame, and clearing the
animation (:func:`clear_solution`) puts every object back in place.

Timing: the path is split into single-object actions by the rule the
planners count actions by (:func:`phyrogen_core.actions.split_actions`), every
action lasts the same number of frames, and within an action the object moves
at constant speed in joint space. Keyframes are linear, so any frame shows the
path's states interpolated linearly, the motion the certificate was checked on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix, Vector

from phyrogen_core.actions import split_actions
from phyrogen_core.chain import JointType, KinematicChain, rotation_matrix

from .scene import PuzzleScene, read_chain

FPS = 24
FRAMES_PER_ACTION = 24
"""In Blender, one second per action at :data:`FPS`."""
PRINCIPAL_AXIS_SLACK = 1e-9


@dataclass(frozen=True)
class SolutionTiming:
    """When each state of a keyframed path is reached.

    ``states`` are the keyframed states (the path, with a segment that moves
    several objects split into one move per object) and ``frames`` their
    frames, increasing; ``frame_end`` may hold the last state a while.
    """

    states: np.ndarray
    frames: np.ndarray
    frame_start: int
    frame_end: int
    actions: int
    fps: int

    def state_at(self, frame: float) -> np.ndarray:
        """The state shown at ``frame``: the path's states interpolated linearly (held outside the range)."""
        return np.array([np.interp(frame, self.frames, column) for column in self.states.T])

    @property
    def seconds(self) -> float:
        return (self.frame_end - self.frame_start + 1) / self.fps


def solution_timing(path: Sequence[Sequence[float]], chain: KinematicChain, frames_per_action: int = FRAMES_PER_ACTION,
                    frame_start: int = 1, hold_frames: int = 0, fps: int = FPS) -> SolutionTiming:
    """The frames of ``path``'s states (joint order of ``chain``): each action ``frames_per_action`` long.

    Raises ValueError when the path's states do not have one value per active joint.
    """
    states = np.asarray(path, dtype=float)
    if states.ndim != 2 or states.shape[1] != len(chain.joint_order) or len(states) == 0:
        raise ValueError(f"a path for {chain.name!r} needs states of {len(chain.joint_order)} joint values "
                         f"({', '.join(chain.joint_order)}), got an array of shape {states.shape}")
    if frames_per_action < 1 or hold_frames < 0 or fps < 1:
        raise ValueError(f"frames_per_action ({frames_per_action}) and fps ({fps}) must be at least 1, "
                         f"hold_frames ({hold_frames}) at least 0")
    actions = split_actions(states, chain.factors)
    keyed = [states[0]]
    frames = [float(frame_start)]
    for index, action in enumerate(actions):
        steps = np.linalg.norm(np.diff(action.states, axis=0), axis=1)
        share = np.cumsum(steps) / steps.sum() if steps.sum() > 0 else np.linspace(0, 1, len(steps) + 1)[1:]
        for state, part in zip(action.states[1:], share, strict=True):
            keyed.append(state)
            frames.append(frame_start + frames_per_action * (index + float(part)))
    last = math.ceil(frames[-1])
    return SolutionTiming(np.array(keyed), np.array(frames), frame_start, last + hold_frames, len(actions), fps)


def planner_solution(folder: str | Path, joint_order: Sequence[str]) -> np.ndarray | None:
    """The benchmark's best solution in a puzzle folder (``solutions/la_rrt_best.json``) in ``joint_order``,
    or None when there is none.

    Read by the format's one strict reader (:func:`phyrogen_core.solution_file.read_solution_file`, as
    ``manipulate`` reads it): :class:`~phyrogen_core.folder.PuzzleFormatError` naming the file when it
    breaks the format or its joints are not the puzzle's.
    """
    from phyrogen_core.folder import BEST_SOLUTION
    from phyrogen_core.solution_file import read_solution_file

    file = Path(folder) / BEST_SOLUTION
    if not file.exists():
        return None
    return read_solution_file(file, folder).path_in(joint_order, str(file))


def frames_per_action_for(actions: int, seconds: float, fps: int, least: int = 4) -> int:
    """Frames per action so that ``actions`` actions last about ``seconds`` (at least ``least`` frames each)."""
    return max(least, round(seconds * fps / max(actions, 1)))


def keyframe_solution(built: PuzzleScene, path: Sequence[Sequence[float]], chain: KinematicChain | None = None,
                      frames_per_action: int = FRAMES_PER_ACTION, frame_start: int = 1, hold_frames: int = 0,
                      fps: int = FPS, scene: bpy.types.Scene | None = None) -> SolutionTiming:
    """Keyframe ``path`` (states in ``chain``'s joint order) on the link objects of ``built``.

    ``chain`` defaults to the one the scene describes. Earlier keyframes of
    the puzzle's links are replaced; ``scene``'s frame range and rate are set
    to the solution's, and the scene is left at its first frame.
    """
    scene = scene or bpy.context.scene
    chain = chain or read_chain(built.collection)
    timing = solution_timing(path, chain, frames_per_action, frame_start, hold_frames, fps)
    clear_solution(built, chain)
    for column, joint in enumerate(chain.active_joints):
        obj = built.links.get(joint.child)
        if obj is None:
            raise ValueError(f"the scene of {chain.name!r} has no link object {joint.child!r} for joint {joint.name!r}")
        axis = rotation_matrix(joint.origin.rpy) @ np.asarray(joint.axis, dtype=float)
        axis = axis / np.linalg.norm(axis)
        values = timing.states[:, column]
        if joint.type is JointType.PRISMATIC:
            _keyframe_prismatic(obj, axis, values, timing.frames)
        elif joint.type is JointType.REVOLUTE:
            _keyframe_revolute(obj, axis, column, timing)
        _make_linear(obj)
    scene.render.fps, scene.render.fps_base = fps, 1.0
    scene.frame_start, scene.frame_end = timing.frame_start, timing.frame_end
    scene.frame_set(timing.frame_start)
    return timing


def clear_solution(built: PuzzleScene, chain: KinematicChain | None = None) -> None:
    """Remove a solution's keyframes and put every link of ``built`` back at its joint origin."""
    chain = chain or read_chain(built.collection)
    for joint in chain.active_joints:
        obj = built.links.get(joint.child)
        if obj is None:
            continue
        obj.animation_data_clear()
        obj.delta_location = (0.0, 0.0, 0.0)
        obj.delta_rotation_euler = (0.0, 0.0, 0.0)
        obj.delta_rotation_quaternion = (1.0, 0.0, 0.0, 0.0)


def _keyframe_prismatic(obj: bpy.types.Object, axis: np.ndarray, values: np.ndarray, frames: np.ndarray) -> None:
    # The origin's rotation is applied after the delta translation's, so the axis is in the parent's frame.
    for value, frame in zip(values, frames, strict=True):
        obj.delta_location = tuple(float(a * value) for a in axis)
        obj.keyframe_insert("delta_location", frame=float(frame))


def _keyframe_revolute(obj: bpy.types.Object, axis: np.ndarray, column: int, timing: SolutionTiming) -> None:
    # Blender rotates by the delta rotation after the object's own (the joint origin's): about the
    # joint axis in the parent's frame. About a principal axis, one Euler angle is linear in the joint value.
    principal = int(np.argmax(np.abs(axis)))
    if obj.rotation_mode in ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX") \
            and abs(abs(axis[principal]) - 1.0) < PRINCIPAL_AXIS_SLACK:
        sign = float(np.sign(axis[principal]))
        for value, frame in zip(timing.states[:, column], timing.frames, strict=True):
            obj.delta_rotation_euler[principal] = sign * float(value)
            obj.keyframe_insert("delta_rotation_euler", index=principal, frame=float(frame))
        return
    # Any other axis: a keyframe on every frame (exact there, linear in between).
    previous = None
    for frame in range(timing.frame_start, math.ceil(timing.frames[-1]) + 1):
        value = float(timing.state_at(frame)[column])
        rotation = Matrix.Rotation(value, 3, Vector(tuple(float(a) for a in axis)))
        if obj.rotation_mode in ("QUATERNION", "AXIS_ANGLE"):
            obj.delta_rotation_quaternion = rotation.to_quaternion()
            obj.keyframe_insert("delta_rotation_quaternion", frame=float(frame))
        else:
            euler = rotation.to_euler(obj.rotation_mode, previous) if previous else rotation.to_euler(obj.rotation_mode)
            obj.delta_rotation_euler = euler
            obj.keyframe_insert("delta_rotation_euler", frame=float(frame))
            previous = euler


def _make_linear(obj: bpy.types.Object) -> None:
    for fcurve in _fcurves(obj):
        for point in fcurve.keyframe_points:
            point.interpolation = "LINEAR"
        fcurve.update()


def _fcurves(obj: bpy.types.Object) -> list:
    data = obj.animation_data
    action = data.action if data is not None else None
    if action is None:
        return []
    if hasattr(action, "fcurves"):  # Blender < 5 (in 4.4 and 4.5, the first slot's channels)
        return list(action.fcurves)
    from bpy_extras import anim_utils  # Blender 5: layered actions

    channels = anim_utils.action_get_channelbag_for_slot(action, data.action_slot)
    return list(channels.fcurves) if channels is not None else []
