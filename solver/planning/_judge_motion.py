"""The compiled judge loop's motion check: :func:`~solver.collision.kernels.motion_collision`'s answer,
with fewer pair tests.

:func:`motion_collision` visits a motion's samples end first and then by halving strides, every pair the
motion moves tested at every sample visited, and answers the first colliding sample in that order. In the
judge's loop (:mod:`solver.planning._judge_loop`) those pair tests were most of a query's time: a free
motion of a staircase step visits every sample, and its shapes barely move from one sample to the next.

:func:`motion_hit` answers the same sample, visiting the samples it must in the same order. A pair found
apart at a sample with a lower bound ``gap`` of its shapes' distance stays apart by more than
:data:`~solver.collision.skipping_move.SKIP_MARGIN` wherever its shapes have moved, together, less than
``gap - SKIP_MARGIN``: ``n`` samples away, at most ``n * m``, ``m`` the bound of how far a point of either
shape moves between consecutive samples that :func:`~solver.collision.skipping_move.motion_ends` uses (kept
for a link whose ancestors the motion only slides; a pair with a link below a turning one is tested at
every sample). The samples visited at a stride ``s`` are the middles of the stretches between samples
visited before (or the start, or the motion's end, visited first). At such a sample a pair is tested only
where neither bound at the stretch's two ends, less its motion since, proves it apart (a bound so proven is
kept for the samples visited later); a stretch whose two ends' bounds prove every pair apart at every sample
inside (:func:`_proven`) is not visited further. A skipped pair is apart by more than SKIP_MARGIN, so every
test of :func:`~solver.collision.kernels._state_valid` would find it apart (the argument of ``motion_ends``):
every sample's verdict is the scan's, the samples passed over are all free, and the first colliding sample in
the scan's order, the answer, is the same.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from solver.collision.kernels import FAR_MARGIN, _near_pair_collides, _poses
from solver.collision.skipping_move import SKIP_MARGIN, _pair_gap


@njit(cache=True, nogil=True, inline="always")
def _sample_count(a, b, steps):
    """motion_collision's number of samples of a -> b (the end included, the start not)."""
    count = 1
    for j in range(a.shape[0]):
        need = int(math.ceil(abs(b[j] - a[j]) / steps[j]))
        if need > count:
            count = need
    return count


@njit(cache=True, nogil=True, inline="always")
def _buffer_sizes(count, d, n_links, n_all, n_shapes):
    """The lengths of :func:`motion_hit_in`'s float and int buffers for a motion of ``count`` samples."""
    return 7 * n_links + n_all * (count + 2) + 2 * n_shapes + d, 2 * n_all + 4 * (count + 1)


@njit(cache=True, nogil=True)
def motion_buffers(count, d, n_links, n_all, n_shapes):
    """Buffers (floats, ints, link flags) for :func:`motion_hit_in` of motions of up to ``count`` samples."""
    n_floats, n_ints = _buffer_sizes(count, d, n_links, n_all, n_shapes)
    return np.empty(n_floats), np.empty(n_ints, dtype=np.int64), np.empty(n_links, dtype=np.bool_)


@njit(cache=True, nogil=True)
def motion_hit(a, b, steps, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center, shape_radius,
               shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns, shape_rho):
    """:func:`~solver.collision.kernels.motion_collision` (``a`` valid): the fraction along a -> b of the
    colliding sample it finds, or -1 if none; ``shape_rho`` each shape's farthest point from its joint."""
    floats, ints, link_moves = motion_buffers(_sample_count(a, b, steps), a.shape[0], n_links, all_pairs.shape[0],
                                              shape_link.shape[0])
    return motion_hit_in(floats, ints, link_moves, a, b, steps, kin_int, kin_float, n_links, shape_link, shape_nv,
                         shape_center, shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol,
                         pair_columns, shape_rho)


@njit(cache=True, nogil=True)
def motion_hit_in(floats, ints, link_moves, a, b, steps, kin_int, kin_float, n_links, shape_link, shape_nv,
                  shape_center, shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns,
                  shape_rho):
    """:func:`motion_hit` in the caller's buffers (:func:`motion_buffers`; a loop making thousands of motion
    checks allocates them once): every entry it reads it writes first in this call, so the answer is the same
    whatever they held. Buffers too short for this motion are replaced by new ones for this call."""
    d = a.shape[0]
    count = _sample_count(a, b, steps)
    # Per link: how far its origin slides and how far it turns between consecutive samples (slide -1: unknown),
    # as motion_ends bounds them.
    # Two buffers carved into every array below: a motion check is a few microseconds, and each allocation
    # of its own would add a tenth of one.
    n_all, n_shapes = all_pairs.shape[0], shape_link.shape[0]
    n_floats, n_ints = _buffer_sizes(count, d, n_links, n_all, n_shapes)
    if floats.shape[0] < n_floats or ints.shape[0] < n_ints or link_moves.shape[0] < n_links:
        floats, ints, link_moves = motion_buffers(count, d, n_links, n_all, n_shapes)
    link_moves[:] = False
    slide, turn = floats[:n_links], floats[n_links:2 * n_links]
    slide[:] = 0.0
    turn[:] = 0.0
    for r in range(kin_int.shape[0]):
        link, parent, column = kin_int[r, 0], kin_int[r, 1], kin_int[r, 2]
        link_moves[link] = kin_int[r, 3] != 0
        if link_moves[link]:
            if link_moves[parent] and (slide[parent] < 0.0 or turn[parent] != 0.0):
                slide[link] = -1.0
            else:
                slide[link] = slide[parent] if link_moves[parent] else 0.0
                if column >= 0:
                    per = abs(b[column] - a[column]) / count
                    slide[link] += math.sqrt(kin_float[r, 3] ** 2 + kin_float[r, 4] ** 2) * per
                    turn[link] = abs(kin_float[r, 5]) * per
    # The pairs the motion moves (motion_collision's), each with its bound per sample.
    index = ints[:n_all]
    n_pairs = 0
    for p in range(all_pairs.shape[0]):
        for j in range(d):
            if pair_columns[p, j] and a[j] != b[j]:
                index[n_pairs] = p
                n_pairs += 1
                break
    move = floats[2 * n_links:2 * n_links + n_pairs]
    for i in range(n_pairs):
        sa, sb = all_pairs[index[i], 0], all_pairs[index[i], 1]
        la, lb = shape_link[sa], shape_link[sb]
        m = math.inf
        if tol >= SKIP_MARGIN and slide[la] >= 0.0 and slide[lb] >= 0.0:
            m = slide[la] + turn[la] * shape_rho[sa] + slide[lb] + turn[lb] * shape_rho[sb]
            m = m * (1.0 + 1e-9) + 1e-12  # room for the rounding of the samples' differences
        move[i] = m
    # bound[i, k]: a lower bound of pair i's distance at sample k, written for every pair of a bound motion
    # at every sample visited (the motion ends at a colliding one) and read only at samples visited before
    o = 2 * n_links + n_pairs
    bound = floats[o:o + n_pairs * (count + 1)].reshape((n_pairs, count + 1))
    o += n_pairs * (count + 1)
    axis = ints[n_all:n_all + n_pairs]  # per pair: its best separating axis when last tested
    axis[:] = 0
    x, y, c = floats[o:o + n_links], floats[o + n_links:o + 2 * n_links], floats[o + 2 * n_links:o + 3 * n_links]
    s, yaws = floats[o + 3 * n_links:o + 4 * n_links], floats[o + 4 * n_links:o + 5 * n_links]
    o += 5 * n_links
    centres = floats[o:o + 2 * n_shapes].reshape((2, n_shapes))
    q = floats[o + 2 * n_shapes:o + 2 * n_shapes + d]
    bounded = True  # every pair's motion bound known: a stretch between two samples can be proven free whole
    for i in range(n_pairs):
        if move[i] == math.inf:
            bounded = False
    full = True
    stride = 1
    while stride * 2 < count:
        stride *= 2
    # The end first; then, stride by stride (halving), the middle sample of each stretch between samples visited
    # before, stretches in order: motion_collision's order. A stretch every pair's bounds at its two ends prove
    # free at every sample inside is dropped: its samples would all be found free, none is the answer.
    o = 2 * n_all
    lows, highs = ints[o:o + count + 1], ints[o + count + 1:o + 2 * (count + 1)]
    next_lows, next_highs = ints[o + 2 * (count + 1):o + 3 * (count + 1)], ints[o + 3 * (count + 1):o + 4 * (count + 1)]
    lows[0], highs[0] = -1, count  # (-1: the end itself, visited with no sample visited before)
    n = 1
    while n > 0 and stride > 0:
        m_next = 0
        ended = False
        for r in range(n):
            low, high = lows[r], highs[r]
            if low < 0:
                k, low, ended = count, 0, True
            else:
                k = low + stride
                if k >= high:  # no sample of this stride inside: the stretch waits for a finer one
                    next_lows[m_next], next_highs[m_next] = low, high
                    m_next += 1
                    continue
            # -- sample k, between samples low (0: the start, no bound) and high (k: none) visited before it;
            # a pair is tested only where neither bound, less its shapes' motion since, proves it apart
            posed = False
            for i in range(n_pairs):
                m = move[i]
                if m < math.inf:
                    known = -math.inf
                    if low >= 1:
                        known = bound[i, low] - (k - low) * m
                    if high != k:
                        known = max(known, bound[i, high] - (high - k) * m)
                    if known > SKIP_MARGIN:
                        bound[i, k] = known
                        continue
                if not posed:
                    t = k / count
                    for j in range(d):
                        q[j] = a[j] + (b[j] - a[j]) * t
                    _poses(q, kin_int, kin_float, x, y, c, s, yaws, full)
                    for h in range(shape_link.shape[0]):
                        link = shape_link[h]
                        if not full and not link_moves[link]:  # a fixed shape's centre stays where the first put it
                            continue
                        cx, cy = shape_center[h, 0], shape_center[h, 1]
                        centres[0, h] = x[link] + c[link] * cx - s[link] * cy
                        centres[1, h] = y[link] + s[link] * cx + c[link] * cy
                    full = False
                    posed = True
                pa, pb = all_pairs[index[i], 0], all_pairs[index[i], 1]
                if m == math.inf:
                    if _near_pair_collides(pa, pb, x, y, c, s, centres, shape_link, shape_nv, shape_center,
                                           shape_radius, shape_verts, shape_normals, shape_extent, tol):
                        return k / count
                    continue
                reach = shape_radius[pa] + shape_radius[pb] - tol
                ex, ey = centres[0, pb] - centres[0, pa], centres[1, pb] - centres[1, pa]
                far = reach + FAR_MARGIN
                if reach > 0.0 and ex * ex + ey * ey >= far * far:  # _near_pair_collides's skip: apart
                    bound[i, k] = math.sqrt(ex * ex + ey * ey) - (shape_radius[pa] + shape_radius[pb])
                    continue
                # Enough: apart at every sample; good: the samples visited next, half the stride away, go.
                collides, gap, axis[i] = _pair_gap(pa, pb, x, y, c, s, shape_link, shape_nv, shape_center,
                                                   shape_radius, shape_verts, shape_normals, shape_extent, tol,
                                                   m * count + SKIP_MARGIN, axis[i], m * stride + SKIP_MARGIN)
                if collides:
                    return k / count
                bound[i, k] = gap
            # -- the stretches either side of k, unless proven free whole
            if k - low > 1 and not (bounded and _proven(low, k, n_pairs, move, bound)):
                next_lows[m_next], next_highs[m_next] = low, k
                m_next += 1
            if high - k > 1 and not (bounded and _proven(k, high, n_pairs, move, bound)):
                next_lows[m_next], next_highs[m_next] = k, high
                m_next += 1
        lows, next_lows = next_lows, lows
        highs, next_highs = next_highs, highs
        n = m_next
        if not ended:
            stride //= 2
    return -1.0


BOUND_SLACK = 1e-9
"""Relative room in :func:`_proven`'s sums of bounds, far above their rounding (about 1e-16 relative)."""
ROUNDING_ROOM = 1e-12
"""Metres of room in :func:`_proven`'s sums of bounds: their rounding is about 1e-15 m at puzzle sizes."""


@njit(cache=True, nogil=True, inline="always")
def _proven(low, high, n_pairs, move, bound):
    """Whether every pair is proven apart by more than SKIP_MARGIN at every sample strictly between the
    visited samples ``low`` and ``high`` (``low`` 0: the start, of no bound), by its bounds A at ``low`` and B at
    ``high``, shapes moving ``m`` a sample: a sample t samples after ``low`` is proven by A where
    A - t m > SKIP_MARGIN, by B where B - (n - t) m > SKIP_MARGIN (n = high - low). Where A + B exceeds
    n m + 2 SKIP_MARGIN one of the two holds at every t (if A - t m <= SKIP_MARGIN, then
    B - (n - t) m >= A + B - n m - SKIP_MARGIN > SKIP_MARGIN); from the start, B alone must reach t = 1."""
    n = high - low
    for i in range(n_pairs):
        m, right = move[i], bound[i, high]
        if low >= 1:
            if not bound[i, low] + right > (n * m + 2.0 * SKIP_MARGIN) * (1.0 + BOUND_SLACK) + ROUNDING_ROOM:
                return False
        elif not right > ((n - 1) * m + SKIP_MARGIN) * (1.0 + BOUND_SLACK) + ROUNDING_ROOM:
            return False
    return True


COUNT_CAP = 4096
"""The most samples a motion may have for :func:`count_bound`'s buffers (a longer one gets its own)."""


@njit(cache=True, nogil=True)
def count_bound(lower, upper, steps):
    """The most samples of a motion inside [lower, upper] at ``steps`` (at most :data:`COUNT_CAP`): the size
    to make a loop's buffers for; a motion beyond it is still answered, in buffers of its own."""
    count = 1
    for j in range(lower.shape[0]):
        span = (upper[j] - lower[j]) / steps[j]
        if not span < COUNT_CAP:
            return COUNT_CAP
        need = int(math.ceil(span))
        if need > count:
            count = need
    return count
