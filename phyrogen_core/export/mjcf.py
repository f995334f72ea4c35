"""MJCF (MuJoCo) text of a :class:`~phyrogen_core.chain.KinematicChain`, and its place in a puzzle folder.

The same chain as the URDF (:mod:`phyrogen_core.export.urdf`), in MuJoCo's own
format, so that a puzzle loads in MuJoCo without a URDF conversion:

- **Links** become nested ``<body>`` elements named after the links, under
  one body for the root (``base_link``); a fixed joint is a body nested
  without a joint, an active joint a ``<joint>`` of the same name inside its
  child body (``slide`` for prismatic, ``hinge`` for revolute) whose
  ``range`` is the URDF's ``lower upper`` (``limited="true"``). A joint's
  origin is its child body's ``pos`` and ``euler``; ``eulerseq="XYZ"``
  (rotations about the fixed axes x, then y, then z) is URDF's roll-pitch-yaw,
  so the numbers are the URDF's, digit for digit.
- **Geometry**: boxes and cylinders are MuJoCo primitives (half sizes); a
  :class:`ConvexPrism` is one ``<mesh>`` per convex piece with its vertices
  inline (the file needs no mesh files); MuJoCo collides with the convex hull
  of a mesh, which is exact for a convex piece. Visual geoms (class
  ``visual``, group 2) never collide; collision geoms (class ``collision``,
  group 3, hidden by MuJoCo's viewer by default) do. Every geom takes its
  geometry's colour through a material named as the URDF's.
- **The goal marker** (:attr:`Role.GOAL_MARKER`) is a body of ``<site>``
  elements: sites never collide. A prism, which no site can be, becomes a
  non-colliding visual geom.
- **Inertia** is the URDF's (:func:`~phyrogen_core.export.urdf.link_inertia`),
  written per body; ``inertiafromgeom="false"`` keeps MuJoCo from replacing it.

- **Dynamics** (:mod:`~phyrogen_core.export.mjcf_dynamics`, every number and its rule there): each
  active joint's ``damping`` and ``frictionloss``, a ``<position>`` servo per active joint (named
  as the joint), stiff contact parameters in the ``collision`` class, a floor plane, and, given the
  certificate, the keyframes ``start`` and ``goal`` (``qpos`` and ``ctrl``).

Which geoms may touch follows the collision model (:mod:`solver.collision.model`):
geoms of *different* objects, at least one of them moving. MuJoCo by default
drops contacts between a body and its parent body; objects mounted on other
objects would lose their contacts that way, so that filter is disabled and
the pairs of bodies of the same object (an object's links always touch, as
its hinge does) are excluded one by one instead. Bodies welded to the world
(the base and the static scenery) never collide with each other in MuJoCo,
as in our model.

Everything is written in a fixed order through
:func:`~phyrogen_core.export.formatting.number`: equal chains give
byte-identical files. A puzzle folder holds the file as
``mjcf/<name>.xml`` (:func:`write_mjcf`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..atomic_writes import OutputError, require_stage_folder
from ..chain import Geometry, JointType, KinematicChain, Link, Role
from ..errors import PuzzleFormatError
from ..folder_layout import name_problem
from ..folder_reads import read_folder_file
from ..geometry import Box, ConvexPrism, Cylinder, Pose
from ..stage_writes import owned_directory
from .formatting import attribute, number, numbers
from .mjcf_dynamics import DYNAMICS, JointDynamics, floor_height, joint_dynamics
from .urdf import color_name, link_inertia

MJCF_FOLDER = "mjcf"
"""The puzzle folder's entry holding the MJCF file: ``mjcf/<name>.xml``."""

_JOINT_TYPES = {JointType.PRISMATIC: "slide", JointType.REVOLUTE: "hinge"}
_FLOOR_MATERIAL = "floor"
_FLOOR_RGBA = (0.85, 0.85, 0.8, 1.0)


_HEAD = ('<?xml version="1.0"?>', '  <compiler angle="radian" eulerseq="XYZ" inertiafromgeom="false"/>')
"""The first and third lines of every MJCF file written here (the model's name between them): how
:func:`check_mjcf_target` knows a file as one of its own."""


def chain_to_mjcf(chain: KinematicChain, certificate: Sequence[Sequence[float]] | None = None) -> str:
    """The MJCF text of ``chain`` (see the module's docstring for what maps to what).

    With a ``certificate``, its first and last states are the keyframes ``start`` and ``goal``
    (joint values and servo targets) and the dynamics are taken at its start; without one (None or
    no states), there are no keyframes and the dynamics are taken at zero (clipped into the limits).

    Self-contained: prism pieces are inline meshes, so the text loads with
    ``mujoco.MjModel.from_xml_string`` as well as from a file. Element names
    are unique because link names are: a body is its link's name, a geom
    ``<link>_<visual|collision>_<index>`` (``_<piece>`` added for a prism
    piece, which also names its mesh), a site ``<link>_visual_<index>``.
    Raises TypeError on an unknown shape, ValueError on a number that is not
    finite.
    """
    given = certificate is not None and len(certificate) > 0
    start = _state(chain, certificate[0], "start") if given else None
    goal = _state(chain, certificate[-1], "goal") if given else None
    writer = _Writer(chain, joint_dynamics(chain, start, DYNAMICS))
    body = writer.body_lines(chain.root, 2)
    d = DYNAMICS
    lines = [_HEAD[0], f"<mujoco model={attribute(chain.name)}>", _HEAD[1],
             f'  <option timestep="{number(d.timestep)}" integrator="implicitfast" cone="elliptic" '
             f'solver="{d.solver}" iterations="{d.solver_iterations}" tolerance="{number(d.solver_tolerance)}">',
             # Contacts between a body and its parent body are kept: see the module's docstring.
             '    <flag filterparent="disable"/>',
             "  </option>",
             "  <default>",
             '    <default class="visual">',
             '      <geom contype="0" conaffinity="0" group="2"/>',
             "    </default>",
             '    <default class="collision">',
             # Bits: puzzle parts collide with each other (2 & 3) and with a user's default geoms
             # (1 & 3), never with the floor (4 & 3, 2 & 1 are 0); see mjcf_dynamics.
             f'      <geom contype="2" conaffinity="3" group="3" condim="3" friction="{numbers(d.contact_friction)}" '
             f'solref="{numbers(d.contact_solref)}" solimp="{numbers(d.contact_solimp)}"/>',
             "    </default>",
             "  </default>"]
    writer.materials[_FLOOR_MATERIAL] = _FLOOR_RGBA
    assets = [f"    <material name={attribute(name)} rgba={attribute(numbers(rgba))}/>"
              for name, rgba in sorted(writer.materials.items())]
    assets += writer.meshes
    lines += ["  <asset>", *assets, "  </asset>"]
    lines += ["  <worldbody>",
              f'    <geom name="floor" type="plane" size="0 0 1" pos="0 0 {number(floor_height(chain, start))}" '
              f'contype="4" conaffinity="1" group="1" material="{_FLOOR_MATERIAL}"/>',
              *body, "  </worldbody>"]
    excludes = writer.exclude_lines()
    if excludes:
        lines += ["  <contact>", *excludes, "  </contact>"]
    if writer.joints:
        lines += ["  <actuator>", *writer.actuator_lines(), "  </actuator>"]
    if start is not None and goal is not None and writer.joints:
        lines += ["  <keyframe>", writer.key_line("start", start), writer.key_line("goal", goal), "  </keyframe>"]
    lines.append("</mujoco>")
    return "\n".join(lines) + "\n"


def _state(chain: KinematicChain, state: Sequence[float], which: str) -> tuple[float, ...]:
    values = tuple(float(v) for v in state)
    if len(values) != len(chain.joint_order) or not all(np.isfinite(values)):
        raise ValueError(f"the certificate's {which} state must be {len(chain.joint_order)} finite joint values, "
                         f"got {state!r}")
    return values


def mjcf_path(folder: str | Path, name: str) -> Path:
    """Where :func:`write_mjcf` puts puzzle ``name``'s MJCF file in its folder: ``mjcf/<name>.xml``."""
    return Path(folder) / MJCF_FOLDER / f"{name}.xml"


def write_mjcf(folder: str | Path, chain: KinematicChain, name: str,
               certificate: Sequence[Sequence[float]] | None = None) -> Path:
    """Write ``chain``'s MJCF (keyframes from ``certificate``: :func:`chain_to_mjcf`) into the puzzle
    folder ``folder`` as ``mjcf/<name>.xml``; return its path.

    The ``mjcf/`` entry is swapped in atomically
    (:func:`~phyrogen_core.folder.owned_directory`): a reader finds the old
    file, the new one or, for the moment of the swap, none, never a part, and
    an interrupted run leaves the old one. Only ``<name>.xml`` is replaced, and
    only when this function wrote it (:func:`check_mjcf_target`); a user's other
    files in ``mjcf/`` and every other entry of the folder are left as they were.
    The text is made before anything is written, so an unwritable chain writes nothing.
    """
    problem = name_problem(name)
    if problem is not None:
        raise ValueError(f"{name!r} cannot name an MJCF file: it {problem}")
    data = chain_to_mjcf(chain, certificate).encode("utf-8")
    check_mjcf_target(folder, name)
    with owned_directory(Path(folder) / MJCF_FOLDER, f"{name}.xml".__eq__) as temporary:
        (temporary / f"{name}.xml").write_bytes(data)
    return mjcf_path(folder, name)


def check_mjcf_target(folder: str | Path, name: str) -> None:
    """Whether :func:`write_mjcf` may write puzzle ``name``'s file into the puzzle folder ``folder``,
    checked before any work: ``mjcf/`` a real folder inside it (not a link), and an existing
    ``mjcf/<name>.xml`` a file this module wrote (it opens as every file of :func:`chain_to_mjcf`
    does), not a user's scene of that name. Raises :class:`~phyrogen_core.folder.OutputError`."""
    target = mjcf_path(folder, name)
    require_stage_folder(target.parent, "MJCF folder", root=folder)
    if not os.path.lexists(target):
        return
    try:
        head = read_folder_file(target, folder).split(b"\n", 3)[:3]
    except PuzzleFormatError as exc:
        raise OutputError(f"{exc}; phyrogen export writes only files of its own there") from None
    if len(head) < 3 or head[0] != _HEAD[0].encode() or not head[1].startswith(b"<mujoco model=") \
            or head[2] != _HEAD[1].encode():
        raise OutputError(f"{target} was not written by phyrogen export (it does not begin as its MJCF files "
                          "do); move it or rename it, and the export writes its own file there")


def object_of_link(link: Link) -> str:
    """The puzzle object a link belongs to: its ``object_name``, else its own name (the collision
    model's rule; the base and a static link without an object are objects of their own)."""
    return link.object_name or link.name


class _Writer:
    """Builds the body tree; collects the materials and meshes it uses on the way."""

    def __init__(self, chain: KinematicChain, dynamics: dict[str, JointDynamics] | None = None):
        self.chain = chain
        self.dynamics = joint_dynamics(chain, None, DYNAMICS) if dynamics is None else dynamics
        self.joints: list[str] = []  # active joints in the file's order: MuJoCo's qpos and ctrl order
        self.materials: dict[str, tuple[float, float, float, float]] = {}
        self.meshes: list[str] = []
        order = {link.name: i for i, link in enumerate(chain.links)}
        self._children: dict[str, list[str]] = {}
        for joint in chain.joints:
            self._children.setdefault(joint.parent, []).append(joint.child)
        for children in self._children.values():
            children.sort(key=order.__getitem__)  # the chain's (and the URDF's) link order

    def body_lines(self, link_name: str, depth: int) -> list[str]:
        chain = self.chain
        link = chain.link(link_name)
        indent = "  " * depth
        joint = chain.parent_joint(link_name)
        frame = "" if joint is None else _frame_attributes(joint.origin)
        lines = [f"{indent}<body name={attribute(link.name)}{frame}>"]
        inner = indent + "  "
        lines.append(_inertial_line(link, inner))
        if joint is not None and joint.is_active:
            self.joints.append(joint.name)
            dynamics = self.dynamics[joint.name]
            lines.append(f"{inner}<joint name={attribute(joint.name)} type={attribute(_JOINT_TYPES[joint.type])} "
                         f'axis="{numbers(joint.axis)}" range="{number(joint.lower)} {number(joint.upper)}" '
                         f'limited="true" damping="{number(dynamics.damping)}" '
                         f'frictionloss="{number(dynamics.frictionloss)}"/>')
        if link.role is Role.GOAL_MARKER:
            # The marker shows the goal and collides with nothing (the collision model skips it too):
            # its visuals are sites, and collision shapes it might have are not written.
            for index, geometry in enumerate(link.visuals):
                lines += self._site_lines(link.name, index, geometry, inner)
        else:
            for index, geometry in enumerate(link.visuals):
                lines += self._geom_lines(link.name, "visual", index, geometry, inner)
            for index, geometry in enumerate(link.collisions):
                lines += self._geom_lines(link.name, "collision", index, geometry, inner)
        for child in self._children.get(link_name, []):
            lines += self.body_lines(child, depth + 1)
        lines.append(f"{indent}</body>")
        return lines

    def actuator_lines(self) -> list[str]:
        """A position servo per active joint, named as its joint (see mjcf_dynamics)."""
        lines = []
        for name in self.joints:
            joint, dynamics = self.chain.joint(name), self.dynamics[name]
            lines.append(f"    <position name={attribute(name)} joint={attribute(name)} kp=\"{number(dynamics.kp)}\" "
                         f'kv="{number(dynamics.kv)}" ctrlrange="{number(joint.lower)} {number(joint.upper)}" '
                         f'ctrllimited="true" forcerange="{number(-dynamics.force_limit)} '
                         f'{number(dynamics.force_limit)}" forcelimited="true"/>')
        return lines

    def key_line(self, name: str, state: Sequence[float]) -> str:
        """A keyframe holding ``state`` (in the chain's joint order) and its servos aimed at it."""
        values = self.chain.state_dict(state)
        ordered = numbers(values[joint] for joint in self.joints)
        return f'    <key name="{name}" qpos="{ordered}" ctrl="{ordered}"/>'

    def exclude_lines(self) -> list[str]:
        """``<exclude>`` for every pair of bodies of one object that both have collision geoms."""
        links = [link for link in self.chain.links if link.collisions and link.role is not Role.GOAL_MARKER]
        # Grouped by object first: the pairs of all links were quadratic in the links (30,000 static
        # boxes, each its own object, took minutes for no line). Same lines, same order as before.
        later: dict[str, list[Link]] = {}
        for link in reversed(links):
            later.setdefault(object_of_link(link), []).append(link)
        lines = []
        for a in links:
            group = later[object_of_link(a)]
            group.pop()  # ``a`` itself; the rest of its object's links follow it in chain order
            lines += [f"    <exclude body1={attribute(a.name)} body2={attribute(b.name)}/>" for b in reversed(group)]
        return lines

    def _material(self, rgba: tuple[float, float, float, float]) -> str:
        name = color_name(rgba)
        self.materials[name] = tuple(float(c) for c in rgba)  # type: ignore[assignment]
        return name

    def _geom_lines(self, link_name: str, kind: str, index: int, geometry: Geometry, indent: str) -> list[str]:
        shape = geometry.shape
        material = self._material(geometry.color)
        frame = _frame_attributes(geometry.origin)
        stem = f"{link_name}_{kind}_{index}"
        if isinstance(shape, ConvexPrism):
            lines = []
            for piece_index, piece in enumerate(shape.pieces):
                name = f"{stem}_{piece_index}"
                half = shape.height / 2
                vertices = " ".join(f"{number(x)} {number(y)} {number(z)}" for z in (-half, half) for x, y in piece)
                self.meshes.append(f"    <mesh name={attribute(name)} vertex={attribute(vertices)}/>")
                lines.append(f"{indent}<geom name={attribute(name)} class={attribute(kind)} "
                             f"type=\"mesh\" mesh={attribute(name)}{frame} material={attribute(material)}/>")
            return lines
        return [f"{indent}<geom name={attribute(stem)} class={attribute(kind)} {_primitive(link_name, shape)}{frame} "
                f"material={attribute(material)}/>"]

    def _site_lines(self, link_name: str, index: int, geometry: Geometry, indent: str) -> list[str]:
        if isinstance(geometry.shape, ConvexPrism):  # a site cannot be a mesh: a geom that never collides
            return self._geom_lines(link_name, "visual", index, geometry, indent)
        return [f"{indent}<site name={attribute(f'{link_name}_visual_{index}')} {_primitive(link_name, geometry.shape)}"
                f"{_frame_attributes(geometry.origin)} material={attribute(self._material(geometry.color))}/>"]


def _primitive(link_name: str, shape: object) -> str:
    """``type`` and ``size`` of a box or cylinder (MuJoCo sizes are half extents)."""
    if isinstance(shape, Box):
        return f'type="box" size="{numbers(np.asarray(shape.size, dtype=float) / 2)}"'
    if isinstance(shape, Cylinder):
        return f'type="cylinder" size="{number(shape.radius)} {number(shape.length / 2)}"'
    raise TypeError(f"link {link_name!r}: unsupported shape {type(shape).__name__}; valid: Box, Cylinder, ConvexPrism")


def _frame_attributes(pose: Pose) -> str:
    """`` pos="..."`` and, when it rotates, `` euler="..."`` (URDF rpy under ``eulerseq="XYZ"``)."""
    text = f' pos="{numbers(pose.xyz)}"'
    if any(float(a) != 0.0 for a in pose.rpy):
        text += f' euler="{numbers(pose.rpy)}"'
    return text


def _inertial_line(link: Link, indent: str) -> str:
    centre, (ixx, iyy, izz) = link_inertia(link)
    return (f'{indent}<inertial pos="{numbers(centre)}" mass="{number(link.mass)}" '
            f'diaginertia="{number(ixx)} {number(iyy)} {number(izz)}"/>')
