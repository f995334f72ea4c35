"""The compiled judge loop's motion check: :func:`~solver.collision.kernels.motion_collision`'s answer,
with fewer pair tests.

:func:`motion_collision` visits a motion's samples end first and then by halving strides, every pair the
motion moves tested at every sample visited, and answers the first colliding sample in that order. In the
judge's loop (:mod:`solver.planning._judge_loop`) those pair tests were most of a query's time: a free
motion of a staircase step visits every sample, and its shapes barely move from one sample to the next.

:func:`motion_hit` visits the same samples in the same order and answers the same sample. A pair found
apart at a sample with a lower bound ``gap`` of its shapes' distance stays apart by more than
:data:`~solver.collision.skipping_move.SKIP_MARGIN` wherever its shapes have moved, together, less than
``gap - SKIP_MARGIN``: ``n`` samples away, at most ``n * m``, ``m`` the bound of how far a point of either
shape moves between consecutive samples that :func:`~solver.collision.skipping_move.motion_ends` uses (kept
for a link whose ancestors the motion only slides; a pair with a link below a turning one is tested at
every sample). A sample visited at stride ``s`` lies ``s`` samples from two samples visited before it (or
the motion's end, visited first), and a pair is tested there only where neither of their bounds, less
``s * m``, proves it apart; a bound so proven is kept for the samples visited later. A skipped pair is
apart by more than SKIP_MARGIN, so every test of :func:`~solver.collision.kernels._state_valid` would find
it apart (the argument of ``motion_ends``): each sample's verdict, and so the answer, is the scan's.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from solver.collision.kernels import FAR_MARGIN, _near_pair_collides, _poses
from solver.collision.skipping_move import SKIP_MARGIN, _pair_gap


@njit(cache=True, nogil=True)
def motion_hit(a, b, steps, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center, shape_radius,
               shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns, shape_rho):
    """:func:`~solver.collision.kernels.motion_collision` (``a`` valid): the fraction along a -> b of the
    colliding sample it finds, or -1 if none; ``shape_rho`` each shape's farthest point from its joint."""
    d = a.shape[0]
    count = 1
    for j in range(d):
        need = int(math.ceil(abs(b[j] - a[j]) / steps[j]))
        if need > count:
            count = need
    # Per link: how far its origin slides and how far it turns between consecutive samples (slide -1: unknown),
    # as motion_ends bounds them.
    link_moves = np.zeros(n_links, dtype=np.bool_)
    slide, turn = np.zeros(n_links), np.zeros(n_links)
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
    index = np.empty(all_pairs.shape[0], dtype=np.int64)
    n_pairs = 0
    for p in range(all_pairs.shape[0]):
        for j in range(d):
            if pair_columns[p, j] and a[j] != b[j]:
                index[n_pairs] = p
                n_pairs += 1
                break
    move = np.empty(n_pairs)
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
    bound = np.empty((n_pairs, count + 1))
    axis = np.zeros(n_pairs, dtype=np.int64)  # per pair: its best separating axis when last tested
    x, y, c, s, yaws = np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links)
    centres = np.empty((2, shape_link.shape[0]))
    q = np.empty(d)
    full = True
    stride = 1
    while stride * 2 < count:
        stride *= 2
    k = count
    while True:
        # The samples visited before k nearest it: k - stride and k + stride, or the end (visited first).
        low = k - stride if k != count else 0
        high = min(k + stride, count) if k != count else count
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
                if _near_pair_collides(pa, pb, x, y, c, s, centres, shape_link, shape_nv, shape_center, shape_radius,
                                       shape_verts, shape_normals, shape_extent, tol):
                    return k / count
                continue
            reach = shape_radius[pa] + shape_radius[pb] - tol
            ex, ey = centres[0, pb] - centres[0, pa], centres[1, pb] - centres[1, pa]
            far = reach + FAR_MARGIN
            if reach > 0.0 and ex * ex + ey * ey >= far * far:  # _near_pair_collides's skip: apart
                bound[i, k] = math.sqrt(ex * ex + ey * ey) - (shape_radius[pa] + shape_radius[pb])
                continue
            # Enough: apart at every sample; good: the samples visited next, ``stride / 2`` away, go.
            collides, gap, axis[i] = _pair_gap(pa, pb, x, y, c, s, shape_link, shape_nv, shape_center, shape_radius,
                                               shape_verts, shape_normals, shape_extent, tol,
                                               m * count + SKIP_MARGIN, axis[i], m * stride + SKIP_MARGIN)
            if collides:
                return k / count
            bound[i, k] = gap
        if k == count:
            k = stride
        else:
            k += 2 * stride
        while k >= count:
            stride //= 2
            if stride == 0:
                return -1.0
            k = stride
