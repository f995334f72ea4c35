"""The paper's time limits as budgets of collision checks (``phyrogen benchmark --budget-from-paper``).

The paper gave each generator's puzzles a time limit (Simple Slider 40 s ... Lockbox Random 600 s;
``phyrogen list`` shows them), on a harness whose collision check was PyBullet's, several times
slower than ours. Seconds here would buy far more search than the paper's planners had, and a
different amount on every machine. A budget of checks is the same everywhere: each limit becomes
``seconds x`` :data:`PAPER_CHECKS_PER_SECOND`, the checks the paper's harness would have made in that
time if checking were all it did (docs/benchmark/README.md, "Paper budgets", states the
measurement behind the constant and the resulting table).
"""

from __future__ import annotations

from collections.abc import Iterable

from phyrogen_core.registry import benchmark_time_limits

PAPER_CHECKS_PER_SECOND = 28_000
"""Collision checks per CPU second of the paper's harness: the median, over the 24 paper puzzles,
of state-validity checks per CPU second done the prototype's way in PyBullet (reset the joints,
closest points at distance 0 over every pair of a moving link and another link) on valid states
(28,160 a second; every pair is checked there, and the verdicts agree with ours on 96.6-100 % of
them), measured by ``benchmarks/pybullet_check_rate.py --valid`` (machine, load and numbers in
docs/benchmark/README.md, "Paper budgets"), rounded to two significant digits. Per puzzle the
rate ranges from 3,600 (Rooms) to 157,000 (Simple Slider 1) a second: one constant is a middle, not
each generator's own. An upper bound on what the paper's planners could check: one of our checks
may be a whole motion, which their harness checked state by state."""


def paper_budget_checks(generator: str) -> int:
    """The check budget of a run on ``generator``'s puzzles: its paper time limit in seconds times
    :data:`PAPER_CHECKS_PER_SECOND`. ValueError for a generator without a paper limit."""
    limits = benchmark_time_limits("paper")
    if generator not in limits:
        raise ValueError(f"generator {generator!r} has no paper time limit (known: {', '.join(limits)})")
    return round(limits[generator] * PAPER_CHECKS_PER_SECOND)


def paper_budgets(generators: Iterable[str] | None = None) -> dict[str, int]:
    """``{generator: paper_budget_checks(generator)}`` for ``generators`` (default: every registered one)."""
    names = benchmark_time_limits("paper") if generators is None else generators
    return {name: paper_budget_checks(name) for name in names}
