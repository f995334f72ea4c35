"""Where the mobile base can drive: a grid of free floor around the puzzle as it stands now.

A cell is free when a vertical cylinder around the base, wide enough for the
square base to turn on the spot with its arm tucked (straight up, inside the
footprint), clears every puzzle part. Free cells are labelled by connected
area; the base reaches the areas near where it stands, and a drive within one
is a shortest 8-connected path. Grasp configurations are kept to bases near
reachable cells, so that the robot never picks a grasp inside a closed room or
corridor of the puzzle, and long moves are planned as tuck, drive, untuck
instead of one search over all ten joints.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .robot import RobotSpec
from .scene import World

CELL = 0.1
"""Metres: side of a floor cell."""
TURN_MARGIN = 0.03
"""Metres the turning circle of the base keeps from the puzzle."""
BORDER = 1.2
"""Metres of floor mapped beyond the puzzle's floor area on each side."""
NEAR = 0.7
"""Metres: a grasp's base, close to the puzzle, may belong to a reachable free cell this near
(untucking the arm moves it from there), if a search over all joints finds the way: a base
in a nook between puzzle parts is, one on the far side of a wall is not (the search fails, and
the next grasp is tried)."""
START_RANGE = 1.0
"""Metres: the base standing where it let go of an object (in a nook of the puzzle, maybe) drives
from a free cell this near; tucking the arm takes it there, if a search over all joints finds the
way."""
NEIGHBOURS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))


def turning_radius(spec: RobotSpec) -> float:
    """The circle the square base sweeps turning on the spot, plus :data:`TURN_MARGIN`."""
    return math.hypot(spec.base_size[0], spec.base_size[1]) / 2 + TURN_MARGIN


@dataclass(frozen=True)
class FloorMap:
    """Free cells (``free[i, j]`` at ``origin + (i, j) * CELL``), labelled by connected area
    (``area``, -1 where not free), and the base's position ``base``. The base reaches every area
    with a cell within :data:`START_RANGE` of it (tucking the arm takes it into one)."""

    origin: np.ndarray
    free: np.ndarray
    area: np.ndarray
    base: np.ndarray

    @cached_property
    def starts(self) -> list[tuple[int, int]]:
        """Free cells within :data:`START_RANGE` of the base, nearest first."""
        cells = np.argwhere(self.free)
        distances = np.linalg.norm(self.origin + CELL * cells - self.base, axis=1)
        order = np.argsort(distances, kind="stable")
        return [(int(cells[k][0]), int(cells[k][1])) for k in order if distances[k] <= START_RANGE]

    @cached_property
    def reachable(self) -> np.ndarray:
        areas = {int(self.area[c]) for c in self.starts}
        return np.isin(self.area, list(areas)) & self.free

    @cached_property
    def _reachable_cells(self) -> tuple[np.ndarray, np.ndarray]:
        """The reachable cells and their centres (asked for once per grasp candidate)."""
        cells = np.argwhere(self.reachable)
        return cells, self.origin + CELL * cells

    def point(self, cell: tuple[int, int]) -> np.ndarray:
        return self.origin + CELL * np.asarray(cell, dtype=float)

    def nearest_reachable(self, xy: np.ndarray, within: float = NEAR) -> tuple[int, int] | None:
        """The reachable cell nearest to ``xy`` if one is within ``within`` metres."""
        cells, centres = self._reachable_cells
        if len(cells) == 0:
            return None
        distances = np.linalg.norm(centres - np.asarray(xy, dtype=float), axis=1)
        best = int(np.argmin(distances))
        return (int(cells[best][0]), int(cells[best][1])) if distances[best] <= within else None

    def start_towards(self, goal: tuple[int, int]) -> tuple[int, int]:
        """The cell near the base to drive to reachable ``goal`` from: the nearest in its area."""
        return next(c for c in self.starts if self.area[c] == self.area[goal])

    def route(self, start: tuple[int, int], goal: tuple[int, int]) -> np.ndarray:
        """Waypoints (x, y) of a shortest 8-connected path over reachable cells, corners only."""
        came: dict[tuple[int, int], tuple[int, int] | None] = {start: None}
        cost = {start: 0.0}
        queue = [(0.0, start)]
        while queue:
            _, here = heapq.heappop(queue)
            if here == goal:
                break
            for di, dj in NEIGHBOURS:
                there = (here[0] + di, here[1] + dj)
                if not (0 <= there[0] < self.free.shape[0] and 0 <= there[1] < self.free.shape[1]):
                    continue
                # A diagonal step needs both side cells free too, or it would cut a corner.
                if not (self.reachable[there] and self.reachable[here[0] + di, here[1]]
                        and self.reachable[here[0], here[1] + dj]):
                    continue
                new = cost[here] + math.hypot(di, dj)
                if new < cost.get(there, math.inf):
                    cost[there], came[there] = new, here
                    heapq.heappush(queue, (new + math.dist(there, goal), there))
        if goal not in came:
            raise ValueError(f"floor cell {goal} is not reachable from {start}")
        cells = [goal]
        while (previous := came[cells[-1]]) is not None:
            cells.append(previous)
        cells.reverse()
        corners = [cells[0]] + [b for a, b, c in zip(cells, cells[1:], cells[2:], strict=False)
                                if (b[0] - a[0], b[1] - a[1]) != (c[0] - b[0], c[1] - b[1])] + [cells[-1]]
        return np.array([self.point(c) for c in dict.fromkeys(corners)])


def floor_map(world: World, half_extent: tuple[float, float], base_xy: np.ndarray, spec: RobotSpec) -> FloorMap:
    """The free floor around the puzzle as it stands in ``world`` now, for the base at ``base_xy``."""
    radius = turning_radius(spec)
    span = np.array(half_extent) + BORDER
    origin = -span
    counts = np.floor(2 * span / CELL).astype(int) + 1
    free = np.zeros(counts, dtype=bool)
    for i in range(counts[0]):
        for j in range(counts[1]):
            free[i, j] = world.floor_clear(origin + CELL * np.array([i, j]), radius)
    area = np.full(counts, -1)
    label = -1
    for seed in map(tuple, np.argwhere(free)):
        if area[seed] >= 0:
            continue
        label += 1
        area[seed] = label
        stack = [seed]
        while stack:
            i, j = stack.pop()
            for di, dj in NEIGHBOURS[:4]:
                n = (i + di, j + dj)
                if 0 <= n[0] < counts[0] and 0 <= n[1] < counts[1] and free[n] and area[n] < 0:
                    area[n] = label
                    stack.append(n)
    return FloorMap(origin, free, area, np.asarray(base_xy, dtype=float)[:2])
