"""Named suites of puzzle sizes: for each generator, the parameters that make its puzzles of the suite.

``phyrogen generate --suite hard --seeds S`` makes, for every generator the
suite lists, the puzzles of seeds S with the suite's parameters (the same as
``phyrogen generate --generator G --set KNOB=VALUE --seeds S`` per generator).

The ``hard`` suite holds, per generator, the smallest size (its difficulty
knob, ``phyrogen list``) found at which OMPL's BIT* and RRT* each solve
fewer than half of their runs within a budget of collision checks derived
from the paper's time limit, while the Maker still certifies the puzzle.
The budgets are the calibrated ones, the paper's limits at
:data:`solver.benchmark.paper_budgets.PAPER_CHECKS_PER_SECOND` (28,000 checks
a second: Simple Slider and Grid World 1,120,000 checks, Continuous Space and
Move N Times 560,000, Lockbox Random 16,800,000), a motion charged by its length
in resolution steps as the benchmark charges it. ``scripts/hard_suite.py`` searches for these sizes, in
small steps up from the paper's (or from the size found at a smaller budget,
``--start``); ``docs/benchmark/hard-suite.md`` has the search's evidence, the
measurement on held-out seeds and the commands that reproduce both.
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
    # Searched with a motion charged by its length (search seeds 70001-70002, the paper budgets at 28,000 checks
    # a second) and measured on held-out seeds 90001-90010 (docs/benchmark/hard-suite.md).
    # Move N Times: the paper's largest size, n = 4, is already hard (BIT* and RRT* 0 of 3 search runs each).
    SuiteEntry("move_n_times", {"n": "4"}),
    # Table I: 4 bars; BIT* solved 2 of 2 search runs at 4 to 8 bars, neither planner 1 of 3 at 9.
    SuiteEntry("continuous_space", {"n_objects": "9"}),
    # Paper sizes 2-5 sliders; BIT* solved 2 of 2 search runs at 5 and 2 of 3 at 6, neither planner 1 of 3 at 7.
    SuiteEntry("simple_slider", {"n_objects": "7"}),
    # Table I: 5 boxes (the knob steps by 2); BIT* solved 2 of 2 search runs at 5 and 2 of 4 at 7, neither
    # planner 1 of 3 at 9.
    SuiteEntry("grid_world", {"n_objects": "9"}),
    # Table I: 7 objects; BIT* solved 2 of 2 search runs at 7, neither planner 1 of 3 at 9. Rooms has no hard
    # size up to the knob's largest, 6 rooms (BIT* solved every search run), so it is not in the suite.
    SuiteEntry("lockbox_random", {"n_objects": "9"}),
)
"""The ``hard`` suite (see the module docstring); ``scripts/hard_suite.py`` found these sizes."""

SUITES: Mapping[str, tuple[SuiteEntry, ...]] = MappingProxyType({"hard": HARD_SUITE})


def get_suite(name: str) -> tuple[SuiteEntry, ...]:
    """The entries of the suite ``name``; raises ParameterError for an unknown one."""
    try:
        return SUITES[name]
    except KeyError:
        raise ParameterError(f"unknown suite {name!r} (known: {', '.join(SUITES)})") from None
