"""Where a free object of :class:`~solver.validation.blocking.BlockingProver` can get to: its run of cells
between walls, and the runs two objects in each other's way leave each other.

A judge accepts a path only where every state it checks is valid, and between two checked states no joint
moves more than a step (:data:`~solver.validation.blocking.LEAST_EROSION` bounds it: cells that wide in any
point's motion are wider than every judge's step). So an object's joint, from cell to checked cell, moves by
at most ``g`` cells, where ``g`` cells are that wide (one cell at a standard proof's levels, a few at a deep
proof's): a run of at least ``g`` blocked cells is a wall it cannot jump (:func:`walls`), and the cells of two
objects i and k at consecutive checked states are at most ``g_i`` and ``g_k`` apart. Every checked state lies
in a cell pair not blocked throughout (a blocked pair collides wherever in its cells the objects are), so the
cell pairs of a path are a walk through free cell pairs from the start's, by such moves: the pairs that walk
can reach (:func:`pair_spans`) hold every state of a path, and their projections hold each object's values.
That is sound for any objects held to their runs: the runs shrink one step at a time, each step from runs
that every path keeps to (by the steps before it), so every path keeps to the runs after it too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from solver.validation.cell_pairs import or_throughout


def walls(blocked: np.ndarray, start: int, width: int) -> tuple[int, int]:
    """The run of cells around ``start`` (not blocked) up to the nearest runs of at least ``width`` blocked
    cells on either side: its first and last cell."""
    if not blocked[start]:
        left, right = _walls(blocked, start, width)
        return int(left), int(right)
    return _walls_around_blocked(blocked, start, width)


@njit(cache=True, nogil=True)
def _walls(blocked, start, width):  # pragma: no cover (compiled)
    """:func:`walls` from an unblocked ``start``: the nearest run of at least ``width`` blocked cells on each
    side, scanned outwards (the first cell after the left one, the last before the right one)."""
    n = len(blocked)
    left, right = 0, n - 1
    j = start - 1
    while j >= 0:
        if blocked[j]:
            end = j + 1
            while j >= 0 and blocked[j]:
                j -= 1
            if end - (j + 1) >= width:
                left = end
                break
        else:
            j -= 1
    j = start + 1
    while j < n:
        if blocked[j]:
            first = j
            while j < n and blocked[j]:
                j += 1
            if j - first >= width:
                right = first - 1
                break
        else:
            j += 1
    return left, right


def _walls_around_blocked(blocked: np.ndarray, start: int, width: int) -> tuple[int, int]:
    """:func:`walls` where ``start`` itself is blocked (the proof stops before it asks: kept as it was)."""
    if width == 1:
        before, after = np.flatnonzero(blocked[:start]), np.flatnonzero(blocked[start + 1:])
        return int(before[-1] + 1 if len(before) else 0), int(start + after[0] if len(after) else len(blocked) - 1)
    edges = np.flatnonzero(np.diff(np.r_[0, blocked.view(np.int8), 0]))
    firsts, ends = edges[::2], edges[1::2]  # blocked runs firsts[k] .. ends[k] - 1
    wide = ends - firsts >= width
    before, after = ends[wide & (ends <= start)], firsts[wide & (firsts > start)]
    return (int(before[-1]) if len(before) else 0), (int(after[0]) - 1 if len(after) else len(blocked) - 1)


@njit(cache=True, nogil=True)
def flood(free, first, second, reach_first, reach_second):  # pragma: no cover (compiled)
    """The cells of the grid ``free`` (bool, n x m) reached from (``first``, ``second``) by moves of at most
    ``reach_first`` rows and ``reach_second`` columns, through free cells only."""
    n, m = free.shape
    seen = np.zeros((n, m), dtype=np.bool_)
    if not free[first, second]:
        return seen
    stack = np.empty(n * m, dtype=np.int64)
    stack[0], top = first * m + second, 1
    seen[first, second] = True
    while top:
        top -= 1
        a, b = divmod(stack[top], m)
        for x in range(max(0, a - reach_first), min(n, a + reach_first + 1)):
            for y in range(max(0, b - reach_second), min(m, b + reach_second + 1)):
                if free[x, y] and not seen[x, y]:
                    seen[x, y] = True
                    stack[top] = x * m + y
                    top += 1
    return seen


@njit(cache=True, nogil=True)
def _reached(table, blocked_i, blocked_k, lo_i, hi_i, lo_k, hi_k, first, second, reach_first,
             reach_second):  # pragma: no cover (compiled)
    """The first and last rows and columns of the cells :func:`flood` reaches in ``pair_spans``' grid of free
    cell pairs (rows ``lo_i``..``hi_i`` of ``table`` and ``blocked_i``, columns ``lo_k``..``hi_k``), relative to
    its corner, from (``first``, ``second``); (-1, -1, -1, -1) when that cell is not free. A cell is free where
    neither ``table`` nor either ``blocked`` marks it, tested as the fill comes to it (the grid is not built);
    the fill stops once it has reached every side of the grid, which no further cell can change."""
    n, m = hi_i - lo_i + 1, hi_k - lo_k + 1
    if table[lo_i + first, lo_k + second] or blocked_i[lo_i + first] or blocked_k[lo_k + second]:
        return -1, -1, -1, -1
    seen = np.zeros((n, m), dtype=np.bool_)
    stack = np.empty(n * m, dtype=np.int64)
    stack[0], top = first * m + second, 1
    seen[first, second] = True
    row_low = row_high = first
    column_low = column_high = second
    while top:
        if row_low == 0 and column_low == 0 and row_high == n - 1 and column_high == m - 1:
            break
        top -= 1
        a, b = divmod(stack[top], m)
        for x in range(max(0, a - reach_first), min(n, a + reach_first + 1)):
            if blocked_i[lo_i + x]:
                continue
            for y in range(max(0, b - reach_second), min(m, b + reach_second + 1)):
                if not seen[x, y] and not blocked_k[lo_k + y] and not table[lo_i + x, lo_k + y]:
                    seen[x, y] = True
                    stack[top] = x * m + y
                    top += 1
                    row_low, row_high = min(row_low, x), max(row_high, x)
                    column_low, column_high = min(column_low, y), max(column_high, y)
    return row_low, row_high, column_low, column_high


def pair_spans(table: np.ndarray, blocked_i: np.ndarray, blocked_k: np.ndarray, span_i: tuple[int, int],
               span_k: tuple[int, int], start_i: int, start_k: int, steps_i: int, steps_k: int
               ) -> tuple[tuple[int, int], tuple[int, int]]:
    """The runs of objects i and k within ``span_i`` and ``span_k`` that the cell pairs reachable from the start's
    hold (see the module docstring): ``table`` (cells of i, cells of k) marks the pairs blocked throughout,
    ``blocked_i`` and ``blocked_k`` the cells each is kept out of whatever the other does, ``steps_i`` and
    ``steps_k`` the most cells a joint moves between checked states. (The rows and columns :func:`flood` reaches
    through the free pairs, found by :func:`_reached` without building the grid, stopping once nothing can
    widen them: ``tests/test_deep_proof.py`` holds it to the flood.)"""
    (lo_i, hi_i), (lo_k, hi_k) = span_i, span_k
    row_low, row_high, column_low, column_high = _reached(table, blocked_i, blocked_k, lo_i, hi_i, lo_k, hi_k,
                                                          start_i - lo_i, start_k - lo_k, steps_i, steps_k)
    if row_low < 0:  # the start pair itself blocked: the caller has found that already
        return span_i, span_k
    return (lo_i + row_low, lo_i + row_high), (lo_k + column_low, lo_k + column_high)


@njit(cache=True, nogil=True)
def prune(table, domain_i, domain_k):  # pragma: no cover (compiled)
    """Arc consistency's step for objects i and k: drops from ``domain_i`` (in place) each cell whose row of
    ``table`` (cells of i, cells of k: the pairs blocked throughout) is blocked at every cell of ``domain_k``
    (all of them where that is empty); whether any was dropped. A row stops at its first cell left free."""
    columns = np.flatnonzero(domain_k)
    changed = False
    for r in range(len(domain_i)):
        if domain_i[r]:
            for c in columns:
                if not table[r, c]:
                    break
            else:
                domain_i[r] = False
                changed = True
    return changed


def emptied(domains: list[np.ndarray], tables: dict[tuple[int, int], np.ndarray]) -> bool:
    """Arc consistency over the free objects' goal cells ``domains`` (narrowed in place), each pair (i, k)
    keeping to the cells of i that some cell of k's domain leaves free (``tables`` as :class:`Runs`' : a pair
    that blocks no cell pair left out): whether some object is left without cells."""
    changed = True
    while changed:
        if any(not mask.any() for mask in domains):
            return True
        changed = False
        for i in range(len(domains)):
            for k in range(len(domains)):
                if k == i:
                    continue
                table = tables.get((i, k))
                if table is not None:
                    changed |= prune(table, domains[i], domains[k])
                elif not domains[k].any() and domains[i].any():  # no cell of k left: none of i has support
                    domains[i][:] = False
                    changed = True
    return any(not mask.any() for mask in domains)


@dataclass
class Runs:
    """Free objects' runs of cells while :class:`~solver.validation.blocking.BlockingProver` narrows them."""

    spans: list[tuple[int, int]]
    """Per object, its run's first and last cell."""
    blocks: list[np.ndarray]
    """Per object, its cells blocked in the last sweep (by the fixed objects or others anywhere in their runs)."""
    fixed: list[np.ndarray]
    """Per object, its cells the fixed objects block."""
    tables: dict[tuple[int, int], np.ndarray]
    """(i, k): the cell pairs of objects i and k blocked throughout (pairs that block none left out)."""
    starts: list[int]
    """Per object, its start's cell."""
    steps: list[int]
    """Per object, the most cells its joint moves between checked states (a wall's least width)."""

    def swept(self) -> bool:
        """Narrows each run to the cells between the walls that the fixed objects and the others anywhere in
        their runs leave it, one object at a time, until none narrows; False when a start cell is blocked."""
        changed = True
        while changed:
            changed = False
            for i in range(len(self.spans)):
                blocked = self.blocks[i] = self.fixed[i].copy()
                for k in range(len(self.spans)):
                    if (i, k) in self.tables:
                        or_throughout(self.tables[i, k], self.spans[k][0], self.spans[k][1], blocked)
                if blocked[self.starts[i]]:
                    return False
                left, right = walls(blocked, self.starts[i], self.steps[i])
                left, right = max(self.spans[i][0], left), min(self.spans[i][1], right)
                if (left, right) != self.spans[i]:
                    self.spans[i], changed = (left, right), True
        return True


def warm_up() -> None:
    """Load the compiled flood fill and arc consistency (from numba's cache, or compile them), for tables in
    memory order and transposed (a table asked the other way round is a view)."""
    flood(np.ones((2, 2), dtype=np.bool_), 0, 0, 1, 1)
    cells = np.zeros(2, dtype=np.bool_)
    walls(cells, 0, 1)
    for table in (np.zeros((2, 2), dtype=np.bool_), np.zeros((2, 2), dtype=np.bool_).T):
        pair_spans(table, cells, cells, (0, 1), (0, 1), 0, 0, 1, 1)
        prune(table, cells.copy(), cells)
        or_throughout(table, 0, 1, cells.copy())
