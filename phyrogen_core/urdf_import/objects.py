"""A URDF's link tree as puzzle objects, found from its structure, never from its names.

- **Static scenery**: every link fixed (through any number of fixed joints)
  to the root becomes one fixed object.
- **A movable object** starts at a prismatic or revolute joint on a static
  link. Geometry-less links with a single movable child joint are helper
  links of the same object: prismatic x -> prismatic y [-> revolute yaw]
  is one R(2) or SE(2) object, whatever the links are called. The link the
  last joint moves is the object's body; every link fixed below it (a hinge,
  a door panel, its handles) is merged into the body with the fixed joints'
  transforms, so the object moves, collides and counts as one.
- **The goal**: the link named ``goal`` and everything below it (the
  prototype's translucent copy of the target) is no object; its pose is read
  by :mod:`phyrogen_core.urdf_import.goal`.

Joint values keep their meaning up to a sign and an offset
(:class:`JointMap`): an axis pointing down turns the other way, and an
object whose limits exclude 0 gets its rest pose moved into them, since
every puzzle starts at 0.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

import numpy as np

from ..chain import Geometry, Role
from ..geometry import Box, Cylinder, Pose
from ..objects import BASE_LINK, Motion, PuzzleObject
from .shapes import frame_yaw, planar_frame, planar_geometries
from .urdf_model import JointSpec, UrdfImportError, UrdfModel

GOAL_LINK = "goal"
KNOB = "knob"
"""The name of the visual a robot grasps (``manipulation.grasp``)."""
AXIS_TOLERANCE = 1e-6
"""How far from horizontal (prismatic) or vertical (revolute) a joint axis may point and still be planar."""
RESERVED = {BASE_LINK, GOAL_LINK}


@dataclass(frozen=True)
class JointMap:
    """How a URDF joint's value maps to the puzzle's joint: ``value = sign * urdf_value - offset``."""

    urdf: str
    joint: str
    sign: float = 1.0
    offset: float = 0.0

    def value(self, urdf_value: float) -> float:
        return self.sign * urdf_value - self.offset


@dataclass(frozen=True)
class ImportedObject:
    """A puzzle object and the URDF links and joints it was made of."""

    obj: PuzzleObject
    links: tuple[str, ...]  # every URDF link of the object: helpers, body, links fixed below it
    joints: tuple[JointMap, ...]  # the URDF's movable joints, from the world outwards
    body_offset: np.ndarray  # 4x4: the URDF body link's frame in the object's frame


@dataclass(frozen=True)
class Scene:
    objects: tuple[ImportedObject, ...]  # movable ones first, in the order of the URDF's joints
    goal_pose: np.ndarray | None  # 4x4 world pose of the goal link
    notes: tuple[str, ...]


def scene_objects(model: UrdfModel) -> Scene:
    """The puzzle objects of ``model`` (see the module's docstring)."""
    return _SceneBuilder(model).build()


class _SceneBuilder:
    def __init__(self, model: UrdfModel) -> None:
        self.model = model
        self.notes: list[str] = []
        self.names: set[str] = set()
        self.hulls: list[str] = []  # meshes that are no extruded outline
        self.world = self._rest_frames()

    def error(self, message: str) -> UrdfImportError:
        return UrdfImportError(f"{self.model.path}: {message}")

    def _rest_frames(self) -> dict[str, np.ndarray]:
        world = {self.model.root: np.eye(4)}
        stack = [self.model.root]
        while stack:
            for joint in self.model.children(stack.pop()):
                world[joint.child] = world[joint.parent] @ joint.origin
                stack.append(joint.child)
        return world

    def build(self) -> Scene:
        model = self.model
        goal_links = self._goal_subtree()
        static = [model.root]
        for link in static:  # grows while it is walked
            static += [j.child for j in model.children(link) if j.type == "fixed" and j.child not in goal_links]
        movable: list[ImportedObject] = []
        for joint in model.joints.values():
            if joint.type != "fixed" and joint.parent in static:
                made = self._movable(joint)
                if made is not None:
                    movable.append(made)
        fixed = self._above_the_floor(movable, [self._static(link) for link in static
                                                if model.links[link].has_geometry])
        goal_pose = self.world[GOAL_LINK] if GOAL_LINK in goal_links else None
        if self.hulls:
            self.notes.append(f"{len(self.hulls)} mesh{'es are' if len(self.hulls) > 1 else ' is'} no extruded "
                              f"outline (3D: {', '.join(self.hulls)}); each becomes the prism over its outline's "
                              "convex hull from its lowest to its highest point, which covers it (conservative)")
        return Scene(tuple(movable) + tuple(fixed), goal_pose, tuple(self.notes))

    def _goal_subtree(self) -> set[str]:
        if GOAL_LINK not in self.model.links:
            return set()
        link = GOAL_LINK
        while (joint := self.model.parent_joint(link)) is not None:
            if joint.type != "fixed":
                raise self.error(f"the goal link {GOAL_LINK!r} hangs on the movable joint {joint.name!r}; it must be "
                                 "fixed to the world, where the target is to go")
            link = joint.parent
        found, stack = {GOAL_LINK}, [GOAL_LINK]
        while stack:
            for joint in self.model.children(stack.pop()):
                if joint.type != "fixed":
                    raise self.error(f"joint {joint.name!r} under the goal link moves; the goal marker must be fixed")
                found.add(joint.child)
                stack.append(joint.child)
        return found

    # -- movable objects -----------------------------------------------------
    def _movable(self, first: JointSpec) -> ImportedObject | None:
        model = self.model
        joints = [first]
        body = first.child
        while len(joints) < 3 and not model.links[body].has_geometry:
            children = model.children(body)
            if len(children) != 1 or children[0].type == "fixed":
                break
            joints.append(children[0])
            body = children[0].child
        merged = self._fixed_below(body)
        motion, axes = self._motion(joints)
        rest = self.world[body]
        frame = planar_frame(rest)
        body_offset = np.linalg.inv(frame) @ rest
        visuals, collisions, sources = self._geometries(merged, body_offset)
        visuals = self._mark_knob(visuals, sources, body)
        links = tuple(j.child for j in joints[:-1]) + tuple(link for link, _ in merged)
        if not collisions:
            self.notes.append(f"the links {list(links)} move (joint {first.name!r}) but have no collision shape; "
                              "they block nothing and are left out")
            return None
        name = self._name(next((link for link, _ in merged if model.links[link].has_geometry), body))
        maps, limits, axis = self._joint_maps(name, motion, joints, axes, frame)
        pose = Pose.planar(frame[0, 3], frame[1, 3], frame[2, 3], frame_yaw(frame))
        obj = PuzzleObject(name, motion, pose, tuple(visuals), tuple(collisions), Role.BLOCKER, limits, axis)
        obj, maps = self._rest_inside_limits(obj, maps)
        order = [j.name for j in joints]
        return ImportedObject(obj, links, tuple(sorted(maps, key=lambda m: order.index(m.urdf))), body_offset)

    def _fixed_below(self, body: str) -> list[tuple[str, np.ndarray]]:
        """The body and every link fixed below it, each with its frame in the body's frame."""
        out = [(body, np.eye(4))]
        for link, transform in out:  # grows while it is walked
            for joint in self.model.children(link):
                if joint.type != "fixed":
                    raise self.error(f"joint {joint.name!r} moves link {joint.child!r} on the movable link "
                                     f"{link!r}; nested mechanisms cannot be imported (every puzzle object moves "
                                     "relative to the world)")
                out.append((joint.child, transform @ joint.origin))
        return out

    def _motion(self, joints: list[JointSpec]) -> tuple[Motion, list[np.ndarray]]:
        """The object's motion and each joint's axis in the world."""
        axes = []
        for joint in joints:
            frame = self.world[joint.parent] @ joint.origin
            axis = frame[:3, :3] @ np.asarray(joint.axis)
            if joint.type == "prismatic" and abs(axis[2]) > AXIS_TOLERANCE:
                raise self.error(f"prismatic joint {joint.name!r} slides along {_show(axis)} in the world, out of "
                                 "the plane; a puzzle's objects slide horizontally")
            if joint.type == "revolute" and abs(abs(axis[2]) - 1.0) > AXIS_TOLERANCE:
                raise self.error(f"revolute joint {joint.name!r} turns about {_show(axis)} in the world; a puzzle's "
                                 "objects turn about the vertical")
            axes.append(axis)
        kinds = [j.type for j in joints]
        if kinds in (["prismatic"], ["revolute"]):
            return Motion(kinds[0]), axes
        if kinds in (["prismatic", "prismatic"], ["prismatic", "prismatic", "revolute"]):
            along = sorted(self._world_axis(j, a) for j, a in zip(joints[:2], axes[:2], strict=True))
            if along != [0, 1]:
                raise self.error(f"joints {joints[0].name!r} and {joints[1].name!r} must slide along the world's x "
                                 "and y axes, one each, to form an R(2) or SE(2) object")
            return (Motion.R2 if len(joints) == 2 else Motion.SE2), axes
        raise self.error(f"joints {[j.name for j in joints]} ({', '.join(kinds)}) move one object in a way that "
                         "cannot be imported; valid: one prismatic or revolute joint, or prismatic x and y "
                         "(then revolute yaw) through geometry-less links")

    def _world_axis(self, joint: JointSpec, axis: np.ndarray) -> int:
        for index in (0, 1):
            if abs(abs(axis[index]) - 1.0) <= AXIS_TOLERANCE:
                return index
        raise self.error(f"prismatic joint {joint.name!r} slides along {_show(axis)} in the world; an R(2) or "
                         "SE(2) object's joints slide along the world's x and y axes")

    def _joint_maps(self, name: str, motion: Motion, joints: list[JointSpec], axes: list[np.ndarray],
                    frame: np.ndarray):
        """The puzzle joints' maps and limits (in ``motion.joint_suffixes`` order) and the sliding axis."""
        maps: dict[str, JointMap] = {}
        limits: dict[str, tuple[float, float]] = {}
        axis = (1.0, 0.0, 0.0)
        for joint, world_axis in zip(joints, axes, strict=True):
            if motion is Motion.PRISMATIC:
                local = frame[:3, :3].T @ world_axis
                local[2] = 0.0
                local /= np.linalg.norm(local)
                axis = tuple(float(a) + 0.0 for a in local)
                key, sign = "", 1.0
            elif joint.type == "revolute":
                key, sign = ("" if motion is Motion.REVOLUTE else "_yaw"), math.copysign(1.0, world_axis[2])
            else:
                index = 0 if abs(world_axis[0]) > abs(world_axis[1]) else 1
                key, sign = ("_x", "_y")[index], math.copysign(1.0, world_axis[index])
            lower, upper = sorted((sign * joint.lower, sign * joint.upper))
            maps[key] = JointMap(joint.name, name + key, sign)
            limits[key] = (lower + 0.0, upper + 0.0)
        order = motion.joint_suffixes
        return [maps[k] for k in order], tuple(limits[k] for k in order), axis

    def _rest_inside_limits(self, obj: PuzzleObject, maps: list[JointMap]):
        """``obj`` with its rest pose moved to where each joint's 0 clipped into its limits puts it."""
        shifts = [min(max(0.0, lower), upper) for lower, upper in obj.limits]
        if not any(shifts):
            return obj, maps
        x, y, z = obj.pose.xyz
        yaw = obj.pose.yaw
        for suffix, shift, joint in zip(obj.motion.joint_suffixes, shifts, maps, strict=True):
            if not shift:
                continue
            self.notes.append(f"joint {joint.urdf!r}: its limits exclude 0, where every puzzle starts; the object "
                              f"starts at {joint.sign * shift:g} instead (its rest pose moved there)")
            if obj.motion is Motion.PRISMATIC:
                c, s = math.cos(yaw), math.sin(yaw)
                x += shift * (c * obj.axis[0] - s * obj.axis[1])
                y += shift * (s * obj.axis[0] + c * obj.axis[1])
            elif suffix == "_x":
                x += shift
            elif suffix == "_y":
                y += shift
            else:
                yaw += shift
        limits = tuple((lower - shift, upper - shift) for (lower, upper), shift in zip(obj.limits, shifts, strict=True))
        maps = [JointMap(m.urdf, m.joint, m.sign, shift) for m, shift in zip(maps, shifts, strict=True)]
        return PuzzleObject(obj.name, obj.motion, Pose.planar(x, y, z, yaw), obj.visuals, obj.collisions, obj.role,
                            limits, obj.axis), maps

    # -- static objects ------------------------------------------------------
    def _static(self, link: str) -> ImportedObject:
        frame = planar_frame(self.world[link])
        offset = np.linalg.inv(frame) @ self.world[link]
        visuals, collisions, _ = self._geometries([(link, np.eye(4))], offset)
        pose = Pose.planar(frame[0, 3], frame[1, 3], frame[2, 3], frame_yaw(frame))
        obj = PuzzleObject(self._name(link), Motion.FIXED, pose, tuple(visuals), tuple(collisions), Role.STATIC)
        return ImportedObject(obj, (link,), (), offset)

    def _above_the_floor(self, movable: list[ImportedObject], fixed: list[ImportedObject]) -> list[ImportedObject]:
        """``fixed`` without the floor: scenery wholly below everything that moves can never meet a
        moving shape (heights never change), and PhyRoGen's puzzles stand on an implicit floor."""
        lows = [_z_range(item.obj, item.obj.collisions)[0] for item in movable]
        if not lows:
            return fixed
        kept, floor = [], []
        for item in fixed:
            shapes = item.obj.collisions or item.obj.visuals
            (floor if _z_range(item.obj, shapes)[1] <= min(lows) + 1e-9 else kept).append(item)
        if floor:
            many = len(floor) > 1
            self.notes.append(f"static link{'s' if many else ''} {', '.join(repr(i.links[0]) for i in floor)} "
                              f"lie{'' if many else 's'} wholly below everything that moves (a floor): left out, "
                              "as every puzzle stands on one")
        return kept

    # -- shared ----------------------------------------------------------------
    def _mark_knob(self, visuals: list[Geometry], sources: list[str], body: str) -> list[Geometry]:
        """``visuals`` with the grasp point marked the way generated puzzles mark it (a visual named
        ``knob``, :mod:`manipulation.grasp`): the highest box or cylinder of a link fixed to the body that
        collides (a handle), as a gripper reaches from above. Nothing changes without such a link, or
        when a visual is named ``knob`` already."""
        if any(g.name == KNOB for g in visuals):
            return visuals
        tops = [(g.origin.xyz[2] + (g.shape.size[2] if isinstance(g.shape, Box) else g.shape.length) / 2, i)
                for i, (g, source) in enumerate(zip(visuals, sources, strict=True))
                if source != body and self.model.links[source].collisions and isinstance(g.shape, Box | Cylinder)]
        if not tops:
            return visuals
        index = max(tops)[1]
        return [replace(g, name=KNOB) if i == index else g for i, g in enumerate(visuals)]

    def _geometries(self, links: list[tuple[str, np.ndarray]], offset: np.ndarray):
        """The visuals and collisions of ``links`` (each with its frame in the object's frame
        ``offset`` maps to), and the link of each visual."""
        visuals: list[Geometry] = []
        collisions: list[Geometry] = []
        sources: list[str] = []
        for link, transform in links:
            spec = self.model.links[link]
            for kind, shapes, out in (("visual", spec.visuals, visuals), ("collision", spec.collisions, collisions)):
                for index, shape in enumerate(shapes):
                    where = f"link {link!r} <{kind}> {index}"
                    try:
                        made, note = planar_geometries(shape, offset @ transform @ shape.origin, where)
                    except ValueError as exc:
                        raise self.error(f"{where}: {exc}") from None
                    out += made
                    if kind == "visual":
                        sources += [link] * len(made)
                    if shape.kind == "mesh" and note:
                        if shape.mesh not in self.hulls:
                            self.hulls.append(shape.mesh)
                    elif note and note not in self.notes:
                        self.notes.append(note)
        return visuals, collisions, sources

    def _name(self, link: str) -> str:
        """A puzzle object name from a URDF link name: letters, digits, '_', '.', '-' only, unique."""
        base = re.sub(r"[^A-Za-z0-9_.\-]+", "_", link).strip("_.-") or "object"
        name, n = base, 1
        while name in self.names or name in RESERVED:
            n += 1
            name = f"{base}_{n}"
        self.names.add(name)
        return name


def _z_range(obj: PuzzleObject, geometries: tuple[Geometry, ...]) -> tuple[float, float]:
    """The lowest and highest world z of ``geometries`` of ``obj`` (vertical prisms, planar poses)."""
    lows, highs = [], []
    for geometry in geometries:
        shape = geometry.shape
        half = (shape.size[2] if isinstance(shape, Box) else shape.length if isinstance(shape, Cylinder)
                else shape.height) / 2
        middle = obj.pose.xyz[2] + geometry.origin.xyz[2]
        lows.append(middle - half)
        highs.append(middle + half)
    return min(lows), max(highs)


def _show(axis: np.ndarray) -> str:
    return "(" + ", ".join(f"{a:.4g}" for a in axis) + ")"
