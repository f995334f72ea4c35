"""Compiled inner loops of the collision model (see ``solver.collision.model`` for the geometry).

Kept apart so the model's construction stays readable Python while the hot
loops (forward kinematics + separating-axis tests, per state) run compiled.
All arrays are prepared by ``CollisionModel._compile_arrays``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _poses(q, kin_int, kin_float, x, y, c, s, yaws, full):
    """Link poses at state ``q`` into x, y, c, s (cos, sin of the yaw) and yaws.

    ``full`` False: only the links whose pose depends on the state (``kin_int[:, 3]``) are
    computed; the others keep what an earlier call on the same buffers wrote, which is the
    same (a fixed link's pose depends on no state). The per-state work is then the moving links'."""
    if full:
        x[0] = 0.0
        y[0] = 0.0
        c[0] = 1.0
        s[0] = 0.0
        yaws[0] = 0.0
    for r in range(kin_int.shape[0]):
        if not full and kin_int[r, 3] == 0:
            continue
        link, parent, column = kin_int[r, 0], kin_int[r, 1], kin_int[r, 2]
        ox, oy, oyaw, ax, ay, rate = (kin_float[r, 0], kin_float[r, 1], kin_float[r, 2],
                                      kin_float[r, 3], kin_float[r, 4], kin_float[r, 5])
        pc, ps = c[parent], s[parent]
        lx = x[parent] + pc * ox - ps * oy
        ly = y[parent] + ps * ox + pc * oy
        yaw = yaws[parent] + oyaw
        value = q[column] if column >= 0 else 1.0
        if ax != 0.0 or ay != 0.0:
            c2, s2 = math.cos(yaw), math.sin(yaw)
            lx += (c2 * ax - s2 * ay) * value
            ly += (s2 * ax + c2 * ay) * value
            if rate != 0.0:
                yaw += rate * value
                c[link] = math.cos(yaw)
                s[link] = math.sin(yaw)
            else:  # the same yaw: its cosine and sine are already known
                c[link] = c2
                s[link] = s2
        else:
            if rate != 0.0:
                yaw += rate * value
            c[link] = math.cos(yaw)
            s[link] = math.sin(yaw)
        x[link] = lx
        y[link] = ly
        yaws[link] = yaw


@njit(cache=True, nogil=True, inline='always')
def _relative_pose(a, b, x, y, c, s, shape_link, shape_center):
    """B's link frame in A's link frame (translation ``rx, ry``, rotation's cosine and sine ``rc, rs``)
    and the centre of B's bounding circle there (``cbx, cby``)."""
    la, lb = shape_link[a], shape_link[b]
    dx, dy = x[lb] - x[la], y[lb] - y[la]
    ca, sa = c[la], s[la]
    rx, ry = ca * dx + sa * dy, -sa * dx + ca * dy
    rc = ca * c[lb] + sa * s[lb]
    rs = ca * s[lb] - sa * c[lb]
    cbx = rc * shape_center[b, 0] - rs * shape_center[b, 1] + rx
    cby = rs * shape_center[b, 0] + rc * shape_center[b, 1] + ry
    return rx, ry, rc, rs, cbx, cby


@njit(cache=True, nogil=True, inline='always')
def _circle_meets_polygon(a, cbx, cby, radius, na, shape_verts, shape_normals):
    """Whether the circle of ``radius`` centred at (cbx, cby) in A's link frame meets A's polygon of
    ``na`` vertices: its centre inside, or an edge nearer than ``radius``."""
    inside = True
    best = 1e300
    for k in range(na):
        px, py = shape_verts[a, k, 0], shape_verts[a, k, 1]
        k2 = (k + 1) % na
        qx, qy = shape_verts[a, k2, 0], shape_verts[a, k2, 1]
        if (cbx - px) * shape_normals[a, k, 0] + (cby - py) * shape_normals[a, k, 1] >= 0.0:
            inside = False
        exx, eyy = qx - px, qy - py
        t = ((cbx - px) * exx + (cby - py) * eyy) / (exx * exx + eyy * eyy)
        t = min(1.0, max(0.0, t))
        hx, hy = px + t * exx - cbx, py + t * eyy - cby
        best = min(best, hx * hx + hy * hy)
    return inside or best < radius * radius


# Inlined into its callers: a call that passes numba arrays pays reference counting on
# each of them, and with thirteen array arguments that cost 20x the test itself
# (benchmarks/collision_speed.py; docs/performance.md).
@njit(cache=True, nogil=True, inline='always')
def _pair_collides(a, b, x, y, c, s, shape_link, shape_nv, shape_center, shape_radius,
                   shape_verts, shape_normals, shape_extent, reach_tol, tol):
    rx, ry, rc, rs, cbx, cby = _relative_pose(a, b, x, y, c, s, shape_link, shape_center)
    # Broad phase: bounding circles.
    ex, ey = cbx - shape_center[a, 0], cby - shape_center[a, 1]
    reach = shape_radius[a] + shape_radius[b] - reach_tol
    if ex * ex + ey * ey >= reach * reach:
        return False
    na, nb = shape_nv[a], shape_nv[b]
    if na == 0:  # circle-circle
        return True
    if nb == 0:
        return _circle_meets_polygon(a, cbx, cby, shape_radius[b] - tol, na, shape_verts, shape_normals)
    # Polygon-polygon: two convex polygons are disjoint iff an edge line of one of them
    # separates them; an edge separates when the other polygon lies beyond it.
    for k in range(na):
        nx, ny = shape_normals[a, k, 0], shape_normals[a, k, 1]
        lowest = 1e300
        for j in range(nb):
            vx, vy = shape_verts[b, j, 0], shape_verts[b, j, 1]
            d = nx * (rc * vx - rs * vy + rx) + ny * (rs * vx + rc * vy + ry)
            if d < lowest:
                lowest = d
        if lowest >= shape_extent[a, k] - tol:
            return False
    # A's vertices in B's frame: inverse of the relative transform.
    for k in range(nb):
        nx, ny = shape_normals[b, k, 0], shape_normals[b, k, 1]
        lowest = 1e300
        for j in range(na):
            vx, vy = shape_verts[a, j, 0] - rx, shape_verts[a, j, 1] - ry
            d = nx * (rc * vx + rs * vy) + ny * (-rs * vx + rc * vy)
            if d < lowest:
                lowest = d
        if lowest >= shape_extent[b, k] - tol:
            return False
    return True


FAR_MARGIN = 1e-6
"""Metres beyond the bounding-circle test's reach at which a pair is skipped before that test: far
more than the rounding difference between the world-frame centres used first and the relative pose
:func:`_pair_collides` computes (about 1e-14 m at puzzle sizes), so a skipped pair is one that test
would have found apart, and every verdict is the same as without the skip."""


@njit(cache=True, nogil=True)
def _state_valid(q, kin_int, kin_float, x, y, c, s, yaws, centres, full, shape_link, shape_nv, shape_center,
                 shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol):
    _poses(q, kin_int, kin_float, x, y, c, s, yaws, full)
    # Each shape's bounding-circle centre in the world, once per state: most candidate pairs stand
    # apart (80 % in Grid World, 97 % in Rooms) and are then skipped at a few operations each.
    for i in range(shape_link.shape[0]):
        link = shape_link[i]
        cx, cy = shape_center[i, 0], shape_center[i, 1]
        centres[0, i] = x[link] + c[link] * cx - s[link] * cy
        centres[1, i] = y[link] + s[link] * cx + c[link] * cy
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        reach = shape_radius[a] + shape_radius[b] - tol
        if reach > 0.0:
            ex, ey = centres[0, b] - centres[0, a], centres[1, b] - centres[1, a]
            far = reach + FAR_MARGIN
            if ex * ex + ey * ey >= far * far:
                continue
        if _pair_collides(a, b, x, y, c, s, shape_link, shape_nv, shape_center,
                          shape_radius, shape_verts, shape_normals, shape_extent, tol, tol):
            return False
    return True


@njit(cache=True, nogil=True)
def check_states(states, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center, shape_radius,
                 shape_verts, shape_normals, shape_extent, pairs, tol):
    out = np.empty(states.shape[0], dtype=np.bool_)
    x, y, c, s, yaws = np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links)
    centres = np.empty((2, shape_link.shape[0]))
    for i in range(states.shape[0]):
        out[i] = _state_valid(states[i], kin_int, kin_float, x, y, c, s, yaws, centres, i == 0, shape_link, shape_nv,
                              shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol)
    return out


PACKED_HEADER = 5
"""Leading values of :func:`state_valid_packed`'s ``ints``: links, kinematic rows, shapes, vertices
per shape, pairs."""


@njit(cache=True, nogil=True)
def state_valid_packed(q, ints, floats):
    """One state's validity as a bool (the single-state queries' entry point), with the model's
    arrays packed into two (``CollisionModel._pack``): a call from Python pays for each argument
    it passes, and this one passes three instead of thirteen.
    The arrays are views of the packed ones, holding the same numbers: the same verdicts. The
    fixed links' poses come packed too (:func:`fixed_poses`), computed by the same code once."""
    n_links, rows, shapes, k, n_pairs = ints[0], ints[1], ints[2], ints[3], ints[4]
    o = PACKED_HEADER
    kin_int = ints[o:o + rows * 4].reshape((rows, 4))
    o += rows * 4
    shape_link = ints[o:o + shapes]
    o += shapes
    shape_nv = ints[o:o + shapes]
    o += shapes
    pairs = ints[o:o + n_pairs * 2].reshape((n_pairs, 2))
    kin_float = floats[0:rows * 6].reshape((rows, 6))
    o = rows * 6
    shape_center = floats[o:o + shapes * 2].reshape((shapes, 2))
    o += shapes * 2
    shape_radius = floats[o:o + shapes]
    o += shapes
    shape_verts = floats[o:o + shapes * k * 2].reshape((shapes, k, 2))
    o += shapes * k * 2
    shape_normals = floats[o:o + shapes * k * 2].reshape((shapes, k, 2))
    o += shapes * k * 2
    shape_extent = floats[o:o + shapes * k].reshape((shapes, k))
    o += shapes * k
    tol = floats[o]
    o += 1
    # The fixed links' poses, computed once by the model (fixed_poses): only the moving links' are computed here.
    poses = floats[o:o + 5 * n_links].reshape((5, n_links)).copy()
    centres = np.empty((2, shapes))
    return _state_valid(q, kin_int, kin_float, poses[0], poses[1], poses[2], poses[3], poses[4], centres, False,
                        shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals, shape_extent,
                        pairs, tol)


@njit(cache=True, nogil=True)
def fixed_poses(q, kin_int, kin_float, n_links):
    """Every link's pose at ``q`` as rows x, y, cos, sin, yaw (N links): the fixed links' entries are
    the same at any state."""
    poses = np.empty((5, n_links))
    _poses(q, kin_int, kin_float, poses[0], poses[1], poses[2], poses[3], poses[4], True)
    return poses


@njit(cache=True, nogil=True)
def motion_collision(a, b, steps, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                     shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns):
    """Fraction along a -> b of a colliding sample (not necessarily the first), or -1 if none.

    ``a`` is assumed valid, so only pairs that a changing joint moves (``pair_columns``) can
    start to collide: a one-object move checks that object's pairs only."""
    hit, count = _motion_hit(a, b, steps, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                             shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns)
    return hit / count if hit > 0 else -1.0


@njit(cache=True, nogil=True)
def motion_stop(a, b, steps, stop, out, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns):
    """Move from ``a`` (valid) towards ``b``, writing where the move ends into ``out``; returns
    :func:`motion_collision`'s fraction (-1: free, ``out`` = ``b``).

    A colliding move ends at ``a`` or, with ``stop``, at the last free sample before the first
    colliding one: the samples ``a + (b - a) * (k / count)`` before the found colliding sample are
    scanned from the start (all pairs), the states a motion check and a batch check of those
    samples would visit, in one call."""
    return _move(a, b, steps, stop, out, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                 shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns)


@njit(cache=True, nogil=True)
def motion_stops(a, b, steps, stop, out, hits, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                 shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns):
    """:func:`motion_stop` for each row of ``a`` and ``b`` (N, d) into ``out`` (N, d); ``hits[i]`` gets
    row i's fraction."""
    for i in range(a.shape[0]):
        hits[i] = _move(a[i], b[i], steps, stop, out[i], kin_int, kin_float, n_links, shape_link, shape_nv,
                        shape_center, shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol,
                        pair_columns)


STEP_TABLE_ROWS = 6
"""Rows of :func:`joint_step`'s ``table``: step per unit action, lower, upper, motion-check step,
centre and inverse half-range of each joint."""


@njit(cache=True, nogil=True)
def joint_step(a, action, table, stop, out, position, kin_int, kin_float, n_links, shape_link, shape_nv,
               shape_center, shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol,
               pair_columns):
    """A simulation's step from ``a`` (valid): the target ``a + clip(action, -1, 1) * table[0]``
    clipped to ``[table[1], table[2]]``, moved to as :func:`motion_stop` moves (samples
    ``table[3]`` apart) into ``out``, and ``position`` = ``(out - table[4]) * table[5]``.

    ``action`` may be longer than the state (padding, ignored but checked). Returns the motion's
    fraction (-1: free), or -2 without writing anything when ``action`` holds a non-finite value.
    The clipping is numpy's ``minimum``/``maximum`` written out, so the target is the same
    number as those ufuncs give."""
    for j in range(action.shape[0]):
        if not math.isfinite(action[j]):
            return -2.0
    d = a.shape[0]
    b = np.empty(d)
    for j in range(d):
        v = float(action[j])
        v = v if v <= 1.0 else 1.0
        v = v if v >= -1.0 else -1.0
        v = v * table[0, j]
        v = v + a[j]
        v = v if v <= table[2, j] else table[2, j]
        b[j] = v if v >= table[1, j] else table[1, j]
    hit = _move(a, b, table[3], stop, out, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns)
    for j in range(d):
        position[j] = (out[j] - table[4, j]) * table[5, j]
    return hit


@njit(cache=True, nogil=True)
def _move(a, b, steps, stop, out, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
          shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns):
    hit, count = _motion_hit(a, b, steps, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                             shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns)
    d = a.shape[0]
    if hit <= 0:
        for j in range(d):
            out[j] = b[j]
        return -1.0
    for j in range(d):
        out[j] = a[j]
    if stop:
        x, y, c, s, yaws = np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links)
        centres = np.empty((2, shape_link.shape[0]))
        q = np.empty(d)
        for k in range(1, hit):
            t = k / count
            for j in range(d):
                q[j] = a[j] + (b[j] - a[j]) * t
            if not _state_valid(q, kin_int, kin_float, x, y, c, s, yaws, centres, k == 1, shape_link, shape_nv,
                                shape_center, shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol):
                break
            for j in range(d):
                out[j] = q[j]
    return hit / count


@njit(cache=True, nogil=True)
def _motion_hit(a, b, steps, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns):
    """(index k of a colliding sample k / count or 0 when none, count)."""
    moving = np.zeros(all_pairs.shape[0], dtype=np.bool_)
    for p in range(all_pairs.shape[0]):
        for j in range(a.shape[0]):
            if pair_columns[p, j] and a[j] != b[j]:
                moving[p] = True
                break
    pairs = all_pairs[moving]
    count = 1
    for j in range(a.shape[0]):
        need = int(math.ceil(abs(b[j] - a[j]) / steps[j]))
        if need > count:
            count = need
    x, y, c, s, yaws = np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links)
    centres = np.empty((2, shape_link.shape[0]))
    q = np.empty(a.shape[0])
    full = True
    # The same states as a scan from start to end, visited end first and then by halving
    # strides (odd multiples of each power of two): a collision in the middle of a long
    # motion, the common case for a failed connection, is found after a few states.
    stride = 1
    while stride * 2 < count:
        stride *= 2
    i = count
    while True:
        t = i / count
        for j in range(a.shape[0]):
            q[j] = a[j] + (b[j] - a[j]) * t
        if not _state_valid(q, kin_int, kin_float, x, y, c, s, yaws, centres, full, shape_link, shape_nv,
                            shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol):
            return i, count
        full = False
        if i == count:
            i = stride
        else:
            i += 2 * stride
        while i >= count:
            stride //= 2
            if stride == 0:
                return 0, count
            i = stride
    return 0, count


@njit(cache=True, nogil=True)
def pair_hits(states, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center, shape_radius,
              shape_verts, shape_normals, shape_extent, pairs, tol):
    hits = np.zeros(pairs.shape[0], dtype=np.bool_)
    x, y, c, s, yaws = np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links)
    for i in range(states.shape[0]):
        _poses(states[i], kin_int, kin_float, x, y, c, s, yaws, i == 0)
        for p in range(pairs.shape[0]):
            if not hits[p] and _pair_collides(pairs[p, 0], pairs[p, 1], x, y, c, s, shape_link, shape_nv,
                                              shape_center, shape_radius, shape_verts, shape_normals,
                                              shape_extent, tol, tol):
                hits[p] = True
    return hits


@njit(cache=True, nogil=True)
def nearest_l1(states: np.ndarray, size: int, query: np.ndarray, weights: np.ndarray) -> int:
    """Index of the row of ``states[:size]`` nearest to ``query`` in weighted L1 (compiled:
    the brute-force scan dominates a run once the trees hold thousands of nodes)."""
    best, best_distance = 0, np.inf
    for i in range(size):
        distance = 0.0
        for j in range(query.shape[0]):
            distance += weights[j] * abs(states[i, j] - query[j])
            if distance >= best_distance:
                break
        if distance < best_distance:
            best, best_distance = i, distance
    return best


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
        if moving[p]:
            continue
        pa, pb = all_pairs[p, 0], all_pairs[p, 1]
        reach = shape_radius[pa] + shape_radius[pb] - tol
        if reach > 0.0:
            ex, ey = centres[0, pb] - centres[0, pa], centres[1, pb] - centres[1, pa]
            far = reach + FAR_MARGIN
            if ex * ex + ey * ey >= far * far:
                continue
        if _pair_collides(pa, pb, x, y, c, s, shape_link, shape_nv, shape_center, shape_radius, shape_verts,
                          shape_normals, shape_extent, tol, tol):
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
