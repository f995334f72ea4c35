"""Running a generator's Maker input without a planner (tests only)."""

from __future__ import annotations

from phyrogen_core.maker import MakerResult, SolveResult, make
from phyrogen_core.registry import get_generator


class AcceptAll:
    """A validator that calls every candidate necessary and solvable."""

    def solve(self, objects, goal, *, budget_scale=1.0):
        # FixJoint turns a movable object ("obj_..") fixed: report that as unsolvable.
        fixed_mover = any(o.name.startswith("obj_") and not o.is_movable for o in objects)
        return SolveResult(not fixed_mover, ((0.0,),))


def run(name: str, seed: int, **overrides) -> MakerResult:
    """Generator ``name`` through the Maker with :class:`AcceptAll` (geometry only)."""
    spec = get_generator(name)
    params = spec.parse_params(overrides)
    spec.check(seed, params)
    return make(spec.build(seed, params), seed, AcceptAll(), name)
