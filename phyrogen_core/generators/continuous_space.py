"""Continuous Space (paper Table I): revolute bars placed at continuous random poses.

The one generator whose layout is not solvable by construction: each new bar
is dropped at a random pose on the swing of the bar added before it, and only
the Maker decides whether it stays: necessary (the puzzle is unsolvable with
it fixed) and harmless (solvable with it free). The transformation mapping
aims the random poses at the swing so that enough candidates survive.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry import Pose
from ..maker import Choice, Draft, MakerInput, Uniform
from ..objects import Motion, PuzzleObject
from ..registry import ParameterError, parameter, register
from . import kit

HINGE_DIAMETER = 0.25
HANDLE_FRACTION = 0.375
"""Handle position along the bar from the hinge, as a fraction of the bar length (prototype)."""
ARC_DEGREES = (0.0, 90.0)
"""First transformation coordinate: where along the previous bar's quarter swing the new bar stands."""
REACH = (0.0, 1.0)
"""Second transformation coordinate: how far out from the previous hinge (see :func:`reach_radius`)."""
MAX_BARS = 20
"""The most bars accepted: 20 take up to about 1 min of CPU time with the longest bars accepted, 25
up to 2 min with the default ones (docs/generators.md#feasible-sizes)."""
BAR_LENGTH = (1.0, 5.0)
"""Accepted bar lengths (m). The handle (a 0.2 m shaft at 0.375 of the length from the hinge) must
stand on the bar; longer bars cost generation time about in proportion (each turn sweeps farther
past the validator's 0.02 m checks): 20 bars 10 m long took 85 s of CPU time."""
MIN_BAR_WIDTH = 0.2
"""The handle's shaft (0.2 m across) must stand on the bar."""
MAX_WIDTH_RATIO = 2 / 3
"""Widest bar accepted, as a share of its length: a new bar's hinge stands L/2 + W/2 .. L from the
previous one (:func:`reach_radius`), a band too narrow for wider bars to block (W = 0.75 L and
0.83 L gave up at the second bar; 2/3 generated on every seed tried)."""
BAR_HEIGHT = (0.05, 10.0)


@dataclass(frozen=True)
class ContinuousSpaceParams:
    """Parameters of Continuous Space (each field says what it means)."""

    n_objects: int = parameter(4, f"how many bars, the target included, 1..{MAX_BARS} (Table I: 4)",
                               difficulty=True)
    bar_length: float = parameter(3.0, f"length of every bar, hinged at its centre (m, {BAR_LENGTH[0]:g}.."
                                       f"{BAR_LENGTH[1]:g})", difficulty=True)
    bar_width: float = parameter(1.0, f"width of every bar, at least {MIN_BAR_WIDTH:g} and at most 2/3 of its "
                                      f"length (m)", difficulty=True)
    bar_height: float = parameter(1.0, f"height of every bar (m, {BAR_HEIGHT[0]:g}..{BAR_HEIGHT[1]:g})")
    min_limit_deg: float = parameter(90.0, "smallest magnitude of a bar's one-sided joint limit (degrees, "
                                           ">= 90 so that the target can make the goal's quarter turn)",
                                     difficulty=True)
    max_limit_deg: float = parameter(180.0, "largest magnitude of a bar's joint limit (degrees, <= 180)",
                                     difficulty=True)
    branching: int = parameter(0, f"extra blockers earlier bars may get in total, 0..{MAX_BARS - 2}: while this "
                                  f"lasts, each new bar blocks a random earlier bar that already has a "
                                  f"blocker instead of the last one; 0 (the paper) gives a single chain",
                               difficulty=True)
    interlock_margin: float = kit.interlock_margin_parameter()

    def validate(self, seed: int) -> None:
        kit.check_interlock_margin(self)
        kit.check_count("branching", self.branching, 0, MAX_BARS - 2,
                        "each bar after the second can add at most one extra blocker")
        kit.check_object_count(self.n_objects, high=MAX_BARS,
                               why=f"generation time grows steeply with the count (20: up to about 1 min of CPU "
                                   f"time, 25: up to 2 min, 40: many minutes; {kit.SIZES_DOC})")
        kit.check_between(self, "bar_length", *BAR_LENGTH, "the handle must stand on the bar; longer bars "
                                                          "cost generation time about in proportion")
        kit.check_between(self, "bar_width", MIN_BAR_WIDTH, BAR_LENGTH[1], "the handle must stand on the bar")
        kit.check_between(self, "bar_height", *BAR_HEIGHT, "a sane size; the height changes only the look")
        if not self.bar_width <= MAX_WIDTH_RATIO * self.bar_length:
            raise ParameterError(
                f"bar_width {self.bar_width} must be at most 2/3 of bar_length {self.bar_length} (a bar, not a "
                f"plate: wider bars leave no room to block the previous one)"
            )
        # The paper's goal turns the target by 90 degrees, which its limits must allow.
        if not 90.0 <= self.min_limit_deg <= self.max_limit_deg <= 180.0:
            raise ParameterError(
                f"joint limit range [{self.min_limit_deg}, {self.max_limit_deg}] degrees must satisfy "
                f"90 <= min_limit_deg <= max_limit_deg <= 180"
            )


@dataclass(frozen=True)
class _Bar:
    x: float
    y: float
    yaw: float
    sign: int  # +1: limits (0, L), turns counter-clockwise; -1: limits (-L, 0)

    def floor_area(self, params: ContinuousSpaceParams) -> kit.OrientedRect:
        return kit.OrientedRect(self.x, self.y, self.yaw, params.bar_length / 2, params.bar_width / 2)


def reach_radius(params: ContinuousSpaceParams, reach: float) -> float:
    """Distance from the previous hinge to the new one for ``reach`` in [0, 1].

    A new bar pointing at the previous hinge from distance r has its near end
    at r - L/2. It must start clear of the previous bar (beyond ~W/2 off its
    axis) and reach into the circle of radius L/2 its ends sweep: r in
    (L/2 + W/2, L).
    """
    lo = params.bar_length / 2 + params.bar_width / 2
    hi = params.bar_length
    return lo + reach * (hi - lo)


def _bar_object(params: ContinuousSpaceParams, index: int, bar: _Bar, limit: float) -> PuzzleObject:
    role, color = kit.role_and_color(index)
    length, width, height = params.bar_length, params.bar_width, params.bar_height
    shaft, knob = kit.handle(height / 2, (HANDLE_FRACTION * length, 0.0), color)
    geometry = (kit.box_geometry((length, width, height), color), shaft, knob)
    visuals = (*geometry, kit.hinge(HINGE_DIAMETER / 2, 1.1 * height))
    limits = ((0.0, limit),) if bar.sign > 0 else ((-limit, 0.0),)
    return PuzzleObject(kit.movable_name(index), Motion.REVOLUTE, Pose.planar(bar.x, bar.y, height / 2, bar.yaw),
                        visuals, geometry, role, limits)


@dataclass(frozen=True)
class _Layout:
    """The bars placed so far and how many extra blockers (``branching``) are left to give."""

    bars: tuple[_Bar, ...]
    branches_left: int


def _attach_for(params: ContinuousSpaceParams):
    def attach(draft: Draft, obj_item: str, joint_item: Motion, tf_item: tuple[float, float], n: int,
               rng: np.random.Generator) -> Draft | None:
        layout: _Layout = draft.context or _Layout((), params.branching)
        bars, branches_left = layout.bars, layout.branches_left
        sign = 1 if rng.random() < 0.5 else -1
        limit = math.radians(float(rng.uniform(params.min_limit_deg, params.max_limit_deg)))
        if not bars:
            # The prototype's target: at the origin with a random yaw.
            bar = _Bar(0.0, 0.0, float(rng.uniform(0.0, 2 * math.pi)), sign)
        else:
            arc_deg, reach = tf_item
            # Every bar but the last already has a blocker: one more makes the dependencies a tree.
            # Drawn only while the budget lasts, so that branching 0 keeps the paper's random stream.
            branch = branches_left > 0 and len(bars) > 1
            blocked = bars[int(rng.integers(len(bars) - 1))] if branch else bars[-1]
            branches_left -= branch
            end = math.pi if rng.random() < 0.5 else 0.0  # either half of the blocked bar
            angle = blocked.yaw + end + blocked.sign * math.radians(arc_deg)
            r = reach_radius(params, reach)
            bar = _Bar(blocked.x + r * math.cos(angle), blocked.y + r * math.sin(angle), angle, sign)
            area = bar.floor_area(params)
            if any(kit.overlaps(area, old.floor_area(params)) for old in bars):
                return None
        new = _bar_object(params, len(bars), bar, limit)
        return Draft(draft.objects + (new,), _Layout(bars + (bar,), branches_left))

    return attach


@register("continuous_space", "Continuous Space", ContinuousSpaceParams, paper_row=2,
          time_limits={"paper": 20.0, "quick": 2.0}, scene_scale=0.4)
def build(seed: int, params: ContinuousSpaceParams) -> MakerInput:
    """Continuous Space: revolute bars at continuous poses, each blocking the one before.

    Mechanism:
        Every object is a 3 x 1 x 1 bar hinged at its centre (a visual hinge
        cylinder, 0.25 across), revolute about z with one-sided limits
        (0, L) or (-L, 0), L drawn from U(90, 180) degrees. The target
        (``obj_00``) must turn 90 degrees; each later bar stands in the swing
        of the bar before it and must itself be turned out of the way first.

    Randomization:
        Table I: objects {Cuboid}, joints {Revolute}, transformations
        [0, 90] x [0, 1], 4 objects. A transformation (a, r) places the new
        bar's hinge on the ray at angle a degrees into the previous bar's
        swing (measured from either end of it, the rng picks), at distance
        L/2 + W/2 + r (L/2 - W/2) from the previous hinge, pointing at it.
        The rng also draws the limits' sign and size, the target's yaw
        U[0, 360) degrees and which end. While the ``branching`` budget lasts,
        the rng picks the bar to block among the earlier ones that already have
        a blocker (every bar but the last), instead of the last. Candidates
        overlapping an earlier
        bar are refused by attach; the Maker rejects the rest that do not
        block or cannot be cleared.

    Goal:
        The paper's rule: the target turned 90 degrees in the direction its
        limits allow.

    Difficulty parameters:
        ``n_objects``; the bar's floor size ``bar_length`` x ``bar_width``;
        the limit range [``min_limit_deg``, ``max_limit_deg``]
        (90 <= min <= max <= 180); ``branching`` (0, the paper: a chain; each
        unit gives an earlier bar one more blocker, so the dependencies form a
        tree, shallower for the same count). ``bar_height`` changes only the look.

    Departures:
        Revolute bars only, as in the paper (the prototype mixed prismatic and
        revolute bars). The two transformation coordinates place a new bar on
        the previous bar's swing, pointing at its hinge, instead of the
        prototype's uniform drop near it. The handle is a box shaft at 0.375 of
        the length from the hinge.

    Design notes: docs/generators.md#continuous-space
    """
    params.validate(seed)
    return kit.paper_input(
        params,
        objects=Choice(("cuboid",)),
        joints=Choice((Motion.REVOLUTE,)),
        transforms=Uniform((ARC_DEGREES[0], REACH[0]), (ARC_DEGREES[1], REACH[1])),
        n_objects=params.n_objects,
        attach=_attach_for(params),
        # (The paper's goal rule: the target's limits allow only one direction, so it needs no draw.)
    )
