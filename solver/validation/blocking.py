"""A geometric proof that objects held fixed keep the target from its goal: necessity without search.

The judges (:mod:`solver.validation.judge`) show necessity by failing to find a path within a
budget: evidence, as strong as the search. Many questions the Maker asks have a plain
geometric answer: a fixed box stands where the target's goal pose is, or where an object must
go to let the target by. :class:`BlockingProver` looks for such an answer, as a proof:

1. Every one-joint object gets its joint range cut into cells (at least 1.2 cm of any point's motion wide,
   wider than a judge's motion-check step, so no judge's motion jumps a cell). Fixed, locked and static
   objects stand at their one pose.
2. *Reachable cells.* A cell of an object is blocked when the object, anywhere in the cell,
   collides with an object that is fixed, or with an object in every cell that object can reach. A
   one-joint object passes every value between two others, so it can reach only the run of
   unblocked cells around its start; this is repeated until nothing changes.
3. *Goal states.* With the target's goal joints at their goal values, every object's cells
   are pruned by arc consistency: a cell stays only while, for every other object, some cell
   of it left is clear of this one. An object left without cells means no valid goal state
   can be reached: the objects held fixed are necessary.

"Collides anywhere in the cell" is the collision kernel's own test (every edge line of either
convex outline has the other outline more than the tolerance beyond it; the tolerance stands for
every shape shrunk by ``s``, :func:`~solver.planning.problem.shrunk_tolerance`), shown at the
cells' centres with a bound for the motion within: in one outline's frame its extent along its own
edge normal is fixed, and every vertex of the other moves by at most its own object's move plus
the first frame's (a shift, plus a turn times the point's distance from the pivot), so that
vertex's projection is raised by that much before the test. A cell pair is tested widest cells
first; only a pair neither blocked nor apart throughout is halved and tested again, down to the
finest cells. Shapes the proof does not model (cylinders) are left out, and outline pairs whose
table would cost more than :data:`PAIR_WORK` projections, which can only make it find less;
objects with more than one free joint take no part (they could be anywhere), unless every joint
of the target is pinned by its goal. So the prover may fail to prove a necessary object necessary
(the judges then decide), never the other way round.

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
from solver.planning.problem import GOAL_SLACK, LOCKED_WIDTH, shrunk_tolerance

PROOF_EROSION = 0.06
"""Metres any point of an object may move from a cell's centre within the cell (cells are twice as wide)."""
LEAST_EROSION = 0.006
"""The finest cells: every cell stays wider (1.2 cm of any point's motion) than the judges' motion checks
step (0.5 cm, 1 cm: :data:`~solver.validation.judge.JUDGE_SETTINGS`, the second judge's), so a judge's
motion through a cell blocked throughout checks a state in it."""
PROOF_SLACK = 1e-6
"""Metres added to the judge's tolerance: a pair proven colliding collides by more than the rounding
between the proof's and the collision model's coordinates."""
PAIR_WORK = 3_000_000
"""The most vertex projections one outline pair's table may take (near cell pairs times axes times
vertices): a pair of many-sided outlines close together over many cells (Lockbox Random's slotted
discs) is left out rather than paid for; a budget in counts, so the same question gets the same answer."""


@dataclass(frozen=True)
class _Outline:
    vertices: np.ndarray  # (k, 2) counter-clockwise, in the object's frame
    normals: np.ndarray  # (k, 2) outward unit normals of the edges from each vertex
    z_low: float
    z_high: float
    radius: float  # the farthest vertex from the vertices' mean
    centre: tuple[float, float]  # the vertices' mean


@dataclass(frozen=True)
class _Cells:
    """Where an object may stand: frame poses (n, 3) of (x, y, yaw) at each cell's centre, how far the
    object may move from there within the cell, ``motions`` (n, 4): its frame's shift (metres), its
    turn (radians) and the pivot (x, y) of the turn, so that a point at distance r from the pivot moves
    at most shift + turn r (:func:`_moves`), and the joint value at each cell's centre (None for an
    object at one pose)."""

    poses: np.ndarray
    motions: np.ndarray
    values: np.ndarray | None
    lower: float = 0.0
    width: float = 0.0  # of one cell, in joint units
    level: int = 0  # the range cut into 2 ** level times as many cells as the widest (0 for one pose too)


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
    radius = float(np.max(np.linalg.norm(vertices - vertices.mean(axis=0), axis=1)))
    centre = vertices.mean(axis=0)
    return _Outline(np.ascontiguousarray(vertices), np.ascontiguousarray(normals), z_low, z_high, radius,
                    (float(centre[0]), float(centre[1])))


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


@njit(cache=True, nogil=True, inline='always')
def _moves(px, py, motion_a, motion_b):
    """How far the point (px, py) can move, relative to either object's frame, while both objects stay
    in their cells: each object's own part is its frame's shift plus its turn times the point's distance
    from its pivot (:class:`_Cells`)."""
    return (motion_a[0] + motion_a[1] * math.hypot(px - motion_a[2], py - motion_a[3])
            + motion_b[0] + motion_b[1] * math.hypot(px - motion_b[2], py - motion_b[3]))


APART, BLOCKED, UNSURE = 0, 1, 2
"""A cell pair's verdict: the outlines collide nowhere in it, everywhere in it, or neither is shown."""


@njit(cache=True, nogil=True, inline='always')
def _place(local, frame, out):
    """``local`` (k, 2) points in the world at ``frame`` (x, y, cos, sin), into ``out``."""
    for j in range(local.shape[0]):
        out[j, 0] = frame[0] + frame[2] * local[j, 0] - frame[3] * local[j, 1]
        out[j, 1] = frame[1] + frame[3] * local[j, 0] + frame[2] * local[j, 1]


@njit(cache=True, nogil=True)
def _pair_verdicts(local_a, normals_a, frames_a, ma, local_b, normals_b, frames_b, mb, first, second,
                   threshold):  # pragma: no cover (compiled)
    """Whether outline a at cell ``first[p]`` and outline b at cell ``second[p]`` collide wherever in
    both cells the objects are (:data:`BLOCKED`), nowhere (:data:`APART`) or neither is shown, by the
    collision kernel's own test: every edge line of either outline has the other outline more than
    ``threshold`` beyond it (:func:`solver.collision.kernels._pair_collides`).

    Vertices ``local_a`` (k, 2) and outward normals ``normals_a`` are in the object's frame, placed at
    each cell's centre by ``frames_a`` (cells, 4: x, y, cos, sin); ``ma`` (cells, 4) says how each cell
    moves the object (:class:`_Cells`). In a's frame a's extent along its own normal is fixed, and each
    vertex of b moves by at most :func:`_moves` of it, so b's least projection moves by at most that
    much: the test holds everywhere when it holds at the centres with each of b's projections raised by
    its vertex's move (and the same in b's frame), and fails everywhere when one edge line fails with
    them lowered."""
    out = np.empty(len(first), dtype=np.int8)
    va, vb = np.empty(local_a.shape), np.empty(local_b.shape)
    na, nb = np.empty(normals_a.shape), np.empty(normals_b.shape)
    shift_a, shift_b = np.empty(va.shape[0]), np.empty(vb.shape[0])
    for p in range(len(first)):
        a, b = first[p], second[p]
        _place(local_a, frames_a[a], va)
        _place(local_b, frames_b[b], vb)
        for k in range(na.shape[0]):
            na[k, 0] = frames_a[a, 2] * normals_a[k, 0] - frames_a[a, 3] * normals_a[k, 1]
            na[k, 1] = frames_a[a, 3] * normals_a[k, 0] + frames_a[a, 2] * normals_a[k, 1]
        for k in range(nb.shape[0]):
            nb[k, 0] = frames_b[b, 2] * normals_b[k, 0] - frames_b[b, 3] * normals_b[k, 1]
            nb[k, 1] = frames_b[b, 3] * normals_b[k, 0] + frames_b[b, 2] * normals_b[k, 1]
        for j in range(va.shape[0]):
            shift_a[j] = _moves(va[j, 0], va[j, 1], ma[a], mb[b])
        for j in range(vb.shape[0]):
            shift_b[j] = _moves(vb[j, 0], vb[j, 1], ma[a], mb[b])
        verdict = BLOCKED
        for side in range(2):
            own, normals = (va, na) if side == 0 else (vb, nb)
            other, shift = (vb, shift_b) if side == 0 else (va, shift_a)
            for k in range(normals.shape[0]):
                nx, ny = normals[k, 0], normals[k, 1]
                extent = -np.inf
                for j in range(own.shape[0]):
                    extent = max(extent, nx * own[j, 0] + ny * own[j, 1])
                raised = lowered = np.inf
                for j in range(other.shape[0]):
                    projection = nx * other[j, 0] + ny * other[j, 1]
                    raised = min(raised, projection + shift[j])
                    lowered = min(lowered, projection - shift[j])
                if extent - lowered <= threshold:
                    verdict = APART
                    break
                if extent - raised <= threshold:
                    verdict = UNSURE
            if verdict == APART:
                break
        out[p] = verdict
    return out


def _centres(outline: _Outline, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The outline's vertices' mean (the centre of its bounding circle) at each frame: x (n,), y (n,)."""
    x, y = outline.centre
    return frames[:, 0] + frames[:, 2] * x - frames[:, 3] * y, frames[:, 1] + frames[:, 3] * x + frames[:, 2] * y


def _centre_moves(centres: tuple[np.ndarray, np.ndarray], cells: _Cells) -> np.ndarray:
    """How far each cell's outline centre (x (n,), y (n,)) may move within its cell."""
    return cells.motions[:, 0] + cells.motions[:, 1] * np.hypot(centres[0] - cells.motions[:, 2],
                                                                centres[1] - cells.motions[:, 3])


class BlockingProver:
    """Proves objects necessary by geometry (see the module docstring). Keeps what it computed about
    each object and each pair of objects, so the questions of one puzzle share it."""

    def __init__(self, erosion: float = PROOF_EROSION, fine: float = LEAST_EROSION):
        self.erosion = erosion
        self.fine = max(fine, LEAST_EROSION)
        self._outlines: dict[PuzzleObject, tuple[_Outline, ...]] = {}
        self._cells: dict[tuple, _Cells] = {}
        self._tables: dict[tuple, np.ndarray] = {}
        self._bounds: dict[tuple, np.ndarray] = {}
        self._worlds: dict[tuple, np.ndarray] = {}
        self._widest: dict[tuple, tuple] = {}
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

    def free_cells(self, obj: PuzzleObject, level: int | None = None) -> _Cells:
        """A one-joint object's cells over its whole range at ``level`` (None: the finest): level 0 the
        widest, in which no point moves more than :attr:`erosion` from a cell's centre, each next level
        halving every cell, down to cells at least twice :attr:`fine` wide in any point's motion."""
        key = (self._id(obj), "levels")
        found = self._cells.get(key)
        (lower, upper), = obj.limits
        if found is None:
            reach = 1.0 if obj.motion is Motion.PRISMATIC else max(_reach(self.outlines(obj)), 1e-3)
            count = max(1, math.ceil((upper - lower) * reach / (2 * self.erosion)))
            halvings = max(0, math.floor(math.log2((upper - lower) * reach / count / (2 * self.fine))))
            found = self._cells[key] = (count, [None] * (halvings + 1))
        count, levels = found
        level = len(levels) - 1 if level is None else level
        if levels[level] is None:
            count <<= level
            width = (upper - lower) / count
            values = lower + width * (np.arange(count) + 0.5)
            poses = _frame_poses(obj, values)
            motions = np.zeros((count, 4))
            motions[:, 2:] = poses[:, :2]
            motions[:, 0 if obj.motion is Motion.PRISMATIC else 1] = width / 2
            levels[level] = _Cells(poses, motions, values, lower, width, level)
        return levels[level]

    def _levels(self, obj: PuzzleObject, cells: _Cells) -> tuple[_Cells, ...]:
        """The object's cells at every level down to ``cells``', widest first (one pose: itself)."""
        return tuple(self.free_cells(obj, level) for level in range(cells.level + 1)) if cells.values is not None \
            else (cells,)

    def placed(self, obj: PuzzleObject, values: tuple[float, ...], spread: float = 0.0) -> _Cells:
        """An object at one pose: its joints at ``values`` (none for a fixed object), each joint within
        ``spread`` of its value (a target at its goal, within the goal's tolerance)."""
        key = (self._id(obj), values, spread)
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
            # The frame shifts by at most the spread along each of its translations, and turns by the spread.
            moves = obj.motion in (Motion.SE2, Motion.R2) or obj.motion is Motion.PRISMATIC
            turns = obj.motion is Motion.REVOLUTE or obj.motion is Motion.SE2 and len(values) > 2
            shift = spread * math.sqrt(2.0) if moves else 0.0
            motion = np.array([[shift, spread if turns else 0.0, pose[0], pose[1]]])
            found = self._cells[key] = _Cells(pose[None, :], motion, None)
        return found

    def _frames(self, obj: PuzzleObject, where: tuple, cells: _Cells) -> np.ndarray:
        """The object's frame at each cell's centre: (n, 4) of x, y and the yaw's cosine and sine."""
        key = (self._id(obj), where)
        found = self._worlds.get(key)
        if found is None:
            found = self._worlds[key] = np.ascontiguousarray(np.stack(
                [cells.poses[:, 0], cells.poses[:, 1], np.cos(cells.poses[:, 2]), np.sin(cells.poses[:, 2])], axis=1))
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

    def _blocked_pairs(self, a, index_a: int, b, index_b: int, table: np.ndarray, threshold: float,
                       sides: int) -> bool:
        """Marks in ``table`` the cell pairs where outline ``index_a`` of a and ``index_b`` of b collide
        throughout, found coarse to fine: a coarse pair blocked throughout marks all its fine pairs, one
        apart throughout is dropped, and only the rest are halved (each side that has finer cells) and
        tested again. False when that would take more than :data:`PAIR_WORK` (nothing marked then)."""
        (obj_a, where_a, cells_a), (obj_b, where_b, cells_b) = a, b
        levels_a, levels_b = self._levels(obj_a, cells_a), self._levels(obj_b, cells_b)
        depth = max(len(levels_a), len(levels_b))
        found_i, found_j, spent = [], [], 0
        i = j = None
        outline_a, outline_b = self.outlines(obj_a)[index_a], self.outlines(obj_b)[index_b]
        for step in range(depth):
            la, lb = min(step, len(levels_a) - 1), min(step, len(levels_b) - 1)
            frames_a = self._frames(obj_a, ("level", la) if cells_a.values is not None else where_a, levels_a[la])
            frames_b = self._frames(obj_b, ("level", lb) if cells_b.values is not None else where_b, levels_b[lb])
            if i is None:  # the widest cells (their verdicts kept: the widest proof asks them first)
                key = (self._id(obj_a), cells_a.values is None and where_a, self._id(obj_b), cells_b.values is None
                       and where_b, index_a, index_b, threshold)
                widest = self._widest.get(key)
                if widest is None:
                    # The pairs whose bounding circles can meet somewhere in their cells.
                    centre_a, centre_b = _centres(outline_a, frames_a), _centres(outline_b, frames_b)
                    reach = (outline_a.radius + outline_b.radius + _centre_moves(centre_a, levels_a[la])[:, None]
                             + _centre_moves(centre_b, levels_b[lb])[None])
                    dx, dy = centre_a[0][:, None] - centre_b[0][None], centre_a[1][:, None] - centre_b[1][None]
                    i, j = np.nonzero(dx * dx + dy * dy < reach * reach)
                    verdicts = None if len(i) * sides > PAIR_WORK else _pair_verdicts(
                        outline_a.vertices, outline_a.normals, frames_a, levels_a[la].motions, outline_b.vertices,
                        outline_b.normals, frames_b, levels_b[lb].motions, i, j, threshold)
                    widest = self._widest[key] = (i, j, verdicts)
                i, j, verdicts = widest
            else:
                verdicts = _pair_verdicts(outline_a.vertices, outline_a.normals, frames_a, levels_a[la].motions,
                                          outline_b.vertices, outline_b.normals, frames_b, levels_b[lb].motions, i, j,
                                          threshold)
            spent += len(i) * sides
            if spent > PAIR_WORK:
                return False
            blocked = verdicts == BLOCKED
            scale_a, scale_b = 1 << (len(levels_a) - 1 - la), 1 << (len(levels_b) - 1 - lb)
            found_i.append((i[blocked], scale_a))
            found_j.append((j[blocked], scale_b))
            unsure = verdicts == UNSURE
            i, j = i[unsure], j[unsure]
            if step + 1 < depth:
                split_a, split_b = la + 1 < len(levels_a), lb + 1 < len(levels_b)
                if split_a:
                    i, j = np.concatenate([2 * i, 2 * i + 1]), np.concatenate([j, j])
                if split_b:
                    i, j = np.concatenate([i, i]), np.concatenate([2 * j, 2 * j + 1])
        for (rows, scale_a), (columns, scale_b) in zip(found_i, found_j, strict=True):
            if len(rows):
                rows = (rows[:, None] * scale_a + np.arange(scale_a)[None])[:, :, None]
                columns = (columns[:, None] * scale_b + np.arange(scale_b)[None])[:, None, :]
                table[rows, columns] = True
        return True

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
            for index_a, outline_a in enumerate(self.outlines(obj_a)):
                for index_b, outline_b in enumerate(self.outlines(obj_b)):
                    if min(outline_a.z_high, outline_b.z_high) - max(outline_a.z_low, outline_b.z_low) <= tolerance:
                        continue
                    sides = (len(outline_a.vertices) + len(outline_b.vertices)) * max(len(outline_a.vertices),
                                                                                     len(outline_b.vertices))
                    # A pair too dear to tabulate is left out, which can only prove less.
                    self._blocked_pairs(a, index_a, b, index_b, table, tolerance + PROOF_SLACK, sides)
        self._tables[key] = table
        return table

    # -- the proof ---------------------------------------------------------------
    def proves(self, objects: Sequence[PuzzleObject], goal: Goal, fixed: Sequence[str], shrink: float) -> bool:
        """Whether, with the objects ``fixed`` held at their start pose and every shape shrunk by
        ``shrink`` metres, no valid state with the target at its goal can be reached from the start."""
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
                elif set(goal.values) == set(obj.joint_names):
                    values = tuple(goal.values[j] for j in obj.joint_names)
                    goal_point = (obj, values, self.placed(obj, values, goal.tolerance + GOAL_SLACK))
                    continue
                else:
                    return False
            if locked:
                points.append((obj, start, self.placed(obj, start)))
            elif len(obj.limits) == 1:
                free.append((obj, ("level", self.free_cells(obj).level), self.free_cells(obj)))
            # an object free in several joints could be anywhere: it takes no part
        if target is None and goal_point is None:
            return False
        if goal_point is not None:
            points = [*points, goal_point]
        # The widest cells first: most proofs that hold (every one of Grid World's) hold there, at a
        # fraction of the finest cells' cost.
        widest = [(obj, ("level", 0), self.free_cells(obj, 0)) for obj, _, _ in free]
        return any(self._settled(entries, points, target, goal, shrink)
                   for entries in ((widest, free) if any(cells.level for _, _, cells in free) else (free,)))

    def _settled(self, free, points, target: int | None, goal: Goal, shrink: float) -> bool:
        """Steps 2 and 3 of the module docstring over the cells of ``free``: whether no goal state is left."""
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
        # Each reach is one run of cells (spans: first and last); a table with no cell pair blocked blocks nothing.
        spans = [(0, len(mask) - 1) for mask in reach]
        tables = {(i, k): table for i, entry in enumerate(free) for k, other in enumerate(free)
                  if k != i and (table := self.table(entry, other, shrink)).any()}
        changed = True
        while changed:
            changed = False
            for i in range(len(free)):
                blocked = fixed_blocks[i].copy()
                for k in range(len(free)):
                    if (i, k) in tables:
                        blocked |= tables[i, k][:, spans[k][0]:spans[k][1] + 1].all(axis=1)
                start = starts[i]
                if blocked[start]:
                    return None
                before, after = np.flatnonzero(blocked[:start]), np.flatnonzero(blocked[start + 1:])
                left = max(spans[i][0], before[-1] + 1 if len(before) else 0)
                right = min(spans[i][1], start + after[0] if len(after) else len(blocked) - 1)
                if (left, right) != spans[i]:
                    spans[i], changed = (left, right), True
                    reach[i] = np.zeros_like(blocked)
                    reach[i][left:right + 1] = True
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
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    normals = np.array([[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    index = np.zeros(1, dtype=np.int64)
    frames, motions = np.array([[0.0, 0.0, 1.0, 0.0]]), np.zeros((1, 4))
    _pair_verdicts(square, normals, frames, motions, square, normals, frames, motions, index, index, 0.0)
