"""Named suites of puzzle sizes: for each generator, the parameters that make its puzzles of the suite.

``phyrogen generate --suite hard --seeds S`` makes, for every generator the
suite lists, the puzzles of seeds S with the suite's parameters (the same as
``phyrogen generate --generator G --set KNOB=VALUE --seeds S`` per generator).

The ``hard`` suite holds, per generator, the smallest size (its difficulty
knob, ``phyrogen list``) found at which OMPL's BIT* and RRT* each solve
fewer than half of their runs within a budget of collision checks derived
from the paper's time limit, while the Maker still certifies the puzzle.
The sizes below were searched at 10,000 checks per second of the paper's
limits, the provisional rate in use before the benchmark's calibration
(:data:`solver.benchmark.paper_budgets.PAPER_CHECKS_PER_SECOND`, 28,000)
landed: at the calibrated budgets they are lower bounds, to be searched again
(``scripts/hard_suite.py search``). ``scripts/hard_suite.py`` searches for these
sizes, in small steps up from the paper's; ``docs/benchmark/hard-suite.md``
has the search's evidence, the measurement on held-out seeds and the
command that reproduces both.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from .registry import ParameterError, get_generator


@dataclass(frozen=True)
class SuiteEntry:
    """One generator of a suite and the parameter values (``--set``) its puzzles have."""

    generator: str
    overrides: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "overrides", MappingProxyType(dict(self.overrides)))

    def params(self):
        """The generator's parameter dataclass with the suite's values."""
        return get_generator(self.generator).parse_params(self.overrides)


HARD_SUITE: tuple[SuiteEntry, ...] = (
    # Paper sizes n = 1-4; at n = 6 BIT* still solved 2 of 4 search runs (70001, 70002), at 7 none.
    SuiteEntry("move_n_times", {"n": "7"}),
    # Table I: 4 bars; BIT* and RRT* solved half of the search runs up to 9 bars, 1 of 4 each at 10.
    SuiteEntry("continuous_space", {"n_objects": "10"}),
    # Paper sizes 2-5 sliders; at 5 BIT* solved 2 of 2 search runs, at 6 neither planner 1 of 3 (not yet
    # measured on held-out seeds: docs/benchmark/hard-suite.md).
    SuiteEntry("simple_slider", {"n_objects": "6"}),
)
"""The ``hard`` suite (see the module docstring); ``scripts/hard_suite.py`` found these sizes."""

SUITES: Mapping[str, tuple[SuiteEntry, ...]] = MappingProxyType({"hard": HARD_SUITE})


def get_suite(name: str) -> tuple[SuiteEntry, ...]:
    """The entries of the suite ``name``; raises ParameterError for an unknown one."""
    try:
        return SUITES[name]
    except KeyError:
        raise ParameterError(f"unknown suite {name!r} (known: {', '.join(SUITES)})") from None
