"""URDF text of a :class:`~phyrogen_core.chain.KinematicChain`.

Boxes and cylinders are URDF primitives; a :class:`ConvexPrism` becomes one
OBJ mesh per convex piece, referenced by a path relative to the URDF file,
so that a puzzle folder can be moved or shared. Links are written in the
chain's own order and joints sorted by name, and every number through
:func:`~phyrogen_core.export.formatting.number`: equal chains give
byte-identical files, and the file reads back to the same chain.

Mesh files are named ``<link>_<visual|collision>_<geometry index>_<piece
index>.obj``; the reader groups the pieces of one prism by that name.
"""

from __future__ import annotations

import re

import numpy as np

from ..chain import (
    BLACK,
    GOAL_GREEN,
    GRAY,
    GREEN,
    RED,
    YELLOW,
    Geometry,
    Joint,
    KinematicChain,
    Link,
    pose_matrix,
)
from ..geometry import Box, ConvexPrism, Cylinder, Pose
from .formatting import attribute, number, numbers
from .obj import prism_piece_obj

MESH_NAME = re.compile(r"^(?P<link>.+)_(?P<kind>visual|collision)_(?P<geometry>\d+)_(?P<piece>\d+)\.obj$")
"""How mesh files are named; the reader relies on it to regroup prism pieces."""

_SAFE_NAME = re.compile(r"^[A-Za-z0-9_.\-]+$")

_COLOR_NAMES = {
    GREEN: "green",
    RED: "red",
    GRAY: "gray",
    BLACK: "black",
    YELLOW: "yellow",
    GOAL_GREEN: "goal_green",
}

# A link without collision shapes gets the inertia of a cube this size.
_DEFAULT_INERTIA_EXTENT = 0.1


def chain_to_urdf(chain: KinematicChain, mesh_dir: str = "../meshes") -> tuple[str, dict[str, str]]:
    """The URDF text of ``chain`` and the mesh files it refers to.

    Returns ``(urdf_text, meshes)`` where ``meshes`` maps a file name (to be
    placed in ``mesh_dir``, which is relative to the URDF file) to its OBJ
    text; it is empty when the chain has no prisms.
    """
    meshes: dict[str, str] = {}
    lines = ['<?xml version="1.0"?>', f"<robot name={attribute(chain.name)}>"]
    inertials: dict[tuple, list[str]] = {}  # a link's inertial lines by its collisions and mass
    for link in chain.links:
        lines += _link_lines(link, mesh_dir.rstrip("/"), meshes, inertials)
    for joint in sorted(chain.joints, key=lambda j: j.name):
        lines += _joint_lines(joint)
    lines.append("</robot>")
    return "\n".join(lines) + "\n", dict(sorted(meshes.items()))


def color_name(rgba: tuple[float, float, float, float]) -> str:
    """A material name for ``rgba``: the palette's name, else one spelled from the numbers."""
    known = _COLOR_NAMES.get(tuple(rgba))
    return known if known is not None else "rgba_" + "_".join(number(c) for c in rgba)


def _link_lines(link: Link, mesh_dir: str, meshes: dict[str, str], inertials: dict[tuple, list[str]]) -> list[str]:
    lines = [f"  <link name={attribute(link.name)}>"]
    # Links of equal collisions and mass (Rooms' walls: 36 links, 7 kinds) have the same inertial text:
    # equal numbers write the same (formatting.number writes floats, -0.0 as 0).
    key = (link.collisions, link.mass)
    inertial = inertials.get(key)
    if inertial is None:
        inertial = inertials[key] = _inertial_lines(link)
    lines += inertial
    for index, geometry in enumerate(link.visuals):
        lines += _geometry_lines(link.name, "visual", index, geometry, mesh_dir, meshes)
    for index, geometry in enumerate(link.collisions):
        lines += _geometry_lines(link.name, "collision", index, geometry, mesh_dir, meshes)
    lines.append("  </link>")
    return lines


def link_inertia(link: Link) -> tuple[np.ndarray, tuple[float, float, float]]:
    """The link's centre of mass and principal moments (ixx, iyy, izz), link frame: a solid box
    of the link's mass filling its collision bounds (a 0.1 m cube at the origin without collisions)."""
    if link.mass < 0:
        raise ValueError(f"link {link.name!r}: mass must be zero or positive, got {link.mass!r}")
    if link.collisions:
        low, high = collision_bounds(link)
        centre, extent = (low + high) / 2, high - low
    else:
        centre, extent = np.zeros(3), np.full(3, _DEFAULT_INERTIA_EXTENT)
    sx, sy, sz = (float(e) ** 2 for e in extent)
    m = link.mass / 12.0
    return centre, (m * (sy + sz), m * (sx + sz), m * (sx + sy))


def _inertial_lines(link: Link) -> list[str]:
    centre, (ixx, iyy, izz) = link_inertia(link)
    return [
        "    <inertial>",
        f'      <origin xyz="{numbers(centre)}" rpy="0 0 0"/>',
        f'      <mass value="{number(link.mass)}"/>',
        f'      <inertia ixx="{number(ixx)}" ixy="0" ixz="0" iyy="{number(iyy)}" iyz="0" izz="{number(izz)}"/>',
        "    </inertial>",
    ]


def collision_bounds(link: Link) -> tuple[np.ndarray, np.ndarray]:
    """The axis-aligned bounding box (low, high corners) of a link's collision shapes, link frame."""
    if not link.collisions:
        raise ValueError(f"link {link.name!r} has no collision shapes, so no collision bounds")
    lows, highs = [], []
    for geometry in link.collisions:
        low, high = _shape_bounds(geometry)
        lows.append(low)
        highs.append(high)
    return np.min(lows, axis=0), np.max(highs, axis=0)


def _shape_bounds(geometry: Geometry) -> tuple[np.ndarray, np.ndarray]:
    m = pose_matrix(geometry.origin)
    rotation, centre = m[:3, :3], m[:3, 3]
    shape = geometry.shape
    if isinstance(shape, Box):
        half = np.abs(rotation) @ (np.asarray(shape.size, dtype=float) / 2)
        return centre - half, centre + half
    if isinstance(shape, Cylinder):
        axis = rotation[:, 2]
        half = shape.radius * np.sqrt(np.clip(1.0 - axis**2, 0.0, 1.0)) + shape.length / 2 * np.abs(axis)
        return centre - half, centre + half
    if isinstance(shape, ConvexPrism):
        h = shape.height / 2
        points = np.array([(x, y, z) for piece in shape.pieces for x, y in piece for z in (-h, h)])
        world = points @ rotation.T + centre
        return world.min(axis=0), world.max(axis=0)
    raise TypeError(f"unsupported shape {type(shape).__name__}; valid: Box, Cylinder, ConvexPrism")


def _origin_line(pose: Pose, indent: str) -> str:
    return f'{indent}<origin xyz="{numbers(pose.xyz)}" rpy="{numbers(pose.rpy)}"/>'


def _geometry_lines(link_name: str, kind: str, index: int, geometry: Geometry, mesh_dir: str,
                    meshes: dict[str, str]) -> list[str]:
    shape = geometry.shape
    if isinstance(shape, Box):
        shapes = [f'<box size="{numbers(shape.size)}"/>']
    elif isinstance(shape, Cylinder):
        shapes = [f'<cylinder radius="{number(shape.radius)}" length="{number(shape.length)}"/>']
    elif isinstance(shape, ConvexPrism):
        if not _SAFE_NAME.match(link_name):
            raise ValueError(f"link name {link_name!r} cannot name a mesh file; "
                             "valid names use letters, digits, '_', '.', '-'")
        shapes = []
        for piece_index, piece in enumerate(shape.pieces):
            file_name = f"{link_name}_{kind}_{index}_{piece_index}.obj"
            meshes[file_name] = prism_piece_obj(piece, shape.height, file_name[:-4])
            shapes.append(f"<mesh filename={attribute(mesh_dir + '/' + file_name)}/>")
    else:
        raise TypeError(f"link {link_name!r}: unsupported shape {type(shape).__name__}; "
                        "valid: Box, Cylinder, ConvexPrism")
    name = f" name={attribute(geometry.name)}" if geometry.name else ""
    lines: list[str] = []
    for shape_line in shapes:
        lines += [f"    <{kind}{name}>", _origin_line(geometry.origin, "      "),
                  f"      <geometry>{shape_line}</geometry>"]
        if kind == "visual":
            lines.append(f"      <material name={attribute(color_name(geometry.color))}>"
                         f'<color rgba="{numbers(geometry.color)}"/></material>')
        lines.append(f"    </{kind}>")
    return lines


def _joint_lines(joint: Joint) -> list[str]:
    lines = [
        f"  <joint name={attribute(joint.name)} type={attribute(joint.type.value)}>",
        f"    <parent link={attribute(joint.parent)}/>",
        f"    <child link={attribute(joint.child)}/>",
        _origin_line(joint.origin, "    "),
    ]
    # A fixed joint has no axis or limits in URDF; the reader restores Joint's defaults.
    if joint.is_active:
        lines.append(f'    <axis xyz="{numbers(joint.axis)}"/>')
        lines.append(f'    <limit lower="{number(joint.lower)}" upper="{number(joint.upper)}" '
                     f'effort="{number(joint.effort)}" velocity="{number(joint.velocity)}"/>')
    lines.append("  </joint>")
    return lines
