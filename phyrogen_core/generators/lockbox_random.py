"""Lockbox Random (paper Table I): alternating sliders and slot discs that lock each other."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..chain import Geometry
from ..geometry import Pose, slot_disc
from ..maker import Choice, Draft, InfiniteSequence, MakerInput
from ..objects import Motion, PuzzleObject
from ..registry import ParameterError, parameter, register
from . import kit

SLIDER_SIZE = (1.4, 0.2, 1.0)
HEIGHT = 1.0
"""Height of sliders and discs (their centres stand at z = HEIGHT / 2)."""
STROKE = 1.0
"""Upper prismatic limit of every slider (the lower one is 0)."""
DISC_GAP = 1.0
"""A disc's centre lies radius + DISC_GAP ahead of the centre of the slider it stops."""
MIN_RADIUS = 1.0
RADIUS_STEP = 0.5
HANDLE_RADIUS_FRACTION = 0.75
"""A disc's handle stands this fraction of its radius from the hinge, beside the slot."""
HINGE_RADIUS_FRACTION = 0.0625
CUBOID, DISK = "cuboid", "disk"
MAX_PARTS = 19
"""The most objects accepted: 19 take up to about 1 min of CPU time with the largest discs
(max_radius 10), 25 up to 2 min with the default ones (docs/generators.md#feasible-sizes)."""
MAX_RADIUS = 10.0


@dataclass(frozen=True)
class LockboxRandomParams:
    """Parameters of Lockbox Random (each field says what it means)."""

    n_objects: int = parameter(7, f"how many objects, 1..{MAX_PARTS}, alternating sliders and discs from the "
                                  f"target slider on (Table I: 7, the target and three disc-slider pairs)",
                               difficulty=True)
    max_radius: float = parameter(3.0, f"largest disc radius (m), {MIN_RADIUS:g}..{MAX_RADIUS:g}; radii are drawn "
                                       f"from 1, 1.5, ... up to it", difficulty=True)
    interlock_margin: float = kit.interlock_margin_parameter()

    def validate(self, seed: int) -> None:
        kit.check_margin_and_count(self, MAX_PARTS, "19: up to about 1 min of CPU time, 25: about 2 min")
        # Larger discs also cost time: every turn sweeps a longer rim past the validator's checks.
        if not MIN_RADIUS <= self.max_radius <= MAX_RADIUS:
            raise ParameterError(
                f"max_radius must lie in [{MIN_RADIUS}, {MAX_RADIUS:g}] (a slider sits 0.7 m deep in a slot "
                f"as long as the radius; larger discs cost generation time), got {self.max_radius}"
            )

    @property
    def radii(self) -> tuple[float, ...]:
        count = int(math.floor((self.max_radius - MIN_RADIUS) / RADIUS_STEP + 1e-9)) + 1
        return tuple(MIN_RADIUS + RADIUS_STEP * k for k in range(count))


@dataclass(frozen=True)
class _Slider:
    centre: tuple[float, float]
    direction: kit.Direction


@dataclass(frozen=True)
class _Disc:
    centre: tuple[float, float]
    radius: float
    slot: kit.Direction


_Part = _Slider | _Disc


def _swept_area(part: _Part) -> kit.Rect | kit.Circle:
    """The floor area a part covers over its whole joint range."""
    if isinstance(part, _Disc):
        return kit.Circle(part.centre[0], part.centre[1], part.radius)
    half = SLIDER_SIZE[0] / 2
    return kit.Rect.along(part.centre, part.direction, half, half + STROKE, SLIDER_SIZE[1] / 2)


def _clear_of(part: _Part, others: tuple[_Part, ...]) -> bool:
    swept = _swept_area(part)
    return not any(kit.overlaps(swept, _swept_area(other)) for other in others)


def _slider_in_slot(disc: _Disc) -> _Slider:
    # Centred on the rim: half its length inside the slot, sliding outward.
    return _Slider(kit.ahead(disc.centre, disc.slot, disc.radius), disc.slot)


def _slider_object(index: int, slider: _Slider) -> PuzzleObject:
    role, color = kit.role_and_color(index)
    body = kit.box_geometry(SLIDER_SIZE, color)
    geometry = (body, *kit.handle(HEIGHT / 2, (0.0, 0.0), color))
    pose = Pose.planar(slider.centre[0], slider.centre[1], HEIGHT / 2, kit.direction_yaw(slider.direction))
    return PuzzleObject(kit.movable_name(index), Motion.PRISMATIC, pose, geometry, geometry, role,
                        ((0.0, STROKE),))


def _disc_object(index: int, disc: _Disc) -> PuzzleObject:
    role, color = kit.role_and_color(index)
    body = Geometry(slot_disc(disc.radius, HEIGHT), Pose(), color, "body")
    grip = kit.handle(HEIGHT / 2, (0.0, HANDLE_RADIUS_FRACTION * disc.radius), color, round_shaft=True)
    visuals = (body, *grip, kit.hinge(HINGE_RADIUS_FRACTION * disc.radius, HEIGHT + kit.HINGE_OVERHANG))
    pose = Pose.planar(disc.centre[0], disc.centre[1], HEIGHT / 2, kit.direction_yaw(disc.slot))
    return PuzzleObject(kit.movable_name(index), Motion.REVOLUTE, pose, visuals, (body, *grip), role,
                        ((-math.pi, math.pi),))


def _attach_for(params: LockboxRandomParams):
    radii = params.radii

    def attach(draft: Draft, obj_item: str, joint_item: Motion, tf_item: float, n: int,
               rng: np.random.Generator) -> Draft | None:
        parts: tuple[_Part, ...] = draft.context or ()
        index = len(draft.objects)
        expected = {CUBOID: Motion.PRISMATIC, DISK: Motion.REVOLUTE}.get(obj_item)
        if expected is not joint_item:
            raise ValueError(
                f"lockbox_random pairs cuboid/prismatic and disk/revolute, got {obj_item}/{joint_item}"
            )
        if obj_item == CUBOID:
            if not parts:
                slider = _Slider((0.0, 0.0), kit.axis_direction(tf_item))
            else:
                # The pose is fixed by the slot of the disc just placed; the drawn
                # transformation has nothing left to choose.
                slider = _slider_in_slot(parts[-1])
                if not _clear_of(slider, parts[:-1]):
                    return None
            new = _slider_object(index, slider)
            return Draft(draft.objects + (new,), parts + (slider,))
        previous = parts[-1]
        slot = kit.axis_direction(tf_item)
        if slot == (-previous.direction[0], -previous.direction[1]):
            return None  # the slot would face the slider this disc has to stop
        radius = radii[int(rng.integers(len(radii)))]
        disc = _Disc(kit.ahead(previous.centre, previous.direction, radius + DISC_GAP), radius, slot)
        # The disc may meet only the slider it stops; the slider that will sit in its slot
        # must find room as well, or the next iteration would have nowhere to go.
        if not _clear_of(disc, parts[:-1]) or not _clear_of(_slider_in_slot(disc), parts):
            return None
        new = _disc_object(index, disc)
        return Draft(draft.objects + (new,), parts + (disc,))

    return attach


@register("lockbox_random", "Lockbox Random", LockboxRandomParams, paper_row=4,
          time_limits={"paper": 600.0, "quick": 10.0}, scene_scale=0.2)
def build(seed: int, params: LockboxRandomParams) -> MakerInput:
    """Lockbox Random: a chain of sliders and slot discs, each locking its neighbours.

    Mechanism:
        Sliders are 1.4 x 0.2 x 1 boxes, prismatic along their long axis with
        limits (0, 1). Discs are regular 32-gon prisms of radius r and height 1
        with a slot from the centre to the rim (width r/2), revolute about their
        centre with limits (-180, 180) deg. A disc stands radius + 1 m ahead of
        the slider it stops, its slot turned away from it: the slider advances
        0.3 m and hits the rim; it can advance its full 1 m only when the disc's
        slot faces it. The next slider sits in that disc's slot, half its length
        inside, so the disc can only turn after it has slid out. Solved from the
        last object back: slide out, turn the disc towards the previous slider,
        slide that one into the slot, and so on down to the target.

    Randomization:
        Objects {Cuboid, Disk, Cuboid, ...} and joints {Prismatic, Revolute,
        Prismatic, ...} are infinite sequences (item n is fixed by n);
        transformations {0, 90, 180, 270} degrees: the target's sliding
        direction, and for a disc the world direction its slot faces, i.e. where
        the chain continues. The rng draws each disc's radius from
        {1, 1.5, 2, 2.5, 3}. A slot facing back at the slider it must stop, or a
        disc (or the slider bound for its slot) that would reach any other
        object's footprint, is rejected (attach returns None) and the Maker
        draws again. N = 7.

    Goal:
        The paper's rule: the target slider (``obj_00``) at the far end of its
        limits, 1.0.

    Difficulty parameters:
        ``n_objects`` (7; the dependency chain grows by one object per
        iteration), ``max_radius`` (3.0; radii are 1, 1.5, ... up to it).

    Departures:
        Disc and slider are separate Maker iterations, as in the paper's Maker
        (the prototype placed them as a pair): the disc's transformation is its
        slot's world direction, and a slider after the target takes its pose
        from the slot. Swept areas must stay apart except for the intended
        slider-disc pairs. The slot disc is exact convex pieces
        (:func:`phyrogen_core.geometry.slot_disc`), not a mesh.

    Design notes: docs/generators.md#lockbox-random
    """
    params.validate(seed)
    return kit.paper_input(
        params,
        objects=InfiniteSequence((CUBOID, DISK)),
        joints=InfiniteSequence((Motion.PRISMATIC, Motion.REVOLUTE)),
        transforms=Choice(kit.QUARTER_TURNS),
        n_objects=params.n_objects,
        attach=_attach_for(params),
    )
