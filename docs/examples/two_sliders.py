"""Two Sliders: the smallest useful generator, the worked example of docs/adding-a-generator.md.

Not one of the built-in generators: the tests load it into a copy of the
registry (tests/test_example_generator.py) and install it as a package of its
own, declared in the ``phyrogen.generators`` entry points (tests/test_plugins.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from phyrogen_core.generators import kit
from phyrogen_core.geometry import Pose
from phyrogen_core.maker import Choice, Draft, MakerInput
from phyrogen_core.objects import Motion, PuzzleObject
from phyrogen_core.registry import ParameterError, parameter, register

LENGTH, WIDTH, HEIGHT, STROKE = 1.0, 0.2, 0.2, 1.0


@dataclass(frozen=True)
class TwoSlidersParams:
    gap: float = parameter(0.3, "free play in front of the target before it hits the blocker (0 < gap < 0.5)",
                           difficulty=True)
    interlock_margin: float = kit.interlock_margin_parameter()

    def validate(self, seed: int) -> None:
        kit.check_interlock_margin(self)
        if not 0 < self.gap < 0.5:
            raise ParameterError(f"gap must lie in (0, 0.5) so that the blocker blocks, got {self.gap}")


def _slider(index: int, centre: tuple[float, float], direction: tuple[int, int]) -> PuzzleObject:
    role, color = kit.role_and_color(index)
    geometry = (kit.box_geometry((LENGTH, WIDTH, HEIGHT), color), *kit.handle(HEIGHT / 2, color=color))
    pose = Pose.planar(centre[0], centre[1], HEIGHT / 2, kit.direction_yaw(direction))
    return PuzzleObject(kit.movable_name(index), Motion.PRISMATIC, pose, geometry, geometry, role, ((0.0, STROKE),))


def _attach_for(params: TwoSlidersParams):
    def attach(draft: Draft, obj_item: str, joint_item: Motion, tf_item: float, n: int,
               rng: np.random.Generator) -> Draft | None:
        if not draft.objects:  # the target, at the origin, slides along +x or -x
            forward = kit.axis_direction(tf_item)
            return Draft((_slider(0, (0.0, 0.0), forward),), forward)
        # The blocker lies across the target's path, ``gap`` ahead of the target's front end,
        # and slides sideways out of the way, to the left or the right.
        forward = draft.context  # the target's direction, kept by the first iteration
        centre = kit.ahead((0.0, 0.0), forward, LENGTH / 2 + params.gap + WIDTH / 2)
        left = kit.turn_left(forward)
        sideways = left if tf_item == 0.0 else kit.scale_cell(left, -1)
        return Draft(draft.objects + (_slider(1, centre, sideways),), forward)

    return attach


@register("two_sliders", "Two Sliders", TwoSlidersParams, time_limits={"paper": 10.0, "quick": 1.0})
def build(seed: int, params: TwoSlidersParams) -> MakerInput:
    """Two Sliders: a target slider whose path is closed by a second slider.

    Mechanism:
        Two 1 x 0.2 x 0.2 sliders with handles, prismatic along their long axis,
        limits (0, 1). The blocker lies across the target's path, ``gap`` ahead
        of it; it must slide out of the way before the target can.

    Randomization:
        Objects {slider}, joints {Prismatic}, transformations {0, 180} degrees:
        the target's direction, then the side the blocker slides to. N = 2.

    Goal:
        The paper's rule: the target at the far end of its limits, 1.0.

    Difficulty parameters:
        ``gap`` (0.3): the free play before the target hits the blocker.

    Departures:
        Not in the paper; an example of how a generator is written.
    """
    params.validate(seed)
    return MakerInput(objects=Choice(("slider",)), joints=Choice((Motion.PRISMATIC,)),
                      transforms=Choice(kit.HALF_TURNS), n_objects=2, attach=_attach_for(params),
                      goal=kit.target_paper_goal, interlock_margin=params.interlock_margin)
