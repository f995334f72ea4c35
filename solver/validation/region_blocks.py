"""The finest level of :mod:`solver.validation.region_proof`'s flood fill, kept by parent cell.

At the finest level nearly every cell the fill reaches lies far from every obstacle: of a Rooms
question's 1.4 million cells (the children of the coarser level's reached cells, within their box)
about 400,000 are reached and fewer than 20,000 lie in a parent cell near an obstacle. So the level is
kept by parent cell (a *block* of ``factor`` x ``factor`` children):

- *closed*: its parent was not reached at the coarser level (every child closed, as before);
- *open*: the parent's centre is farther than ``reach + spread`` from every obstacle, ``spread`` being
  the farthest a child's centre lies from its parent's (the difference of their half-diagonals): every
  child's centre is then farther than ``reach``, so no child is blocked;
- *mixed*: the others, whose children are classified one by one exactly as the dense grid classifies
  them (the same rows, chords and rounding).

The fill then reaches exactly the cells the dense fill reaches: an open block's children are open and
8-connected among themselves, two 8-neighbouring open blocks touch through open children, and an open
block meets a mixed one through the children on their shared side (or corner), which are pushed one
by one. Only the test of openness has a slack (:data:`~solver.validation.region_proof.REGION_SLACK`,
far more than the arithmetic's rounding), and it can only call a block mixed, which costs time, never
a verdict.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

CLOSED = -2
"""A block whose parent was not reached."""
OPEN = -1
"""A block no child of which is blocked; a mixed block holds its index into the children's tables instead."""


@njit(cache=True, nogil=True)
def _bands(vertices, counts, reach):  # pragma: no cover (compiled)
    """The corners of every edge's band, the parallelogram of the points within ``reach`` beside the
    edge, once per obstacle instead of once per row: (n, k, 4) x and y, for :func:`_chord`."""
    px = np.zeros((vertices.shape[0], vertices.shape[1], 4))
    py = np.zeros((vertices.shape[0], vertices.shape[1], 4))
    for o in range(vertices.shape[0]):
        count = counts[o]
        for k in range(count):
            ax, ay = vertices[o, k, 0], vertices[o, k, 1]
            bx, by = vertices[o, (k + 1) % count, 0], vertices[o, (k + 1) % count, 1]
            length = math.hypot(bx - ax, by - ay)
            nx, ny = (by - ay) / length * reach, -(bx - ax) / length * reach
            px[o, k, 0], px[o, k, 1], px[o, k, 2], px[o, k, 3] = ax + nx, bx + nx, bx - nx, ax - nx
            py[o, k, 0], py[o, k, 1], py[o, k, 2], py[o, k, 3] = ay + ny, by + ny, by - ny, ay - ny
    return px, py


@njit(cache=True, nogil=True)
def _chord(vertices, count, px, py, y, reach):  # pragma: no cover (compiled)
    """The x interval of the points on the line at ``y`` within ``reach`` of the convex polygon
    (``lo > hi`` when none), its edges' bands' corners given (:func:`_bands`): the hull of the chords of
    its edges' capsules, which cover the boundary of the polygon grown by ``reach``, a convex set."""
    lo, hi = np.inf, -np.inf
    for k in range(count):
        ax = vertices[k, 0]
        dy = y - vertices[k, 1]
        if abs(dy) <= reach:
            d = math.sqrt(reach * reach - dy * dy)
            lo, hi = min(lo, ax - d), max(hi, ax + d)
        for j in range(4):
            x0, y0, x1, y1 = px[k, j], py[k, j], px[k, (j + 1) % 4], py[k, (j + 1) % 4]
            if (y0 - y) * (y1 - y) > 0:
                continue
            if y0 == y1:
                lo, hi = min(lo, x0, x1), max(hi, x0, x1)
            else:
                x = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
                lo, hi = min(lo, x), max(hi, x)
    return lo, hi


@njit(cache=True, nogil=True)
def _mark(bits, index, factor, lo, hi, j, origin_x, width):  # pragma: no cover (compiled)
    """Block the children of mixed blocks in row ``j`` whose centres lie in [lo, hi] (the dense grid's
    ``_fill``, the same rounding)."""
    if lo > hi:
        return
    first = max(0, int(math.ceil((lo - origin_x) / width - 0.5)))
    last = min(index.shape[0] * factor - 1, int(math.floor((hi - origin_x) / width - 0.5)))
    bj, b = j // factor, j % factor
    for bi in range(first // factor, last // factor + 1):
        k = index[bi, bj]
        if k < 0:
            continue
        for i in range(max(first, bi * factor), min(last, bi * factor + factor - 1) + 1):
            bits[k, i - bi * factor, b] = True


@njit(cache=True, nogil=True)
def _near(vertices, counts, circles, reach, origin_x, origin_y, width, nx, ny):  # pragma: no cover (compiled)
    """(nx, ny) cells whose centres lie within ``reach`` of an obstacle (a cell of the blocks' grid)."""
    rows = np.zeros((ny, nx), dtype=np.bool_)
    mark_obstacles(rows, vertices, counts, circles, reach, origin_x, origin_y, width)
    return rows.T.copy()


@njit(cache=True, nogil=True)
def mark_obstacles(rows, vertices, counts, circles, reach, origin_x, origin_y, width):  # pragma: no cover (compiled)
    """Mark the cells of ``rows`` (row ``j`` at y = origin_y + (j + 0.5) width, cell ``i`` at x = origin_x +
    (i + 0.5) width) whose centres lie within ``reach`` of an obstacle: a convex polygon (:func:`_chord`)
    or a circle."""
    ny = rows.shape[0]
    px, py = _bands(vertices, counts, reach)
    for o in range(vertices.shape[0]):
        count = counts[o]
        low, high = np.inf, -np.inf
        for k in range(count):
            low, high = min(low, vertices[o, k, 1]), max(high, vertices[o, k, 1])
        first = max(0, int(math.ceil((low - reach - origin_y) / width - 0.5)))
        last = min(ny - 1, int(math.floor((high + reach - origin_y) / width - 0.5)))
        for j in range(first, last + 1):
            lo, hi = _chord(vertices[o], count, px[o], py[o], origin_y + (j + 0.5) * width, reach)
            fill_row(rows, lo, hi, j, origin_x, width)
    for o in range(circles.shape[0]):
        cx, cy, grown = circles[o, 0], circles[o, 1], circles[o, 2] + reach
        first = max(0, int(math.ceil((cy - grown - origin_y) / width - 0.5)))
        last = min(ny - 1, int(math.floor((cy + grown - origin_y) / width - 0.5)))
        for j in range(first, last + 1):
            dy = origin_y + (j + 0.5) * width - cy
            if abs(dy) <= grown:
                d = math.sqrt(grown * grown - dy * dy)
                fill_row(rows, cx - d, cx + d, j, origin_x, width)


@njit(cache=True, nogil=True)
def fill_row(rows, lo, hi, j, origin_x, width):  # pragma: no cover (compiled)
    """Mark the cells of row ``j`` (``rows[j]``) whose centres lie in [lo, hi]."""
    if lo > hi:
        return
    first = max(0, int(math.ceil((lo - origin_x) / width - 0.5)))
    last = min(rows.shape[1] - 1, int(math.floor((hi - origin_x) / width - 0.5)))
    for i in range(first, last + 1):
        rows[j, i] = True


@njit(cache=True, nogil=True)
def blocks(vertices, counts, circles, reach, spread, origin_x, origin_y, width, factor, parent, parent_i, parent_j,
           nbx, nby):  # pragma: no cover (compiled)
    """The finest level's cells by block: (index, bits). ``index[bi, bj]`` is :data:`CLOSED`, :data:`OPEN`
    or a mixed block's row of ``bits``, whose ``bits[k, a, b]`` says whether the child (a, b) is blocked.
    The grid is (nbx x nby) blocks of ``factor`` x ``factor`` cells ``width`` across, its first cell's
    corner at (origin_x, origin_y); block (bi, bj)'s parent is ``parent[parent_i + bi, parent_j + bj]``.
    A cell is blocked when its centre lies within ``reach`` of an obstacle (none when ``reach <= 0``)."""
    index = np.full((nbx, nby), CLOSED, dtype=np.int64)
    near = _near(vertices, counts, circles, reach + spread, origin_x, origin_y, width * factor, nbx, nby) \
        if reach > 0 else np.zeros((nbx, nby), dtype=np.bool_)
    mixed = 0
    for bi in range(nbx):
        for bj in range(nby):
            if parent[parent_i + bi, parent_j + bj]:
                if near[bi, bj]:
                    index[bi, bj] = mixed
                    mixed += 1
                else:
                    index[bi, bj] = OPEN
    bits = np.zeros((mixed, factor, factor), dtype=np.bool_)
    if reach <= 0 or mixed == 0:
        return index, bits
    ny = nby * factor
    px, py = _bands(vertices, counts, reach)
    for o in range(vertices.shape[0]):
        count = counts[o]
        low, high = np.inf, -np.inf
        for k in range(count):
            low, high = min(low, vertices[o, k, 1]), max(high, vertices[o, k, 1])
        first = max(0, int(math.ceil((low - reach - origin_y) / width - 0.5)))
        last = min(ny - 1, int(math.floor((high + reach - origin_y) / width - 0.5)))
        for j in range(first, last + 1):
            lo, hi = _chord(vertices[o], count, px[o], py[o], origin_y + (j + 0.5) * width, reach)
            _mark(bits, index, factor, lo, hi, j, origin_x, width)
    for o in range(circles.shape[0]):
        cx, cy, grown = circles[o, 0], circles[o, 1], circles[o, 2] + reach
        first = max(0, int(math.ceil((cy - grown - origin_y) / width - 0.5)))
        last = min(ny - 1, int(math.floor((cy + grown - origin_y) / width - 0.5)))
        for j in range(first, last + 1):
            dy = origin_y + (j + 0.5) * width - cy
            if abs(dy) <= grown:
                d = math.sqrt(grown * grown - dy * dy)
                _mark(bits, index, factor, cx - d, cx + d, j, origin_x, width)
    for bi in range(nbx):  # a mixed block none of whose children is blocked is an open one
        for bj in range(nby):
            k = index[bi, bj]
            if k >= 0 and not bits[k].any():
                index[bi, bj] = OPEN
    return index, bits


@njit(cache=True, nogil=True)
def is_open(index, bits, factor, i, j):  # pragma: no cover (compiled)
    """Whether cell (i, j) of the blocks' grid may be entered."""
    k = index[i // factor, j // factor]
    return k == OPEN or (k >= 0 and not bits[k, i % factor, j % factor])


@njit(cache=True, nogil=True)
def _log2(factor):  # pragma: no cover (compiled)
    shift = 0
    while (1 << shift) < factor:
        shift += 1
    return shift


@njit(cache=True, nogil=True)
def fill(index, bits, factor, start_i, start_j):  # pragma: no cover (compiled)
    """The cells an 8-connected fill from the open cell (start_i, start_j) reaches: (the open blocks
    reached, the mixed blocks' children reached). A depth-first fill of single cells in mixed blocks,
    of whole blocks in open ones, each marked when first pushed (so pushed once). ``factor`` is a power
    of two, the grid under 2 ** 31 cells a side."""
    nbx, nby = index.shape
    nx, ny = nbx * factor, nby * factor
    shift, mask = _log2(factor), factor - 1  # shifts, not divisions: a division costs tens of cycles
    whole = np.zeros((nbx, nby), dtype=np.bool_)
    reached = np.zeros(bits.shape, dtype=np.bool_)
    opened = 0
    for bi in range(nbx):
        for bj in range(nby):
            opened += index[bi, bj] == OPEN
    stack = np.empty(bits.size + opened + 1, dtype=np.int64)
    bi, bj = start_i >> shift, start_j >> shift
    if index[bi, bj] == OPEN:
        whole[bi, bj] = True
    else:
        reached[index[bi, bj], start_i & mask, start_j & mask] = True
    stack[0] = (start_i << 32) | start_j
    top = 1
    while top > 0:
        top -= 1
        i, j = stack[top] >> 32, stack[top] & 0xFFFFFFFF
        bi, bj = i >> shift, j >> shift
        if index[bi, bj] == OPEN:
            for di in range(-1, 2):
                for dj in range(-1, 2):
                    ci, cj = bi + di, bj + dj
                    if (di == 0 and dj == 0) or ci < 0 or cj < 0 or ci >= nbx or cj >= nby:
                        continue
                    q = index[ci, cj]
                    if q == OPEN:
                        if not whole[ci, cj]:
                            whole[ci, cj] = True
                            stack[top] = ((ci << shift) << 32) | (cj << shift)
                            top += 1
                    elif q >= 0:  # its children beside this block: a column, a row or a corner
                        a0 = factor - 1 if di < 0 else 0
                        a1 = 0 if di > 0 else factor - 1
                        b0 = factor - 1 if dj < 0 else 0
                        b1 = 0 if dj > 0 else factor - 1
                        for a in range(a0, a1 + 1):
                            for b in range(b0, b1 + 1):
                                if not bits[q, a, b] and not reached[q, a, b]:
                                    reached[q, a, b] = True
                                    stack[top] = (((ci << shift) + a) << 32) | ((cj << shift) + b)
                                    top += 1
        else:
            for x in range(i - 1, i + 2):
                for y in range(j - 1, j + 2):
                    if (x == i and y == j) or x < 0 or y < 0 or x >= nx or y >= ny:
                        continue
                    ci, cj = x >> shift, y >> shift
                    q = index[ci, cj]
                    if q == OPEN:
                        if not whole[ci, cj]:
                            whole[ci, cj] = True
                            stack[top] = (x << 32) | y
                            top += 1
                    elif q >= 0 and not bits[q, x & mask, y & mask] and not reached[q, x & mask, y & mask]:
                        reached[q, x & mask, y & mask] = True
                        stack[top] = (x << 32) | y
                        top += 1
    return whole, reached


@njit(cache=True, nogil=True)
def meets(index, whole, reached, factor, x0, y0, x1, y1):  # pragma: no cover (compiled)
    """Whether a reached cell lies in the cells [x0, x1) x [y0, y1) (clipped to the grid; x0, y0 >= 0)."""
    nbx, nby = index.shape
    x1, y1 = min(x1, nbx * factor), min(y1, nby * factor)
    if x0 >= x1 or y0 >= y1:
        return False
    for bi in range(x0 // factor, (x1 - 1) // factor + 1):
        for bj in range(y0 // factor, (y1 - 1) // factor + 1):
            k = index[bi, bj]
            if k == OPEN and whole[bi, bj]:
                return True
            if k >= 0:
                for i in range(max(x0, bi * factor), min(x1, bi * factor + factor)):
                    for j in range(max(y0, bj * factor), min(y1, bj * factor + factor)):
                        if reached[k, i - bi * factor, j - bj * factor]:
                            return True
    return False
