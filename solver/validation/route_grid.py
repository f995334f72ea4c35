"""The workspace grid of a routed re-plan (:meth:`solver.validation.validator.OmplValidator._replan_routed`):
the outlines it reasons with, the target's way through the free cells (A*, compiled) and the route's record.

The compiled search visits the cells in the order Python's ``heapq`` would: a binary heap pops the
smallest (estimate, cell) entry whatever its layout, and entries that compare equal are the same
entry, so the same pushes give the same pops, the same costs and the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from phyrogen_core.chain import pose_matrix
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder
from phyrogen_core.objects import PuzzleObject


def footprint(obj: PuzzleObject) -> np.ndarray | None:
    """World (x, y) points whose hull holds every collision shape of ``obj`` at its creation
    pose, or None for a shape this does not know."""
    points = []
    for geometry in obj.collisions:
        shape = geometry.shape
        if isinstance(shape, Box):
            hx, hy = shape.size[0] / 2, shape.size[1] / 2
            local = [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)]
        elif isinstance(shape, Cylinder):
            r = shape.radius
            local = [(-r, -r), (r, -r), (r, r), (-r, r)]
        elif isinstance(shape, ConvexPrism):
            local = [p for piece in shape.pieces for p in piece]
        else:
            return None
        frame = pose_matrix(obj.pose) @ pose_matrix(geometry.origin)
        points.append(np.asarray(local, dtype=float) @ frame[:2, :2].T + frame[:2, 3])
    return np.concatenate(points) if points else None


@dataclass(frozen=True)
class Route:
    """A routed re-plan's way: the problem columns of the target's x and y and of all its joints,
    and its legs, each the route's points (x, y) along the leg and the point where it ends."""

    columns: tuple[int, int]
    target_columns: tuple[int, ...]
    legs: list[tuple[np.ndarray, np.ndarray]]


def grid_path(free: np.ndarray, roomy: np.ndarray, start: tuple[int, int], end: tuple[int, int]):
    """The cheapest 8-connected way between two cells through ``free`` cells (a cell that is not
    ``roomy`` costs 4x: the way keeps to where the target can turn), as (k, 2) cell indices, or
    None. Diagonal steps need both cells beside them free, so the way never cuts a corner."""
    way = _grid_path(np.ascontiguousarray(free, dtype=np.bool_), np.ascontiguousarray(roomy, dtype=np.bool_),
                     int(start[0]), int(start[1]), int(end[0]), int(end[1]))
    return None if len(way) == 0 else way


_NEIGHBOURS = np.array([(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)], dtype=np.int64)


@njit(cache=True, nogil=True)
def _estimate(i, j, end_i, end_j):
    """Octile distance: never more than the cost left (A*)."""
    dx, dy = abs(i - end_i), abs(j - end_j)
    return max(dx, dy) + 0.41421356237309515 * min(dx, dy)


@njit(cache=True, nogil=True)
def _before(keys, cells, a, b):
    return keys[a] < keys[b] or (keys[a] == keys[b] and cells[a] < cells[b])


@njit(cache=True, nogil=True)
def _grid_path(free, roomy, start_i, start_j, end_i, end_j):
    """:func:`grid_path` compiled: the way's cells, or an empty (0, 2) array when there is none."""
    width, height = free.shape
    n = width * height
    open_ = free.ravel()
    cost = np.where(roomy.ravel(), 1.0, 4.0)
    source, sink = start_i * height + start_j, end_i * height + end_j
    best = np.full(n, np.inf)
    came = np.full(n, -1, dtype=np.int64)
    done = np.zeros(n, dtype=np.bool_)
    best[source] = 0.0
    capacity = 8 * n + 1  # every cell pushes at most its eight neighbours (each only when done)
    keys = np.empty(capacity)
    cells = np.empty(capacity, dtype=np.int64)
    keys[0], cells[0] = _estimate(start_i, start_j, end_i, end_j), source
    size = 1
    while size > 0:
        cell = cells[0]
        size -= 1
        keys[0], cells[0] = keys[size], cells[size]  # pop the smallest (estimate, cell): sift the last down
        k = 0
        while True:
            child = 2 * k + 1
            if child >= size:
                break
            if child + 1 < size and _before(keys, cells, child + 1, child):
                child += 1
            if not _before(keys, cells, child, k):
                break
            keys[k], keys[child] = keys[child], keys[k]
            cells[k], cells[child] = cells[child], cells[k]
            k = child
        if cell == sink:
            break
        if done[cell]:
            continue
        done[cell] = True
        i, j = cell // height, cell % height
        distance = best[cell]
        for m in range(8):
            di, dj = _NEIGHBOURS[m, 0], _NEIGHBOURS[m, 1]
            a, b = i + di, j + dj
            if not (0 <= a < width and 0 <= b < height):
                continue
            other = a * height + b
            if not open_[other]:
                continue
            if di != 0 and dj != 0 and not (open_[a * height + j] and open_[i * height + b]):
                continue
            step = (1.4142135623730951 if di != 0 and dj != 0 else 1.0) * cost[other]
            if distance + step < best[other]:
                best[other] = distance + step
                came[other] = cell
                keys[size], cells[size] = distance + step + _estimate(a, b, end_i, end_j), other  # push: sift up
                k = size
                size += 1
                while k > 0:
                    parent = (k - 1) // 2
                    if not _before(keys, cells, k, parent):
                        break
                    keys[k], keys[parent] = keys[parent], keys[k]
                    cells[k], cells[parent] = cells[parent], cells[k]
                    k = parent
    if best[sink] == np.inf:
        return np.empty((0, 2), dtype=np.int64)
    length = 1
    c = sink
    while c != source:
        c = came[c]
        length += 1
    way = np.empty((length, 2), dtype=np.int64)
    c = sink
    for k in range(length - 1, -1, -1):
        way[k, 0], way[k, 1] = c // height, c % height
        c = came[c]
    return way
