"""Compiled inner loops of the collision model (see ``solver.collision.model`` for the geometry).

Kept apart so the model's construction stays readable Python while the hot
loops (forward kinematics + separating-axis tests, per state) run compiled.
All arrays are prepared by ``CollisionModel._compile_arrays``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from solver.collision.jit_cache import refresh_stale_jit_cache

refresh_stale_jit_cache()  # before anything compiled here or in the files that call it is loaded from the cache


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


@njit(cache=True, nogil=True, inline='always')
def _poses_and_centres(q, kin_int, kin_float, x, y, c, s, yaws, centres, full, shape_link, shape_center):
    """:func:`_poses`, then each shape's bounding-circle centre in the world, once per state: most candidate
    pairs stand apart (80 % in Grid World, 97 % in Rooms) and are then skipped at a few operations each."""
    _poses(q, kin_int, kin_float, x, y, c, s, yaws, full)
    for i in range(shape_link.shape[0]):
        link, cx, cy = shape_link[i], shape_center[i, 0], shape_center[i, 1]
        centres[0, i] = x[link] + c[link] * cx - s[link] * cy
        centres[1, i] = y[link] + s[link] * cx + c[link] * cy


@njit(cache=True, nogil=True)
def _state_valid(q, kin_int, kin_float, x, y, c, s, yaws, centres, full, shape_link, shape_nv, shape_center,
                 shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol):
    _poses_and_centres(q, kin_int, kin_float, x, y, c, s, yaws, centres, full, shape_link, shape_center)
    for p in range(pairs.shape[0]):
        if _near_pair_collides(pairs[p, 0], pairs[p, 1], x, y, c, s, centres, shape_link, shape_nv, shape_center,
                               shape_radius, shape_verts, shape_normals, shape_extent, tol):
            return False
    return True


@njit(cache=True, nogil=True, inline='always')
def _near_pair_collides(a, b, x, y, c, s, centres, shape_link, shape_nv, shape_center, shape_radius, shape_verts,
                        shape_normals, shape_extent, tol):
    """:func:`_pair_collides` of shapes ``a`` and ``b`` (``tol`` both tolerances), a pair whose
    world-frame bounding-circle centres (``centres``) stand :data:`FAR_MARGIN` beyond reach skipped first."""
    reach = shape_radius[a] + shape_radius[b] - tol
    if reach > 0.0:
        ex, ey = centres[0, b] - centres[0, a], centres[1, b] - centres[1, a]
        far = reach + FAR_MARGIN
        if ex * ex + ey * ey >= far * far:
            return False
    return _pair_collides(a, b, x, y, c, s, shape_link, shape_nv, shape_center, shape_radius, shape_verts,
                          shape_normals, shape_extent, tol, tol)


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


@njit(inline="always")
def _unpacked(ints, floats):
    """The model's arrays as views of the packed ones (``CollisionModel._pack``), holding the same
    numbers, and a copy of the fixed links' poses (:func:`fixed_poses`, computed by the same code once)."""
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
    poses = floats[o:o + 5 * n_links].reshape((5, n_links)).copy()
    return (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
            shape_extent, pairs, tol, poses)


@njit(cache=True, nogil=True)
def state_valid_packed(q, ints, floats):
    """One state's validity as a bool (the single-state queries' entry point), with the model's
    arrays packed into two (``CollisionModel._pack``): a call from Python pays for each argument
    it passes, and this one passes three instead of thirteen.
    The arrays are views of the packed ones, holding the same numbers: the same verdicts. The
    fixed links' poses come packed too (:func:`fixed_poses`), computed by the same code once."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, poses) = _unpacked(ints, floats)
    # Only the moving links' poses are computed here.
    centres = np.empty((2, len(shape_link)))
    return _state_valid(q, kin_int, kin_float, poses[0], poses[1], poses[2], poses[3], poses[4], centres, False,
                        shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals, shape_extent,
                        pairs, tol)


@njit(cache=True, nogil=True)
def pair_hits_packed(q, ints, floats):
    """:func:`pair_hits` of the one state ``q``, with the model packed as for :func:`state_valid_packed`
    (a goal sampler asks which pairs collide one state at a time): the same pair test on the same
    numbers, the same answers."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, poses) = _unpacked(ints, floats)
    x, y, c, s, yaws = poses[0], poses[1], poses[2], poses[3], poses[4]
    _poses(q, kin_int, kin_float, x, y, c, s, yaws, False)
    hits = np.zeros(pairs.shape[0], dtype=np.bool_)
    for p in range(pairs.shape[0]):
        hits[p] = _pair_collides(pairs[p, 0], pairs[p, 1], x, y, c, s, shape_link, shape_nv, shape_center,
                                 shape_radius, shape_verts, shape_normals, shape_extent, tol, tol)
    return hits


@njit(cache=True, nogil=True)
def pair_hits_rows(states, ints, floats):
    """:func:`pair_hits_packed` of each row of ``states`` (N, d) in one call: row i of the result is
    that state's colliding pairs (a goal sampler's repair asks it of all its draws at once)."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, poses) = _unpacked(ints, floats)
    x, y, c, s, yaws = poses[0], poses[1], poses[2], poses[3], poses[4]
    hits = np.zeros((states.shape[0], pairs.shape[0]), dtype=np.bool_)
    for i in range(states.shape[0]):
        _poses(states[i], kin_int, kin_float, x, y, c, s, yaws, False)
        for p in range(pairs.shape[0]):
            hits[i, p] = _pair_collides(pairs[p, 0], pairs[p, 1], x, y, c, s, shape_link, shape_nv, shape_center,
                                        shape_radius, shape_verts, shape_normals, shape_extent, tol, tol)
    return hits


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


@njit(cache=True, nogil=True)
def first_colliding_motion(states, known, steps, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                           shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol, pair_columns):
    """Index ``i`` of the first motion ``states[i] -> states[i + 1]`` that :func:`motion_collision` finds
    colliding, or -1: the same motion checks, in the same order, in one call; a motion with
    ``known[i]`` (known to be free) is not checked."""
    for i in range(states.shape[0] - 1):
        if known[i]:
            continue
        hit, _ = _motion_hit(states[i], states[i + 1], steps, kin_int, kin_float, n_links, shape_link, shape_nv,
                             shape_center, shape_radius, shape_verts, shape_normals, shape_extent, all_pairs, tol,
                             pair_columns)
        if hit > 0:
            return i
    return -1


@njit(cache=True, nogil=True)
def motion_collides_packed(a, b, steps, ints, floats, pair_columns):
    """Whether :func:`motion_collision` finds the motion ``a -> b`` colliding, with the model packed as
    for :func:`state_valid_packed` (a planner's motion query: six arguments instead of sixteen)."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, _poses_kept) = _unpacked(ints, floats)
    hit, _ = _motion_hit(a, b, steps, kin_int, kin_float, ints[0], shape_link, shape_nv, shape_center,
                         shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol, pair_columns)
    return hit > 0


@njit(cache=True, nogil=True)
def _pairs_valid(q, kin_int, kin_float, x, y, c, s, yaws, centres, full, shape_link, shape_nv, shape_center,
                 shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol, moving, which):
    """:func:`_state_valid` over the pairs ``p`` with ``moving[p] == which`` only (the same tests)."""
    _poses_and_centres(q, kin_int, kin_float, x, y, c, s, yaws, centres, full, shape_link, shape_center)
    for p in range(pairs.shape[0]):
        if moving[p] == which and _near_pair_collides(pairs[p, 0], pairs[p, 1], x, y, c, s, centres, shape_link,
                                                      shape_nv, shape_center, shape_radius, shape_verts,
                                                      shape_normals, shape_extent, tol):
            return False
    return True


@njit(cache=True, nogil=True)
def path_collisions(states, steps, stop, held_only, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                    shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol, pair_columns):
    """How many of the points ``solver.planning.problem.segment_points`` puts along the path ``states``
    (its first state excluded) collide; with ``stop``, 1 at the first colliding one.

    The same points (``a + (b - a) * (k / count)``, ``count`` the most steps a joint needs) and, at
    each, the same pair tests as :func:`check_states`, but a pair that no joint changing along a
    segment moves (``pair_columns``) is tested once, at the segment's first point: every point of
    the segment holds exactly its values there, so its verdict is the same at every one. With
    ``held_only`` only those pairs are tested. (A segment's points go into a block first: the tests
    then run as fast as :func:`check_states`'.)"""
    d = states.shape[1]
    x, y, c, s, yaws = np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links)
    centres = np.empty((2, shape_link.shape[0]))
    moving = np.empty(pairs.shape[0], dtype=np.bool_)
    bad = 0
    full = True
    for i in range(states.shape[0] - 1):
        a, b = states[i], states[i + 1]
        most = 0.0
        for j in range(d):
            ratio = abs(b[j] - a[j]) / steps[j]
            if ratio > most:
                most = ratio
        count = max(1, int(math.ceil(most)))
        for p in range(pairs.shape[0]):
            moving[p] = False
            for j in range(d):
                if pair_columns[p, j] and a[j] != b[j]:
                    moving[p] = True
                    break
        points = 1 if held_only else count
        block = np.empty((points, d))
        for k in range(1, points + 1):
            t = k / count
            for j in range(d):
                block[k - 1, j] = a[j] + (b[j] - a[j]) * t
        if not _pairs_valid(block[0], kin_int, kin_float, x, y, c, s, yaws, centres, full, shape_link, shape_nv,
                            shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol, moving,
                            False):
            bad += count
            if stop:
                return 1
            continue
        full = False
        for k in range(0 if held_only else count):
            if not _pairs_valid(block[k], kin_int, kin_float, x, y, c, s, yaws, centres, False, shape_link, shape_nv,
                                shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol,
                                moving, True):
                bad += 1
                if stop:
                    return 1
    return bad


@njit(cache=True, nogil=True)
def pair_hits_changed(states, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center, shape_radius,
                      shape_verts, shape_normals, shape_extent, pairs, tol, pair_columns):
    """:func:`pair_hits`: the pairs that collide at any row of ``states``; a pair is tested again only at
    a row where a joint that moves it (``pair_columns``) changed since the row before (its shapes stand
    exactly where they stood, so its verdict is the same), and a row equal to the one before is skipped."""
    d = states.shape[1]
    hits = np.zeros(pairs.shape[0], dtype=np.bool_)
    changed = np.empty(d, dtype=np.bool_)
    x, y, c, s, yaws = np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links)
    for i in range(states.shape[0]):
        any_changed = i == 0
        for j in range(d):
            changed[j] = i == 0 or states[i, j] != states[i - 1, j]
            any_changed = any_changed or changed[j]
        if not any_changed:
            continue
        _poses(states[i], kin_int, kin_float, x, y, c, s, yaws, i == 0)
        for p in range(pairs.shape[0]):
            if hits[p]:
                continue
            moved = i == 0
            for j in range(d):
                if moved or pair_columns[p, j] and changed[j]:
                    moved = True
                    break
            if moved and _pair_collides(pairs[p, 0], pairs[p, 1], x, y, c, s, shape_link, shape_nv, shape_center,
                                        shape_radius, shape_verts, shape_normals, shape_extent, tol, tol):
                hits[p] = True
    return hits
