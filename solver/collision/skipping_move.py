"""The skipping batched move (:func:`motion_ends`) and what it reasons with: the pair-gap bounds that let it
skip the samples at which a pair is proven apart.

Compiled like :mod:`solver.collision.kernels` (whose pose and pair tests it calls, the inline ones compiled
into it), apart from it because the skipping is a job of its own: the same states as
:func:`~solver.collision.kernels.motion_stops`, bit for bit, with fewer pair tests.
numba's cache follows each function's own file only; :mod:`solver.collision.jit_cache` drops this file's
cached entries too when ``kernels.py`` changes.
Functions named below without a module are :mod:`solver.collision.kernels`'s.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from solver.collision.kernels import FAR_MARGIN, _circle_meets_polygon, _near_pair_collides, _poses, _relative_pose

SKIP_MARGIN = 1e-9
"""Metres by which a pair must be proven apart at a sample :func:`_first_hit` skips. Far more than the
rounding of the distances and motions it reasons with (about 1e-14 m at puzzle sizes), and far less
than the tolerance (:data:`~solver.collision.model.DEFAULT_TOLERANCE`): shapes that are truly apart by
it are found apart by every test of :func:`_state_valid`, whatever order it tries them in."""


@njit(cache=True, nogil=True, inline='always')
def _pair_gap(a, b, x, y, c, s, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
              shape_extent, tol, enough, first, good):
    """:func:`_pair_collides`'s verdict (the same tests, the same numbers) and, when apart, a lower bound
    of the distance between the two shapes (negative when none is known): the bounding circles' gap or,
    for two polygons, the largest separation along an edge normal tried (each one is a lower bound of
    the Euclidean distance), and the index of that axis (A's edges, then B's). Polygon axes are tried
    from ``first`` on (the one that separated best at the pair's last test: the pose changed little
    since) until one separates by ``enough``, or the first by ``good``. The verdict does not depend on
    the order: the shapes are apart when any axis separates them."""
    rx, ry, rc, rs, cbx, cby = _relative_pose(a, b, x, y, c, s, shape_link, shape_center)
    ex, ey = cbx - shape_center[a, 0], cby - shape_center[a, 1]
    reach = shape_radius[a] + shape_radius[b] - tol
    disc_gap = math.sqrt(ex * ex + ey * ey) - (shape_radius[a] + shape_radius[b])
    if ex * ex + ey * ey >= reach * reach:
        return False, disc_gap, first
    na, nb = shape_nv[a], shape_nv[b]
    if na == 0:
        return True, -1.0, first
    if nb == 0:
        return _circle_meets_polygon(a, cbx, cby, shape_radius[b] - tol, na, shape_verts, shape_normals), \
            disc_gap, first
    gap = disc_gap
    apart = False
    best = first
    axes = na + nb
    for n in range(axes):
        k = first + n
        if k >= axes:
            k -= axes
        lowest = 1e300
        if k < na:
            nx, ny = shape_normals[a, k, 0], shape_normals[a, k, 1]
            for j in range(nb):
                vx, vy = shape_verts[b, j, 0], shape_verts[b, j, 1]
                d = nx * (rc * vx - rs * vy + rx) + ny * (rs * vx + rc * vy + ry)
                if d < lowest:
                    lowest = d
            extent = shape_extent[a, k]
        else:
            nx, ny = shape_normals[b, k - na, 0], shape_normals[b, k - na, 1]
            for j in range(na):
                vx, vy = shape_verts[a, j, 0] - rx, shape_verts[a, j, 1] - ry
                d = nx * (rc * vx + rs * vy) + ny * (-rs * vx + rc * vy)
                if d < lowest:
                    lowest = d
            extent = shape_extent[b, k - na]
        if lowest >= extent - tol:
            apart = True
            if lowest - extent > gap:
                gap = lowest - extent
                best = k
            # Enough to skip to the end; or the axis that separated best last time still lets a sample go.
            if gap >= enough or (n == 0 and gap >= good):
                return False, gap, best
    return not apart, gap, best


@njit(cache=True, nogil=True)
def _rest_apart(x, y, c, s, centres, moving, shape_link, shape_nv, shape_center, shape_radius, shape_verts,
                shape_normals, shape_extent, all_pairs, tol):
    """Whether every pair a move does not move (``moving`` False) stands apart at the poses and centres
    in the buffers: those of any of its samples, where such a pair stands as at the move's start."""
    for p in range(all_pairs.shape[0]):
        if not moving[p] and _near_pair_collides(all_pairs[p, 0], all_pairs[p, 1], x, y, c, s, centres, shape_link,
                                                 shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
                                                 shape_extent, tol):
            return False
    return True


@njit(cache=True, nogil=True)
def _end_scratch(d, n_links, n_shapes, n_pairs):
    """Scratch buffers of :func:`_first_hit`, in its argument order."""
    return (np.empty(d), np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links),
            np.empty(n_links), np.empty((2, n_shapes)), np.empty(n_links), np.empty(n_links),
            np.zeros(n_links, dtype=np.bool_), np.empty(n_pairs, dtype=np.bool_), np.empty(n_pairs, dtype=np.int64),
            np.empty(n_pairs, dtype=np.int64), np.empty(n_pairs))


@njit(cache=True, nogil=True)
def motion_ends(starts, ends, steps, stop, out, hits, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns, shape_rho):
    """Where each move from a row of ``starts`` (N, d) towards the same row of ``ends`` ends, into ``out``,
    as :func:`motion_stops` ends it (the same states, bit for bit); ``hits[i]`` gets the fraction of row
    i's first colliding sample, or -1 when the move is free.

    As in :func:`_move`, a colliding move ends at its start or, with ``stop``, at the sample before the
    first colliding one; :func:`_move` finds that sample by rescanning with every pair, so a pair the
    move does not move, colliding at the start already, ends it at the start.

    The first colliding sample of a move: the samples and the pairs :func:`_motion_hit` checks,
    scanned from the start, skipping what is proven.

    After a pair is found apart at sample i with a lower bound ``gap`` of its shapes' distance, it is not
    tested again before sample i + n + 1, n = floor((gap - SKIP_MARGIN) / m), where m bounds how far a
    point of either shape moves between consecutive samples. That bound is known for a link whose
    ancestors the motion only slides (every moving link in Grid World, Continuous Space and Rooms):
    the sum of the sliding joints' changes per sample times their axis lengths plus, for a revolute
    joint of its own, the turn per sample times the shape's farthest point from the joint
    (``shape_rho``); a pair with a link below a turning one is tested at every sample. A
    skipped sample's pairs are all proven apart by more than SKIP_MARGIN, so every test of
    :func:`_state_valid` would have found them apart there: the first colliding sample is the one a
    test of every sample finds. The scan is written out in the loop over moves: a call per move, with
    this many array arguments, costs a quarter of a Grid World move in reference counting."""
    d = starts.shape[1]
    q, x, y, c, s, yaws, centres, slide, turn, link_moves, moving, pair_index, due, pair_move = _end_scratch(
        d, n_links, shape_link.shape[0], all_pairs.shape[0])
    full = True  # a fixed link's pose and shape centres, once: the same at every state
    axis = np.zeros(all_pairs.shape[0], dtype=np.int64)  # per pair: its best separating axis when last tested
    for row in range(starts.shape[0]):
        a, b, o = starts[row], ends[row], out[row]
        count = 1
        for j in range(d):
            need = int(math.ceil(abs(b[j] - a[j]) / steps[j]))
            if need > count:
                count = need
        # Per link: how far its origin slides and how far it turns between consecutive samples (slide -1: unknown).
        for r in range(kin_int.shape[0]):
            link, parent, column = kin_int[r, 0], kin_int[r, 1], kin_int[r, 2]
            link_moves[link] = kin_int[r, 3] != 0
            slide[link], turn[link] = 0.0, 0.0
            if link_moves[link]:
                if link_moves[parent] and (slide[parent] < 0.0 or turn[parent] != 0.0):
                    slide[link] = -1.0  # carried by a turning link: no bound kept
                else:
                    # A parent that only slides carries the link's frame along without turning it.
                    slide[link] = slide[parent] if link_moves[parent] else 0.0
                    if column >= 0:
                        per = abs(b[column] - a[column]) / count
                        slide[link] += math.sqrt(kin_float[r, 3] ** 2 + kin_float[r, 4] ** 2) * per
                        turn[link] = abs(kin_float[r, 5]) * per
        n_pairs = 0
        for p in range(all_pairs.shape[0]):
            moving[p] = False
            for j in range(d):
                if pair_columns[p, j] and a[j] != b[j]:
                    moving[p] = True
                    break
            if not moving[p]:
                continue
            sa, sb = all_pairs[p, 0], all_pairs[p, 1]
            la, lb = shape_link[sa], shape_link[sb]
            m = math.inf
            if tol >= SKIP_MARGIN and slide[la] >= 0.0 and slide[lb] >= 0.0:
                m = slide[la] + turn[la] * shape_rho[sa] + slide[lb] + turn[lb] * shape_rho[sb]
                m = m * (1.0 + 1e-9) + 1e-12  # room for the rounding of the samples' differences
            due[n_pairs] = 1
            pair_move[n_pairs] = m
            pair_index[n_pairs] = p
            n_pairs += 1
        hit = 0
        nxt = 1 if n_pairs else count + 1  # the next sample any pair is due at
        while True:
            k = nxt
            if k > count:
                break
            nxt = count + 1
            t = k / count
            for j in range(d):
                q[j] = a[j] + (b[j] - a[j]) * t
            _poses(q, kin_int, kin_float, x, y, c, s, yaws, full)
            for i in range(shape_link.shape[0]):
                link = shape_link[i]
                if not full and not link_moves[link]:  # a fixed shape's centre stays where the first sample put it
                    continue
                cx, cy = shape_center[i, 0], shape_center[i, 1]
                centres[0, i] = x[link] + c[link] * cx - s[link] * cy
                centres[1, i] = y[link] + s[link] * cx + c[link] * cy
            full = False
            for i in range(n_pairs):
                if due[i] != k:
                    if due[i] < nxt:
                        nxt = due[i]
                    continue
                p = pair_index[i]
                pa, pb = all_pairs[p, 0], all_pairs[p, 1]
                m = pair_move[i]
                enough = m * (count - k) + SKIP_MARGIN if m < math.inf else math.inf
                reach = shape_radius[pa] + shape_radius[pb] - tol
                ex, ey = centres[0, pb] - centres[0, pa], centres[1, pb] - centres[1, pa]
                far = reach + FAR_MARGIN
                if reach > 0.0 and ex * ex + ey * ey >= far * far:
                    clear = shape_radius[pa] + shape_radius[pb] + enough
                    if ex * ex + ey * ey >= clear * clear * (1.0 + 1e-12):  # apart to the end, without a root
                        due[i] = count + 1
                        continue
                    gap = math.sqrt(ex * ex + ey * ey) - (shape_radius[pa] + shape_radius[pb])
                else:
                    collides, gap, axis[p] = _pair_gap(pa, pb, x, y, c, s, shape_link, shape_nv, shape_center,
                                                       shape_radius, shape_verts, shape_normals, shape_extent, tol,
                                                       enough, axis[p], m + SKIP_MARGIN)
                    if collides:
                        hit = k
                        break
                if gap >= enough:
                    due[i] = count + 1
                elif gap > SKIP_MARGIN:
                    due[i] = k + 1 + int(math.floor((gap - SKIP_MARGIN) / m))
                else:
                    due[i] = k + 1
                if due[i] < nxt:
                    nxt = due[i]
            if hit:
                break
        if hit <= 0:
            for j in range(d):
                o[j] = b[j]
            hits[row] = -1.0
            continue
        hits[row] = hit / count
        if stop and hit > 1 and _rest_apart(x, y, c, s, centres, moving, shape_link, shape_nv, shape_center,
                                            shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol):
            t = (hit - 1) / count
            for j in range(d):
                o[j] = a[j] + (b[j] - a[j]) * t
        else:
            for j in range(d):
                o[j] = a[j]
