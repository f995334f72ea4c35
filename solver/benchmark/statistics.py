"""Statistics of benchmark runs: success rates with confidence intervals, medians with bootstrap intervals.

Pure functions on plain numbers (numpy and the standard library only), so that the summary table,
the results page and the tests compute every number the same way.

- **Success rate**: ``k`` of ``n`` runs solved, with a 95 % Wilson score interval
  (:func:`wilson_interval`; Clopper-Pearson's exact interval as an option,
  :func:`clopper_pearson_interval`). Wilson's interval keeps close to its stated coverage for the
  small run counts a benchmark affords and, unlike the normal approximation, does not collapse
  to a point at 0/n or n/n: 10/10 gives [0.722, 1], so ten clean runs bound the failure rate
  below about 28 %, not at 0.
- **Solved**: per the paper, a puzzle is solved when *all* its runs succeeded; "at least one
  run" is the weaker, optimistic count. Both are reported, side by side.
- **Time and checks to the first solution**: the median over *all* runs, a run without a
  solution counting as infinite (not within its time limit or check budget). A median over the
  solved runs only would make a planner that solves 1 run in 10, quickly, look fast. When half
  or more of the runs failed the median is infinite, and so is the interval's upper end when
  the failures could make up half of a resample.
- **Cost at the end of the budget**: the median final action cost over the solved runs.
- Medians carry a seeded percentile-bootstrap 95 % interval (:func:`bootstrap_median`): the
  caller passes a Generator from :func:`phyrogen_core.seeding.stable_rng`, so the same runs give
  the same interval, byte for byte, on any machine.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

CONFIDENCE = 0.95
BOOTSTRAP_RESAMPLES = 2000
"""Resamples per bootstrap interval: the 2.5 % and 97.5 % order statistics then sit 50 resamples in."""
INTERVAL_METHODS = ("wilson", "clopper-pearson")


@dataclass(frozen=True)
class Proportion:
    """``successes`` of ``runs``, the rate and its interval [low, high] at ``confidence``."""

    successes: int
    runs: int
    low: float
    high: float
    method: str = "wilson"
    confidence: float = CONFIDENCE

    @property
    def rate(self) -> float:
        return self.successes / self.runs if self.runs else math.nan


@dataclass(frozen=True)
class Estimate:
    """A median and its bootstrap interval over ``samples`` values; ``inf`` means "not within the budget"."""

    value: float
    low: float
    high: float
    samples: int
    confidence: float = CONFIDENCE


def _check_counts(successes: int, runs: int) -> None:
    for name, value in (("successes", successes), ("runs", runs)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer):
            raise ValueError(f"{name} must be a whole number, got {value!r}")
    if runs < 1 or not 0 <= successes <= runs:
        raise ValueError(f"need 0 <= successes <= runs and runs >= 1, got {successes} of {runs}")


def _check_confidence(confidence: float) -> None:
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence!r}")


def normal_quantile(p: float) -> float:
    """The standard normal distribution's ``p``-quantile, by bisection on ``math.erf`` (to 1e-15)."""
    if not 0 < p < 1:
        raise ValueError(f"a quantile needs 0 < p < 1, got {p!r}")
    return _bisect(lambda x: 0.5 * (1.0 + math.erf(x / math.sqrt(2.0))), p, -40.0, 40.0, 200)


def wilson_interval(successes: int, runs: int, confidence: float = CONFIDENCE) -> Proportion:
    """Wilson's score interval for ``successes`` of ``runs``."""
    _check_counts(successes, runs)
    _check_confidence(confidence)
    z = normal_quantile(0.5 + confidence / 2)
    p = successes / runs
    denominator = 1 + z * z / runs
    center = (p + z * z / (2 * runs)) / denominator
    half = z / denominator * math.sqrt(p * (1 - p) / runs + z * z / (4 * runs * runs))
    # At 0/n and n/n the formula's end is 0 or 1 up to rounding; say it exactly.
    low = 0.0 if successes == 0 else max(0.0, center - half)
    high = 1.0 if successes == runs else min(1.0, center + half)
    return Proportion(int(successes), int(runs), low, high, "wilson", confidence)


def _continued_fraction(a: float, b: float, x: float) -> float:
    # The incomplete beta function's continued fraction, by the modified Lentz method.
    tiny = 1e-300
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1.0)
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 1000):
        for numerator in (m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m)),
                          -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1))):
            d = 1.0 + numerator * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + numerator / c
            c = c if abs(c) > tiny else tiny
            h *= c * d
        if abs(c * d - 1.0) < 1e-15:
            break
    return h


def regularized_incomplete_beta(a: float, b: float, x: float) -> float:
    """I_x(a, b), the beta distribution's CDF at ``x`` (a, b > 0)."""
    if a <= 0 or b <= 0:
        raise ValueError(f"the beta distribution needs a, b > 0, got a={a!r}, b={b!r}")
    if x <= 0:
        return 0.0
    if x >= 1:
        return 1.0
    log_front = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x)
    # The continued fraction converges fast for x < (a + 1) / (a + b + 2); use the symmetry beyond.
    if x < (a + 1) / (a + b + 2):
        return math.exp(log_front) * _continued_fraction(a, b, x) / a
    return 1.0 - math.exp(log_front) * _continued_fraction(b, a, 1.0 - x) / b


def beta_quantile(p: float, a: float, b: float) -> float:
    """The beta(a, b) distribution's ``p``-quantile, by bisection on :func:`regularized_incomplete_beta`."""
    if not 0 <= p <= 1:
        raise ValueError(f"a quantile needs 0 <= p <= 1, got {p!r}")
    # 100 halvings, 2**-100: well below a float's resolution near any quantile we need.
    return _bisect(lambda x: regularized_incomplete_beta(a, b, x), p, 0.0, 1.0, 100)


def _bisect(cdf: Callable[[float], float], p: float, low: float, high: float, steps: int) -> float:
    """The ``p``-quantile of a distribution, its increasing ``cdf`` bisected ``steps`` times on [low, high]."""
    for _ in range(steps):
        middle = 0.5 * (low + high)
        if cdf(middle) < p:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


def clopper_pearson_interval(successes: int, runs: int, confidence: float = CONFIDENCE) -> Proportion:
    """Clopper and Pearson's exact interval: at least the stated coverage, wider than Wilson's."""
    _check_counts(successes, runs)
    _check_confidence(confidence)
    alpha = 1 - confidence
    low = 0.0 if successes == 0 else beta_quantile(alpha / 2, successes, runs - successes + 1)
    high = 1.0 if successes == runs else beta_quantile(1 - alpha / 2, successes + 1, runs - successes)
    return Proportion(int(successes), int(runs), low, high, "clopper-pearson", confidence)


def success_interval(successes: int, runs: int, method: str = "wilson",
                     confidence: float = CONFIDENCE) -> Proportion:
    """The success rate's interval by ``method`` (:data:`INTERVAL_METHODS`)."""
    if method == "wilson":
        return wilson_interval(successes, runs, confidence)
    if method == "clopper-pearson":
        return clopper_pearson_interval(successes, runs, confidence)
    raise ValueError(f"unknown interval method {method!r}; valid: {', '.join(INTERVAL_METHODS)}")


def median(values: Sequence[float]) -> float:
    """The median, with ``inf`` allowed (a run that found nothing): the mean of the middle two, inf if one is."""
    ordered = np.sort(np.asarray(values, dtype=float))
    if ordered.size == 0 or np.isnan(ordered).any():
        raise ValueError("a median needs at least one value and no NaN")
    middle = ordered.size // 2
    if ordered.size % 2:
        return float(ordered[middle])
    return float(0.5 * ordered[middle - 1] + 0.5 * ordered[middle])


def bootstrap_median(values: Sequence[float], rng: np.random.Generator, resamples: int = BOOTSTRAP_RESAMPLES,
                     confidence: float = CONFIDENCE) -> Estimate:
    """The median of ``values`` (``inf`` allowed) with a percentile-bootstrap interval.

    ``resamples`` samples of ``len(values)`` values drawn with replacement by ``rng``; the interval's
    ends are order statistics of their medians (no interpolation, so an infinite end stays infinite
    rather than turning into NaN)."""
    data = np.asarray(values, dtype=float)
    if data.size == 0 or np.isnan(data).any():
        raise ValueError("a bootstrap needs at least one value and no NaN")
    if isinstance(resamples, bool) or not isinstance(resamples, int) or resamples < 1:
        raise ValueError(f"resamples must be a whole number of at least 1, got {resamples!r}")
    _check_confidence(confidence)
    draws = np.sort(data[rng.integers(0, data.size, size=(resamples, data.size))], axis=1)
    middle = data.size // 2
    if data.size % 2:
        medians = draws[:, middle]
    else:
        medians = 0.5 * draws[:, middle - 1] + 0.5 * draws[:, middle]
    medians = np.sort(medians)
    alpha = 1 - confidence
    low = medians[max(0, math.floor(alpha / 2 * resamples))]
    high = medians[min(resamples - 1, math.ceil((1 - alpha / 2) * resamples) - 1)]
    return Estimate(median(data), float(low), float(high), int(data.size), confidence)


def censored_times(solved: Sequence[bool], values: Sequence[float | None]) -> list[float]:
    """Per run, the value at its first solution, or ``inf`` for a run that found none within its budget."""
    if len(solved) != len(values):
        raise ValueError(f"{len(solved)} outcomes but {len(values)} values")
    out = []
    for ok, value in zip(solved, values, strict=True):
        if ok and value is None:
            raise ValueError("a solved run without its value at the first solution")
        out.append(float(value) if ok else math.inf)
    return out


@dataclass(frozen=True)
class CellStatistics:
    """Everything the summary and the results page say about one planner on one puzzle."""

    experiment: str
    planner: str
    success: Proportion
    time_to_first: Estimate  # seconds; inf for runs without a solution
    checks_to_first: Estimate | None  # None where the runs did not record it (they went on past it)
    final_cost: Estimate | None  # over solved runs; None when none solved

    @property
    def runs(self) -> int:
        return self.success.runs

    @property
    def solved_all(self) -> bool:
        """Solved per the paper: every run succeeded."""
        return self.success.successes == self.success.runs

    @property
    def solved_any(self) -> bool:
        """Solved by at least one run (the optimistic count)."""
        return self.success.successes > 0


def cell_statistics(experiment: str, planner: str, solved: Sequence[bool], first_times: Sequence[float | None],
                    costs: Sequence[float | None], first_checks: Sequence[int | None] | None,
                    rng_for, method: str = "wilson", resamples: int = BOOTSTRAP_RESAMPLES) -> CellStatistics:
    """The statistics of one (puzzle, planner) cell from its runs' outcomes.

    ``first_checks``: the collision checks each run spent up to its first solution, or None when
    they were not recorded. ``rng_for(quantity)`` gives the bootstrap's Generator for a quantity
    ("time", "checks", "cost"); pass ``lambda q: stable_rng("bootstrap", experiment, planner, q)``
    so that every cell and quantity has its own stable stream."""
    solved = [bool(s) for s in solved]
    if not solved:
        raise ValueError(f"{experiment} / {planner}: no runs")
    success = success_interval(sum(solved), len(solved), method)
    times = bootstrap_median(censored_times(solved, first_times), rng_for("time"), resamples)
    checks = None
    if first_checks is not None:
        checks = bootstrap_median(censored_times(solved, first_checks), rng_for("checks"), resamples)
    solved_costs = [float(c) for ok, c in zip(solved, costs, strict=True) if ok and c is not None]
    cost = bootstrap_median(solved_costs, rng_for("cost"), resamples) if solved_costs else None
    return CellStatistics(experiment, planner, success, times, checks, cost)


@dataclass(frozen=True)
class PlannerTotals:
    """One planner over every puzzle: puzzles solved (all runs, any run) and its runs pooled."""

    planner: str
    puzzles: int
    solved_all: int
    solved_any: int
    pooled: Proportion  # every run of every puzzle, pooled (the puzzles differ: a summary, not a model)
    median_time_to_first: float | None  # median over puzzles of the per-puzzle medians (inf allowed)


def planner_totals(cells: Sequence[CellStatistics], method: str = "wilson") -> list[PlannerTotals]:
    """Totals per planner, in the order the planners first appear in ``cells``."""
    out = []
    for planner in dict.fromkeys(c.planner for c in cells):
        mine = [c for c in cells if c.planner == planner]
        successes = sum(c.success.successes for c in mine)
        runs = sum(c.success.runs for c in mine)
        out.append(PlannerTotals(planner, len(mine), sum(c.solved_all for c in mine), sum(c.solved_any for c in mine),
                                 success_interval(successes, runs, method),
                                 median([c.time_to_first.value for c in mine])))
    return out
