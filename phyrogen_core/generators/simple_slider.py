"""Simple Slider (paper Table I): a staircase of T-shaped sliders, each blocking the one before."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import Pose
from ..maker import Choice, Draft, MakerInput
from ..objects import Motion, PuzzleObject
from ..registry import ParameterError, parameter, register
from . import kit

SLIDER_WIDTH = 0.2
SLIDER_HEIGHT = 0.2
STROKE = 1.0
"""Upper prismatic limit of every slider (the lower one is 0)."""
PITCH = 1.0
"""Distance from a slider's centre to the centre of the slider across its path."""
BASE_ANGLES = (-90.0, 0.0)
"""The prototype's orientation (degrees) of even and odd sliders, before the transformation."""
MAX_SLIDERS = 50
"""The longest chain accepted: 50 sliders take about 27 s of CPU time (the cost grows about as
n^3: 20 take 1.2 s, 30 about 4.5 s; docs/generators.md#feasible-sizes)."""


@dataclass(frozen=True)
class SimpleSliderParams:
    """Parameters of Simple Slider (each field says what it means)."""

    n_objects: int = parameter(0, f"how many sliders, 1..{MAX_SLIDERS}; 0: Seed + 1, taken from the seed as the "
                                  f"paper does (so seeds 1..{MAX_SLIDERS - 1})", difficulty=True)
    gap: float = parameter(0.1, "free play in front of each slider before it hits the next, 0 < gap < 0.5 "
                                "(the prototype's 0.1); also sets the slider length 1.8 - 2 * gap",
                           difficulty=True)
    interlock_margin: float = kit.interlock_margin_parameter()

    def count(self, seed: int) -> int:
        return kit.seed_sized(self, "n_objects", seed + 1, "Seed + 1")

    def validate(self, seed: int) -> None:
        kit.check_interlock_margin(self)
        count = self.count(seed)
        if count > MAX_SLIDERS:
            raise ParameterError(
                f"n_objects must lie in 1..{MAX_SLIDERS}, got {count} sliders"
                + (f" (Seed + 1, seed {seed})" if self.n_objects == 0 else "")
                + f": {MAX_SLIDERS} take about 30 s of CPU time, growing as n^3 ({kit.SIZES_DOC}); "
                f"use a seed up to {MAX_SLIDERS - 1} or set n_objects"
            )
        # A slider must travel 1 - gap to clear the path it crosses but is stopped after
        # ``gap`` by the next one: it only blocks when gap < 1 - gap.
        if not 0 < self.gap < 0.5:
            raise ParameterError(
                f"gap must lie in (0, 0.5) so that each slider blocks the previous one, got {self.gap}"
            )

    @property
    def slider_length(self) -> float:
        return 1.8 - 2 * self.gap


@dataclass(frozen=True)
class _Slider:
    """Where a slider sits and which way it slides (an axis-aligned unit vector)."""

    centre: tuple[float, float]
    direction: kit.Direction


def _swept_area(slider: _Slider, half_length: float) -> kit.Rect:
    """The floor area the slider covers over its whole stroke."""
    return kit.Rect.along(slider.centre, slider.direction, half_length, half_length + STROKE, SLIDER_WIDTH / 2)


def _slider_object(index: int, slider: _Slider, motion: Motion, length: float) -> PuzzleObject:
    role, color = kit.role_and_color(index)
    body = kit.box_geometry((length, SLIDER_WIDTH, SLIDER_HEIGHT), color)
    geometry = (body, *kit.handle(SLIDER_HEIGHT / 2, (0.0, 0.0), color))
    yaw = kit.direction_yaw(slider.direction)
    pose = Pose.planar(slider.centre[0], slider.centre[1], SLIDER_HEIGHT / 2, yaw)
    return PuzzleObject(kit.movable_name(index), motion, pose, geometry, geometry, role, ((0.0, STROKE),))


def _next_slider(placed: tuple[_Slider, ...], flip: float) -> _Slider:
    """The next slider of the staircase for a flip (degrees): across the previous slider's
    path, PITCH ahead of its centre (the prototype's step)."""
    direction = kit.axis_direction(BASE_ANGLES[len(placed) % 2] + flip)
    if not placed:
        return _Slider((0.0, 0.0), direction)
    return _Slider(kit.ahead(placed[-1].centre, placed[-1].direction, PITCH), direction)


def _fits(slider: _Slider, placed: tuple[_Slider, ...], half_length: float) -> bool:
    """Only the previous slider may interact with the new one; a staircase that folds back onto
    an older slider would add dependencies nobody asked for."""
    swept = _swept_area(slider, half_length)
    return not any(kit.overlaps(swept, _swept_area(old, half_length)) for old in placed[:-1])


def _can_grow(placed: tuple[_Slider, ...], half_length: float, more: int) -> bool:
    """Whether some flips place ``more`` sliders after ``placed`` without folding. Checked before a
    slider is accepted, so the Maker never walks into a staircase with no way on (at 7 sliders
    about 1 seed in 10 used to give up after all its restarts); a zigzag always has one."""
    return more == 0 or any(
        _fits(slider, placed, half_length) and _can_grow((*placed, slider), half_length, more - 1)
        for slider in (_next_slider(placed, flip) for flip in kit.HALF_TURNS)
    )


def _attach_for(params: SimpleSliderParams, count: int):
    half_length = params.slider_length / 2

    def attach(draft: Draft, obj_item: str, joint_item: Motion, tf_item: float, n: int,
               rng: np.random.Generator) -> Draft | None:
        placed: tuple[_Slider, ...] = draft.context or ()
        slider = _next_slider(placed, tf_item)
        if not _fits(slider, placed, half_length) or not _can_grow((*placed, slider), half_length,
                                                                    count - len(placed) - 1):
            return None
        new = _slider_object(len(draft.objects), slider, joint_item, params.slider_length)
        return Draft(draft.objects + (new,), placed + (slider,))

    return attach


@register("simple_slider", "Simple Slider", SimpleSliderParams, paper_row=1,
          time_limits={"paper": 40.0, "quick": 4.0}, scene_scale=0.5)
def build(seed: int, params: SimpleSliderParams) -> MakerInput:
    """Simple Slider: a chain of T-shaped sliders laid out as a staircase.

    Mechanism:
        Every slider is a 1.6 x 0.2 x 0.2 box (for gap = 0.1) with a handle on top,
        prismatic along its long axis with limits (0, 1). Each new slider lies
        across the path of the previous one, 1 m ahead of that one's centre, so
        the previous slider can move only ``gap`` before it hits the new one; the
        new slider clears that path by sliding 1 m either way. Solved by moving
        the sliders from the last to the first.

    Randomization:
        Objects {T-shaped slider}, joints {Prismatic}, transformations {0, 180}
        degrees, N = Seed + 1. The transformation flips a slider (and thus its
        sliding direction) relative to the prototype's orientation (-90 degrees
        for even, 0 for odd sliders); the next slider is placed in front of
        wherever the flipped slider now slides, so the staircase turns left or
        right. A flip that would fold the staircase onto an older slider, or
        leave no flips for the sliders still to come that do not, is rejected
        (attach returns None) and the Maker draws again.

    Goal:
        The paper's rule: the target (``obj_00``, the first slider) at the far end
        of its limits, 1.0.

    Difficulty parameters:
        ``n_objects`` (0: Seed + 1) sets the length of the dependency chain;
        ``gap`` the free play between a slider and the next (0 < gap < 0.5).

    Departures:
        Each slider's flip is drawn, and the next slider follows the flipped
        slider's sliding direction, so that every flip still yields a chain in
        which each slider is necessary; with all transformations 0 the layout
        is exactly the prototype's fixed staircase.

    Design notes: docs/generators.md#simple-slider
    """
    params.validate(seed)
    return kit.paper_input(
        params,
        objects=Choice(("t_slider",)),
        joints=Choice((Motion.PRISMATIC,)),
        transforms=Choice(kit.HALF_TURNS),
        n_objects=params.count(seed),
        attach=_attach_for(params, params.count(seed)),
    )
