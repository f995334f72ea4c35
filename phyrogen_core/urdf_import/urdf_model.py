"""A URDF file as plain data: links with their shapes, joints, colours; meshes found and read.

Lenient where other tools' URDFs differ from ours (materials by name, mesh
scales, ``file://`` and ``package://`` paths from another machine, binary
STL), strict about what would make a wrong puzzle (numbers that are not
finite, a joint without limits, a tree that is no tree). Every problem is an
:class:`UrdfImportError` naming the file and the element.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..chain import GRAY, RGBA, pose_matrix
from ..errors import PuzzleFormatError
from ..export.reader import MAX_MAGNITUDE
from ..folder_reads import MAX_FILE_BYTES, read_folder_file
from ..geometry import Pose
from ..mesh_files import MeshFormatError, read_triangles
from ..xml_fields import XmlFields, parse_urdf

MESH_SEARCH_LIMIT = 10_000
"""Most folder entries looked at when searching a moved mesh by its name."""


class UrdfImportError(ValueError):
    """A URDF that cannot be imported as a puzzle; the message names the file and says what is wrong."""


@dataclass(frozen=True)
class ShapeSpec:
    """One ``<visual>`` or ``<collision>`` of a link: a primitive, or mesh triangles (scaled)."""

    kind: str  # box, cylinder, sphere, mesh
    origin: np.ndarray  # 4x4, in the link frame
    size: tuple[float, ...] = ()  # box: x y z; cylinder: radius, length; sphere: radius
    triangles: np.ndarray | None = None
    mesh: str = ""  # the mesh file as found (for messages)
    color: RGBA = GRAY
    name: str = ""


@dataclass(frozen=True)
class LinkSpec:
    name: str
    visuals: tuple[ShapeSpec, ...] = ()
    collisions: tuple[ShapeSpec, ...] = ()

    @property
    def has_geometry(self) -> bool:
        return bool(self.visuals or self.collisions)


@dataclass(frozen=True)
class JointSpec:
    name: str
    type: str  # fixed, prismatic, revolute (continuous is read as revolute over one turn)
    parent: str
    child: str
    origin: np.ndarray  # 4x4
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    lower: float = 0.0
    upper: float = 0.0


@dataclass
class UrdfModel:
    """The links and joints of a URDF, and what reading it had to tell (``notes``)."""

    path: Path
    name: str
    links: dict[str, LinkSpec]
    joints: dict[str, JointSpec]  # by name, in file order
    root: str
    notes: list[str] = field(default_factory=list)

    def children(self, link: str) -> list[JointSpec]:
        return [j for j in self.joints.values() if j.parent == link]

    def parent_joint(self, link: str) -> JointSpec | None:
        return next((j for j in self.joints.values() if j.child == link), None)


def read_urdf_model(path: str | Path) -> UrdfModel:
    """Read the URDF file ``path`` and every mesh it names."""
    path = Path(path)
    if not path.is_file():
        what = "is a folder, not a URDF file" if path.is_dir() else "no such URDF file"
        raise UrdfImportError(f"{path}: {what}")
    try:
        raw = read_folder_file(path, Path(os.path.realpath(path)).parent, f"{path}")  # size and kind checked
    except PuzzleFormatError as exc:
        raise UrdfImportError(str(exc)) from None
    return _Reader(path).model(parse_urdf(raw, str(path), UrdfImportError))


class _Reader(XmlFields):
    def __init__(self, path: Path) -> None:
        self.path = path
        self.materials: dict[str, RGBA] = {}
        self.meshes: dict[str, tuple[np.ndarray, str]] = {}
        self.notes: list[str] = []
        self.moved: dict[tuple[str, str], list[str]] = {}  # (folder written, folder used) -> mesh names

    def error(self, message: str) -> UrdfImportError:
        return UrdfImportError(f"{self.path}: {message}")

    def note(self, message: str) -> None:
        if message not in self.notes:
            self.notes.append(message)

    def model(self, robot: ET.Element) -> UrdfModel:
        for material in robot.findall("material"):
            color = material.find("color")
            if color is not None:
                self.materials[material.get("name", "")] = self.rgba(color, "top-level <material>")
        links: dict[str, LinkSpec] = {}
        for element in robot.findall("link"):
            link = self.link(element)
            if link.name in links:
                raise self.error(f"two links are named {link.name!r}")
            links[link.name] = link
        joints: dict[str, JointSpec] = {}
        parent_of: dict[str, str] = {}
        for element in robot.findall("joint"):
            joint = self.joint(element)
            if joint.name in joints:
                raise self.error(f"two joints are named {joint.name!r}")
            for end in (joint.parent, joint.child):
                if end not in links:
                    raise self.error(f"joint {joint.name!r} names the link {end!r}, which the file does not define")
            if joint.child in parent_of:
                raise self.error(f"link {joint.child!r} is the child of two joints: {parent_of[joint.child]!r} "
                                 f"and {joint.name!r}")
            parent_of[joint.child] = joint.name
            joints[joint.name] = joint
        if not links:
            raise self.error("the URDF defines no link")
        roots = [name for name in links if name not in parent_of]
        if len(roots) != 1:
            raise self.error(f"a URDF needs exactly one root link (no joint's child), found {roots or 'none'} "
                             "(a joint loop?)")
        for (written, used), names in self.moved.items():
            self.note(f"{len(names)} mesh{'es' if len(names) > 1 else ''} named by a path that does not exist here "
                      f"({written!r}) found in {used}: {', '.join(names)}")
        model = UrdfModel(self.path, robot.get("name", "") or self.path.stem, links, joints, roots[0], self.notes)
        seen, stack = {roots[0]}, [roots[0]]
        while stack:
            for joint in model.children(stack.pop()):
                seen.add(joint.child)
                stack.append(joint.child)
        if len(seen) != len(links):
            raise self.error(f"links not connected to the root {roots[0]!r}: {sorted(set(links) - seen)[:5]}")
        return model

    # -- links -------------------------------------------------------------
    def link(self, element: ET.Element) -> LinkSpec:
        name = self.attribute(element, "name", "<link>")
        visuals = tuple(self.shape(e, f"link {name!r} <visual> {i}", True)
                        for i, e in enumerate(element.findall("visual")))
        collisions = tuple(self.shape(e, f"link {name!r} <collision> {i}", False)
                           for i, e in enumerate(element.findall("collision")))
        return LinkSpec(name, tuple(v for v in visuals if v is not None), tuple(c for c in collisions if c is not None))

    def shape(self, element: ET.Element, where: str, visual: bool) -> ShapeSpec | None:
        origin = self.pose(element.find("origin"), where)
        geometry = element.find("geometry")
        if geometry is None or len(geometry) != 1:
            raise self.error(f"{where}: <geometry> must hold exactly one shape")
        (shape,) = geometry
        color = self.color(element.find("material"), where) if visual else GRAY
        name = element.get("name", "")
        if shape.tag == "box":
            size = self.numbers(shape, "size", where, 3, positive=True)
            return ShapeSpec("box", origin, size, color=color, name=name)
        if shape.tag == "cylinder":
            size = (self.numbers(shape, "radius", where, 1, positive=True)[0],
                    self.numbers(shape, "length", where, 1, positive=True)[0])
            return ShapeSpec("cylinder", origin, size, color=color, name=name)
        if shape.tag == "sphere":
            return ShapeSpec("sphere", origin, self.numbers(shape, "radius", where, 1, positive=True), color=color,
                             name=name)
        if shape.tag == "mesh":
            triangles, found = self.mesh(shape, where)
            return ShapeSpec("mesh", origin, (), triangles, found, color, name)
        raise self.error(f"{where}: unsupported shape <{shape.tag}>; valid: box, cylinder, sphere, mesh")

    def mesh(self, element: ET.Element, where: str) -> tuple[np.ndarray, str]:
        filename = self.attribute(element, "filename", f"{where} <mesh>")
        scale = np.array(self.numbers(element, "scale", where, 3) if element.get("scale") is not None
                         else (1.0, 1.0, 1.0))
        if np.any(scale == 0):
            raise self.error(f"{where}: mesh scale {element.get('scale')!r} has a zero factor; every factor must be "
                             "non-zero")
        found = self.find_mesh(filename, where)
        key = str(found)
        if key not in self.meshes:
            label = f"{self.path}: {where}: mesh {found}"
            try:
                raw = read_folder_file(found, Path(os.path.realpath(found)).parent, label, MAX_FILE_BYTES)
                triangles = read_triangles(raw, label, found.suffix, MAX_MAGNITUDE)
            except (PuzzleFormatError, MeshFormatError) as exc:
                raise UrdfImportError(str(exc)) from None
            self.meshes[key] = (triangles, self.shown(found))
        triangles, shown = self.meshes[key]
        return triangles * scale, shown

    def find_mesh(self, filename: str, where: str) -> Path:
        """The mesh file ``filename`` names: as written (relative to the URDF's folder), else the
        file of the longest tail of that path under the URDF's folder or its parent (an absolute
        path or ``package://`` URI from another machine), else the one file of that name under the
        parent's ``meshes/`` or the URDF's folder. Each fallback is noted."""
        text = filename
        for prefix in ("file://", "package://", "model://"):
            if text.startswith(prefix):
                text = text[len(prefix):]
                break
        if not text or "\0" in text:
            raise self.error(f"{where}: mesh filename {filename!r} is empty or malformed")
        here = self.path.parent
        relative = not filename.startswith(("file://", "package://", "model://")) and not os.path.isabs(text)
        if relative and (here / text).is_file():
            return here / text
        if not relative and filename.startswith("file://") and Path(text).is_file():
            return Path(text)
        parts = [p for p in Path(text).parts if p not in ("/", "\\", "..", ".")]
        for base in (here, here.parent):
            for k in range(len(parts)):
                candidate = base.joinpath(*parts[k:])
                if candidate.is_file():
                    return self.fallen_back(filename, candidate)
        matches = self.search(parts[-1] if parts else "", [here.parent / "meshes", here])
        if len(matches) == 1:
            return self.fallen_back(filename, matches[0])
        if len(matches) > 1:
            raise self.error(f"{where}: mesh {filename!r} is missing, and several files are named "
                             f"{parts[-1]!r}: {[self.shown(m) for m in matches[:4]]}; fix the path in the URDF")
        raise self.error(f"{where}: mesh {filename!r} is missing, and no file of that name lies under "
                         f"{here.parent / 'meshes'} or {here}")

    def search(self, name: str, folders: list[Path]) -> list[Path]:
        found: set[Path] = set()
        looked = 0
        for folder in folders:
            if not name or not folder.is_dir():
                continue
            for directory, subfolders, files in os.walk(folder):
                subfolders.sort()
                looked += len(files) + len(subfolders)
                if name in files:
                    found.add(Path(os.path.realpath(Path(directory) / name)))
                if looked > MESH_SEARCH_LIMIT:
                    break
        return sorted(found)

    def fallen_back(self, filename: str, found: Path) -> Path:
        written = filename.rsplit("/", 1)[0] + "/" if "/" in filename else filename
        names = self.moved.setdefault((written, self.shown(found.parent) + "/"), [])
        if found.name not in names:
            names.append(found.name)
        return found

    def shown(self, path: Path) -> str:
        try:
            return os.path.relpath(path, self.path.parent)
        except ValueError:
            return str(path)

    def color(self, element: ET.Element | None, where: str) -> RGBA:
        if element is None:
            return GRAY
        color = element.find("color")
        if color is not None:
            return self.rgba(color, f"{where} <material>")
        return self.materials.get(element.get("name", ""), GRAY)

    def rgba(self, element: ET.Element, where: str) -> RGBA:
        r, g, b, a = self.numbers(element, "rgba", where, 4)
        return tuple(min(1.0, max(0.0, c)) for c in (r, g, b, a))  # type: ignore[return-value]

    # -- joints ------------------------------------------------------------
    def joint(self, element: ET.Element) -> JointSpec:
        name = self.attribute(element, "name", "<joint>")
        where = f"joint {name!r}"
        kind = self.attribute(element, "type", where)
        parent, child = (self.attribute(self.child(element, tag, where), "link", f"{where} <{tag}>")
                         for tag in ("parent", "child"))
        origin = self.pose(element.find("origin"), where)
        if kind == "fixed":
            return JointSpec(name, kind, parent, child, origin)
        if kind not in ("prismatic", "revolute", "continuous"):
            raise self.error(f"{where}: joint type {kind!r} cannot be imported; valid: fixed, prismatic, revolute, "
                             "continuous")
        axis_element = element.find("axis")
        axis = np.array(self.numbers(axis_element, "xyz", f"{where} <axis>", 3)
                        if axis_element is not None and axis_element.get("xyz") is not None else (1.0, 0.0, 0.0))
        norm = float(np.linalg.norm(axis))
        if not norm > 1e-9:
            raise self.error(f"{where}: <axis> {axis_element.get('xyz') if axis_element is not None else ''!r} "
                             "is the zero vector")
        unit = tuple(float(a) / norm for a in axis)
        if element.find("mimic") is not None:
            raise self.error(f"{where}: <mimic> joints cannot be imported (a puzzle's joints move independently)")
        if kind == "continuous":
            self.note(f"continuous joint {name!r} is imported as a revolute joint over one turn, [-pi, pi]")
            return JointSpec(name, "revolute", parent, child, origin, unit, -math.pi, math.pi)  # type: ignore[arg-type]
        limit = element.find("limit")
        if limit is None or limit.get("lower") is None or limit.get("upper") is None:
            raise self.error(f"{where}: a {kind} joint needs <limit lower=... upper=...>")
        lower = self.numbers(limit, "lower", f"{where} <limit>", 1)[0]
        upper = self.numbers(limit, "upper", f"{where} <limit>", 1)[0]
        if not lower <= upper:
            raise self.error(f"{where} <limit>: lower={lower!r} exceeds upper={upper!r}")
        return JointSpec(name, kind, parent, child, origin, unit, lower, upper)  # type: ignore[arg-type]

    # -- primitives --------------------------------------------------------
    def numbers(self, element: ET.Element, name: str, where: str, size: int,
                positive: bool = False) -> tuple[float, ...]:
        text = self.attribute(element, name, where)
        try:
            values = tuple(float(v) for v in text.split())
        except ValueError:
            values = ()
        if len(values) != size:
            raise self.error(f"{where}: {name}={text[:60]!r} must be {size} number{'s' if size > 1 else ''}")
        for value in values:
            if not -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE:  # also false for NaN
                raise self.error(f"{where}: {name}={text[:60]!r} must hold finite numbers within "
                                 f"+-{MAX_MAGNITUDE:g}")
            if positive and not value > 0:
                raise self.error(f"{where}: {name}={text[:60]!r} must be positive")
        return values

    def pose(self, element: ET.Element | None, where: str) -> np.ndarray:
        if element is None:
            return np.eye(4)
        xyz = self.numbers(element, "xyz", where, 3) if element.get("xyz") is not None else (0.0, 0.0, 0.0)
        rpy = self.numbers(element, "rpy", where, 3) if element.get("rpy") is not None else (0.0, 0.0, 0.0)
        return pose_matrix(Pose(xyz, rpy))  # type: ignore[arg-type]
