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
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, TypeVar

from ..chain import Geometry, Joint, JointType, KinematicChain, Link, Role
from ..geometry import Box, ConvexPrism, Cylinder, Pose, Shape
from ..objects import Motion
from ..puzzle import Goal
from .metadata import FORMAT_VERSION
from .obj import read_prism_piece
from .urdf import MESH_NAME

GOAL_LINK = "goal"
_T = TypeVar("_T")
_DEFAULT_COLOR = next(f.default for f in fields(Geometry) if f.name == "color")


class PuzzleFormatError(ValueError):
    """A puzzle folder, its ``puzzle.json`` or its URDF is missing or malformed."""


@dataclass(frozen=True)
class LoadedPuzzle:
    """A puzzle read from its folder: the chain plus the planning problem."""

    chain: KinematicChain
    metadata: dict[str, Any]
    start: tuple[float, ...]
    goal: Goal
    certificate: tuple[tuple[float, ...], ...]
    joint_order: tuple[str, ...]


def read_puzzle_dir(path: str | Path) -> LoadedPuzzle:
    """Read the folder written by :func:`~phyrogen_core.export.output.write_puzzle`.

    Raises :class:`PuzzleFormatError` naming the file and the problem when the
    folder, ``puzzle.json``, the URDF or a mesh is missing or malformed.
    """
    folder = Path(path)
    if not folder.is_dir():
        raise PuzzleFormatError(f"{folder}: no such puzzle folder")
    json_path = folder / "puzzle.json"
    metadata = _read_metadata(json_path)
    name = _field(metadata, "name", str, json_path)
    joint_order = tuple(_string_list(metadata, "joint_order", json_path))
    objects = _field(metadata, "objects", list, json_path)
    urdf_path = folder / "urdf" / f"{name}.urdf"
    chain = read_urdf(urdf_path, link_roles(objects, json_path))
    if chain.joint_order != joint_order:
        raise PuzzleFormatError(f"{json_path}: joint_order {list(joint_order)} does not match the active "
                                f"joints of {urdf_path.name}: {list(chain.joint_order)}")
    start = _state(metadata.get("start"), len(joint_order), "start", json_path)
    certificate = tuple(
        _state(state, len(joint_order), f"certificate[{i}]", json_path)
        for i, state in enumerate(_field(metadata, "certificate", list, json_path))
    )
    return LoadedPuzzle(chain, metadata, start, _goal(metadata, joint_order, json_path), certificate,
                        joint_order)


def link_roles(objects: Sequence[Any], source: Path | str = "puzzle.json") -> dict[str, tuple[Role, str]]:
    """Link name -> (role, object name), from the metadata's ``objects`` list.

    An object's body link carries its name; SE(2) and R(2) objects add the
    helper links ``<object>_base_x`` and ``<object>_base_y``.
    """
    roles: dict[str, tuple[Role, str]] = {GOAL_LINK: (Role.GOAL_MARKER, GOAL_LINK)}
    for index, entry in enumerate(objects):
        where = f"objects[{index}]"
        if not isinstance(entry, Mapping):
            raise PuzzleFormatError(f"{source}: {where} must be an object with name, motion, role")
        name = _field(entry, "name", str, source, where)
        role = _enum(Role, _field(entry, "role", str, source, where), source, f"{where}.role")
        motion = _enum(Motion, _field(entry, "motion", str, source, where), source, f"{where}.motion")
        roles[name] = (role, name)
        if motion in (Motion.SE2, Motion.R2):
            roles[name + "_base_x"] = (Role.HELPER, name)
            roles[name + "_base_y"] = (Role.HELPER, name)
    return roles


def read_urdf(path: Path, roles: Mapping[str, tuple[Role, str]] | None = None) -> KinematicChain:
    """The chain described by the URDF file at ``path``.

    ``roles`` maps link names to (role, object name); the root link gets
    :attr:`Role.BASE`, other unnamed links :class:`Link`'s defaults.
    Mesh paths are resolved relative to the URDF file.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise PuzzleFormatError(f"{path}: URDF file is missing") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PuzzleFormatError(f"{path}: cannot read the URDF: {exc}") from None
    try:
        robot = ET.fromstring(text)
    except ET.ParseError as exc:
        raise PuzzleFormatError(f"{path}: malformed XML: {exc}") from None
    return _UrdfReader(path, roles or {}).chain(robot)


class _UrdfReader:
    """One URDF file's parse; holds the file name for error messages and a mesh cache."""

    def __init__(self, path: Path, roles: Mapping[str, tuple[Role, str]]) -> None:
        self.path = path
        self.roles = roles
        self.meshes: dict[Path, tuple[tuple[tuple[float, float], ...], float]] = {}
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
                self.materials[self.attribute(material, "name", "<material>")] = self.rgba(color)
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
        inertial = element.find("inertial")
        mass_element = inertial.find("mass") if inertial is not None else None
        mass = 0.0 if mass_element is None else self.number(mass_element, "value", f"link {name!r} <mass>")
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
        if "://" in filename:
            raise self.error(f"{where}: mesh {filename!r} must be a path relative to the URDF file")
        mesh_path = (self.path.parent / filename).resolve()
        if mesh_path not in self.meshes:
            try:
                text = mesh_path.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                raise self.error(f"{where}: cannot read mesh {filename!r}: {exc}") from None
            try:
                self.meshes[mesh_path] = read_prism_piece(text)
            except ValueError as exc:
                raise PuzzleFormatError(f"{mesh_path}: not a convex prism: {exc}") from None
        piece, height = self.meshes[mesh_path]
        match = MESH_NAME.match(mesh_path.name)
        group = (match["kind"], match["geometry"]) if match else None
        return self.guarded(lambda: ConvexPrism((piece,), height), where), group

    def color(self, element: ET.Element | None, where: str) -> tuple[float, float, float, float]:
        if element is None:
            return _DEFAULT_COLOR
        color = element.find("color")
        if color is not None:
            return self.rgba(color)
        name = element.get("name", "")
        if name not in self.materials:
            raise self.error(f"{where}: material {name!r} has no colour and is not defined at the top level")
        return self.materials[name]

    def rgba(self, element: ET.Element) -> tuple[float, float, float, float]:
        r, g, b, a = self.vector(element, "rgba", "<color>", 4)
        return (r, g, b, a)

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
        if joint_type is JointType.FIXED:
            return self.guarded(lambda: Joint(name, joint_type, parent, child, origin), where)
        axis_element = element.find("axis")
        axis = (1.0, 0.0, 0.0) if axis_element is None else self.vector(axis_element, "xyz", where, 3)
        limit = self.child(element, "limit", where)
        lower = self.number(limit, "lower", where, 0.0)
        upper = self.number(limit, "upper", where, 0.0)
        effort = self.number(limit, "effort", where)
        velocity = self.number(limit, "velocity", where)
        return self.guarded(
            lambda: Joint(name, joint_type, parent, child, origin, axis, lower, upper, effort, velocity),
            where,
        )

    # -- primitives --------------------------------------------------------
    def child(self, element: ET.Element, tag: str, where: str) -> ET.Element:
        found = element.find(tag)
        if found is None:
            raise self.error(f"{where}: missing <{tag}>")
        return found

    def attribute(self, element: ET.Element, name: str, where: str) -> str:
        value = element.get(name)
        if value is None:
            raise self.error(f"{where}: missing attribute {name!r}")
        return value

    def number(self, element: ET.Element, name: str, where: str, default: float | None = None) -> float:
        if default is not None and element.get(name) is None:
            return default
        text = self.attribute(element, name, where)
        try:
            return float(text)
        except ValueError:
            raise self.error(f"{where}: attribute {name}={text!r} is not a number") from None

    def vector(self, element: ET.Element, name: str, where: str, size: int) -> tuple[float, ...]:
        text = self.attribute(element, name, where)
        try:
            values = tuple(float(v) for v in text.split())
        except ValueError:
            raise self.error(f"{where}: attribute {name}={text!r} must be {size} numbers") from None
        if len(values) != size:
            raise self.error(f"{where}: attribute {name}={text!r} must be {size} numbers")
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
            raise self.error(f"{where}: {exc}") from None


# -- puzzle.json -------------------------------------------------------------
def _read_metadata(path: Path) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise PuzzleFormatError(f"{path}: puzzle.json is missing") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PuzzleFormatError(f"{path}: cannot read: {exc}") from None
    try:
        metadata = json.loads(text)
    except json.JSONDecodeError as exc:
        raise PuzzleFormatError(f"{path}: malformed JSON: {exc}") from None
    if not isinstance(metadata, dict):
        raise PuzzleFormatError(f"{path}: must hold a JSON object, got {type(metadata).__name__}")
    version = metadata.get("format_version")
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= FORMAT_VERSION:
        raise PuzzleFormatError(f"{path}: format_version {version!r} is not supported; "
                                f"valid: 1 to {FORMAT_VERSION}")
    return metadata


def _field(mapping: Mapping[str, Any], key: str, kind: type, source: Path | str, where: str = "") -> Any:
    label = f"{where}.{key}" if where else key
    if key not in mapping:
        raise PuzzleFormatError(f"{source}: missing key {label!r}")
    value = mapping[key]
    if not isinstance(value, kind) or (kind is not bool and isinstance(value, bool)):
        raise PuzzleFormatError(f"{source}: {label} must be a {kind.__name__}, got {value!r}")
    return value


def _string_list(mapping: Mapping[str, Any], key: str, source: Path) -> list[str]:
    values = _field(mapping, key, list, source)
    if not all(isinstance(v, str) for v in values):
        raise PuzzleFormatError(f"{source}: {key} must be a list of strings, got {values!r}")
    return values


def _number(value: Any, label: str, source: Path) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise PuzzleFormatError(f"{source}: {label} must be a number, got {value!r}")
    return float(value)


def _state(value: Any, size: int, label: str, source: Path) -> tuple[float, ...]:
    if not isinstance(value, list) or len(value) != size:
        raise PuzzleFormatError(f"{source}: {label} must be a list of {size} numbers (one per joint), "
                                f"got {value!r}")
    return tuple(_number(v, f"{label}[{i}]", source) for i, v in enumerate(value))


def _goal(metadata: Mapping[str, Any], joint_order: Sequence[str], source: Path) -> Goal:
    goal = _field(metadata, "goal", dict, source)
    target = _field(goal, "target", str, source, "goal")
    values = _field(goal, "values", dict, source, "goal")
    for joint_name in values:
        if joint_name not in joint_order:
            raise PuzzleFormatError(f"{source}: goal joint {joint_name!r} is not in joint_order "
                                    f"{list(joint_order)}")
    tolerance = _number(goal.get("tolerance"), "goal.tolerance", source)
    return Goal(target, {k: _number(v, f"goal.values.{k}", source) for k, v in values.items()}, tolerance)


def _enum(kind, value: str, source: Path | str, label: str):
    try:
        return kind(value)
    except ValueError:
        valid = [member.value for member in kind]
        raise PuzzleFormatError(f"{source}: {label} {value!r} is not valid; valid: {valid}") from None
