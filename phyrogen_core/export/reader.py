"""Reading a puzzle folder back: URDF -> chain, ``puzzle.json`` -> start, goal, certificate.

The URDF reader covers the subset the writer produces (boxes, cylinders,
prism pieces as OBJ meshes, fixed / prismatic / revolute joints) and gives
back the chain the file was written from: links in file order, joints in the
order of their child links (the order :func:`~phyrogen_core.objects.build_chain`
uses), numbers exact. What URDF cannot hold is restored from the metadata
(link roles and object names) or from defaults:

- a fixed joint gets :class:`Joint`'s default axis and limits;
- a collision shape takes the colour of the visual with the same shape and
  origin (URDF collisions have no colour), else :class:`Geometry`'s default.

Reading is strict, so that no later stage (``phyrogen check``, the
benchmark, the robot) meets a puzzle it cannot trust:

- **Files**: every file read (``puzzle.json``, the URDF, each OBJ mesh) must
  lie inside the puzzle folder after symbolic links are resolved, be a
  regular file and hold at most :data:`~phyrogen_core.folder.MAX_FILE_BYTES`
  (:func:`~phyrogen_core.folder.read_folder_file`). Mesh paths are relative
  to the URDF file; the puzzle's ``name`` keeps
  :func:`~phyrogen_core.folder.name_problem`'s rule. No other entry of the
  folder, referenced or not, is a link that leads out of it or a FIFO, device
  or socket (:func:`~phyrogen_core.folder.require_no_escapes`).
- **Numbers**: every number in ``puzzle.json`` is finite; every number of
  the URDF and the meshes, and every joint value in ``puzzle.json`` (start,
  goal, certificate, joint limits), is finite and within
  :data:`MAX_MAGNITUDE`. Sizes, radii, lengths and mesh heights are positive,
  masses, efforts and velocities not negative, colour channels in [0, 1],
  lower limits at most upper ones.
- **Agreement**: ``joint_order`` and ``joint_limits`` state exactly the
  URDF's active joints (type, lower, upper); ``start`` is the start state
  every planner uses (:func:`start_state`); the goal keeps
  :func:`goal_problems`' rule (its target is an object, its joints are active
  joints, its tolerance small against their ranges, its values reachable,
  the start not already in it).

Every violation raises :class:`PuzzleFormatError` naming the file and the
field, in one line.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from numbers import Real
from pathlib import Path
from typing import Any, TypeVar

from ..chain import Geometry, Joint, JointType, KinematicChain, Link, Role
from ..errors import PuzzleFormatError
from ..folder import PuzzleFolder
from ..folder_layout import METADATA_FILE, name_problem
from ..folder_reads import read_folder_file, read_folder_json, real_folder, real_path_under, require_no_escapes
from ..geometry import Box, ConvexPrism, Cylinder, Pose, Shape
from ..objects import Motion
from ..puzzle import Goal
from ..record import MAX_MAGNITUDE, ObjectRecord, PuzzleRecord
from ..xml_fields import XmlFields, parse_urdf
from .metadata import start_state
from .obj import read_prism_piece
from .urdf import MESH_NAME

GOAL_LINK = "goal"
GOAL_TOLERANCE_SHARE = 0.1
"""A goal's tolerance must be less than this share of the range of each goal joint: the goal
region then covers at most a fifth of the range, so reaching it takes a real move (generators use
1e-3, against ranges of 1 or more)."""
STATE_SLACK = 1e-9
"""How far a state may lie outside the joint limits, or off the start state, and still count as on it."""
_T = TypeVar("_T")
_DEFAULT_COLOR = next(f.default for f in fields(Geometry) if f.name == "color")


@dataclass(frozen=True)
class LoadedPuzzle:
    """A puzzle read from its folder: the chain plus the planning problem."""

    chain: KinematicChain
    record: PuzzleRecord
    """Everything ``puzzle.json`` says (:mod:`phyrogen_core.record`)."""

    @property
    def name(self) -> str:
        return self.record.name

    @property
    def start(self) -> tuple[float, ...]:
        return self.record.start

    @property
    def goal(self) -> Goal:
        return self.record.goal

    @property
    def certificate(self) -> tuple[tuple[float, ...], ...]:
        return self.record.certificate

    @property
    def joint_order(self) -> tuple[str, ...]:
        return self.record.joint_order


def read_puzzle_dir(path: str | Path) -> LoadedPuzzle:
    """Read the folder written by :func:`~phyrogen_core.export.output.write_puzzle`, strictly
    (see the module's docstring for the rules).

    Raises :class:`PuzzleFormatError` naming the file and the problem when the
    folder, ``puzzle.json``, the URDF or a mesh is missing, malformed, outside
    the folder, or disagrees with the rest.
    """
    folder = Path(path)
    if not folder.is_dir():
        what = "is a file, not a puzzle folder" if os.path.lexists(folder) else "no such puzzle folder"
        raise PuzzleFormatError(f"{folder}: {what}")
    json_path = folder / METADATA_FILE
    real_root = real_folder(folder)  # resolved once for every file read here
    record = PuzzleRecord.from_dict(read_folder_json(json_path, folder, f"{json_path}: puzzle.json",
                                                     real_root=real_root), str(json_path))
    problem = name_problem(record.name)
    if problem is not None:
        raise PuzzleFormatError(f"{json_path}: name {record.name!r} {problem}")
    urdf_path = PuzzleFolder(folder, record.name).urdf
    chain = read_urdf(urdf_path, link_roles(record.objects), root=folder, real_root=real_root)
    if chain.joint_order != record.joint_order:
        raise PuzzleFormatError(f"{json_path}: joint_order {list(record.joint_order)} does not match the active "
                                f"joints of {urdf_path.name}: {list(chain.joint_order)}")
    _check_joint_limits(record, chain, json_path, urdf_path.name)
    _check_start(record.start, chain, json_path)
    problems = goal_problems(record.goal, chain, record.start)
    if problems:
        raise PuzzleFormatError(f"{json_path}: goal: {problems[0]}")
    require_no_escapes(folder, name=record.name)  # the files it does not reference too: a stage may copy them
    return LoadedPuzzle(chain, record)


def goal_problems(goal: Goal, chain: KinematicChain, start: Sequence[float] | None = None) -> list[str]:
    """Why ``goal`` is no sensible goal for ``chain`` (empty when it is one).

    The tolerance is a finite positive number below
    :data:`GOAL_TOLERANCE_SHARE` of the range (upper - lower limit) of every
    goal joint; each goal joint is an active joint of the chain and its value
    a finite number within its limits (give or take the tolerance), so the
    goal can be reached; and ``start`` (joint order), when given, is not
    already in the goal.
    """
    tolerance = goal.tolerance
    if not isinstance(tolerance, Real) or not math.isfinite(tolerance) or tolerance <= 0:
        return [f"tolerance {tolerance!r} must be a finite positive number"]
    if not goal.values:
        return ["it constrains no joint"]
    problems: list[str] = []
    for name, value in goal.values.items():
        if name not in chain.joint_order:
            problems.append(f"joint {name!r} is not an active joint; valid: {list(chain.joint_order)}")
            continue
        joint = chain.joint(name)
        if not isinstance(value, Real) or not math.isfinite(value):
            problems.append(f"value of joint {name!r} is {value!r}; it must be a finite number")
            continue
        span = joint.upper - joint.lower
        if not tolerance < GOAL_TOLERANCE_SHARE * span:
            problems.append(f"tolerance {tolerance!r} is not small against joint {name!r}'s range {span!r}: "
                            f"it must be less than {GOAL_TOLERANCE_SHARE} x the range")
        if not joint.lower - tolerance <= value <= joint.upper + tolerance:
            problems.append(f"value {value!r} of joint {name!r} lies outside its limits "
                            f"[{joint.lower!r}, {joint.upper!r}]: the goal cannot be reached")
    if not problems and start is not None and len(start) == len(chain.joint_order):
        if goal.is_reached(dict(zip(chain.joint_order, start, strict=True))):
            problems.append("the start state is already in the goal")
    return problems


def link_roles(objects: Sequence[ObjectRecord]) -> dict[str, tuple[Role, str]]:
    """Link name -> (role, object name), from the record's objects.

    An object's body link carries its name; SE(2) and R(2) objects add the
    helper links ``<object>_base_x`` and ``<object>_base_y``.
    """
    roles: dict[str, tuple[Role, str]] = {GOAL_LINK: (Role.GOAL_MARKER, GOAL_LINK)}
    for entry in objects:
        roles[entry.name] = (entry.role, entry.name)
        if entry.motion in (Motion.SE2, Motion.R2):
            roles[entry.name + "_base_x"] = (Role.HELPER, entry.name)
            roles[entry.name + "_base_y"] = (Role.HELPER, entry.name)
    return roles


def read_urdf(path: Path, roles: Mapping[str, tuple[Role, str]] | None = None,
              root: str | Path | None = None, *, real_root: str | None = None) -> KinematicChain:
    """The chain described by the URDF file at ``path``.

    ``roles`` maps link names to (role, object name); the root link gets
    :attr:`Role.BASE`, other unnamed links :class:`Link`'s defaults.
    Mesh paths are relative to the URDF file. ``root`` is the puzzle folder
    the URDF and every mesh must lie in (by default the folder above the
    URDF's, as in ``<puzzle>/urdf/<name>.urdf``); ``real_root`` its real path, if known.
    """
    path = Path(path)
    root = path.parent.parent if root is None else Path(root)
    real_root = real_folder(root) if real_root is None else real_root
    raw = read_folder_file(path, root, f"{path}: URDF file", real_root=real_root)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise PuzzleFormatError(f"{path}: the URDF is not UTF-8 text: {exc}") from None
    return _UrdfReader(path, roles or {}, root, real_root).chain(parse_urdf(text, str(path), PuzzleFormatError))


class _UrdfReader(XmlFields):
    """One URDF file's parse; holds the file name for error messages and a mesh cache."""

    def __init__(self, path: Path, roles: Mapping[str, tuple[Role, str]], root: Path, real_root: str) -> None:
        self.path = path
        self.roles = roles
        self.root = root
        self.real_root = real_root
        self.meshes: dict[str, tuple[tuple[tuple[float, float], ...], float]] = {}
        self.materials: dict[str, tuple[float, float, float, float]] = {}

    def error(self, message: str) -> PuzzleFormatError:
        return PuzzleFormatError(f"{self.path}: {message}")

    def chain(self, robot: ET.Element) -> KinematicChain:
        if robot.tag != "robot":
            raise self.error(f"root element must be <robot>, got <{robot.tag}>")
        name = self.attribute(robot, "name", "<robot>")
        for material in robot.findall("material"):
            color = material.find("color")
            if color is not None:
                name = self.attribute(material, "name", "<material>")
                self.materials[name] = self.rgba(color, f"<material> {name!r} <color>")
        joints = [self.joint(element) for element in robot.findall("joint")]
        children = {j.child for j in joints}
        link_elements = robot.findall("link")
        roots = [self.attribute(e, "name", "<link>") for e in link_elements]
        roots = [n for n in roots if n not in children]
        if len(roots) != 1:
            raise self.error(f"a URDF needs exactly one root link (a link that is no joint's child), "
                             f"found {roots}")
        links = [self.link(element, roots[0]) for element in link_elements]
        position = {link.name: i for i, link in enumerate(links)}
        joints.sort(key=lambda j: position.get(j.child, len(position)))
        try:
            return KinematicChain(tuple(links), tuple(joints), roots[0], name)
        except ValueError as exc:
            raise self.error(str(exc)) from None

    # -- links -------------------------------------------------------------
    def link(self, element: ET.Element, root: str) -> Link:
        name = self.attribute(element, "name", "<link>")
        role, object_name = (Role.BASE, "") if name == root else self.roles.get(name, (Role.STATIC, ""))
        mass = self.mass(element.find("inertial"), f"link {name!r} <inertial>")
        visuals = self.geometries(element.findall("visual"), name, "visual")
        collisions = self.geometries(element.findall("collision"), name, "collision")
        colors = {(g.shape, g.origin): g.color for g in reversed(visuals)}
        collisions = [
            Geometry(g.shape, g.origin, colors.get((g.shape, g.origin), _DEFAULT_COLOR), g.name)
            for g in collisions
        ]
        return Link(name, tuple(visuals), tuple(collisions), role, object_name, mass)

    def geometries(self, elements: list[ET.Element], link: str, kind: str) -> list[Geometry]:
        out: list[Geometry] = []
        group: tuple[str, str] | None = None  # (kind, geometry index) of the prism being assembled
        for index, element in enumerate(elements):
            where = f"link {link!r} <{kind}> {index}"
            origin = self.pose(element.find("origin"), where)
            color = self.color(element.find("material"), where) if kind == "visual" else _DEFAULT_COLOR
            geometry_name = element.get("name", "")
            shape, mesh_group = self.shape(element.find("geometry"), where)
            if isinstance(shape, ConvexPrism) and mesh_group is not None and out and mesh_group == group:
                previous = out[-1]
                assert isinstance(previous.shape, ConvexPrism)
                if (previous.origin, previous.color, previous.name) != (origin, color, geometry_name):
                    raise self.error(f"{where}: pieces of one prism must share origin, material and name")
                if previous.shape.height != shape.height:
                    raise self.error(f"{where}: pieces of one prism must share a height, got "
                                     f"{previous.shape.height!r} and {shape.height!r}")
                prism = ConvexPrism(previous.shape.pieces + shape.pieces, shape.height)
                out[-1] = Geometry(prism, origin, color, geometry_name)
                continue
            group = mesh_group
            out.append(Geometry(shape, origin, color, geometry_name))
        return out

    def shape(self, element: ET.Element | None, where: str) -> tuple[Shape, tuple[str, str] | None]:
        if element is None or len(element) != 1:
            raise self.error(f"{where}: <geometry> must hold exactly one shape")
        (shape,) = element
        if shape.tag == "box":
            return self.guarded(lambda: Box(self.vector(shape, "size", where, 3)), where), None
        if shape.tag == "cylinder":
            return self.guarded(lambda: Cylinder(self.number(shape, "radius", where),
                                                 self.number(shape, "length", where)), where), None
        if shape.tag == "mesh":
            return self.mesh(shape, where)
        raise self.error(f"{where}: unsupported shape <{shape.tag}>; valid: box, cylinder, mesh")

    def mesh(self, element: ET.Element, where: str) -> tuple[Shape, tuple[str, str] | None]:
        filename = self.attribute(element, "filename", f"{where} <mesh>")
        scale = element.get("scale")
        if scale is not None and self.vector(element, "scale", where, 3) != (1.0, 1.0, 1.0):
            raise self.error(f"{where}: mesh scale {scale!r} is not supported; valid: '1 1 1' or none")
        if filename.startswith("file://"):
            filename = filename[len("file://"):]
        if ("://" in filename or not filename or os.path.isabs(filename) or filename.startswith("\\")
                or "\0" in filename):
            raise self.error(f"{where}: mesh {filename!r} must be a path relative to the URDF file, "
                             "inside the puzzle folder")
        mesh_path = self.path.parent / filename
        key = real_path_under(os.fspath(mesh_path), os.fspath(self.root), self.real_root)
        if key not in self.meshes:
            raw = read_folder_file(mesh_path, self.root, f"{self.path}: {where}: cannot read mesh {filename!r}: "
                                                         "the file", real_root=self.real_root)
            try:
                text = raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise self.error(f"{where}: cannot read mesh {filename!r}: not UTF-8 text: {exc}") from None
            try:
                self.meshes[key] = read_prism_piece(text, MAX_MAGNITUDE)
            except ValueError as exc:
                raise PuzzleFormatError(f"{os.path.normpath(mesh_path)}: not a convex prism: {exc}") from None
        piece, height = self.meshes[key]
        match = MESH_NAME.match(os.path.basename(key))
        group = (match["kind"], match["geometry"]) if match else None
        return self.guarded(lambda: ConvexPrism((piece,), height), where), group

    def color(self, element: ET.Element | None, where: str) -> tuple[float, float, float, float]:
        if element is None:
            return _DEFAULT_COLOR
        color = element.find("color")
        if color is not None:
            return self.rgba(color, f"{where} <material> <color>")
        name = element.get("name", "")
        if name not in self.materials:
            raise self.error(f"{where}: material {name!r} has no colour and is not defined at the top level")
        return self.materials[name]

    def rgba(self, element: ET.Element, where: str) -> tuple[float, float, float, float]:
        r, g, b, a = self.vector(element, "rgba", where, 4, low=0.0, high=1.0)
        return (r, g, b, a)

    def mass(self, inertial: ET.Element | None, where: str) -> float:
        """The link's mass (0 without ``<inertial>``); the other inertial numbers are checked, not kept
        (the writer derives them from the collision shapes)."""
        if inertial is None:
            return 0.0
        self.pose(inertial.find("origin"), where)
        inertia = inertial.find("inertia")
        if inertia is not None:
            for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
                if inertia.get(key) is not None:
                    self.number(inertia, key, f"{where} <inertia>")
        mass_element = inertial.find("mass")
        return 0.0 if mass_element is None else self.number(mass_element, "value", f"{where} <mass>", low=0.0)

    # -- joints ------------------------------------------------------------
    def joint(self, element: ET.Element) -> Joint:
        name = self.attribute(element, "name", "<joint>")
        where = f"joint {name!r}"
        kind = self.attribute(element, "type", where)
        valid = [t.value for t in JointType]
        if kind not in valid:
            raise self.error(f"{where}: unsupported type {kind!r}; valid: {valid}")
        joint_type = JointType(kind)
        parent = self.attribute(self.child(element, "parent", where), "link", f"{where} <parent>")
        child = self.attribute(self.child(element, "child", where), "link", f"{where} <child>")
        origin = self.pose(element.find("origin"), where)
        axis_element = element.find("axis")
        limit = element.find("limit")
        if joint_type is JointType.FIXED:
            # Not kept (a fixed joint has no axis or limits), but no number in the file may be bad.
            if axis_element is not None and axis_element.get("xyz") is not None:
                self.vector(axis_element, "xyz", f"{where} <axis>", 3)
            for key in ("lower", "upper", "effort", "velocity"):
                if limit is not None and limit.get(key) is not None:
                    self.number(limit, key, f"{where} <limit>")
            return self.guarded(lambda: Joint(name, joint_type, parent, child, origin), where)
        axis = (1.0, 0.0, 0.0) if axis_element is None else self.vector(axis_element, "xyz", f"{where} <axis>", 3)
        if limit is None:
            raise self.error(f"{where}: missing <limit>")
        lower = self.number(limit, "lower", f"{where} <limit>", 0.0)
        upper = self.number(limit, "upper", f"{where} <limit>", 0.0)
        if not lower <= upper:
            raise self.error(f"{where} <limit>: lower={lower!r} exceeds upper={upper!r}")
        effort = self.number(limit, "effort", f"{where} <limit>", low=0.0)
        velocity = self.number(limit, "velocity", f"{where} <limit>", low=0.0)
        return self.guarded(
            lambda: Joint(name, joint_type, parent, child, origin, axis, lower, upper, effort, velocity),
            where,
        )

    # -- primitives --------------------------------------------------------
    def number(self, element: ET.Element, name: str, where: str, default: float | None = None,
               low: float = -MAX_MAGNITUDE, high: float = MAX_MAGNITUDE) -> float:
        """The attribute ``name`` as a finite number in [``low``, ``high``] (``default`` when absent, if given)."""
        if default is not None and element.get(name) is None:
            return default
        return self.vector(element, name, where, 1, low, high)[0]

    def vector(self, element: ET.Element, name: str, where: str, size: int,
               low: float = -MAX_MAGNITUDE, high: float = MAX_MAGNITUDE) -> tuple[float, ...]:
        """The attribute ``name`` as ``size`` finite numbers, each in [``low``, ``high``]."""
        text = self.attribute(element, name, where)
        try:
            values = tuple(map(float, text.split()))
        except ValueError:
            values = ()
        if len(values) == size and all(low <= v <= high and math.isfinite(v) for v in values):
            return values  # (a URDF holds hundreds of numbers: the messages below only for a bad one)
        wanted = "a number" if size == 1 else f"{size} numbers"
        try:
            values = tuple(float(v) for v in text.split())
        except ValueError:
            raise self.error(f"{where}: attribute {name}={_show(text)} is not {wanted}" if size == 1 else
                             f"{where}: attribute {name}={_show(text)} must be {wanted}") from None
        if len(values) != size:
            raise self.error(f"{where}: attribute {name}={_show(text)} must be {wanted}")
        for value in values:
            if not math.isfinite(value):
                raise self.error(f"{where}: attribute {name}={_show(text)} "
                                 + ("is not a finite number" if size == 1 else "holds a number that is not finite")
                                 + "; every number in a puzzle's URDF must be finite")
            if not low <= value <= high:
                raise self.error(f"{where}: attribute {name}={_show(text)} must lie in [{low:g}, {high:g}]")
        return values

    def pose(self, element: ET.Element | None, where: str) -> Pose:
        if element is None:
            return Pose()
        xyz = self.vector(element, "xyz", where, 3) if element.get("xyz") is not None else (0.0, 0.0, 0.0)
        rpy = self.vector(element, "rpy", where, 3) if element.get("rpy") is not None else (0.0, 0.0, 0.0)
        return Pose(xyz, rpy)  # type: ignore[arg-type]

    def guarded(self, build: Callable[[], _T], where: str) -> _T:
        """``build()``, with the model's own ValueError turned into a format error naming the file."""
        try:
            return build()
        except PuzzleFormatError:
            raise
        except ValueError as exc:
            message = str(exc)
            # The model names the joint or link itself ("joint 'a': axis ..."); say it once.
            raise self.error(message if message.startswith(f"{where}:") else f"{where}: {message}") from None


# -- puzzle.json against the URDF -------------------------------------------------
def _check_joint_limits(record: PuzzleRecord, chain: KinematicChain, source: Path, urdf: str) -> None:
    """``joint_limits`` must state each active joint of the URDF, with its type and limits, and nothing else."""
    named = sorted(limit.joint for limit in record.joint_limits)
    if named != sorted(chain.joint_order):
        raise PuzzleFormatError(f"{source}: joint_limits names the joints {named}; the active joints of "
                                f"{urdf} are {sorted(chain.joint_order)}")
    for name in chain.joint_order:
        limit, joint = record.limit(name), chain.joint(name)
        if (limit.type, limit.lower, limit.upper) != (joint.type, joint.lower, joint.upper):
            raise PuzzleFormatError(f"{source}: joint_limits.{name} says {limit.type.value} [{limit.lower!r}, "
                                    f"{limit.upper!r}], but {urdf} has {joint.type.value} [{joint.lower!r}, "
                                    f"{joint.upper!r}]")


def _check_start(start: Sequence[float], chain: KinematicChain, source: Path) -> None:
    """``start`` must lie within the limits and be :func:`start_state`, the state every planner starts from."""
    for index, (joint, value, rest) in enumerate(zip(chain.active_joints, start, start_state(chain), strict=True)):
        label = f"start[{index}] (joint {joint.name!r})"
        if not joint.lower - STATE_SLACK <= value <= joint.upper + STATE_SLACK:
            raise PuzzleFormatError(f"{source}: {label} = {value!r} lies outside the joint's limits "
                                    f"[{joint.lower!r}, {joint.upper!r}]")
        if abs(value - rest) > STATE_SLACK:
            raise PuzzleFormatError(f"{source}: {label} = {value!r} is not the start state every planner uses "
                                    f"(each joint at 0 clipped into its limits, here {rest!r})")


def _show(value: Any, width: int = 80) -> str:
    """``repr(value)``, cut to ``width`` characters: messages stay one short line whatever a file holds."""
    text = repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."

