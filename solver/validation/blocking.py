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
   unblocked cells around its start; this is repeated until nothing changes, then (where the goal is left
   in reach) with the cell pairs two objects reach together (:mod:`solver.validation.cell_reach`).
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
finest cells. (What the test computes of one outline at one cell is computed once for all the pairs the
cell takes part in, an edge line stops at the first vertex that shows it decides nothing, and at the finest
cells only "blocked throughout or not" is asked: the same numbers compared, fewer of them:
:mod:`solver.validation.cell_pairs`, whose ``pair_verdicts`` is the test written out pair by pair, which the
tests hold the tables to.)
Shapes the proof does not model (cylinders) are left out, and outline pairs whose
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

from phyrogen_core.chain import Role, pose_matrix
from phyrogen_core.geometry import Box, ConvexPrism
from phyrogen_core.objects import Motion, PuzzleObject
from phyrogen_core.puzzle import Goal
from solver.planning.problem import GOAL_SLACK, LOCKED_WIDTH, shrunk_tolerance
from solver.validation import cell_pairs, cell_reach
from solver.validation.cell_pairs import refine, widest_pairs
from solver.validation.cell_reach import Runs, pair_spans

PROOF_EROSION = 0.06
"""Metres any point of an object may move from a cell's centre within the cell (cells are twice as wide)."""
LEAST_EROSION = 0.006
"""The finest cells: every cell stays wider (1.2 cm of any point's motion) than the judges' motion checks
step (0.5 cm, 1 cm: :data:`~solver.validation.judge.JUDGE_SETTINGS`, the second judge's), so a judge's
motion through a cell blocked throughout checks a state in it."""
DEEP_EROSION = 0.0005
"""The finest cells of a *deep* proof (a question asked again, :meth:`BlockingProver.proves`): 1 mm of any
point's motion, or fewer cells where that takes more than :data:`DEEP_CELLS`. They are narrower than the
judges' motion-check steps, so a run of blocked cells keeps an object on its side only when the run is at
least as wide as a cell of :data:`LEAST_EROSION` (:func:`~solver.validation.cell_reach.walls`). Continuous
Space's slivers (a bar solved at twice the margin, not at the margin) block by a few millimetres more than the
tolerance: less than the bound 1.2 cm cells leave for the motion within them."""
DEEP_CELLS = 2048
"""The most cells of one object in a deep proof (a table of two: 4 million pairs, kept while the proof runs)."""
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
    at most shift + turn r (``cell_pairs._moves``), and the joint value at each cell's centre (None for an
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


def _one_pivot(motions: np.ndarray) -> bool:
    """Whether cells with these motions (:class:`_Cells`) all turn about the same pivot."""
    return bool(np.all(motions[:, 2:] == motions[0, 2:]))


class BlockingProver:
    """Proves objects necessary by geometry (see the module docstring). Keeps what it computed about
    each object and each pair of objects, so the questions of one puzzle share it."""

    def __init__(self, erosion: float = PROOF_EROSION, fine: float = LEAST_EROSION, deep: float = DEEP_EROSION):
        self.erosion = erosion
        self.fine = max(fine, LEAST_EROSION)
        self.deep = min(deep, self.fine)
        self._failed: set[tuple] = set()  # questions the standard cells did not prove: asked again, deep
        self._outlines: dict[PuzzleObject, tuple[_Outline, ...]] = {}
        self._cells: dict[tuple, _Cells] = {}
        self._tables: dict[tuple, np.ndarray] = {}
        self._bounds: dict[tuple, tuple] = {}
        self._worlds: dict[tuple, np.ndarray] = {}
        self._widest: dict[tuple, tuple] = {}
        self._runs: dict[tuple, tuple] = {}
        self._finest_first = False  # the order the two proofs are tried in (the same answer either way)
        self._reaches: dict[int, float] = {}
        self._blocks: dict[tuple, np.ndarray | None] = {}
        self._kept: dict[int, PuzzleObject] = {}  # keys hold objects by id (hashing one costs more than a check)

    def _id(self, obj: PuzzleObject) -> int:
        key = id(obj)
        self._kept.setdefault(key, obj)  # alive as long as the prover, so no other object gets its id
        return key

    # -- per object ------------------------------------------------------------
    def outlines(self, obj: PuzzleObject) -> tuple[_Outline, ...]:
        found = self._outlines.get(id(obj))  # found: registered when it was made
        if found is None:
            found = self._outlines[self._id(obj)] = _outlines(obj)
        return found

    def _reach(self, obj: PuzzleObject) -> float:
        """:func:`_reach` of the object's outlines, kept."""
        found = self._reaches.get(id(obj))
        if found is None:
            found = self._reaches[self._id(obj)] = _reach(self.outlines(obj))
        return found

    def _joint_reach(self, obj: PuzzleObject) -> float:
        """Metres of any point's motion per unit of the object's joint, at most (as the cells are sized)."""
        return 1.0 if obj.motion is Motion.PRISMATIC else max(self._reach(obj), 1e-3)

    def free_cells(self, obj: PuzzleObject, level: int | None = None) -> _Cells:
        """A one-joint object's cells over its whole range at ``level`` (None: the finest of a standard proof):
        level 0 the widest, in which no point moves more than :attr:`erosion` from a cell's centre, each next
        level halving every cell, down to cells at least twice :attr:`fine` wide in any point's motion (a
        standard proof's finest) and further down to twice :attr:`deep` (a deep proof's, :meth:`deepest`)."""
        key = (id(obj), "levels")
        found = self._cells.get(key)
        (lower, upper), = obj.limits
        if found is None:
            self._id(obj)  # registered with its first cells (found: registered before)
            reach = self._joint_reach(obj)
            count = max(1, math.ceil((upper - lower) * reach / (2 * self.erosion)))
            halvings, deep = (max(0, math.floor(math.log2((upper - lower) * reach / count / (2 * fine))))
                              for fine in (self.fine, self.deep))
            deep = max(halvings, min(deep, math.floor(math.log2(max(1, DEEP_CELLS // count)))))
            found = self._cells[key] = (count, [None] * (deep + 1), halvings)
        count, levels, finest = found
        level = finest if level is None else level
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

    def deepest(self, obj: PuzzleObject) -> _Cells:
        """A one-joint object's cells at a deep proof's finest level."""
        self.free_cells(obj, 0)
        return self.free_cells(obj, len(self._cells[(self._id(obj), "levels")][1]) - 1)

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
        key = (id(obj), where)  # (entries' objects are registered: free_cells, placed)
        found = self._worlds.get(key)
        if found is None:
            found = self._worlds[key] = np.ascontiguousarray(np.stack(
                [cells.poses[:, 0], cells.poses[:, 1], np.cos(cells.poses[:, 2]), np.sin(cells.poses[:, 2])], axis=1))
        return found

    # -- per pair ----------------------------------------------------------------
    def _box(self, obj: PuzzleObject, where: tuple, cells: _Cells) -> tuple[float, float, float, float]:
        """The (x, y) bounds of everything the object covers over its cells: low x, low y, high x, high y."""
        key = (id(obj), where)
        found = self._bounds.get(key)
        if found is None:
            rho = self._reach(obj)
            low = cells.poses[:, :2].min(axis=0) - rho
            high = cells.poses[:, :2].max(axis=0) + rho
            found = self._bounds[key] = (float(low[0]), float(low[1]), float(high[0]), float(high[1]))
        return found

    def _shape(self, obj: PuzzleObject, where: tuple, cells: _Cells, index: int) -> tuple:
        """The object's outline ``index`` at all its ``cells``, every level from the widest down to theirs in
        one run (a free object) or at its one pose, as :mod:`~solver.validation.cell_pairs` takes it, each cell
        prepared when a pair first asks it; where each level's cells start; whether every cell turns about
        one pivot. Kept for the prover's questions."""
        free = cells.values is not None
        key = (id(obj), where)
        run = self._runs.get(key)
        if run is None or run[0] is not cells:  # a level once made stays: the deepest stands for all
            levels = self._levels(obj, cells)
            frames = np.concatenate([self._frames(obj, ("level", level.level) if free else where, level)
                                     for level in levels])
            motions = np.concatenate([level.motions for level in levels])
            bases = np.cumsum([0, *(len(level.poses) for level in levels[:-1])]).astype(np.int64)
            run = self._runs[key] = (cells, frames, motions, bases, _one_pivot(motions), {})
        _, frames, motions, bases, one, shapes = run
        shape = shapes.get(index)
        if shape is None:
            outline = self.outlines(obj)[index]
            n, k = len(frames), len(outline.vertices)
            shape = shapes[index] = (outline.vertices, outline.normals, frames, motions, np.empty((n, k, 2)),
                                     np.empty((n, k, 2)), np.empty((n, k)), np.empty((n, k)),
                                     np.zeros(n, dtype=np.bool_))
        return shape, bases, one

    def _blocked_pairs(self, a, index_a: int, b, index_b: int, table: np.ndarray, threshold: float,
                       sides: int) -> bool:
        """Marks in ``table`` the cell pairs where outline ``index_a`` of a and ``index_b`` of b collide
        throughout, found coarse to fine: a coarse pair blocked throughout marks all its fine pairs, one
        apart throughout is dropped, and only the rest are halved (each side that has finer cells) and
        tested again (``cell_pairs.refine``). False when that would take more than :data:`PAIR_WORK` (nothing
        marked then)."""
        (obj_a, where_a, cells_a), (obj_b, where_b, cells_b) = a, b
        key = (id(obj_a), cells_a.values is None and where_a, id(obj_b), cells_b.values is None
               and where_b, index_a, index_b, threshold)
        widest = self._widest.get(key)
        shape_a, bases_a, one_a = self._shape(obj_a, where_a, cells_a, index_a)
        shape_b, bases_b, one_b = self._shape(obj_b, where_b, cells_b, index_b)
        if widest is None:  # the widest cells' verdicts, kept: the widest proof asks them first
            outline_a, outline_b = self.outlines(obj_a)[index_a], self.outlines(obj_b)[index_b]
            count_a, count_b = (int(bases[1]) if len(bases) > 1 else len(shape[2]) for shape, bases in
                                ((shape_a, bases_a), (shape_b, bases_b)))
            i, j, verdicts, within = widest_pairs(shape_a, count_a, *outline_a.centre, outline_a.radius, shape_b,
                                                  count_b, *outline_b.centre, outline_b.radius, one_a, one_b,
                                                  threshold, sides, PAIR_WORK)
            verdicts = verdicts if within else None
            widest = self._widest[key] = (i, j, verdicts, within and not verdicts.any())
        i, j, verdicts, apart = widest
        if verdicts is None:  # more than PAIR_WORK at the widest cells alone
            return False
        if apart:  # every widest pair apart (or none near): nothing to halve, nothing marked
            return True
        return refine(shape_a, bases_a, shape_b, bases_b, one_a, one_b, i, j, verdicts, threshold, sides,
                       len(i) * sides, PAIR_WORK, table)

    def table(self, a: tuple[PuzzleObject, tuple, _Cells], b: tuple[PuzzleObject, tuple, _Cells],
              shrink: float) -> np.ndarray:
        """(cells of a, cells of b): whether a there overlaps b there wherever in both cells they are."""
        id_a, id_b = id(a[0]), id(b[0])
        key = (id_a, a[1], id_b, b[1], shrink)
        found = self._tables.get(key)
        if found is not None:
            return found
        flipped = self._tables.get((id_b, b[1], id_a, a[1], shrink))
        if flipped is not None:
            return flipped.T
        (obj_a, where_a, cells_a), (obj_b, where_b, cells_b) = a, b
        shape = (len(cells_a.poses), len(cells_b.poses))
        box_a, box_b = self._box(obj_a, where_a, cells_a), self._box(obj_b, where_b, cells_b)
        near = box_a[0] < box_b[2] and box_a[1] < box_b[3] and box_b[0] < box_a[2] and box_b[1] < box_a[3]
        # Never near: no cell pair; a large table (a deep proof's) then takes no memory.
        table = np.zeros(shape, dtype=bool) if near or shape[0] * shape[1] < 1 << 16 else \
            np.broadcast_to(np.zeros((1, 1), dtype=bool), shape)
        if near:
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

    def _blocking(self, a, b, shrink: float) -> np.ndarray | None:
        """:meth:`table`, or None when it blocks no cell pair. Kept; a table asked the other way round is the
        kept one's transposed view (the compiled readers take either)."""
        key = (id(a[0]), a[1], id(b[0]), b[1], shrink)
        found = self._blocks.get(key, False)
        if found is False:
            flipped = self._blocks.get((key[2], key[3], key[0], key[1], shrink), False)
            if flipped is not False:
                found = None if flipped is None else flipped.T
            else:
                table = self.table(a, b, shrink)
                # (A table never near is a view of one False: .any() over it crawls, ~4x a contiguous table's.)
                found = table if table.strides != (0, 0) and table.any() else None
            self._blocks[key] = found
        return found

    # -- the proof ---------------------------------------------------------------
    def proves(self, objects: Sequence[PuzzleObject], goal: Goal, fixed: Sequence[str], shrink: float) -> bool:
        """Whether, with the objects ``fixed`` held at their start pose and every shape shrunk by
        ``shrink`` metres, no valid state with the target at its goal can be reached from the start.

        A question this prover failed to prove before, asked again, is tried once more with the cells of a
        deep proof (:data:`DEEP_EROSION`): the judge asks again only where a search is due that a sliver of
        slack may make long (:func:`~solver.validation.judge.judge`), so cheap questions stay cheap."""
        question = (tuple(self._id(obj) for obj in objects), goal.target, tuple(sorted(goal.values.items())),
                    goal.tolerance, frozenset(fixed), shrink)
        if question in self._failed:
            return self._proves(objects, goal, fixed, shrink, deep=True)
        if self._proves(objects, goal, fixed, shrink, deep=False):
            return True
        self._failed.add(question)
        return False

    def _proves(self, objects: Sequence[PuzzleObject], goal: Goal, fixed: Sequence[str], shrink: float,
                deep: bool) -> bool:
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
        if deep:  # the standard proof failed: only finer cells can prove more
            finer = [(obj, ("level", cells.level), cells) for obj, _, _ in free
                     for cells in (self.deepest(obj),)]
            kept = set(self._tables), set(self._blocks)
            proven = any(a[2].level > b[2].level for a, b in zip(finer, free, strict=True)) and \
                self._settled((finer,), points, target, goal, shrink) is not None
            self._forget(*kept)
            return proven
        if not any(cells.level for _, _, cells in free):
            return self._settled((free,), points, target, goal, shrink) is not None
        # A proof holds at the widest cells or at the finest (either will do: the answer is the same in either
        # order). The widest first, where most proofs that hold hold (every one of Grid World's), at a
        # fraction of the finest cells' cost; after a proof that held only at the finest, the finest first
        # (Lockbox Random's hold there, and the finest tables' widest verdicts are the widest tables').
        widest = [(obj, ("level", 0), self.free_cells(obj, 0)) for obj, _, _ in free]
        held = self._settled((free, widest) if self._finest_first else (widest, free), points, target, goal, shrink)
        if held == 1:  # held at the second cells tried only: those first next time
            self._finest_first = not self._finest_first
        return held is not None

    def _forget(self, tables: set, blocks: set) -> None:
        """Drops the tables made since the prover held only these keys (a deep proof's: large, seldom reused)."""
        for made, before in ((self._tables, tables), (self._blocks, blocks)):
            for key in set(made) - before:
                del made[key]

    def _settled(self, levels, points, target: int | None, goal: Goal, shrink: float) -> int | None:
        """Steps 2 and 3 of the module docstring over the free objects' cells at each of ``levels``: the index of
        the first whose cells leave no goal state, or None. The reach of objects one at a time at every level
        first; only where that leaves a goal state at each, of pairs too (dearer), from where it stopped (a
        proof either way: the answer is the same in any order, and Lockbox Random's pairs never prove more)."""
        runs = []
        for index, free in enumerate(levels):
            runs.append(self._narrowed(free, points, shrink))
            if runs[-1] is not None and self._emptied(free, points, _domains(free, runs[-1], target, goal), shrink):
                return index
        for index, (free, run) in enumerate(zip(levels, runs, strict=True)):
            if run is not None and self._paired(run) and \
                    self._emptied(free, points, _domains(free, run, target, goal), shrink):
                return index
        return None

    def _narrowed(self, free, points, shrink: float) -> Runs | None:
        """Per free object, its run of reachable cells (step 2 of the module docstring: first and last), with
        what :meth:`_paired` resumes from; None when a start cell itself is blocked (the model and the proof
        disagree: no proof)."""
        starts = []
        for obj, _, cells in free:
            (lo, hi), = obj.limits
            start = min(max(0.0, lo), hi)
            starts.append(min(len(cells.poses) - 1, int((start - cells.lower) // cells.width)) if cells.width else 0)
        # Walls: runs of blocked cells at least 1.2 cm of motion wide, which no judge's motion step jumps.
        steps = [max(1, math.ceil(2 * LEAST_EROSION / self._joint_reach(obj) / cells.width - 1e-9))
                 if cells.width else 1 for obj, _, cells in free]
        fixed_blocks = []
        for entry in free:
            blocked = np.zeros(len(entry[2].poses), dtype=bool)
            for point in points:
                blocked |= self.table(entry, point, shrink)[:, 0]
            fixed_blocks.append(blocked)
        # Each reach is one run of cells (spans: first and last); a table with no cell pair blocked blocks nothing.
        spans = [(0, len(entry[2].poses) - 1) for entry in free]
        tables = {(i, k): table for i, entry in enumerate(free) for k, other in enumerate(free)
                  if k != i and (table := self._blocking(entry, other, shrink)) is not None}
        runs = Runs(spans, list(fixed_blocks), fixed_blocks, tables, starts, steps)
        return runs if runs.swept() else None

    @staticmethod
    def _paired(runs: Runs) -> bool:
        """Narrows :meth:`_narrowed`'s runs: two objects keep each other to the cell pairs they reach together
        (cell_reach), then the runs one by one again, until neither narrows: whether any did (no start blocked).
        (Not at a deep proof's cells: a flood through them costs a hundred times more, for few proofs.)"""
        spans, blocks, tables, starts, steps = runs.spans, runs.blocks, runs.tables, runs.starts, runs.steps
        narrowed = False
        while True:
            changed = False
            for i, k in [(i, k) for i, k in tables if i < k and steps[i] == steps[k] == 1]:
                pair = pair_spans(tables[i, k], blocks[i], blocks[k], spans[i], spans[k], starts[i], starts[k],
                                  steps[i], steps[k])
                if pair != (spans[i], spans[k]):
                    (spans[i], spans[k]), changed = pair, True
            if not changed:
                return narrowed
            narrowed = True
            if not runs.swept():
                return False

    def _emptied(self, free, points, domains: list[np.ndarray], shrink: float) -> bool:
        """Arc consistency over goal states (step 3): whether some object is left without cells."""
        for i, entry in enumerate(free):
            for point in points:
                domains[i] &= ~self.table(entry, point, shrink)[:, 0]
        return cell_reach.emptied(domains, {(i, k): table for i, entry in enumerate(free) for k, other in
                                            enumerate(free) if k != i and
                                            (table := self._blocking(entry, other, shrink)) is not None})


def _domains(free, runs: Runs, target: int | None, goal: Goal) -> list[np.ndarray]:
    """Per free object, the cells of its run, the target's only those within its goal's tolerance."""
    domains = []
    for (_, _, cells), (left, right) in zip(free, runs.spans, strict=True):
        domains.append(np.zeros(len(cells.poses), dtype=bool))
        domains[-1][left:right + 1] = True
    if target is not None:
        obj, _, cells = free[target]
        (value,) = (goal.values[j] for j in obj.joint_names)
        near = goal.tolerance + GOAL_SLACK
        low = cells.lower + cells.width * np.arange(len(domains[target]))
        domains[target] &= (low <= value + near) & (low + cells.width >= value - near)
    return domains


def warm_up() -> None:
    """Load the proof's compiled test (from numba's cache, or compile it), as a server does before it forks."""
    cell_pairs.warm_up()
    cell_reach.warm_up()
