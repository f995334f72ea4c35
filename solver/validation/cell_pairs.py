"""The compiled cell-pair test of :class:`~solver.validation.blocking.BlockingProver`: whether two convex
outlines, each anywhere in a cell of its object's motion, collide throughout, nowhere, or neither is shown.

:func:`pair_verdicts` is the test written out pair by pair (the reference the tests hold the rest to);
:func:`widest_pairs` and :func:`refine` build a table coarse to fine with the very same numbers compared,
fewer of them (see :mod:`solver.validation.blocking`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, inline='always')
def _moves(px, py, motion_a, motion_b):
    """How far the point (px, py) can move, relative to either object's frame, while both objects stay
    in their cells: each object's own part is its frame's shift plus its turn times the point's distance
    from its pivot (:class:`~solver.validation.blocking._Cells`)."""
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
def pair_verdicts(local_a, normals_a, frames_a, ma, local_b, normals_b, frames_b, mb, first, second,
                   threshold):  # pragma: no cover (compiled)
    """Whether outline a at cell ``first[p]`` and outline b at cell ``second[p]`` collide wherever in
    both cells the objects are (:data:`BLOCKED`), nowhere (:data:`APART`) or neither is shown, by the
    collision kernel's own test: every edge line of either outline has the other outline more than
    ``threshold`` beyond it (:func:`solver.collision.kernels._pair_collides`).

    Vertices ``local_a`` (k, 2) and outward normals ``normals_a`` are in the object's frame, placed at
    each cell's centre by ``frames_a`` (cells, 4: x, y, cos, sin); ``ma`` (cells, 4) says how each cell
    moves the object (``blocking._Cells``). In a's frame a's extent along its own normal is fixed, and each
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


@njit(cache=True, nogil=True)
def _ready(local, normals, frames, motions, vertices, turned, extents, turns, done, c):
    """Prepares cell ``c`` of an outline's shape (``BlockingProver._shape``) when first asked: what
    :func:`pair_verdicts` computes of the outline at a cell, kept for every pair the cell takes part in (its
    vertices and normals in the world, its extent along each of its own normals, each vertex's own turn part
    of :func:`_moves`), by the same expressions, so the verdicts compare the very same numbers. (Arrays one
    by one and cells by index: a tuple unpacked or a row taken costs reference counts in every call.)"""
    if done[c]:
        return
    k = local.shape[0]
    for j in range(k):
        vertices[c, j, 0] = frames[c, 0] + frames[c, 2] * local[j, 0] - frames[c, 3] * local[j, 1]
        vertices[c, j, 1] = frames[c, 1] + frames[c, 3] * local[j, 0] + frames[c, 2] * local[j, 1]
        turned[c, j, 0] = frames[c, 2] * normals[j, 0] - frames[c, 3] * normals[j, 1]
        turned[c, j, 1] = frames[c, 3] * normals[j, 0] + frames[c, 2] * normals[j, 1]
    for m in range(k):
        extent = -np.inf
        for j in range(k):
            extent = max(extent, turned[c, m, 0] * vertices[c, j, 0] + turned[c, m, 1] * vertices[c, j, 1])
        extents[c, m] = extent
    for j in range(k):
        turns[c, j] = motions[c, 1] * math.hypot(vertices[c, j, 0] - motions[c, 2], vertices[c, j, 1] - motions[c, 3])
    done[c] = True


@njit(cache=True, nogil=True)
def _away(vertices, c, j, motions, cell, one_pivot, memo, done):
    """The distance of vertex ``j`` at cell ``c`` from the other object's pivot at its ``cell``; kept per
    cell in ``memo`` when that object turns about one pivot in every cell (a revolute joint's axis)."""
    if not one_pivot:
        return math.hypot(vertices[c, j, 0] - motions[cell, 2], vertices[c, j, 1] - motions[cell, 3])
    if not done[c]:
        for m in range(vertices.shape[1]):
            memo[c, m] = math.hypot(vertices[c, m, 0] - motions[0, 2], vertices[c, m, 1] - motions[0, 3])
        done[c] = True
    return memo[c, j]


@njit(cache=True, nogil=True)
def _side(turned, extents, c, vertices, d, threshold, hint, shift, known, tag, own_turns, of_first, first, second,
          cross, motions, cell, one_pivot, memo, done, verdict, blocked_only):  # pragma: no cover (compiled)
    """One outline's edge lines (at cell ``c``) against the other's vertices (at cell ``d``) raised and
    lowered by their moves: :data:`APART` when one line has them all beyond it even lowered, else
    :data:`UNSURE` when one fails raised, else :data:`BLOCKED` (:func:`pair_verdicts`' test). A line with
    one vertex raised deeper than the threshold decides nothing (every least projection only falls as
    more vertices come, and rounding keeps that order), so its other vertices are not projected; once the
    pair is unsure (``verdict`` says what is known already), only a line apart can change it, and a line
    with one vertex lowered deeper than the threshold is not apart; where only blocked or not matters
    (``blocked_only``: the finest cells' pairs, whose verdict marks a table or nothing) the first line that
    is not deep ends the test. ``hint`` keeps, per line, the vertex that ended it last, tried first.

    A vertex's move is summed when first needed for the pair ``tag`` (kept in ``shift``, ``known``) in
    :func:`_moves`' order: ``first`` (the first object's shift), the first object's turn part, ``second``
    (the second's shift), the second's turn part; the vertices' own object's part is ``own_turns`` (made
    by :func:`_ready`), the other's is ``cross`` times the distance from its pivot (:func:`_away`; a turn
    of 0 adds 0 and is left out); ``of_first``: the vertices are the first object's."""
    count = vertices.shape[1]
    for m in range(turned.shape[1]):
        nx, ny, extent = turned[c, m, 0], turned[c, m, 1], extents[c, m]
        raised = lowered = np.inf
        deep = False
        start = hint[m]
        for step in range(count):
            j = start + step
            if j >= count:
                j -= count
            if known[j] != tag:
                if cross == 0.0:
                    part = 0.0
                else:
                    part = cross * _away(vertices, d, j, motions, cell, one_pivot, memo, done)
                if of_first:  # own turn, then the second object's shift and turn
                    shift[j] = first + own_turns[d, j] + second + part if cross != 0.0 else \
                        first + own_turns[d, j] + second
                else:  # the first object's turn, then the second's (own) shift and turn
                    shift[j] = (first + part if cross != 0.0 else first) + second + own_turns[d, j]
                known[j] = tag
            projection = nx * vertices[d, j, 0] + ny * vertices[d, j, 1]
            raised = min(raised, projection + shift[j])
            lowered = min(lowered, projection - shift[j])
            if extent - (lowered if verdict == UNSURE else raised) > threshold:
                hint[m] = j
                deep = True
                break
        if deep:
            continue
        if extent - lowered <= threshold:
            return APART
        if extent - raised <= threshold:
            if blocked_only:
                return UNSURE
            verdict = UNSURE
    return verdict


@njit(cache=True, nogil=True)
def _verdicts(sa, sb, base_a, base_b, first, second, threshold, one_a, one_b, memo_a, done_a, memo_b, done_b,
              table, last):  # pragma: no cover (compiled)
    """:func:`pair_verdicts` of the cell pairs (``first``, ``second``) of two outline shapes
    (``BlockingProver._shape``; the cells of the level asked start at ``base_a``, ``base_b``). The
    verdict does not hang on the order the edge lines are tried in (any line apart makes it apart), so one
    side is tried at a time (:func:`_side`). At the ``last`` level a pair already blocked in ``table`` (by
    another outline pair of the same objects) is not tested: its verdict marks nothing new."""
    local_a, normals_a, frames_a, ma, va, na, ea, ta, ready_a = sa
    local_b, normals_b, frames_b, mb, vb, nb, eb, tb, ready_b = sb
    out = np.empty(len(first), dtype=np.int8)
    shift_a, shift_b = np.empty(va.shape[1]), np.empty(vb.shape[1])
    known_a, known_b = np.full(va.shape[1], -1, dtype=np.int64), np.full(vb.shape[1], -1, dtype=np.int64)
    hint_a, hint_b = np.zeros(na.shape[1], dtype=np.int64), np.zeros(nb.shape[1], dtype=np.int64)
    for p in range(len(first)):
        if last and table[first[p], second[p]]:
            out[p] = APART
            continue
        a, b = base_a + first[p], base_b + second[p]
        _ready(local_a, normals_a, frames_a, ma, va, na, ea, ta, ready_a, a)
        _ready(local_b, normals_b, frames_b, mb, vb, nb, eb, tb, ready_b, b)
        ma0, ma1, mb0, mb1 = ma[a, 0], ma[a, 1], mb[b, 0], mb[b, 1]
        verdict = _side(na, ea, a, vb, b, threshold, hint_a, shift_b, known_b, p, tb, False, ma0, mb0, ma1, ma, a,
                        one_a, memo_b, done_b, BLOCKED, last)
        if verdict == BLOCKED or verdict == UNSURE and not last:
            verdict = _side(nb, eb, b, va, a, threshold, hint_b, shift_a, known_a, p, ta, True, ma0, mb0, mb1, mb, b,
                            one_b, memo_a, done_a, verdict, last)
        out[p] = verdict
    return out


@njit(cache=True, nogil=True)
def _memos(sa, sb, one_a, one_b):  # pragma: no cover (compiled)
    """Room for :func:`_away`'s distances: of a's vertices from b's one pivot, and of b's from a's."""
    memo_a = np.empty(sa[4].shape[:2]) if one_b else np.empty((0, 0))
    done_a = np.zeros(sa[4].shape[0] if one_b else 0, dtype=np.bool_)
    memo_b = np.empty(sb[4].shape[:2]) if one_a else np.empty((0, 0))
    done_b = np.zeros(sb[4].shape[0] if one_a else 0, dtype=np.bool_)
    return memo_a, done_a, memo_b, done_b


@njit(cache=True, nogil=True)
def refine(sa, bases_a, sb, bases_b, one_a, one_b, first, second, widest, threshold, sides, spent, budget,
            table):  # pragma: no cover (compiled)
    """``BlockingProver._blocked_pairs`` from the widest cells' verdicts on: each pair neither blocked
    nor apart halved (each side with finer levels: ``bases_a`` holds where each level's cells start in
    ``sa``) and tested again, down to the finest; the pairs blocked at any level marked in ``table`` at the
    finest. False, nothing marked, when the pairs tested would exceed ``budget`` (counting ``sides`` each,
    ``spent`` already)."""
    levels_a, levels_b = len(bases_a), len(bases_b)
    depth = max(levels_a, levels_b)
    memo_a, done_a, memo_b, done_b = _memos(sa, sb, one_a, one_b)
    rows, columns = np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)  # blocked pairs' first fine cells
    ends = np.zeros(depth, dtype=np.int64)  # per step: where its pairs end in rows and columns, their scales
    scales_a, scales_b = np.zeros(depth, dtype=np.int64), np.zeros(depth, dtype=np.int64)
    i, j, verdicts = first, second, widest
    for step in range(depth):
        la, lb = min(step, levels_a - 1), min(step, levels_b - 1)
        if step:
            verdicts = _verdicts(sa, sb, bases_a[la], bases_b[lb], i, j, threshold, one_a, one_b, memo_a, done_a,
                                 memo_b, done_b, table, step + 1 == depth)
        blocked = verdicts == BLOCKED
        scales_a[step], scales_b[step] = 1 << (levels_a - 1 - la), 1 << (levels_b - 1 - lb)
        rows = np.concatenate((rows, i[blocked] * scales_a[step]))
        columns = np.concatenate((columns, j[blocked] * scales_b[step]))
        ends[step] = len(rows)
        if step + 1 == depth:
            break
        unsure = verdicts == UNSURE
        i, j = i[unsure], j[unsure]
        split_a, split_b = la + 1 < levels_a, lb + 1 < levels_b
        if split_a:
            i, j = np.concatenate((2 * i, 2 * i + 1)), np.concatenate((j, j))
        if split_b:
            i, j = np.concatenate((i, i)), np.concatenate((2 * j, 2 * j + 1))
        spent += len(i) * sides
        if spent > budget:
            return False
    step = 0
    for p in range(len(rows)):
        while p >= ends[step]:
            step += 1
        table[rows[p]:rows[p] + scales_a[step], columns[p]:columns[p] + scales_b[step]] = True
    return True


@njit(cache=True, nogil=True)
def widest_verdicts(sa, sb, one_a, one_b, first, second, threshold):  # pragma: no cover (compiled)
    """:func:`_verdicts` of the widest cells' pairs (the first level of both shapes)."""
    memo_a, done_a, memo_b, done_b = _memos(sa, sb, one_a, one_b)
    return _verdicts(sa, sb, 0, 0, first, second, threshold, one_a, one_b, memo_a, done_a, memo_b, done_b,
                     np.zeros((1, 1), dtype=np.bool_), False)


@njit(cache=True, nogil=True)
def _circle_moves(frames, motions, count, x, y):  # pragma: no cover (compiled)
    """The outline's bounding-circle centre, its vertices' mean (``x``, ``y``) in the object's frame, at each of
    the first ``count`` cells' centres (x (n,), y (n,)), and how far it may move within the cell (n,)."""
    xs, ys, moves = np.empty(count), np.empty(count), np.empty(count)
    for c in range(count):
        xs[c] = frames[c, 0] + frames[c, 2] * x - frames[c, 3] * y
        ys[c] = frames[c, 1] + frames[c, 3] * x + frames[c, 2] * y
        moves[c] = motions[c, 0] + motions[c, 1] * math.hypot(xs[c] - motions[c, 2], ys[c] - motions[c, 3])
    return xs, ys, moves


@njit(cache=True, nogil=True)
def widest_pairs(sa, count_a, x_a, y_a, radius_a, sb, count_b, x_b, y_b, radius_b, one_a, one_b, threshold, sides,
            budget):  # pragma: no cover (compiled)
    """The widest cells' pairs (the first ``count_a`` and ``count_b`` cells of the shapes) whose bounding circles
    (centred at the outline's (``x``, ``y``) with ``radius``, grown by the centre's move) can meet, in row
    order, and their :func:`_verdicts` (none, and False, past ``budget``: ``sides`` each)."""
    xa, ya, move_a = _circle_moves(sa[2], sa[3], count_a, x_a, y_a)
    xb, yb, move_b = _circle_moves(sb[2], sb[3], count_b, x_b, y_b)
    radii = radius_a + radius_b
    first, second = np.empty(count_a * count_b, dtype=np.int64), np.empty(count_a * count_b, dtype=np.int64)
    n = 0
    for p in range(count_a):
        for q in range(count_b):
            reach = radii + move_a[p] + move_b[q]
            dx, dy = xa[p] - xb[q], ya[p] - yb[q]
            if dx * dx + dy * dy < reach * reach:
                first[n], second[n] = p, q
                n += 1
    first, second = first[:n].copy(), second[:n].copy()
    if n * sides > budget:
        return first, second, np.empty(0, dtype=np.int8), False
    return first, second, widest_verdicts(sa, sb, one_a, one_b, first, second, threshold), True


@njit(cache=True, nogil=True)
def or_throughout(table, first, last, blocked):  # pragma: no cover (compiled)
    """Sets ``blocked[r]`` where ``table[r, first:last + 1]`` is all true (each row left at its first false)."""
    for r in range(table.shape[0]):
        if not blocked[r]:
            for c in range(first, last + 1):
                if not table[r, c]:
                    break
            else:
                blocked[r] = True


def warm_up() -> None:
    """Load the compiled test (from numba's cache, or compile it), as a server does before it forks."""
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    normals = np.array([[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    index, base = np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64)
    frames, motions = np.array([[0.0, 0.0, 1.0, 0.0]]), np.zeros((1, 4))
    shape = (square, normals, frames, motions, np.empty((1, 4, 2)), np.empty((1, 4, 2)), np.empty((1, 4)),
             np.empty((1, 4)), np.zeros(1, dtype=np.bool_))
    _, _, verdicts, _ = widest_pairs(shape, 1, 0.5, 0.5, 1.0, shape, 1, 0.5, 0.5, 1.0, True, False, 0.0, 1, 1)
    refine(shape, base, shape, base, True, False, index, index, verdicts, 0.0, 1, 1, 1,
           np.zeros((1, 1), dtype=np.bool_))
    or_throughout(np.zeros((1, 1), dtype=np.bool_), 0, 0, np.zeros(1, dtype=np.bool_))
