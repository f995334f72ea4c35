"""A geometric proof that objects held fixed keep a target that moves in the plane from its goal.

:class:`~solver.validation.blocking.BlockingProver` proves necessity for objects that move in one
joint. A target that moves in x and y (Rooms' robot, Move N Times' cuboid) could be anywhere, so it
leaves that proof out; :func:`proves` follows a single point of it instead, and over-approximates
where that point can go:

1. *The point.* ``p`` is the centre of a disk of radius ``r`` inside one collision shape of the
   target (a box's centre and half its smaller side, a cylinder itself). It moves continuously with
   the target: ``p = (x0 + x, y0 + y) + R(yaw0 + yaw) p_local``.
2. *Obstacles.* Only objects that cannot move: fixed, static, held fixed by the question, or with
   every joint of zero width, at their start pose. Every movable object is left out: removing an
   obstacle only enlarges the free space, so this can only prove less. Only shapes whose z extent
   overlaps the disk's shape by more than the judge's tolerance take part (the collision model
   drops the other pairs).
3. *Blocked cells.* The plane is cut into square cells. A cell is blocked when its centre ``c`` is
   within ``r - t - h - REGION_SLACK`` of an obstacle (``t`` the judge's tolerance,
   :func:`~solver.planning.problem.shrunk_tolerance`; ``h`` the cell's half-diagonal): then every
   ``p`` in the cell is nearer than ``r - t`` to the obstacle, and the collision model finds the
   target and the obstacle colliding (see below).
4. *Reach.* From the start cell, a flood fill through unblocked cells (8-connected). If no cell it
   reaches meets the box where ``p`` can be with the target at its goal (goal joints within the
   goal's tolerance plus :data:`~solver.planning.problem.GOAL_SLACK`; a joint the goal does not pin
   anywhere within its limits), no path the judges accept ends at the goal: the objects held fixed
   are necessary. Cells are tried coarse first (:data:`REGION_LEVELS`, down to :data:`REGION_CELL`);
   a finer level searches only the children of the cells the coarser one reached (a cell blocked at
   a coarse level holds only colliding points, so every way through fine cells runs through reached
   coarse cells too). The finest level is kept by parent cell (:mod:`solver.validation.region_blocks`):
   the children of a parent far from every obstacle are filled at once, the others one by one; it
   reaches the same cells, so the verdicts are those of the dense grid.

Why ``dist(p, O) < r - t`` is a collision in the judges' model
(:func:`solver.collision.kernels._pair_collides`): a point ``q`` of the obstacle ``O`` lies within
``r - t`` of ``p``. For an edge of ``O`` (outward normal ``n``, the obstacle's extent ``e`` along it),
the target's lowest projection is at most ``n.p - r < n.q - t <= e - t``; for an edge of the target
(extent ``f >= m.p + r``), the obstacle's lowest projection is at most ``m.q < m.p + r - t <= f - t``;
so no edge line separates them by the tolerance. The bounding circles (each holds its shape, the
target's holds the disk) have centres nearer than the sum of their radii less ``t``. A circle against
a polygon or a circle is the same inequality. So the proof is sound for the kernel's one-sided
separating-axis test, which finds thin obstacles (Move N Times' 0.08 m door at a 0.08 m tolerance)
colliding where a shrink would not.

Discrete checks: both judges accept a path only when each of its motions holds at
:data:`~solver.planning.problem.FINE_RESOLUTION` (no point moves more than that per joint between
two checked states), so ``p`` moves at most :data:`MAX_JUMP` between two checked states: less than
a cell, so two consecutive states lie in the same or in neighbouring cells, and a path cannot jump
over a blocked cell.

The proof may fail to prove a necessary object necessary (the judges then decide), never the other
way round. Its work is bounded by counts (:data:`MAX_CELLS` per level), it makes no random draws
and spends no collision query of a judge's budget.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from phyrogen_core.chain import Role, pose_matrix
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder
from phyrogen_core.objects import Motion, PuzzleObject
from phyrogen_core.puzzle import Goal
from solver.planning.problem import FINE_RESOLUTION, GOAL_SLACK, LOCKED_WIDTH, shrunk_tolerance
from solver.validation import region_blocks

REGION_CELL = 0.0075
"""Metres across a cell at the finest level. Rooms' robot (0.375 m) against a door's 0.2 m gaps at
the top rung (0.04 shrink, 0.08 tolerance) leaves 0.015 m of slack in all, two cells' half-diagonals."""
REGION_LEVELS = (6, 3, 0)
"""The levels of cells tried, coarse to fine, as powers of two times :data:`REGION_CELL`: 0.48, 0.06 and
0.0075 m across. A coarse level settles roomy puzzles (Move N Times' door at any rung) at little cost;
the finest one is needed where the slack is a few millimetres (Rooms' doors at the top rung)."""
MAX_CELLS = 8_000_000
"""The most cells one level's grid may hold; a larger grid ends the proof (no proof). Rooms' largest
size (6 rooms at scaling 4, a 16 x 16 m walk at worst) needs about 5 million at the finest level."""
REGION_SLACK = 1e-6
"""Metres taken off every distance that proves a collision: far more than the rounding of the
model's and the proof's arithmetic at puzzle sizes (about 1e-14 m), so a proven overlap is strictly
more than the judge's tolerance."""
Z_SLACK = 1e-9
"""Metres more than the tolerance by which z extents must overlap for an obstacle to count."""
MAX_JUMP = 3 * FINE_RESOLUTION
"""Metres ``p`` may move between two states a judge checks: at most FINE_RESOLUTION along each of x
and y and as much again by the turn, (sqrt(2) + 1) x FINE_RESOLUTION, rounded up."""
assert REGION_CELL > MAX_JUMP, "a path could jump over a blocked cell"


@dataclass(frozen=True)
class _Disk:
    """A disk inside one collision shape of the target: its centre in the target's body frame, its
    radius and the shape's z extent."""

    centre: tuple[float, float]
    radius: float
    z_low: float
    z_high: float


@dataclass(frozen=True)
class _Obstacles:
    """World outlines of the shapes that cannot move: convex polygons (padded) and circles."""

    vertices: np.ndarray  # (n, k, 2)
    counts: np.ndarray  # (n,) vertices of each polygon
    circles: np.ndarray  # (m, 3) centre x, y and radius
    z: np.ndarray  # (n + m, 2) z extents, polygons first


def _convex_ccw(piece: np.ndarray) -> np.ndarray | None:
    """The polygon when it is strictly convex and counter-clockwise, as the collision model reads it
    (its edge normals point out only then), else None (left out)."""
    points = piece.tolist()  # floats: the same products as numpy's, without its calls' overhead
    edges = [(bx - ax, by - ay) for (ax, ay), (bx, by) in zip(points, points[1:] + points[:1], strict=True)]
    crosses = (ex * fy - ey * fx for (ex, ey), (fx, fy) in zip(edges, edges[1:] + edges[:1], strict=True))
    return piece if all(cross > 0 for cross in crosses) else None


def _shapes(obj: PuzzleObject, frame: tuple[float, float, float]):
    """(polygons, circles) of the object's modelled collision shapes with its frame at ``frame``
    (x, y, yaw): polygons as ((k, 2) vertices, z low, z high), circles as (x, y, radius, z low, z high).
    Shapes the collision model reads differently (tilted) are left out."""
    x, y, yaw = frame
    c, s = math.cos(yaw), math.sin(yaw)
    rotation = np.array([[c, -s], [s, c]])
    polygons, circles = [], []
    for geometry in obj.collisions:
        if not geometry.origin.is_planar:
            continue
        matrix = pose_matrix(geometry.origin)
        local_rotation, offset = matrix[:2, :2], matrix[:2, 3]
        z = obj.pose.xyz[2] + matrix[2, 3]
        shape = geometry.shape
        if isinstance(shape, Cylinder):
            centre = rotation @ offset + (x, y)
            circles.append((float(centre[0]), float(centre[1]), shape.radius, z - shape.length / 2,
                            z + shape.length / 2))
            continue
        if isinstance(shape, Box):
            hx, hy = shape.size[0] / 2, shape.size[1] / 2
            pieces, half = [np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])], shape.size[2] / 2
        elif isinstance(shape, ConvexPrism):
            pieces, half = [np.array(piece, dtype=np.float64) for piece in shape.pieces], shape.height / 2
        else:
            continue
        for piece in pieces:
            convex = _convex_ccw(piece @ local_rotation.T + offset) if len(piece) >= 3 else None
            if convex is not None:
                polygons.append((convex @ rotation.T + (x, y), z - half, z + half))
    return polygons, circles


_DISKS: dict[tuple, _Disk | None] = {}
""":func:`_disk` by what it reads (the target's collision shapes and height) and the tolerance: a puzzle's
questions ask about the same target at the same margin again and again, its limits grown between them
(a new object, the same shapes)."""


def _kept_disk(target: PuzzleObject, tolerance: float) -> _Disk | None:
    key = (target.collisions, target.pose.xyz[2], tolerance)
    if key not in _DISKS:
        if len(_DISKS) >= _KEPT_MOST:
            _DISKS.clear()
        _DISKS[key] = _disk(target, tolerance)
    return _DISKS[key]


def _disk(target: PuzzleObject, tolerance: float) -> _Disk | None:
    """The largest disk this finds inside one of the target's shapes (a polygon's vertex mean and its
    distance to the nearest edge line; a cylinder itself), if wider than ``tolerance``."""
    polygons, circles = _shapes(target, (0.0, 0.0, 0.0))
    best = None
    for x, y, radius, low, high in circles:
        if best is None or radius > best.radius:
            best = _Disk((x, y), radius, low, high)
    for vertices, low, high in polygons:
        centre = vertices.mean(axis=0)
        edges = np.concatenate((vertices[1:], vertices[:1])) - vertices  # np.roll's values, at less cost
        normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1) / np.linalg.norm(edges, axis=1)[:, None]
        radius = float(np.min(np.sum(normals * (vertices - centre), axis=1)))
        if best is None or radius > best.radius:
            best = _Disk((float(centre[0]), float(centre[1])), radius, low, high)
    return best if best is not None and best.radius > tolerance + REGION_SLACK else None


def _start_frame(obj: PuzzleObject) -> tuple[float, float, float]:
    """The world (x, y, yaw) of the object's frame with its joints at their start (0 within the limits)."""
    x, y, _ = obj.pose.xyz
    yaw = obj.pose.yaw
    values = [min(max(0.0, lo), hi) for lo, hi in obj.limits]
    if obj.motion is Motion.PRISMATIC:
        axis = np.asarray(obj.axis[:2], dtype=np.float64) / np.linalg.norm(obj.axis)
        c, s = math.cos(yaw), math.sin(yaw)
        return (x + values[0] * (c * axis[0] - s * axis[1]), y + values[0] * (s * axis[0] + c * axis[1]), yaw)
    if obj.motion is Motion.REVOLUTE:
        return (x, y, yaw + values[0])
    if obj.motion in (Motion.SE2, Motion.R2):
        return (x + values[0], y + values[1], yaw + (values[2] if len(values) > 2 else 0.0))
    return (x, y, yaw)


_KEPT: dict[int, tuple[PuzzleObject, tuple]] = {}
""":func:`_shapes` of objects at their start pose, by id (the object kept with them, so no other object
gets its id while it is here): a puzzle's questions ask about the same walls again and again."""
_KEPT_MOST = 4096


def _start_shapes(obj: PuzzleObject):
    found = _KEPT.get(id(obj))
    if found is None or found[0] is not obj:
        if len(_KEPT) >= _KEPT_MOST:
            _KEPT.clear()
        found = _KEPT[id(obj)] = (obj, _shapes(obj, _start_frame(obj)))
    return found[1]


def _obstacles(objects: Sequence[PuzzleObject], target: PuzzleObject, fixed: set[str], disk: _Disk,
               tolerance: float) -> _Obstacles:
    polygons, circles = [], []
    for obj in objects:
        if obj is target or obj.role is Role.GOAL_MARKER:
            continue
        if obj.is_movable and obj.name not in fixed and not all(hi - lo < LOCKED_WIDTH for lo, hi in obj.limits):
            continue  # it could step aside: left out, which can only prove less
        more_polygons, more_circles = _start_shapes(obj)
        polygons += more_polygons
        circles += more_circles

    def counts(low: float, high: float) -> bool:
        return min(high, disk.z_high) - max(low, disk.z_low) > tolerance + Z_SLACK

    polygons = [p for p in polygons if counts(p[1], p[2])]
    circles = [c for c in circles if counts(c[3], c[4])]
    k = max((len(p[0]) for p in polygons), default=3)
    vertices = np.zeros((len(polygons), k, 2))
    for i, (v, _, _) in enumerate(polygons):
        vertices[i, :len(v)] = v
    counts_ = np.array([len(p[0]) for p in polygons], dtype=np.int64)
    circle_array = np.array([c[:3] for c in circles], dtype=np.float64).reshape(len(circles), 3)
    z = np.array([p[1:] for p in polygons] + [c[3:] for c in circles], dtype=np.float64).reshape(-1, 2)
    return _Obstacles(vertices, counts_, circle_array, z)


@njit(cache=True, nogil=True)
def _closed(vertices, counts, circles, reach, origin_x, origin_y, width, nx, ny, parent, factor, parent_i,
            parent_j):  # pragma: no cover (compiled)
    """(nx, ny) cells a flood fill may not enter: those whose centres lie within ``reach`` of an
    obstacle, and, with a ``parent`` level (its reached cells, ``factor`` times as wide; its cell
    (``parent_i``, ``parent_j``) holds this grid's first cell), those whose parent cell was not
    reached. A transposed view: rows of cells along x are filled, and lie contiguous in memory."""
    closed = np.zeros((ny, nx), dtype=np.bool_)
    if parent.shape[0] > 0:
        for j in range(ny):
            row = parent_j + j // factor
            for block in range((nx + factor - 1) // factor):
                if not parent[parent_i + block, row]:
                    closed[j, block * factor:min(nx, (block + 1) * factor)] = True
    if reach > 0:
        region_blocks.mark_obstacles(closed, vertices, counts, circles, reach, origin_x, origin_y, width)
    return closed.T


@njit(cache=True, nogil=True)
def _reach(closed, start_i, start_j):  # pragma: no cover (compiled)
    """The cells an 8-connected flood fill from the start cell reaches through cells not ``closed``,
    and their bounding box (first row, first column, last row, last column; -1 first: the fill gave
    up, no answer). A scanline fill: each run of open cells along x is marked at once, and seeds the
    runs beside it in the rows above and below (one cell further at either end: diagonal steps). The
    result is a transposed view, as ``closed`` is, so that runs lie contiguous in memory."""
    nx, ny = closed.shape
    reached = np.zeros((ny, nx), dtype=np.bool_).T
    # Every run marked is a whole run of open cells of its row, and seeds each run beside it at most once
    # before that one is marked, so seeds come in pairs of touching runs of neighbouring rows: about
    # 2 nx ny at most. Should a grid need more, the fill stops with no box (no proof: sound).
    stack = np.empty(2 * nx * ny + 4 * ny + 1, dtype=np.int64)
    stack[0] = start_i * ny + start_j
    top = 1
    box = np.array([start_i, start_j, start_i, start_j])
    while top > 0:
        top -= 1
        i, j = divmod(stack[top], ny)
        if reached[i, j]:
            continue
        left = i
        while left > 0 and not closed[left - 1, j] and not reached[left - 1, j]:
            left -= 1
        right = i
        while right < nx - 1 and not closed[right + 1, j] and not reached[right + 1, j]:
            right += 1
        for a in range(left, right + 1):
            reached[a, j] = True
        box[0], box[1], box[2], box[3] = min(box[0], left), min(box[1], j), max(box[2], right), max(box[3], j)
        for b in (j - 1, j + 1):
            if b < 0 or b >= ny:
                continue
            run = False
            for a in range(max(0, left - 1), min(nx, right + 2)):
                open_ = not closed[a, b] and not reached[a, b]
                if open_ and not run:
                    if top == stack.shape[0]:
                        box[0] = -1
                        return reached, box
                    stack[top] = a * ny + b
                    top += 1
                run = open_
    return reached, box


def _turned(offset: tuple[float, float], angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * offset[0] - s * offset[1], s * offset[0] + c * offset[1]])


def proves(objects: Sequence[PuzzleObject], goal: Goal, fixed: Sequence[str], shrink: float) -> bool:
    """Whether, with the objects ``fixed`` held at their start pose and every shape shrunk by ``shrink``
    metres (the judges' model), the target, an object that moves in x and y, cannot reach its goal
    (see the module docstring). False means no proof, not that the goal can be reached."""
    target = next((o for o in objects if o.name == goal.target), None)
    if target is None or target.motion not in (Motion.SE2, Motion.R2) or target.name in fixed:
        return False
    if not set(goal.values) <= set(target.joint_names):
        return False
    tolerance = shrunk_tolerance(shrink)
    disk = _kept_disk(target, tolerance)
    if disk is None:
        return False
    obstacles = _obstacles(objects, target, set(fixed), disk, tolerance)
    if len(obstacles.counts) + len(obstacles.circles) == 0:
        return False
    # Where p can be: its frame's box over the limits, the disk's centre turned about it.
    x0, y0, _ = target.pose.xyz
    yaw0 = target.pose.yaw
    offset = disk.centre
    arm = math.hypot(*offset)
    near = goal.tolerance + GOAL_SLACK
    pinned = {j: (v - near, v + near) for j, v in goal.values.items()}
    start = [min(max(0.0, lo), hi) for lo, hi in target.limits]
    frame_low = np.array([x0 + target.limits[0][0], y0 + target.limits[1][0]])
    frame_high = np.array([x0 + target.limits[0][1], y0 + target.limits[1][1]])
    goal_low, goal_high = frame_low.copy(), frame_high.copy()
    for axis, name in enumerate(target.joint_names[:2]):
        if name in pinned:
            goal_low[axis], goal_high[axis] = (v + (x0, y0)[axis] for v in pinned[name])
    if target.motion is Motion.R2:  # no turn: p keeps its offset
        turned = _turned(offset, yaw0)
        spread = goal_spread = 0.0
        goal_turned = start_turned = turned
    else:
        turned, spread = np.zeros(2), arm
        start_turned = _turned(offset, yaw0 + start[2])
        yaw_goal = pinned.get(target.joint_names[2])
        if yaw_goal is None:
            goal_turned, goal_spread = turned, arm
        else:  # an arc of the goal's tolerance lies within arm x near of its middle
            goal_turned, goal_spread = _turned(offset, yaw0 + sum(yaw_goal) / 2), arm * near + REGION_SLACK
    low, high = frame_low + turned - spread, frame_high + turned + spread
    goal_low, goal_high = goal_low + goal_turned - goal_spread, goal_high + goal_turned + goal_spread
    point = np.array([x0 + start[0], y0 + start[1]]) + start_turned
    coarsest = REGION_CELL * 2 ** REGION_LEVELS[0]
    origin = low - coarsest
    size = np.ceil((high + coarsest - origin) / coarsest).astype(np.int64)
    window = np.zeros(2, dtype=np.int64)  # the level's first cell (global indices)
    parent, factor, parent_first = np.zeros((0, 0), dtype=np.bool_), 1, np.zeros(2, dtype=np.int64)
    for index, level in enumerate(REGION_LEVELS):
        width = REGION_CELL * 2 ** level
        if int(size[0]) * int(size[1]) > MAX_CELLS:
            return False
        corner = origin + window * width
        reach = disk.radius - tolerance - width * math.sqrt(0.5) - REGION_SLACK
        if index > 0 and index + 1 == len(REGION_LEVELS):
            return _finest_proves(obstacles, reach, corner, width, factor, parent, parent_first, size, point,
                                  goal_low, goal_high)
        closed = _closed(obstacles.vertices, obstacles.counts, obstacles.circles, reach, corner[0], corner[1], width,
                         int(size[0]), int(size[1]), parent, factor, int(parent_first[0]), int(parent_first[1]))
        i, j = (int(v) for v in np.floor((point - corner) / width))
        if not (0 <= i < size[0] and 0 <= j < size[1]) or closed[i, j]:
            return False  # the start itself collides (or was not reached): the judges decide
        reached, box = _reach(closed, i, j)
        if box[0] < 0:
            return False
        # Every cell that meets the box where p is at the goal (and a cell more).
        g0, g1 = _cells(corner, width, goal_low, goal_high)
        if not reached[g0[0]:g1[0], g0[1]:g1[1]].any():
            return True
        if index + 1 < len(REGION_LEVELS):
            # The next level: the children of the cells reached, within their bounding box.
            factor = 2 ** (level - REGION_LEVELS[index + 1])
            parent = reached
            parent_first = box[:2]
            window = factor * (window + box[:2])
            size = factor * (box[2:] - box[:2] + 1)
    return False


def _cells(corner: np.ndarray, width: float, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The first and past-the-last cells that meet the box [low, high] where p is at the goal (and a
    cell more), clipped at the grid's first cell."""
    g0 = np.maximum(0, np.floor((low - corner) / width).astype(np.int64) - 1)
    g1 = np.maximum(0, np.floor((high - corner) / width).astype(np.int64) + 2)
    return g0, g1


def _finest_proves(obstacles: _Obstacles, reach: float, corner: np.ndarray, width: float, factor: int,
                   parent: np.ndarray, parent_first: np.ndarray, size: np.ndarray, point: np.ndarray,
                   goal_low: np.ndarray, goal_high: np.ndarray) -> bool:
    """The finest level, kept by parent cell (:mod:`solver.validation.region_blocks`): whether no cell
    the fill reaches from the start meets the goal's cells, the verdict of the dense grid's fill."""
    i, j = (int(v) for v in np.floor((point - corner) / width))
    if not (0 <= i < size[0] and 0 <= j < size[1]):
        return False
    spread = (factor - 1) * width * math.sqrt(0.5)  # a child's centre from its parent's, at most
    index, bits = region_blocks.blocks(obstacles.vertices, obstacles.counts, obstacles.circles, reach,
                                       spread + REGION_SLACK, corner[0], corner[1], width, factor, parent,
                                       int(parent_first[0]), int(parent_first[1]), int(size[0]) // factor,
                                       int(size[1]) // factor)
    if not region_blocks.is_open(index, bits, factor, i, j):
        return False  # the start itself collides (or was not reached): the judges decide
    whole, reached = region_blocks.fill(index, bits, factor, i, j)
    g0, g1 = _cells(corner, width, goal_low, goal_high)
    return not region_blocks.meets(index, whole, reached, factor, int(g0[0]), int(g0[1]), int(g1[0]), int(g1[1]))


def warm_up() -> None:
    """Load the proof's compiled functions (from numba's cache, or compile them), as a server does before it forks."""
    square = np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]])
    closed = _closed(square, np.array([4], dtype=np.int64), np.array([[3.0, 3.0, 0.5]]), 0.1, -1.0, -1.0, 0.5, 12, 12,
                     np.zeros((0, 0), dtype=np.bool_), 1, 0, 0)
    reached, _ = _reach(closed, 0, 0)
    _closed(square, np.array([4], dtype=np.int64), np.zeros((0, 3)), 0.1, -1.0, -1.0, 0.25, 24, 24, reached, 2, 0, 0)
    index, bits = region_blocks.blocks(square, np.array([4], dtype=np.int64), np.array([[3.0, 3.0, 0.5]]), 0.1, 0.2,
                                       -1.0, -1.0, 0.25, 2, reached, 0, 0, 12, 12)
    whole, reached = region_blocks.fill(index, bits, 2, 0, 0)
    region_blocks.is_open(index, bits, 2, 0, 0)
    region_blocks.meets(index, whole, reached, 2, 0, 0, 24, 24)
