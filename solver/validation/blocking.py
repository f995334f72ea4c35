"""A geometric proof that objects held fixed keep the target from its goal: necessity without search.

The judges (:mod:`solver.validation.judge`) show necessity by failing to find a path within a
budget: evidence, as strong as the search. Many questions the Maker asks have a plain
geometric answer: a fixed box stands where the target's goal pose is, or where an object must
go to let the target by. :class:`BlockingProver` looks for such an answer, as a proof:

1. Every one-joint object gets its joint range cut into cells, small enough that no point of
   it moves more than :data:`PROOF_EROSION` metres within a cell. Fixed, locked and static
   objects stand at their one pose.
2. *Reachable cells.* A cell of an object is blocked when the object, anywhere in the cell,
   overlaps an object that is fixed, or an object in every cell that object can reach. A
   one-joint object passes every value between two others, so it can reach only the run of
   unblocked cells around its start; this is repeated until nothing changes.
3. *Goal states.* With the target's goal joints at their goal values, every object's cells
   are pruned by arc consistency: a cell stays only while, for every other object, some cell
   of it left is clear of this one. An object left without cells means no valid goal state
   can be reached: the objects held fixed are necessary.

"Overlaps anywhere in the cell" is proven from the cell's centre, conservatively: two convex
outlines whose every separating-axis overlap exceeds ``2 c (s + e)`` (``s`` the judge's shrink,
``e`` how far any point moves within a cell, ``c`` the outlines' corner factor, the largest
``1 / sin(alpha / 2)`` of an interior angle; 1 for two rectangles whose sides are parallel, which
share their separating axes) contain outlines eroded by ``s + e`` that meet,
so the outlines eroded by ``s`` meet wherever in their cells the objects are, and the
collision model of the judge's problem (every shape shrunk by ``s``,
:func:`~solver.planning.problem.shrunk_tolerance`) finds them colliding. Shapes the proof does
not model (cylinders, thin outlines an erosion would collapse) are left out, which can only
make it find less; objects with more than one free joint take no part (they could be
anywhere), unless every joint of the target is pinned by its goal. So the prover may fail to
prove a necessary object necessary (the judges then decide), never the other way round.

It makes no random draws and spends no collision queries of a judge's budget.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from phyrogen_core.chain import Role, pose_matrix
from phyrogen_core.geometry import Box, ConvexPrism
from phyrogen_core.objects import Motion, PuzzleObject
from phyrogen_core.puzzle import Goal
from solver.collision.model import DEFAULT_TOLERANCE
from solver.planning.problem import GOAL_SLACK, LOCKED_WIDTH, shrunk_tolerance

PROOF_EROSION = 0.03
"""Metres any point of an object may move within one cell of its joint range."""
PROOF_SLACK = 1e-4
"""Metres added to every erosion, so that an overlap proven at a cell's centre is strictly more
than the judge's tolerance everywhere in the cell."""
ERODE_HEADROOM = 0.9
"""An outline takes part in a proof only while eroding it keeps every edge at least a tenth of its
length (the corner-factor bound needs every vertex to survive the erosion)."""
PARALLEL = 1e-9
PAIR_WORK = 50_000
"""The most vertex projections one outline pair's table may take (near cell pairs times axes times
vertices): a pair of many-sided outlines close together over many cells (Lockbox Random's slotted
discs) is left out rather than paid for; a budget in counts, so the same question gets the same answer."""
"""Radians within which two rectangles count as parallel (corner factor 1)."""
MAX_EROSION = 0.2
"""The largest shrink plus cell erosion a proof is tried with (metres)."""


@dataclass(frozen=True)
class _Outline:
    vertices: np.ndarray  # (k, 2) counter-clockwise, in the object's frame
    normals: np.ndarray  # (k, 2) outward unit normals of the edges from each vertex
    z_low: float
    z_high: float
    corner: float  # the largest 1 / sin(alpha / 2) over its interior angles alpha
    radius: float  # the farthest vertex from the vertices' mean
    erodible: float  # the largest erosion (metres) that keeps every edge at 1 - ERODE_HEADROOM of its length
    phase: float | None  # a rectangle's first edge direction in the object's frame; None for other outlines


@dataclass(frozen=True)
class _Cells:
    """Where an object may stand: frame poses (n, 3) of (x, y, yaw), one per cell, and the joint
    value at each cell's centre (None for an object at one pose)."""

    poses: np.ndarray
    values: np.ndarray | None
    lower: float = 0.0
    width: float = 0.0  # of one cell, in joint units


def _outline(vertices: np.ndarray, z_low: float, z_high: float) -> _Outline | None:
    vertices = np.asarray(vertices, dtype=np.float64)
    area = 0.5 * float(np.sum(vertices[:, 0] * np.roll(vertices[:, 1], -1) - np.roll(vertices[:, 0], -1) *
                              vertices[:, 1]))
    if area <= 0:
        vertices = vertices[::-1]
        if area == 0:
            return None
    edges = np.roll(vertices, -1, axis=0) - vertices
    lengths = np.linalg.norm(edges, axis=1)
    if np.any(lengths <= 1e-9):
        return None
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1) / lengths[:, None]
    incoming = -np.roll(edges, 1, axis=0)
    cosines = np.sum(incoming * edges, axis=1) / (np.roll(lengths, 1) * lengths)
    angles = np.arccos(np.clip(cosines, -1.0, 1.0))  # interior angle at each vertex
    if np.any(angles <= 1e-6) or np.any(angles >= math.pi - 1e-9):
        return None
    # Erosion by r moves an edge's ends inward along it by r cot(alpha / 2) at each end.
    shortening = 1 / np.tan(angles / 2) + np.roll(1 / np.tan(angles / 2), -1)
    erodible = float(np.min(ERODE_HEADROOM * lengths / shortening))
    radius = float(np.max(np.linalg.norm(vertices - vertices.mean(axis=0), axis=1)))
    rectangle = len(vertices) == 4 and bool(np.all(np.abs(angles - math.pi / 2) < PARALLEL))
    phase = math.atan2(edges[0, 1], edges[0, 0]) if rectangle else None
    return _Outline(vertices, normals, z_low, z_high, float(np.max(1 / np.sin(angles / 2))), radius, erodible,
                    phase)


_OUTLINES: dict[tuple, tuple[_Outline, ...]] = {}
"""Outlines by (collision geometries, frame height): a puzzle's objects repeat a few shapes, and a
dataset worker's puzzles repeat them again. Exactly what :func:`_outlines` computes."""
_OUTLINES_KEPT = 4096


def _outlines(obj: PuzzleObject) -> tuple[_Outline, ...]:
    """The object's box and prism shapes as outlines in its frame; others are left out."""
    key = (obj.collisions, obj.pose.xyz[2])
    found = _OUTLINES.get(key)
    if found is None:
        if len(_OUTLINES) >= _OUTLINES_KEPT:
            _OUTLINES.clear()
        found = _OUTLINES[key] = _computed_outlines(obj)
    return found


def _computed_outlines(obj: PuzzleObject) -> tuple[_Outline, ...]:
    out = []
    for geometry in obj.collisions:
        origin = geometry.origin
        if not origin.is_planar:
            continue
        matrix = pose_matrix(origin)
        shape = geometry.shape
        if isinstance(shape, Box):
            hx, hy, hz = (v / 2 for v in shape.size)
            pieces, half = [np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])], hz
        elif isinstance(shape, ConvexPrism):
            pieces, half = [np.array(piece, dtype=np.float64) for piece in shape.pieces], shape.height / 2
        else:
            continue
        z = obj.pose.xyz[2] + matrix[2, 3]
        for piece in pieces:
            outline = _outline(piece @ matrix[:2, :2].T + matrix[:2, 3], z - half, z + half)
            if outline is not None:
                out.append(outline)
    return tuple(out)


def _reach(outlines: Sequence[_Outline]) -> float:
    """The farthest any modelled point stands from the object's frame origin."""
    return max((float(np.max(np.linalg.norm(o.vertices, axis=1))) for o in outlines), default=0.0)


def _frame_poses(obj: PuzzleObject, values: np.ndarray) -> np.ndarray:
    """(n, 3) world (x, y, yaw) of a one-joint object's frame at joint ``values`` (n,)."""
    x, y, _ = obj.pose.xyz
    yaw = obj.pose.yaw
    poses = np.empty((len(values), 3))
    if obj.motion is Motion.PRISMATIC:
        axis = np.asarray(obj.axis[:2], dtype=np.float64) / np.linalg.norm(obj.axis)
        c, s = math.cos(yaw), math.sin(yaw)
        direction = np.array([c * axis[0] - s * axis[1], s * axis[0] + c * axis[1]])
        poses[:, 0] = x + values * direction[0]
        poses[:, 1] = y + values * direction[1]
        poses[:, 2] = yaw
    else:
        poses[:, 0], poses[:, 1], poses[:, 2] = x, y, yaw + values
    return poses


def _world(outline: _Outline, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The outline's vertices and normals at each of ``poses``: (n, k, 2) each."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    rotation = np.stack([np.stack([c, -s], axis=1), np.stack([s, c], axis=1)], axis=1)  # (n, 2, 2)
    vertices = np.einsum("nij,kj->nki", rotation, outline.vertices) + poses[:, None, :2]
    normals = np.einsum("nij,kj->nki", rotation, outline.normals)
    return vertices, normals


@njit(cache=True, nogil=True)
def _pair_overlaps(va, na, vb, nb, first, second, threshold):  # pragma: no cover (compiled)
    """:func:`_overlaps` of the pairs (``va[first[p]]``, ``vb[second[p]]``), compiled: the same products,
    sums, extremes and comparison, in a loop instead of numpy's temporaries (the same answers)."""
    out = np.empty(len(first), dtype=np.bool_)
    for p in range(len(first)):
        a, b = first[p], second[p]
        overlap = np.inf
        for side in range(2):
            normals = na[a] if side == 0 else nb[b]
            for k in range(normals.shape[0]):
                nx, ny = normals[k, 0], normals[k, 1]
                low_a, high_a = np.inf, -np.inf
                for j in range(va.shape[1]):
                    v = nx * va[a, j, 0] + ny * va[a, j, 1]
                    low_a, high_a = min(low_a, v), max(high_a, v)
                low_b, high_b = np.inf, -np.inf
                for j in range(vb.shape[1]):
                    v = nx * vb[b, j, 0] + ny * vb[b, j, 1]
                    low_b, high_b = min(low_b, v), max(high_b, v)
                overlap = min(overlap, min(high_a, high_b) - max(low_a, low_b))
        out[p] = overlap > threshold[p]
    return out


def _overlaps(va: np.ndarray, na: np.ndarray, vb: np.ndarray, nb: np.ndarray, threshold: float) -> np.ndarray:
    """Whether outline pairs (``va[i]``, ``vb[i]``) overlap by more than ``threshold`` along every edge
    normal of both (the separating-axis test of :mod:`solver.collision.kernels`, with ``threshold`` as its
    tolerance); vertices and normals (p, k, 2)."""
    overlap = None
    for normals in (na, nb):
        on_a = np.einsum("pkd,pjd->pkj", normals, va)
        on_b = np.einsum("pkd,pjd->pkj", normals, vb)
        over = np.minimum(on_a.max(axis=2), on_b.max(axis=2)) - np.maximum(on_a.min(axis=2), on_b.min(axis=2))
        low = over.min(axis=1)
        overlap = low if overlap is None else np.minimum(overlap, low)
    return overlap > threshold


class BlockingProver:
    """Proves objects necessary by geometry (see the module docstring). Keeps what it computed about
    each object and each pair of objects, so the questions of one puzzle share it."""

    def __init__(self, erosion: float = PROOF_EROSION):
        self.erosion = erosion
        self._outlines: dict[PuzzleObject, tuple[_Outline, ...]] = {}
        self._cells: dict[tuple, _Cells] = {}
        self._tables: dict[tuple, np.ndarray] = {}
        self._bounds: dict[tuple, np.ndarray] = {}
        self._worlds: dict[tuple, tuple] = {}
        self._kept: dict[int, PuzzleObject] = {}  # keys hold objects by id (hashing one costs more than a check)

    def _id(self, obj: PuzzleObject) -> int:
        key = id(obj)
        self._kept.setdefault(key, obj)  # alive as long as the prover, so no other object gets its id
        return key

    # -- per object ------------------------------------------------------------
    def outlines(self, obj: PuzzleObject) -> tuple[_Outline, ...]:
        key = self._id(obj)
        found = self._outlines.get(key)
        if found is None:
            found = self._outlines[key] = _outlines(obj)
        return found

    def free_cells(self, obj: PuzzleObject) -> _Cells:
        """A one-joint object's cells over its whole range."""
        key = (self._id(obj), "free")
        found = self._cells.get(key)
        if found is None:
            (lower, upper), = obj.limits
            reach = 1.0 if obj.motion is Motion.PRISMATIC else max(_reach(self.outlines(obj)), 1e-3)
            count = max(1, math.ceil((upper - lower) * reach / (2 * self.erosion)))
            width = (upper - lower) / count
            values = lower + width * (np.arange(count) + 0.5)
            found = self._cells[key] = _Cells(_frame_poses(obj, values), values, lower, width)
        return found

    def placed(self, obj: PuzzleObject, values: tuple[float, ...]) -> _Cells:
        """An object at one pose: its joints at ``values`` (none for a fixed object)."""
        key = (self._id(obj), values)
        found = self._cells.get(key)
        if found is None:
            x, y, z = obj.pose.xyz
            yaw = obj.pose.yaw
            if obj.motion in (Motion.PRISMATIC, Motion.REVOLUTE):
                pose = _frame_poses(obj, np.array(values))[0]
            elif obj.motion in (Motion.SE2, Motion.R2):
                pose = np.array([x + values[0], y + values[1], yaw + (values[2] if len(values) > 2 else 0.0)])
            else:
                pose = np.array([x, y, yaw])
            found = self._cells[key] = _Cells(pose[None, :], None)
        return found

    def _world(self, obj: PuzzleObject, where: tuple, cells: _Cells, index: int):
        """Outline ``index`` of the object over its cells: ((vertices, normals), the vertices' means)."""
        key = (self._id(obj), where, index)
        found = self._worlds.get(key)
        if found is None:
            world = _world(self.outlines(obj)[index], cells.poses)
            found = self._worlds[key] = (world, world[0].mean(axis=1))
        return found

    # -- per pair ----------------------------------------------------------------
    def _box(self, obj: PuzzleObject, where: tuple, cells: _Cells) -> np.ndarray:
        """The (x, y) bounds of everything the object covers over its cells: [low x, low y, high x, high y]."""
        key = (self._id(obj), where)
        found = self._bounds.get(key)
        if found is None:
            rho = _reach(self.outlines(obj))
            low = cells.poses[:, :2].min(axis=0) - rho
            high = cells.poses[:, :2].max(axis=0) + rho
            found = self._bounds[key] = np.concatenate([low, high])
        return found

    def table(self, a: tuple[PuzzleObject, tuple, _Cells], b: tuple[PuzzleObject, tuple, _Cells],
              shrink: float) -> np.ndarray:
        """(cells of a, cells of b): whether a there overlaps b there wherever in both cells they are."""
        id_a, id_b = self._id(a[0]), self._id(b[0])
        key = (id_a, a[1], id_b, b[1], shrink)
        found = self._tables.get(key)
        if found is not None:
            return found
        flipped = self._tables.get((id_b, b[1], id_a, a[1], shrink))
        if flipped is not None:
            return flipped.T
        (obj_a, where_a, cells_a), (obj_b, where_b, cells_b) = a, b
        table = np.zeros((len(cells_a.poses), len(cells_b.poses)), dtype=bool)
        box_a, box_b = self._box(obj_a, where_a, cells_a), self._box(obj_b, where_b, cells_b)
        if np.all(box_a[:2] < box_b[2:]) and np.all(box_b[:2] < box_a[2:]):
            tolerance = shrunk_tolerance(shrink)
            erosion = shrink + self.erosion + PROOF_SLACK
            for index_a, outline_a in enumerate(self.outlines(obj_a)):
                for index_b, outline_b in enumerate(self.outlines(obj_b)):
                    if min(outline_a.z_high, outline_b.z_high) - max(outline_a.z_low, outline_b.z_low) <= tolerance:
                        continue
                    if erosion > min(outline_a.erodible, outline_b.erodible):
                        continue  # too thin for the bound: left out, which can only prove less
                    world_a, centre_a = self._world(obj_a, where_a, cells_a, index_a)
                    world_b, centre_b = self._world(obj_b, where_b, cells_b, index_b)
                    least = max(2 * erosion, DEFAULT_TOLERANCE)
                    # Only cell pairs whose bounding circles overlap by more than the threshold can.
                    reach = outline_a.radius + outline_b.radius - least
                    near = np.sum((centre_a[:, None] - centre_b[None]) ** 2, axis=2) < reach * abs(reach)
                    i, j = np.nonzero(near & ~table)
                    sides_a, sides_b = len(outline_a.vertices), len(outline_b.vertices)
                    if len(i) * (sides_a + sides_b) * max(sides_a, sides_b) > PAIR_WORK:
                        continue  # too dear: left out, which can only prove less
                    if len(i):
                        threshold = np.full(len(i), max(2 * max(outline_a.corner, outline_b.corner) * erosion,
                                                        DEFAULT_TOLERANCE))
                        if outline_a.phase is not None and outline_b.phase is not None:
                            turn = np.mod(cells_a.poses[i, 2] + outline_a.phase - cells_b.poses[j, 2] - outline_b.phase,
                                          math.pi / 2)
                            threshold[np.minimum(turn, math.pi / 2 - turn) < PARALLEL] = least
                        hit = _pair_overlaps(world_a[0], world_a[1], world_b[0], world_b[1], i, j, threshold)
                        table[i[hit], j[hit]] = True
        self._tables[key] = table
        return table

    # -- the proof ---------------------------------------------------------------
    def proves(self, objects: Sequence[PuzzleObject], goal: Goal, fixed: Sequence[str], shrink: float) -> bool:
        """Whether, with the objects ``fixed`` held at their start pose and every shape shrunk by
        ``shrink`` metres, no valid state with the target at its goal can be reached from the start."""
        if shrink + self.erosion + PROOF_SLACK > MAX_EROSION:
            return False
        fixed = set(fixed)
        points: list[tuple[PuzzleObject, tuple, _Cells]] = []
        free: list[tuple[PuzzleObject, tuple, _Cells]] = []
        target = None
        goal_point = None
        for obj in objects:
            if obj.role is Role.GOAL_MARKER or not self.outlines(obj) and obj.name != goal.target:
                continue
            start = tuple(float(min(max(0.0, lo), hi)) for lo, hi in obj.limits)
            locked = obj.name in fixed or all(hi - lo < LOCKED_WIDTH for lo, hi in obj.limits)
            if obj.name == goal.target:
                if not set(goal.values) <= set(obj.joint_names):
                    return False
                if locked:  # held away from its goal, the target never reaches it
                    held = dict(zip(obj.joint_names, start, strict=True))
                    return any(abs(held[j] - v) > goal.tolerance + GOAL_SLACK for j, v in goal.values.items())
                if len(obj.limits) == 1:
                    target = len(free)
                elif set(goal.values) == set(obj.joint_names) and goal.tolerance * (2 + _reach(self.outlines(obj))) \
                        <= self.erosion:
                    values = tuple(goal.values[j] for j in obj.joint_names)
                    goal_point = (obj, values, self.placed(obj, values))
                    continue
                else:
                    return False
            if locked:
                points.append((obj, start, self.placed(obj, start)))
            elif len(obj.limits) == 1:
                free.append((obj, "free", self.free_cells(obj)))
            # an object free in several joints could be anywhere: it takes no part
        if target is None and goal_point is None:
            return False
        reach = self._reachable(free, points, shrink)
        if reach is None:
            return False
        domains = [mask.copy() for mask in reach]
        if target is not None:
            obj, _, cells = free[target]
            (value,) = (goal.values[j] for j in obj.joint_names)
            near = goal.tolerance + GOAL_SLACK
            low = cells.lower + cells.width * np.arange(len(domains[target]))
            domains[target] &= (low <= value + near) & (low + cells.width >= value - near)
        if goal_point is not None:
            points = [*points, goal_point]
        return self._emptied(free, points, domains, shrink)

    def _reachable(self, free, points, shrink: float) -> list[np.ndarray] | None:
        """Per free object, its reachable cells (step 2 of the module docstring); None when a start
        cell itself is blocked (the model and the proof disagree: no proof)."""
        reach = [np.ones(len(cells.poses), dtype=bool) for _, _, cells in free]
        starts = []
        for obj, _, cells in free:
            (lo, hi), = obj.limits
            start = min(max(0.0, lo), hi)
            starts.append(min(len(cells.poses) - 1, int((start - cells.lower) // cells.width)) if cells.width else 0)
        fixed_blocks = []
        for entry in free:
            blocked = np.zeros(len(entry[2].poses), dtype=bool)
            for point in points:
                blocked |= self.table(entry, point, shrink)[:, 0]
            fixed_blocks.append(blocked)
        changed = True
        while changed:
            changed = False
            for i, entry in enumerate(free):
                blocked = fixed_blocks[i].copy()
                for k, other in enumerate(free):
                    if k != i:
                        blocked |= self.table(entry, other, shrink)[:, reach[k]].all(axis=1)
                start = starts[i]
                if blocked[start]:
                    return None
                run = np.zeros_like(blocked)
                left = start
                while left > 0 and not blocked[left - 1]:
                    left -= 1
                right = start
                while right < len(blocked) - 1 and not blocked[right + 1]:
                    right += 1
                run[left:right + 1] = True
                run &= reach[i]
                if not np.array_equal(run, reach[i]):
                    reach[i], changed = run, True
        return reach

    def _emptied(self, free, points, domains: list[np.ndarray], shrink: float) -> bool:
        """Arc consistency over goal states (step 3): whether some object is left without cells."""
        for i, entry in enumerate(free):
            for point in points:
                domains[i] &= ~self.table(entry, point, shrink)[:, 0]
        changed = True
        while changed:
            if any(not mask.any() for mask in domains):
                return True
            changed = False
            for i, entry in enumerate(free):
                for k, other in enumerate(free):
                    if k == i:
                        continue
                    kept = domains[i] & ~self.table(entry, other, shrink)[:, domains[k]].all(axis=1)
                    if not np.array_equal(kept, domains[i]):
                        domains[i], changed = kept, True
        return any(not mask.any() for mask in domains)


def warm_up() -> None:
    """Load the proof's compiled test (from numba's cache, or compile it), as a server does before it forks."""
    square = np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]])
    normals = np.array([[[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]]])
    index = np.zeros(1, dtype=np.int64)
    _pair_overlaps(square, normals, square, normals, index, index, np.zeros(1))
