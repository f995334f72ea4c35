"""An exact, vectorized collision model built straight from a kinematic chain.

Every PhyRoGen puzzle is planar: objects stand on the floor, prismatic joints
slide horizontally, revolute joints turn about the vertical axis. A
collision shape (box, vertical cylinder, convex prism) therefore keeps its z
extent forever and moves rigidly in the plane, so two shapes collide exactly
when their z intervals overlap and their 2D outlines (convex polygons or
circles) overlap. Pairs whose z intervals never overlap are dropped once, at
construction; the rest are tested with the separating-axis theorem, batched
over many states at a time with numpy.

Touching is not collision: two shapes collide only when they interpenetrate
by more than ``tolerance`` along every separating axis (or, for circles, the
distance). That is why no ``link_shrink`` is needed.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from phyrogen_core.chain import Joint, JointType, KinematicChain, Role, joint_motion, pose_matrix
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder
from solver.collision import kernels as _kernels
from solver.collision import skipping_move as _skipping
from solver.collision.shape_table import ShapeTable, descendants, revolute_reach, shared_shape_table

_FLOAT64 = np.dtype(np.float64)
DEFAULT_TOLERANCE = 1e-6
"""Penetration (metres) below which touching shapes count as contact-free."""


class UnsupportedGeometryError(ValueError):
    """The chain is not planar, so the exact planar model does not apply."""


@dataclass(frozen=True)
class _Outline:
    """One collision shape as a 2D outline in its link frame plus its z interval."""

    link: int
    obj: str
    vertices: np.ndarray | None  # (k, 2) counter-clockwise, None for circles
    center: np.ndarray  # (2,) bounding-circle centre (circle centre for circles)
    radius: float  # bounding radius (circle radius for circles)
    z_low: float
    z_high: float
    normals: np.ndarray | None = None  # (k, 2) outward unit edge normals, None for circles
    extent: np.ndarray | None = None  # (k,) the outline's projection on each of its normals peaks here

    @property
    def is_circle(self) -> bool:
        return self.vertices is None


def _planar(matrix: np.ndarray, what: str) -> tuple[float, float, float, float]:
    r = matrix[:3, :3]
    if abs(r[2, 2] - 1.0) > 1e-9:
        raise UnsupportedGeometryError(f"{what} is tilted; the collision model needs planar poses")
    return float(matrix[0, 3]), float(matrix[1, 3]), float(matrix[2, 3]), math.atan2(r[1, 0], r[0, 0])


_SHAPES: dict[tuple, list[tuple]] = {}
"""Outlines of a collision geometry at a link height, by (shape, origin, height): a puzzle's models
(one per judge question, candidate and certificate check) are built from the same few shapes many
times. What is kept is exactly what :func:`_outlines_of_geometry` computes, so no model changes."""
_SHAPES_KEPT = 4096


def _outlines_of_geometry(geometry, link_index: int, obj: str, frame: np.ndarray) -> list[_Outline]:
    """Outlines of one collision geometry; ``frame`` is the link frame's z-pose at rest (4x4)."""
    key = (geometry.shape, geometry.origin, float(frame[2, 3]))
    found = _SHAPES.get(key)
    if found is None:
        if len(_SHAPES) >= _SHAPES_KEPT:
            _SHAPES.clear()
        found = _SHAPES[key] = [(*(_read_only(v) for v in (o.vertices, o.center)), o.radius, o.z_low, o.z_high,
                                 *(_read_only(v) for v in _edge_normals(o.vertices)))
                                for o in _computed_outlines(geometry, link_index, obj, frame)]
    return [_Outline(link_index, obj, *shape) for shape in found]


_ORIGINS: dict[bytes, tuple[float, float, float]] = {}
"""A joint origin's planar x, y and yaw, by the exact numbers of its pose (a puzzle's models are built
from the same joints many times): what :func:`_planar` computes of its matrix, so no model changes."""


def _joint_origin(joint: Joint) -> tuple[float, float, float]:
    key = _exact(*joint.origin.xyz, *joint.origin.rpy)
    found = _ORIGINS.get(key)
    if found is None:
        ox, oy, _, oyaw = _planar(pose_matrix(joint.origin), f"joint {joint.name!r} origin")
        if len(_ORIGINS) >= _SHAPES_KEPT:
            _ORIGINS.clear()
        found = _ORIGINS[key] = (ox, oy, oyaw)
    return found


_MATRICES: dict[tuple, np.ndarray] = {}


def _rest_transforms(chain: KinematicChain, locked: Mapping[str, float]) -> dict[str, np.ndarray]:
    """``chain.link_transforms`` at every joint 0 but the ``locked`` ones: the same products of the same
    matrices, each joint's origin and motion matrix kept by its exact numbers (building them is most of
    the cost, and a puzzle's models are built from the same joints many times)."""
    world = {chain.root: np.eye(4)}
    keys: dict[str, tuple] = {chain.root: ()}
    for link_name in chain.links_in_tree_order[1:]:
        joint = chain.parent_joint(link_name)
        assert joint is not None
        q = float(locked.get(joint.name, 0.0)) if joint.is_active else 0.0
        origin_key = ("origin", _exact(*joint.origin.xyz, *joint.origin.rpy))
        motion_key = ("motion", joint.type, _exact(*joint.axis, q))
        # The product too, by its factors' keys and its parent's (a puzzle's growing chains share most links).
        key = keys[link_name] = (keys[joint.parent], origin_key, motion_key)
        found = _PRODUCTS.get(key)
        if found is None:
            origin = _kept(origin_key, pose_matrix, joint.origin)
            motion = _kept(motion_key, joint_motion, joint, q)
            if len(_PRODUCTS) >= _SHAPES_KEPT:
                _PRODUCTS.clear()
            found = _PRODUCTS[key] = _read_only((world[joint.parent] @ origin) @ motion)
        world[link_name] = found
    return world


_PRODUCTS: dict[tuple, np.ndarray] = {}


def _exact(*values: float) -> bytes:
    """The numbers' exact bits as a key (``-0.0`` apart from ``0.0``, which a tuple of floats would not keep)."""
    return struct.pack(f"{len(values)}d", *values)


def _kept(key: tuple, build, *arguments) -> np.ndarray:
    found = _MATRICES.get(key)
    if found is None:
        if len(_MATRICES) >= _SHAPES_KEPT:
            _MATRICES.clear()
        found = _MATRICES[key] = _read_only(build(*arguments))
    return found


def _edge_normals(v: np.ndarray | None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """A polygon's outward unit edge normals and its extent along each (None, None for a circle)."""
    if v is None:
        return None, None
    edges = np.roll(v, -1, axis=0) - v
    nrm = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    # A convex polygon's projection on its own outward normal peaks at that edge's line.
    return nrm, (v @ nrm.T).max(axis=0)


def _read_only(array: np.ndarray | None) -> np.ndarray | None:
    if array is not None:
        array.flags.writeable = False  # shared by every model built from the shape
    return array


def _computed_outlines(geometry, link_index: int, obj: str, frame: np.ndarray) -> list[_Outline]:
    # Outline vertices are expressed in the link frame (x/y), the z interval in the world.
    z = _planar(frame @ pose_matrix(geometry.origin), f"collision geometry of link #{link_index}")[2]
    rel = pose_matrix(geometry.origin)
    ox, oy, _, oyaw = _planar(rel, f"collision geometry origin of link #{link_index}")
    c, s = math.cos(oyaw), math.sin(oyaw)
    rot = np.array([[c, -s], [s, c]])

    def make(poly: np.ndarray, height: float) -> _Outline:
        world = poly @ rot.T + (ox, oy)
        center = world.mean(axis=0)
        radius = float(np.max(np.linalg.norm(world - center, axis=1)))
        return _Outline(link_index, obj, world, center, radius, z - height / 2, z + height / 2)

    shape = geometry.shape
    if isinstance(shape, Box):
        hx, hy, hz = (v / 2 for v in shape.size)
        return [make(np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]]), 2 * hz)]
    if isinstance(shape, ConvexPrism):
        return [make(np.array(piece, dtype=float), shape.height) for piece in shape.pieces]
    if isinstance(shape, Cylinder):
        center = np.array([ox, oy])
        return [_Outline(link_index, obj, None, center, shape.radius, z - shape.length / 2, z + shape.length / 2)]
    raise UnsupportedGeometryError(f"unsupported collision shape {shape!r}")


def _chain_outlines(chain: KinematicChain, links: Sequence[str], rest: Mapping[str, np.ndarray]) -> list[_Outline]:
    outlines: list[_Outline] = []
    for index, name in enumerate(links):
        link = chain.link(name)
        if link.role is Role.GOAL_MARKER:
            continue
        # Rest-pose z of the link frame; the planar motion never changes it.
        z = rest[name][2, 3]
        for geometry in link.collisions:
            key = (geometry.shape, geometry.origin, float(z), index, link.object_name or name)
            found = _PLACED.get(key)
            if found is None:  # kept by what _outlines_of_geometry reads (its cache holds the same z key)
                frame = np.eye(4)
                frame[2, 3] = z
                if len(_PLACED) >= _SHAPES_KEPT:
                    _PLACED.clear()
                found = _PLACED[key] = _outlines_of_geometry(geometry, index, link.object_name or name, frame)
            outlines += found
    return outlines


_PLACED: dict[tuple, list[_Outline]] = {}


def _heights(rest: Mapping[str, np.ndarray], links: Sequence[str]) -> bytes:
    """Every link frame's rest height, by its exact bits."""
    return _exact(*(rest[name][2, 3] for name in links))


class _ChainParts:
    """What the models of one chain share, whatever joints they lock at 0.0 and whatever their tolerance:
    the zero state's link transforms, the outlines, the shape table, each link's descendants and each
    revolute joint's reach (filled as models ask)."""

    def __init__(self, chain: KinematicChain):
        self.chain = chain  # kept alive with its parts, so no other chain gets its id while they are kept
        links = chain.links_in_tree_order
        self.link_index = {name: i for i, name in enumerate(links)}
        self.rest = _rest_transforms(chain, {})
        self.heights = _heights(self.rest, links)
        self.outlines = _chain_outlines(chain, links, self.rest)
        self.table = shared_shape_table(self.outlines)
        self.descendants = descendants(chain, links, self.link_index)
        self.reach: dict[str, float] = {}


_PARTS: dict[int, _ChainParts] = {}
_PARTS_KEPT = 32


def _chain_parts(chain: KinematicChain) -> _ChainParts | None:
    """The chain's :class:`_ChainParts`, the last few kept by the chain's identity (a chain is immutable);
    None when its shapes are not planar (the model then raises, as it always did)."""
    found = _PARTS.get(id(chain))
    if found is not None and found.chain is chain:
        return found
    try:
        found = _ChainParts(chain)
    except UnsupportedGeometryError:
        return None
    if len(_PARTS) >= _PARTS_KEPT:
        del _PARTS[next(iter(_PARTS))]
    _PARTS[id(chain)] = found
    return found


class CollisionModel:
    """Validity of joint states of a planar chain.

    ``locked`` maps joint names to values at which they are held (the
    Maker's FixJoint); the state vector holds the remaining active joints in
    chain order (:attr:`joint_order`).
    """

    def __init__(self, chain: KinematicChain, locked: Mapping[str, float] | None = None,
                 tolerance: float = DEFAULT_TOLERANCE):
        self.chain = chain
        self.tolerance = tolerance
        locked = dict(locked or {})
        unknown = set(locked) - set(chain.joint_order)
        if unknown:
            raise ValueError(f"cannot lock unknown joints {sorted(unknown)}")
        self.locked = locked
        self.joint_order = tuple(j for j in chain.joint_order if j not in locked)
        self._column = {name: i for i, name in enumerate(self.joint_order)}
        parts = _chain_parts(chain)
        self._links = list(chain.links_in_tree_order)
        self._link_index = {name: i for i, name in enumerate(self._links)} if parts is None else parts.link_index
        self._joint_steps = self._compile_kinematics()
        self._moving = self._moving_links()
        # At a locked value of exactly 0.0 a joint's motion matrix is its unlocked one at the zero state.
        at_zero = parts is not None and _exact(*map(float, locked.values())) == bytes(8 * len(locked))
        rest = self._rest = parts.rest if at_zero else _rest_transforms(chain, locked)
        self._reach: np.ndarray | None = None
        self._parts = parts if at_zero else None  # its joint reach holds for this model too
        if parts is not None and (at_zero or _heights(rest, self._links) == parts.heights):
            # The outlines depend on the links' rest heights alone, and the planar motion keeps them.
            self._outlines, table = parts.outlines, parts.table
        else:
            self._outlines = _chain_outlines(chain, self._links, rest)
            table = shared_shape_table(self._outlines)
        self._compile_arrays(table)

    # -- construction ------------------------------------------------------
    def _compile_kinematics(self) -> list[tuple[int, int, float, float, float, int, float, float, float]]:
        """Per non-root link: (link, parent, origin x, y, yaw, column, axis x, axis y, yaw rate)."""
        steps = []
        for name in self._links[1:]:
            joint: Joint = self.chain.parent_joint(name)  # type: ignore[assignment]
            ox, oy, oyaw = _joint_origin(joint)
            column, ax, ay, rate, offset = -1, 0.0, 0.0, 0.0, 0.0
            if joint.is_active:
                if joint.type is JointType.PRISMATIC:
                    if abs(joint.axis[2]) > 1e-9:
                        raise UnsupportedGeometryError(f"prismatic joint {joint.name!r} axis is not horizontal")
                    ax, ay = joint.axis[0], joint.axis[1]
                else:
                    if abs(abs(joint.axis[2]) - 1.0) > 1e-9:
                        raise UnsupportedGeometryError(f"revolute joint {joint.name!r} axis is not vertical")
                    rate = math.copysign(1.0, joint.axis[2])
                if joint.name in self.locked:
                    offset = self.locked[joint.name]
                    ax, ay, rate = ax * offset, ay * offset, rate * offset
                else:
                    column = self._column[joint.name]
            # Locked joints fold into constants: the column stays -1, the step uses (ax, ay, rate) * 1.
            steps.append((self._link_index[name], self._link_index[joint.parent], ox, oy, oyaw,
                          column, ax, ay, rate))
        return steps

    def _moving_links(self) -> set[int]:
        moving: set[int] = set()
        for link, parent, *_rest, column, _ax, _ay, _rate in self._joint_steps:
            if column >= 0 or parent in moving:
                moving.add(link)
        return moving

    def _compile_arrays(self, table: ShapeTable) -> None:
        """Flatten kinematics, shapes and candidate pairs into arrays for the compiled kernels."""
        steps = self._joint_steps
        # Columns: link, parent, state column (-1: none), whether the link's pose depends on the state.
        self._kin_int = np.array([(s[0], s[1], s[5], s[0] in self._moving) for s in steps],
                                 dtype=np.int64).reshape(-1, 4)
        self._kin_float = np.array([(s[2], s[3], s[4], s[6], s[7], s[8]) for s in steps],
                                   dtype=np.float64).reshape(-1, 6)
        self._shape_link, self._shape_nv = table.link, table.nv
        self._shape_center, self._shape_radius, self._shape_rho = table.center, table.radius, table.rho
        self._shape_verts, self._shape_normals, self._shape_extent = table.verts, table.normals, table.extent
        # Candidate pairs (i < j, in that order): shapes of different objects and links, one of them
        # moving, whose z intervals overlap by more than the tolerance; a circle always second.
        moving = np.zeros(len(self._links), dtype=np.bool_)
        moving[list(self._moving)] = True
        self._pairs = table.kept(moving, self.tolerance)
        # Which state columns move each pair's shapes (a joint moves its child link and all below).
        link_columns = np.zeros((len(self._links), len(self.joint_order)), dtype=np.bool_)
        for link, parent, *_rest, column, _ax, _ay, _rate in self._joint_steps:
            link_columns[link] = link_columns[parent]
            if column >= 0:
                link_columns[link, column] = True
        shape_links = table.link
        self._pair_columns = np.ascontiguousarray(link_columns[shape_links[self._pairs[:, 0]]] |
                                                  link_columns[shape_links[self._pairs[:, 1]]])
        self._arguments = self._args()
        self._state_shape = (len(self.joint_order),)
        self._packed_int, self._packed_float = self._pack(table)

    @cached_property
    def _pair_objects(self) -> list[tuple[str, str]]:
        """Each pair's object names in its order, sorted below (built when first asked: most models never are)."""
        return [(self._outlines[a].obj, self._outlines[b].obj) for a, b in self._pairs.tolist()]

    @cached_property
    def _pair_names(self) -> list[tuple[str, str]]:
        return [tuple(sorted(names)) for names in self._pair_objects]

    def _args(self) -> tuple:
        return (self._kin_int, self._kin_float, len(self._links), self._shape_link, self._shape_nv,
                self._shape_center, self._shape_radius, self._shape_verts, self._shape_normals,
                self._shape_extent, self._pairs, self.tolerance)

    def _pack(self, table: ShapeTable) -> tuple[np.ndarray, np.ndarray]:
        """The kernels' arrays in two flat ones (:func:`~solver.collision.kernels.state_valid_packed`); the
        shapes' part is the table's, packed once (:attr:`ShapeTable.packed`)."""
        verts = self._shape_verts
        header = [len(self._links), len(self._kin_int), len(self._shape_link), verts.shape[1], len(self._pairs)]
        assert len(header) == _kernels.PACKED_HEADER
        shape_ints, shape_floats = table.packed
        ints = np.concatenate([np.array(header, dtype=np.int64), self._kin_int.ravel(), shape_ints,
                               self._pairs.ravel()]).astype(np.int64)
        floats = np.concatenate([self._kin_float.ravel(), shape_floats, [self.tolerance],
                                 self._fixed_poses().ravel()]).astype(np.float64)
        return ints, floats

    def _fixed_poses(self) -> np.ndarray:
        """(5, links): x, y, cos, sin and yaw of every link at the zero state; the fixed links' are
        theirs at any state."""
        zero = np.zeros(len(self.joint_order))
        return _kernels.fixed_poses(zero, self._kin_int, self._kin_float, len(self._links))

    @property
    def packed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The arrays of the packed entry points (:func:`~solver.collision.kernels.state_valid_packed`,
        :func:`~solver.collision.kernels.motion_collides_packed`): ints, floats and the pairs' columns."""
        return self._packed_int, self._packed_float, self._pair_columns

    # -- queries -----------------------------------------------------------
    @property
    def pair_count(self) -> int:
        return len(self._pairs)

    def _as_states(self, states) -> np.ndarray:
        states = np.ascontiguousarray(np.atleast_2d(np.asarray(states, dtype=np.float64)))
        if states.shape[1] != len(self.joint_order):
            raise ValueError(f"states have {states.shape[1]} values, model has {len(self.joint_order)} joints")
        return states

    def check(self, states) -> np.ndarray:
        """Validity of each row of ``states`` (N, d): True = collision-free."""
        return _kernels.check_states(self._as_states(states), *self._arguments)

    def check_prepared(self, states: np.ndarray) -> np.ndarray:
        """:meth:`check` without input conversion: ``states`` must be a C-contiguous float64 (N, d) array."""
        return _kernels.check_states(states, *self._arguments)

    def is_valid(self, state: Sequence[float]) -> bool:
        if type(state) is np.ndarray and state.dtype is _FLOAT64 and state.shape == self._state_shape:
            # The planners' single-state query: straight to the compiled entry point with three
            # arguments, no copy (a strided row is read in place).
            return _kernels.state_valid_packed(state, self._packed_int, self._packed_float)
        return bool(_kernels.check_states(self._as_states(state), *self._arguments)[0])

    def check_motion(self, start: Sequence[float], end: Sequence[float], steps: np.ndarray) -> bool:
        """Whether the straight joint-space segment is collision-free, sampled so that no
        joint moves more than ``steps[j]`` between samples (the start is assumed valid)."""
        return self.motion_collision(start, end, steps) < 0

    def motion_collision(self, start: Sequence[float], end: Sequence[float], steps: np.ndarray) -> float:
        """Like :meth:`check_motion`, but where it fails: the fraction along the segment of a
        colliding sample (not necessarily the first one), or -1 when the segment is free."""
        a = np.asarray(start, dtype=np.float64)
        b = np.asarray(end, dtype=np.float64)
        return float(_kernels.motion_collision(a, b, steps, *self._arguments, self._pair_columns))

    def first_colliding_motion(self, states: np.ndarray, steps: np.ndarray, known: np.ndarray | None = None) -> int:
        """Index ``i`` of the first motion ``states[i] -> states[i + 1]`` that :meth:`check_motion` finds
        colliding, or -1 when none does: the same checks in the same order, in one compiled call,
        those with ``known[i]`` (motions the caller knows are free) left out. ``states``: a
        C-contiguous float64 (N, d) array."""
        if known is None:
            known = np.zeros(max(len(states) - 1, 0), dtype=np.bool_)
        return int(_kernels.first_colliding_motion(states, known, steps, *self._arguments, self._pair_columns))

    def path_collisions(self, states: np.ndarray, steps: np.ndarray, stop: bool = False) -> int:
        """How many of the points :func:`~solver.planning.problem.segment_points` puts along ``states``
        (a C-contiguous float64 (N, d) array; its first state excluded) :meth:`check` finds colliding
        (with ``stop``: 1 at the first), without building them: the same points and verdicts in one
        compiled call, the pairs a segment does not move tested once per segment."""
        return int(_kernels.path_collisions(states, steps, stop, False, *self._arguments, self._pair_columns))

    def path_free(self, states: np.ndarray, steps: np.ndarray) -> bool:
        """Whether :meth:`path_collisions` is 0, found faster: the pairs a segment does not move tested at
        its first point, the others by :meth:`motion_ends` (the same points; those where a pair is
        proven apart skipped, so a colliding point is found whatever is skipped)."""
        if len(states) < 2:
            return True
        if _kernels.path_collisions(states, steps, True, True, *self._arguments, self._pair_columns):
            return False
        return bool((self.motion_ends(states[:-1], states[1:], steps, False)[1] < 0).all())

    def motion_stop(self, start: np.ndarray, end: np.ndarray, steps: np.ndarray, stop: bool,
                    out: np.ndarray) -> float:
        """Move along the straight segment from ``start`` (valid) towards ``end``; where the move ends goes
        into ``out``: ``end`` when the segment is free, else ``start`` or, with ``stop``, the last free
        sample before the first colliding one (samples as in :meth:`check_motion`). Returns
        :meth:`motion_collision`'s fraction. All arrays C-contiguous float64 of one value per joint
        (``out`` not ``start``); one compiled call, for a simulation's step."""
        return _kernels.motion_stop(start, end, steps, stop, out, *self._arguments, self._pair_columns)

    def motion_stops(self, starts: np.ndarray, ends: np.ndarray, steps: np.ndarray, stop: bool) -> tuple[np.ndarray,
                                                                                                        np.ndarray]:
        """:meth:`motion_stop` for each row of ``starts`` and ``ends`` (N, d; C-contiguous float64), in one
        compiled call: (where each move ends, each move's fraction)."""
        out = np.empty_like(starts)
        hits = np.empty(len(starts))
        _kernels.motion_stops(starts, ends, steps, stop, out, hits, *self._arguments, self._pair_columns)
        return out, hits

    def motion_ends(self, starts: np.ndarray, ends: np.ndarray, steps: np.ndarray, stop: bool) -> tuple[np.ndarray,
                                                                                                       np.ndarray]:
        """Where each move ends, exactly as :meth:`motion_stops` ends it, found faster: samples at which
        every pair is proven apart are skipped (:func:`~solver.collision.skipping_move.motion_ends`). The
        fractions are those of each move's first colliding sample (-1: free); only their signs agree
        with :meth:`motion_stops`'."""
        out = np.empty_like(starts)
        hits = np.empty(len(starts))
        _skipping.motion_ends(starts, ends, steps, stop, out, hits, *self._arguments, self._pair_columns,
                             self._shape_rho)
        return out, hits

    @staticmethod
    def step_table(max_step: np.ndarray, lower: np.ndarray, upper: np.ndarray, steps: np.ndarray,
                   center: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """The per-joint constants of :meth:`joint_step` as one array (one argument per call)."""
        table = np.ascontiguousarray(np.stack([max_step, lower, upper, steps, center, scale]), dtype=np.float64)
        assert table.shape[0] == _kernels.STEP_TABLE_ROWS
        return table

    def joint_step(self, start: np.ndarray, action: np.ndarray, table: np.ndarray, stop: bool, out: np.ndarray,
                   position: np.ndarray) -> float:
        """A simulation's bounded step from ``start`` (valid), in one compiled call: the target is
        ``start + clip(action, -1, 1) * max_step`` clipped to the limits (``table``, from :meth:`step_table`),
        the move to it ends as :meth:`motion_stop` ends one (into ``out``), and ``position`` gets
        ``(out - center) * scale``. ``action``: C-contiguous float32 or float64, at least one value per
        joint (the rest are checked, not used). Returns the motion's fraction (-1: free), or -2 (nothing
        written) when ``action`` holds a value that is not finite."""
        return _kernels.joint_step(start, action, table, stop, out, position, *self._arguments, self._pair_columns)

    def colliding_objects(self, states) -> set[tuple[str, str]]:
        """Pairs of object names that collide at any of ``states``."""
        if type(states) is np.ndarray and states.dtype is _FLOAT64 and states.shape[0] == 1 and \
                states.shape[1:] == self._state_shape:
            # One state (a goal sampler's repair step): the packed entry point, three arguments.
            hits = _kernels.pair_hits_packed(states[0], self._packed_int, self._packed_float)
        else:
            hits = _kernels.pair_hits(self._as_states(states), *self._arguments)
        names = self._pair_names
        return {names[p] for p in hits.nonzero()[0].tolist()}

    def colliding_objects_with(self, states: np.ndarray, obj: str) -> set[tuple[str, str]]:
        """The pairs of :meth:`colliding_objects` that hold ``obj``: its pairs' tests alone, each
        repeated only at a row where a joint that moves it changed (``states``: C-contiguous float64)."""
        mask = np.array([obj in names for names in self._pair_objects], dtype=np.bool_)
        if not mask.any():
            return set()
        (*arguments, _pairs, tolerance) = self._arguments
        hits = _kernels.pair_hits_changed(states, *arguments, self._pairs[mask], tolerance, self._pair_columns[mask])
        names = [n for n, m in zip(self._pair_names, mask.tolist(), strict=True) if m]
        return {names[p] for p in hits.nonzero()[0].tolist()}

    def colliding_objects_each(self, states: np.ndarray) -> list[set[tuple[str, str]]]:
        """:meth:`colliding_objects` of each row of ``states`` (a C-contiguous float64 (N, d) array), the
        same pair test in one compiled call: one set of colliding object pairs per state."""
        names = self._pair_names
        rows, pairs = _kernels.pair_hits_rows(states, self._packed_int, self._packed_float).nonzero()
        found: list[set[tuple[str, str]]] = [set() for _ in range(len(states))]
        for row, p in zip(rows.tolist(), pairs.tolist(), strict=True):  # each row's pairs in order, as before
            found[row].add(names[p])
        return found

    def joint_reach(self) -> np.ndarray:
        """Per state joint: how far (metres) a unit of motion can move any collision point.

        1 for prismatic joints; for revolute joints the largest distance from
        the joint axis of any collision vertex it carries. Motion checks use it
        to turn a resolution in metres into per-joint steps.
        """
        if self._reach is None:
            self._reach = self._joint_reach()
        return self._reach.copy()

    def _joint_reach(self) -> np.ndarray:
        parts = self._parts
        known = {} if parts is None else parts.reach  # a revolute joint's reach, by name
        below = descendants(self.chain, self._links, self._link_index) if parts is None else parts.descendants
        reach = np.ones(len(self.joint_order))
        for index, name in enumerate(self.joint_order):
            joint = self.chain.joint(name)
            if joint.type is not JointType.REVOLUTE:
                continue
            found = known.get(name)
            if found is None:
                found = known[name] = revolute_reach(self._outlines, below[joint.child], self._rest, self._links,
                                                     joint.child)
            reach[index] = found
        return reach

    def motion_steps(self, resolution: float) -> np.ndarray:
        """Per-joint step sizes so that no collision point moves more than ``resolution``."""
        return resolution / self.joint_reach()


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel on a two-box model."""
    from phyrogen_core.chain import Geometry
    from phyrogen_core.geometry import Pose
    from phyrogen_core.objects import Motion, PuzzleObject, build_chain

    geometry = (Geometry(Box((1.0, 1.0, 1.0))),)
    objects = [PuzzleObject(f"obj_0{i}", Motion.PRISMATIC, Pose.planar(2.0 * i, 0.0, 0.5), geometry, geometry,
                            limits=((0.0, 1.0),)) for i in range(2)]
    model = CollisionModel(build_chain(objects))
    states = np.zeros((2, 2))
    model.check(states)
    model.is_valid(states[0])
    model.check_motion(states[0], states[1] + 1.0, np.full(2, 0.1))
    model.colliding_objects(states)
    model.colliding_objects(states[:1])
