"""Running a generator's Maker input without a planner (tests only)."""

from __future__ import annotations

from phyrogen_core.maker import MakerResult, SolveResult, make
from phyrogen_core.registry import get_generator


class AcceptAll:
    """A validator that calls every candidate necessary and solvable."""

    def solve(self, objects, goal, *, budget_scale=1.0):
        return SolveResult(True, ((0.0,),))

    def necessity(self, objects, goal, fixed, margin, *, budget_scale=1.0):
        return margin


def run(name: str, seed: int, **overrides) -> MakerResult:
    """Generator ``name`` through the Maker with :class:`AcceptAll` (geometry only)."""
    spec = get_generator(name)
    params = spec.parse_params(overrides)
    spec.check(seed, params)
    return make(spec.build(seed, params), seed, AcceptAll(), name)
