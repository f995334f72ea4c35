"""What every benchmark planner shares: the anytime result and its recorder.

A planner gets a :class:`~solver.planning.problem.Problem` (the collision model and
the free joints' bounds, start and goal) and a time limit; it reports a
:class:`PlanResult`: the best path it found, scored with the paper's action
cost (:func:`phyrogen_core.actions.count_actions`, the same function for every
planner), when it found its first solution, and how the best cost evolved.
Paths in a result list states in the problem's joint order
(``problem.model.joint_order``); :func:`solver.planning.problem.chain_path` expands
them to the chain's full joint order.
"""

from __future__ import annotations

import enum
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from phyrogen_core.actions import count_actions
from solver.planning.problem import FINE_RESOLUTION, Path, Problem, in_goal, path_is_valid, problem_factors

PLANNING_RESOLUTION = 0.01
"""Metres any collision point may move between two states checked while planning, for every
planner alike. At 0.02, diagonal RRT* edges sometimes clipped a corner that the final
fine-resolution check (:data:`~solver.planning.problem.FINE_RESOLUTION`) then caught."""


@dataclass(frozen=True)
class ProgressSample:
    """One progress point of a run: OMPL's ``time``, ``best cost`` (inf: none yet), ``iterations``."""

    time: float
    best_cost: float
    iterations: int


@dataclass(frozen=True)
class PlanResult:
    """What one planner run produced."""

    planner: str
    solved: bool
    path: Path  # best path, problem joint order; empty when unsolved
    action_cost: int | None
    first_solution_time: float | None
    time: float
    iterations: int
    progress: tuple[ProgressSample, ...]
    status: str  # one of OMPL's PlannerStatus names, e.g. "Exact solution", "Timeout"
    rejected: int = 0  # solution paths dropped because they failed the fine-resolution check
    best_solution_time: float | None = None  # when the returned path was found
    checks: int = 0  # collision checks spent (:class:`CheckCounter`), the unit of a check budget
    cpu_time: float = 0.0  # process CPU seconds of the run (time.process_time), beside the wall ``time``
    first_solution_checks: int | None = None  # collision checks spent when the first kept path was found
    # The run's shared goal sampler (None: the run had none): an unsolved run with no goal state, or
    # whose sampler gave out, is weaker evidence than one that had goal states and found no path.
    goal_states: int | None = None  # valid goal states it found
    goal_exhausted: bool | None = None  # its own budget ran out: no new goal state could come
    end: str = "stopped"  # why the run ended: one of END_REASONS

    @property
    def length(self) -> float:
        """Joint-space (L2) length of the best path, OMPL's ``solution length``."""
        states = np.asarray(self.path, dtype=float)
        if len(states) < 2:
            return 0.0
        return float(np.linalg.norm(np.diff(states, axis=0), axis=1).sum())


END_REASONS = ("solved", "budget", "clock", "stopped")
"""Why a run ended, one reason each: ``solved``, it stopped at its first solution (``until_first``);
``budget``, its budget was spent (checks, CPU seconds, or, for a run with neither, its time limit);
``clock``, the wall-clock backstop ended a run that had a budget in checks or CPU seconds before that
budget was spent (its result is not the budget's: the benchmark reports it apart); ``stopped``, the
planner ended by itself (an invalid start, a crash)."""

PROGRESS_SAMPLES = 50
"""Progress samples of a run under a check budget, one each this share of the budget (see
:meth:`AnytimeRecorder.sample`); the wall-clock interval is for runs without one."""

MAX_BUDGET_CPU = 24 * 3600.0
"""The largest CPU-seconds budget a run may have: a day."""

MAX_BUDGET_CHECKS = 10**9
"""The largest check budget a run may have: about three hours of checks at 100,000 a second."""


def check_budget_checks(budget: object) -> None:
    """Raise ValueError unless ``budget`` is None or a whole number in 1..:data:`MAX_BUDGET_CHECKS`."""
    if budget is None:
        return
    if isinstance(budget, bool) or not isinstance(budget, int) or not 1 <= budget <= MAX_BUDGET_CHECKS:
        raise ValueError(f"check budget must be a whole number of collision checks from 1 to "
                         f"{MAX_BUDGET_CHECKS}, got {budget!r}")


def check_budget_cpu(budget: object) -> None:
    """Raise ValueError unless ``budget`` is None or a finite number of CPU seconds in (0, :data:`MAX_BUDGET_CPU`]."""
    if budget is None:
        return
    if isinstance(budget, bool) or not isinstance(budget, int | float) or not 0 < budget <= MAX_BUDGET_CPU:
        raise ValueError(f"CPU budget must be a number of CPU seconds above 0 and at most {MAX_BUDGET_CPU:g}, "
                         f"got {budget!r}")


def check_run_limits(time_limit: float, budget_checks: int | None, budget_cpu: float | None) -> None:
    """Raise ValueError unless a run's limits are a positive time limit and at most one budget, each
    valid (:func:`check_budget_checks`, :func:`check_budget_cpu`)."""
    if not time_limit > 0:
        raise ValueError(f"time limit must be a positive number of seconds, got {time_limit!r}")
    check_budget_checks(budget_checks)
    check_budget_cpu(budget_cpu)
    if budget_checks is not None and budget_cpu is not None:
        raise ValueError("a run has one budget: in checks or in CPU seconds, not both")


BACKSTOP_SECONDS = 600.0
"""A budgeted run's wall-clock backstop, at the least; it grows with the budget (:func:`backstop_seconds`)."""

BACKSTOP_CHECKS_PER_SECOND = 100.0
"""The wall-clock backstop's rate: checks (motions by their length) a wall second. Planners spend
0.7-6.3 million a CPU second (docs/benchmark/README.md, "Charging the work"): thousands of times
this, so only a run that stops checking (a hang) meets its backstop, even on a crowded core."""


def backstop_seconds(budget_checks: int) -> float:
    """The wall-clock backstop of a run of ``budget_checks`` checks: :data:`BACKSTOP_CHECKS_PER_SECOND`,
    far below any planner's rate on any puzzle measured, and at least :data:`BACKSTOP_SECONDS`."""
    return max(BACKSTOP_SECONDS, budget_checks / BACKSTOP_CHECKS_PER_SECOND)


def motion_length(start, end, steps) -> int:
    """The states a motion check tests when the motion is free: the resolution steps of its longest
    joint move, at least 1 (how :func:`solver.collision.kernels.motion_collision` samples it)."""
    moves = np.abs(np.asarray(end, dtype=float) - np.asarray(start, dtype=float)) / steps
    return max(1, int(np.ceil(moves.max()))) if moves.size else 1


class CheckCounter:
    """A collision model that counts the checks made through it, the same way for every planner:
    one per state whose validity is asked (singly or in a batch, OMPL's state validity checker
    included), and per motion (OMPL's motion validator included) either one (``by_length`` False,
    the Maker's judges' unit, which generated puzzles depend on) or its length in resolution steps
    (:func:`motion_length`: the states it tests, as the paper's harness checked a motion state by
    state; the benchmark's unit, so that a long motion is not charged as one state). A check budget
    is spent in these units, so a budgeted run does the same work on any machine under any load."""

    def __init__(self, model, by_length: bool = False):
        self._model = model
        self.checks = 0
        self.by_length = bool(by_length)

    def __getattr__(self, name):
        return getattr(self._model, name)

    def check(self, states):
        result = self._model.check(states)
        self.checks += len(result)
        return result

    def check_prepared(self, states):
        self.checks += len(states)
        return self._model.check_prepared(states)

    def is_valid(self, state) -> bool:
        self.checks += 1
        return self._model.is_valid(state)

    def colliding_objects(self, states):
        self.checks += len(np.atleast_2d(states))
        return self._model.colliding_objects(states)

    def check_motion(self, start, end, steps) -> bool:
        self.checks += motion_length(start, end, steps) if self.by_length else 1
        return self._model.check_motion(start, end, steps)

    def motion_collision(self, start, end, steps) -> float:
        self.checks += motion_length(start, end, steps) if self.by_length else 1
        return self._model.motion_collision(start, end, steps)


def count_checks(problem: Problem, by_length: bool = False) -> Problem:
    """``problem`` with its model behind a :class:`CheckCounter` (itself if it has one already, whatever
    its unit: the first to count decides). ``by_length``: motions are charged by their length (the
    benchmark's unit; :func:`solver.planning.registry.PlannerSpec.plan` counts so for every planner).
    Build the planner, its goal sampler and its recorder all on the returned problem."""
    if isinstance(problem.model, CheckCounter):
        return problem
    return replace(problem, model=CheckCounter(problem.model, by_length))


class Offer(enum.Enum):
    """What :meth:`AnytimeRecorder.offer_checked` made of a path."""

    BEST = "the new best path"
    CLIPPED = "cheaper, but it clips a corner at fine resolution (counted, dropped)"
    NO_GAIN = "not cheaper than the best so far"


class AnytimeRecorder:
    """Keeps the best path a planner has found, its first-solution time and the cost over time.

    Every candidate is scored with :func:`count_actions`. When the run ends,
    the best path is re-checked at fine resolution (every planner checks at
    the coarser planning resolution while it runs); a path that fails is
    dropped with the improvements it made, and the previous best counts, so
    a result only ever holds fine-checked paths, with the times they were found.
    The clock starts when the recorder is made, after the compiled collision
    kernels are loaded (:func:`warm_up`).

    With ``budget_checks`` the run ends once that many collision checks are
    spent (counted by the problem's :class:`CheckCounter`: build the problem
    with :func:`count_checks`); ``time_limit`` is then only a backstop against
    a run that stops checking. Nothing a budgeted planner decides may read the
    clock: it asks :meth:`usage` (checks then, seconds otherwise), so the same
    seed and budget give the same path, cost and checks under any load. With
    ``budget_cpu`` the run ends after that many CPU seconds of its process
    (machine-dependent, but blind to other processes' load), the time limit
    again a backstop. :attr:`end` says which ended it (:data:`END_REASONS`).
    """

    def __init__(self, planner: str, problem: Problem, time_limit: float, progress_interval: float,
                 budget_checks: int | None = None, budget_cpu: float | None = None):
        check_run_limits(time_limit, budget_checks, budget_cpu)
        self.budget_cpu = None if budget_cpu is None else float(budget_cpu)
        self.end: str | None = None  # set by the first expired() that says True
        self.counter = problem.model if isinstance(problem.model, CheckCounter) else None
        if budget_checks is not None and self.counter is None:
            raise ValueError("a check budget needs a problem that counts its checks (count_checks(problem))")
        self.budget_checks = budget_checks
        if self.counter is not None:
            # The run's goal sampler, built on the same counter, ends its calls with the run
            # (solver.planning.goal_sampling): one call once overran a 3 s run by 13 s.
            self.counter.run = self
        # The fine-resolution check of offered paths is the benchmark's scoring, the same for every
        # planner, not the planner's search: it does not spend the planner's budget.
        self._referee = self.counter._model if self.counter is not None else problem.model
        warm_up(problem)
        self._checks_before = self.counter.checks if self.counter is not None else 0
        self.planner = planner
        self.problem = problem
        self.time_limit = float(time_limit)
        self.interval = float(progress_interval)
        self.factors = problem_factors(problem)
        self.started = time.perf_counter()
        self.cpu_started = time.process_time()
        self.improvements: list[tuple[float, int, np.ndarray]] = []  # (time, action cost, path)
        self.improvement_checks: list[int] = []  # checks spent when each improvement was found
        self.samples: list[tuple[float, int]] = []  # (time, iterations)
        self._next_sample = 0.0
        self.clipped = 0  # paths dropped while running for failing the fine check
        self.fine_steps = problem.model.motion_steps(FINE_RESOLUTION)

    @property
    def best_cost(self) -> float:
        return self.improvements[-1][1] if self.improvements else math.inf

    @property
    def has_solution(self) -> bool:
        return bool(self.improvements)

    def elapsed(self) -> float:
        return time.perf_counter() - self.started

    def checks(self) -> int:
        """Collision checks spent since the recorder was made (0 when the problem does not count them)."""
        return self.counter.checks - self._checks_before if self.counter is not None else 0

    def cpu(self) -> float:
        """CPU seconds of this process since the recorder was made."""
        return time.process_time() - self.cpu_started

    def usage(self) -> float:
        """How much of the run is spent, in the unit that ends it: checks under a check budget, CPU
        seconds under a CPU budget, else seconds."""
        if self.budget_checks is not None:
            return float(self.checks())
        return self.cpu() if self.budget_cpu is not None else self.elapsed()

    def expired(self) -> bool:
        """Whether the run is over; the first time it is, :attr:`end` records why (budget or clock)."""
        if self.end is not None:
            return True
        if self.budget_checks is not None and self.checks() >= self.budget_checks:
            self.end = "budget"
        elif self.budget_cpu is not None and self.cpu() >= self.budget_cpu:
            self.end = "budget"
        elif self.elapsed() >= self.time_limit:
            # Without another budget the time limit is the budget; with one, the clock is a backstop.
            self.end = "clock" if self.budget_checks is not None or self.budget_cpu is not None else "budget"
        return self.end is not None

    def improves(self, path: Sequence[Sequence[float]]) -> bool:
        """Whether ``path`` would need fewer actions than the best so far (no other check)."""
        return count_actions(np.asarray(path, dtype=float), self.factors) < self.best_cost

    def moment(self) -> tuple[float, int]:
        """(seconds, checks) spent so far: when a path was found, for :meth:`offer`'s ``found_at``."""
        return self.elapsed(), self.checks()

    def offer(self, path: Sequence[Sequence[float]], found_at: tuple[float, int] | None = None) -> bool:
        """Consider a solution path (valid at planning resolution); True when it became the new best.
        ``found_at``: the :meth:`moment` the planner found it, when that was before this call (an OMPL
        planner's path is read after its ``solve`` slice ends); default now."""
        states = np.asarray(path, dtype=float)
        if len(states) < 1 or not in_goal(self.problem, states[-1]):
            return False
        if np.max(np.abs(states[0] - self.problem.start)) > 1e-9:
            return False
        cost = count_actions(states, self.factors)
        if cost >= self.best_cost:
            return False
        seconds, checks = self.moment() if found_at is None else found_at
        self.improvements.append((seconds, cost, states.copy()))
        self.improvement_checks.append(checks)
        return True

    def offer_checked(self, path: Sequence[Sequence[float]], found_at: tuple[float, int] | None = None) -> Offer:
        """Offer ``path`` if it is cheaper than the best so far and holds at fine resolution.

        A cheaper path that clips is counted (:meth:`clip`) and dropped: kept, it would block
        every equally cheap path that holds (:meth:`offer` takes strictly cheaper ones only).
        """
        if not self.improves(path):
            return Offer.NO_GAIN
        if not self._holds(np.asarray(path, dtype=float)):
            self.clip()
            return Offer.CLIPPED
        return Offer.BEST if self.offer(path, found_at) else Offer.NO_GAIN

    def _holds(self, states: np.ndarray) -> bool:
        """Whether a path holds at fine resolution (:meth:`offer_checked`, and the best path again in
        :meth:`result`)."""
        return path_is_valid(self._referee, states, self.fine_steps)

    def clip(self) -> None:
        """Count a solution path the planner dropped because it failed the fine-resolution check."""
        self.clipped += 1

    def sample(self, iterations: int, force: bool = False) -> None:
        """Record a progress sample if the sampling interval has passed (or ``force``). Under a check
        budget the interval is 1/:data:`PROGRESS_SAMPLES` of the budget in checks, so that the same
        run samples at the same iterations under any load (only the samples' times differ)."""
        now = self.elapsed()
        if self.budget_checks is not None and math.isfinite(self.interval):
            spent = self.checks()
            if force or spent >= self._next_sample:
                self.samples.append((now, iterations))
                self._next_sample = spent + max(1, math.ceil(self.budget_checks / PROGRESS_SAMPLES))
            return
        if force or now >= self._next_sample:
            self.samples.append((now, iterations))
            self._next_sample = now + self.interval

    def result(self, iterations: int, status: str | None = None) -> PlanResult:
        self.sample(iterations, force=True)
        elapsed = self.elapsed()
        rejected = self.clipped
        kept = list(self.improvements)
        while kept and not self._holds(kept[-1][2]):
            kept.pop()
            rejected += 1
        progress = []
        for t, count in self.samples:
            costs = [cost for found, cost, _ in kept if found <= t]
            progress.append(ProgressSample(t, float(min(costs)) if costs else math.inf, count))
        solved = bool(kept)
        if status is None:
            status = "Exact solution" if solved else "Timeout"
        best = tuple(tuple(float(v) for v in s) for s in kept[-1][2]) if solved else ()
        # A goal sampler built on this run's counter announced itself there (solver.planning.goal_sampling).
        sampler = getattr(self.counter, "goal_sampler", None) if self.counter is not None else None
        goals = sampler.account() if sampler is not None else None
        return PlanResult(self.planner, solved, best, kept[-1][1] if solved else None,
                          kept[0][0] if solved else None, elapsed, iterations, tuple(progress), status, rejected,
                          kept[-1][0] if solved else None, self.checks(), self.cpu(),
                          self.improvement_checks[0] if solved else None,
                          goals.states if goals is not None else None, goals.exhausted if goals is not None else None,
                          # A planner that ended by itself with a solution stopped at it (until first).
                          self.end or ("solved" if solved else "stopped"))


def planning_steps(problem: Problem, resolution: float = PLANNING_RESOLUTION) -> np.ndarray:
    """Per-joint steps for collision checks while planning (metres of motion of any point)."""
    return problem.model.motion_steps(resolution)


def warm_up(problem: Problem) -> None:
    """Load the compiled collision kernels before a run's clock starts (the first call pays for it)."""
    model = problem.model
    start = np.ascontiguousarray(problem.start, dtype=float)
    model.is_valid(start)
    model.check_prepared(start[None, :].copy())
    model.check_motion(start, start, planning_steps(problem))
