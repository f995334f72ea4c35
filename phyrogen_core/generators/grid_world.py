"""Grid World (paper Table I): cuboids on a unit grid, each parked in a cell another one needs."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry import Pose
from ..maker import Choice, Draft, MakerInput
from ..objects import Motion, PuzzleObject
from ..registry import ParameterError, parameter, register
from . import kit

# Grid cell (i, j) is the unit square [i, i+1] x [j, j+1], centre (i + 0.5, j + 0.5).
ORIGIN: kit.Cell = (0, 0)
PRISMATIC_CELLS = 2
REVOLUTE_CELLS = 3
HANDLE_FRACTION = 0.375
"""A revolute bar's handle sits this fraction of its length from the hinge (prototype)."""
HINGE_RADIUS = 0.1
CCW, CW = 1, -1
MAX_CUBOIDS = 25
"""The most cuboids accepted: 25 take up to about 40 s of CPU time, 30 about 70 s, and the cost
climbs steeply from there (50 did not finish in minutes; docs/generators.md#feasible-sizes)."""
MAX_BRANCHING = 3 * (MAX_CUBOIDS - 1)
"""Each turning bar opens at most 3 extra start cells, so more branching than this has no effect."""


def min_clearance() -> float:
    """Smallest clearance e for which a turning bar never reaches a box in a cell next to its
    sweep: the bar's corner radius sqrt((1.5 - e/2)^2 + (0.5 - e/2)^2) must stay below
    1.5 + e/2, i.e. h^2 - 7h + 1/4 < 0 with h = e/2."""
    return 7.0 - math.sqrt(48.0)


@dataclass(frozen=True)
class GridWorldParams:
    """Parameters of Grid World (each field says what it means)."""

    n_objects: int = parameter(5, f"how many cuboids, the target included, 1..{MAX_CUBOIDS} (Table I: 5)",
                               difficulty=True)
    branching: int = parameter(6, "extra start cells turning bars may open in total (the prototype's "
                                  "branching_factor_target), 0..72; 0 gives a single chain of dependencies",
                               difficulty=True)
    clearance: float = parameter(0.1, "the prototype's e: each box is a whole number of cells minus e per side "
                                      "pair; smaller is tighter (min_clearance() < e < 0.5)", difficulty=True)
    allow_clockwise: bool = parameter(True, "whether bars may turn clockwise too (else counter-clockwise only)",
                                      difficulty=True)
    interlock_margin: float = kit.interlock_margin_parameter()

    def validate(self, seed: int) -> None:
        kit.check_margin_and_count(self, MAX_CUBOIDS, "25: up to about 40 s of CPU time, 30: about 70 s, 50: "
                                                      "many minutes")
        kit.check_count("branching", self.branching, 0, MAX_BRANCHING,
                        f"each of at most {MAX_CUBOIDS - 1} turning bars opens at most 3 extra start cells")
        low = min_clearance()
        if not low < self.clearance < 0.5:
            raise ParameterError(
                f"clearance must lie in ({low:.4f}, 0.5): below, a turning bar hits boxes beside "
                f"its sweep; from 0.5 on, a box no longer blocks its neighbour; got {self.clearance}"
            )


@dataclass(frozen=True)
class GridState:
    """What the grid generator remembers between iterations (immutable).

    ``occupied``: every cell some object covers or sweeps. ``queue``: start cells, FIFO;
    each is a cell an earlier object must move into, so whatever is parked there blocks it.
    ``branches_left``: how many extra start cells turning bars may still open.
    """

    occupied: frozenset[kit.Cell]
    queue: tuple[kit.Cell, ...]
    branches_left: int


def prismatic_cells(start: kit.Cell, u: kit.Direction) -> tuple[kit.Cell, ...]:
    """Cells besides ``start`` that a box in (start, start + u) sliding one cell along u needs."""
    return (kit.add_cells(start, u), kit.add_cells(start, kit.scale_cell(u, 2)))


def revolute_cells(start: kit.Cell, u: kit.Direction, sense: int) -> tuple[kit.Cell, ...]:
    """Cells besides ``start`` that a bar over (start, start+u, start+2u), hinged at its middle
    and turning 90 degrees (``sense`` CCW or CW), needs: its other two cells, its two final
    cells and the two corners its ends sweep through, in that order."""
    v = kit.scale_cell(kit.turn_left(u), sense)
    hinge_cell = kit.add_cells(start, u)
    minus_v = kit.scale_cell(v, -1)
    return (
        hinge_cell,
        kit.add_cells(start, kit.scale_cell(u, 2)),
        kit.add_cells(hinge_cell, v),
        kit.add_cells(hinge_cell, minus_v),
        kit.add_cells(start, kit.scale_cell(u, 2), v),
        kit.add_cells(start, minus_v),
    )


def _free(cells: tuple[kit.Cell, ...], occupied: frozenset[kit.Cell]) -> bool:
    return not any(c in occupied for c in cells)


def _senses(state: GridState, start: kit.Cell, u: kit.Direction, allow_clockwise: bool) -> list[int]:
    senses = (CCW, CW) if allow_clockwise else (CCW,)
    return [s for s in senses if _free(revolute_cells(start, u, s), state.occupied)]


def _anything_fits(state: GridState, start: kit.Cell, allow_clockwise: bool) -> bool:
    for angle in kit.QUARTER_TURNS:
        u = kit.axis_direction(angle)
        if _free(prismatic_cells(start, u), state.occupied) or _senses(state, start, u, allow_clockwise):
            return True
    return False


def _centre(cell: kit.Cell) -> tuple[float, float]:
    return (cell[0] + 0.5, cell[1] + 0.5)


def _cuboid(index: int, motion: Motion, start: kit.Cell, u: kit.Direction, sense: int, e: float) -> PuzzleObject:
    role, color = kit.role_and_color(index)
    height = 1.0 - e
    cells = PRISMATIC_CELLS if motion is Motion.PRISMATIC else REVOLUTE_CELLS
    length = cells - e
    body = kit.box_geometry((length, 1.0 - e, height), color)
    # The frame sits at the box centre: half a cell ahead of the start cell for a
    # two-cell slider, on the middle cell (the hinge) for a three-cell bar.
    offset = 0.5 if motion is Motion.PRISMATIC else 1.0
    x, y = _centre(start)
    pose = Pose.planar(x + offset * u[0], y + offset * u[1], height / 2, kit.direction_yaw(u))
    if motion is Motion.PRISMATIC:
        grip = kit.handle(height / 2, (0.0, 0.0), color)
        visuals = (body, *grip)
        limits = ((0.0, 1.0),)
    else:
        grip = kit.handle(height / 2, (HANDLE_FRACTION * length, 0.0), color)
        visuals = (body, *grip, kit.hinge(HINGE_RADIUS, height + kit.HINGE_OVERHANG))
        quarter = math.pi / 2
        limits = ((0.0, quarter),) if sense == CCW else ((-quarter, 0.0),)
    return PuzzleObject(kit.movable_name(index), motion, pose, visuals, (body, *grip), role, limits)


def _attach_for(params: GridWorldParams):
    def attach(draft: Draft, obj_item: str, joint_item: Motion, tf_item: float, n: int,
               rng: np.random.Generator) -> Draft | None:
        state: GridState = draft.context
        # A start cell where nothing fits any more is dropped (the prototype restarted the
        # whole puzzle instead); the object that sweeps it stays blocked by the others.
        queue = state.queue
        while queue and not _anything_fits(state, queue[0], params.allow_clockwise):
            queue = queue[1:]
        if not queue:
            return None
        start, u = queue[0], kit.axis_direction(tf_item)
        if joint_item is Motion.PRISMATIC:
            cells = prismatic_cells(start, u)
            if not _free(cells, state.occupied):
                return None
            sense, new_starts = 0, (cells[-1],)
            branches_left = state.branches_left
        else:
            senses = _senses(state, start, u, params.allow_clockwise)
            if not senses:
                return None
            sense = senses[int(rng.integers(len(senses)))]
            cells = revolute_cells(start, u, sense)
            # Each of the bar's last four cells (final places and swept corners) blocks it:
            # one becomes a start cell, the others too while the branching budget lasts.
            candidates = [cells[k] for k in rng.permutation(4) + 2]
            extra = min(state.branches_left, len(candidates) - 1)
            new_starts = tuple(candidates[: 1 + extra])
            branches_left = state.branches_left - extra
        new = _cuboid(len(draft.objects), joint_item, start, u, sense, params.clearance)
        context = GridState(state.occupied | frozenset(cells), queue[1:] + new_starts, branches_left)
        return Draft(draft.objects + (new,), context)

    return attach


@register("grid_world", "Grid World", GridWorldParams, paper_row=3,
          time_limits={"paper": 40.0, "quick": 4.0}, scene_scale=0.25)
def build(seed: int, params: GridWorldParams) -> MakerInput:
    """Grid World: boxes on a unit grid; each new box is parked in a cell an earlier one needs.

    Mechanism:
        Objects live on a unit grid. A prismatic box covers 2 cells, (2 - e) x (1 - e)
        x (1 - e), and slides one cell along its long axis (limits (0, 1)). A revolute
        bar covers 3 cells, (3 - e) x (1 - e) x (1 - e), hinged at its middle cell, and
        turns 90 degrees counter-clockwise (limits (0, 90) deg) or clockwise
        ((-90, 0) deg); it needs its 3 cells, the 2 cells it ends in and the 2 corner
        cells its ends sweep through. e = 0.1 leaves room between boxes in
        neighbouring cells. A FIFO queue holds start cells, cells that an earlier
        object must move into; each new object covers the head cell, so it blocks
        that object. A prismatic box adds the cell it slides into; a bar adds one of
        its last four cells (shuffled) and, while the branching budget lasts, the
        others too, so dependencies form a tree. Solvable by moving the objects in
        reverse order; everything else on the grid is out of each other's way.

    Randomization:
        Objects {Cuboid}, joints {Revolute, Prismatic}, transformations
        {0, 90, 180, 270} degrees (the direction from the start cell in which the
        object extends), N = 5. The rng also picks a bar's turning sense among
        the free ones and shuffles its new start cells. Combinations whose cells
        are taken are rejected (attach returns None) and the Maker draws again.

    Goal:
        The paper's rule: a prismatic target (``obj_00``) at the far end of its
        limits (1 cell); a revolute target turned by 90 degrees in its allowed sense.

    Difficulty parameters:
        ``n_objects`` (5), ``branching`` (6: extra start cells bars may open;
        0 gives a chain of dependencies), ``clearance`` (e = 0.1; smaller is
        tighter, bounded below so a turning bar never reaches a box beside its
        sweep), ``allow_clockwise`` (True).

    Departures:
        Each object's joint is drawn from {Revolute, Prismatic} as in the
        paper (the prototype fixed 3 prismatic + 2 revolute). A start cell
        where nothing fits any more is dropped instead of restarting the
        puzzle. Revolute bars point along their direction (yaw 0/90/180/270).

    Design notes: docs/generators.md#grid-world
    """
    params.validate(seed)
    return kit.paper_input(
        params,
        objects=Choice(("cuboid",)),
        joints=Choice((Motion.REVOLUTE, Motion.PRISMATIC)),
        transforms=Choice(kit.QUARTER_TURNS),
        n_objects=params.n_objects,
        attach=_attach_for(params),
        initial=Draft((), GridState(frozenset({ORIGIN}), (ORIGIN,), params.branching)),
    )
