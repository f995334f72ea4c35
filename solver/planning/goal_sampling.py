"""Valid goal states for every planner alike: one seeded, deterministic stream per run.

A goal state has the target's goal joints at their goal values and every
other joint anywhere within its limits. Planners need valid ones: LA-RRT
roots its goal tree in them, BIT* takes them as goal vertices, RRT* and
LBT-RRT steer toward them (goal bias). Uniform goal states are rarely
valid: on the paper's puzzles, of 200,000 drawn, Lockbox Random 1-4 had
0-2 valid ones (every lock must happen to be open), Simple Slider 3 and 4
had 201 and 26, Grid World 3 had 349. A planner that draws its own uniform goal states
therefore starves on these puzzles (BIT*, which asks OMPL's goal region for
a bounded number of samples, made no iteration at all), and a planner that
builds goal states from its own search tree gets what the others cannot.

So every planner draws from one :class:`GoalSampler`, built from the
problem and a goal seed. The benchmark gives every planner of a run the
same goal seed, so run ``r`` of every planner sees the same goal states in
the same order. Each state of the stream is made from one uniform goal
candidate:

- valid as drawn: kept;
- otherwise *repaired* by min-conflicts: an object (other than the pinned
  goal joints) that takes part in a collision gets fresh uniform values,
  a few candidates at once; the first valid candidate ends the repair,
  else the one with the fewest colliding pairs is kept (never more than
  before) and the next round picks an object again. A lockbox's locks open
  one after another this way: a disc turns until its slot frees the
  slider, which then may slide out.
- a candidate not repaired within its rounds is dropped.

Only the problem (collision model, limits, goal) is used, nothing a planner
found, so every planner can have the same states. All draws come from the
sampler's own numpy Generator, and the work is bounded by a budget of
checked states, never seconds: the k-th goal state of a run is the same on
every machine, whichever planner asks and whenever it asks. The stream
holds at most :attr:`GoalSamplerSettings.capacity` states: a planner that
asks for more (RRT*'s goal bias, LA-RRT's new goal roots) gets no new ones
(:meth:`GoalSampler.next`) or one of those found again (:meth:`GoalSampler.sample`).

Goal sampling is part of the run, not a side cost: its checks go through the
run's collision model (counted like every other check), and a sampler bound to
the run (:meth:`GoalSampler.bind`) stops inside a call as soon as the run is
over, its check budget or its clock spent. An audit found one unbound call
spending 13-16 s of a 3 s run. What a run's sampler did is reported
(:meth:`GoalSampler.account`): a run that ended unsolved with no goal state,
or after its sampler gave out, is not the same evidence as one that had goal
states and found no path to them.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from phyrogen_core.seeding import stable_seed
from solver.collision.model import CollisionModel
from solver.planning import _goal_stream as stream
from solver.planning._isolated_step import compiled_piece, factor_table
from solver.planning.anytime import AnytimeRecorder, CheckCounter
from solver.planning.problem import Problem, problem_factors

GOAL_SAMPLING_VERSION = "2"
"""Bumped when the sampler's algorithm changes (the benchmark journal keys runs by it). 2: a call
stops when its run's budget or clock is spent (:meth:`GoalSampler.bind`)."""


@dataclass(frozen=True)
class GoalSamplerSettings:
    """How many goal states a run may have and how much checking may go into finding them."""

    capacity: int = 16
    """Distinct goal states per run (BIT* takes them all as goal vertices at once)."""
    budget: int = 100_000
    """States checked (candidates, repair draws, colliding-pair queries) over the whole run; the
    paper's lockboxes take about 1,000 per goal state, so 16 cost about a sixth of this."""
    batch: int = 64
    """Uniform candidates drawn and checked at once."""
    repair_rounds: int = 30
    """Objects resampled, one after another, before a candidate is dropped."""
    repair_draws: int = 16
    """Fresh values tried for the resampled object in one round."""

    def __post_init__(self) -> None:
        for name in ("capacity", "budget", "batch", "repair_rounds", "repair_draws"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < (0 if name == "repair_rounds" else 1):
                raise ValueError(f"{name} must be a whole number of at least "
                                 f"{0 if name == 'repair_rounds' else 1}, got {value!r}")

    @property
    def tag(self) -> str:
        """A short digest of the algorithm version and these settings, for journal keys."""
        text = f"{GOAL_SAMPLING_VERSION}:{self!r}"
        return f"goals{GOAL_SAMPLING_VERSION}-{hashlib.sha256(text.encode()).hexdigest()[:8]}"


DEFAULT_GOAL_SETTINGS = GoalSamplerSettings()


def goal_seed(puzzle: str, run: int, base_seed: int = 0) -> int:
    """The goal seed of run ``run`` on ``puzzle``: the same for every planner (no planner in it)."""
    return stable_seed("goals", base_seed, puzzle, run)


def default_goal_seed(seed: int) -> int:
    """The goal seed of a run planned on its own with ``seed`` (a stream apart from the planner's)."""
    return stable_seed("goals", seed)


class RunLimit(Protocol):
    """What a sampler needs of its run (an :class:`~solver.planning.anytime.AnytimeRecorder`)."""

    budget_checks: int | None

    def checks(self) -> int: ...

    def expired(self) -> bool: ...


@dataclass(frozen=True)
class GoalAccount:
    """What one run's goal sampling did, for its result."""

    states: int  # valid goal states found
    candidates: int  # uniform candidates drawn (each repaired when invalid)
    checks: int  # states checked while sampling (candidates, repair draws, colliding-pair queries)
    exhausted: bool  # the sampler's own budget ran out: no new goal state could come
    cut_by_run: bool  # a call stopped because the run's budget or clock was spent

    def describe(self) -> str:
        """One phrase for reports, e.g. "0 goal states in 1,204 checked (sampler exhausted)"."""
        ended = " (sampler exhausted)" if self.exhausted else " (cut by the run's budget)" if self.cut_by_run else ""
        return f"{self.states} goal states in {self.checks:,} checked{ended}"


class GoalSampler:
    """The stream of valid goal states of one run (see the module docstring). ``compiled``: where it applies
    (:meth:`_compiled_limits`), :meth:`next` is one compiled call (:mod:`solver.planning._goal_stream`), the same
    stream; False keeps the Python search (the reference the tests compare with)."""

    def __init__(self, problem: Problem, seed: int, settings: GoalSamplerSettings | None = None, *,
                 compiled: bool = True):
        self.problem = problem
        self.settings = settings or DEFAULT_GOAL_SETTINGS
        self.rng = np.random.default_rng(seed)
        self.model = problem.model
        self.goal_columns = np.array(sorted(problem.goal_columns), dtype=np.int64)
        self.goal_values = np.array([problem.goal_columns[c] for c in self.goal_columns.tolist()])
        factors = problem_factors(problem)
        pinned = set(self.goal_columns.tolist())
        free = {name: np.array([c for c in columns if c not in pinned], dtype=np.int64)
                for name, columns in factors.items()}
        # Objects a repair may move: those with a joint the goal leaves free.
        self.free = {name: columns for name, columns in free.items() if len(columns)}
        self.states: list[np.ndarray] = []
        self.checked = 0
        self.candidates = 0  # uniform candidates drawn
        self.repaired = 0  # states of the stream that needed a repair
        self._block = np.empty((0, len(problem.start)))
        self._valid = np.empty(0, dtype=bool)
        self._next = 0
        self._budget_spent = False
        self._run: RunLimit | None = None
        self.cut_by_run = False  # a call stopped because the run was over
        self._tables = self._compiled_tables() if compiled else None
        if isinstance(self.model, CheckCounter):
            # So that the run's result reports this sampler's account (AnytimeRecorder.result).
            self.model.goal_sampler = self

    def bind(self, run: RunLimit) -> GoalSampler:
        """Stop every later call as soon as ``run`` is over: a check it would spend past the run's
        check budget is not spent, and an expired run (budget or clock) gets no new state. A sampler
        on a problem built with :func:`~solver.planning.anytime.count_checks` is bound to the
        :class:`~solver.planning.anytime.AnytimeRecorder` made on it without this call."""
        self._run = run
        return self

    def account(self) -> GoalAccount:
        """What the sampler did so far (see :class:`GoalAccount`)."""
        return GoalAccount(len(self.states), self.candidates, self.checked, self._budget_spent, self.cut_by_run)

    # -- the stream -----------------------------------------------------------
    @property
    def exhausted(self) -> bool:
        """No new state will come: the stream is full, its budget is spent, or its run is over."""
        return len(self.states) >= self.settings.capacity or self._budget_spent or self.cut_by_run

    def next(self) -> np.ndarray | None:
        """The next new goal state of the stream (a copy), or None once it is exhausted."""
        if self.exhausted:
            return None
        limits = self._compiled_limits()
        if limits is not None:
            return self._next_compiled(limits)
        while not self.exhausted:
            if self._next == len(self._block):
                if not self._draw_block():
                    break
            candidate = self._block[self._next]
            valid = bool(self._valid[self._next])
            self._next += 1
            self.candidates += 1
            if not valid:
                candidate = self._repair(candidate)
                if candidate is None:
                    continue
                self.repaired += 1
            self.states.append(candidate.copy())
            return candidate.copy()
        return None

    def sample(self, rng: np.random.Generator) -> np.ndarray | None:
        """A new goal state while the stream lasts, then one of those found, drawn with the caller's
        ``rng`` (goal bias); None when none was found at all."""
        state = self.next()
        if state is not None or not self.states:
            return state
        return self.states[int(rng.integers(len(self.states)))].copy()

    # -- the compiled search -------------------------------------------------------
    def _compiled_tables(self) -> tuple | None:
        """What :func:`~solver.planning._goal_stream.next_state` needs of the model and the objects; None where
        the model is not ours (counted by a :class:`CheckCounter` or not)."""
        real = self.model._model if type(self.model) is CheckCounter else self.model
        if type(real) is not CollisionModel:
            return None
        names = sorted({name for pair in real._pair_objects for name in pair})
        number = {name: i for i, name in enumerate(names)}
        pair_objects = np.array([(number[a], number[b]) for a, b in real._pair_objects],
                                dtype=np.int64).reshape(-1, 2)
        movable = [name for name in names if name in self.free]  # objects a repair may move, in name order
        object_free = np.array([movable.index(name) if name in self.free else -1 for name in names], dtype=np.int64)
        free_columns, free_sizes = factor_table([self.free[name] for name in movable])
        return (self.goal_columns, self.goal_values.astype(np.float64), free_columns, free_sizes, object_free,
                pair_objects, len(names), real._packed_int, real._packed_float, real._pair_columns)

    def _compiled_limits(self) -> np.ndarray | None:
        """The settings and the run's limits as the compiled search reads them; None where it does not apply:
        no tables, or a run whose end a clock may decide (only checks may end a run inside a compiled call)
        or that does not count this sampler's checks."""
        if self._tables is None:
            return None
        run = self._run if self._run is not None else getattr(self.model, "run", None)
        settings = self.settings
        limits = [settings.capacity, settings.budget, settings.batch, settings.repair_rounds, settings.repair_draws,
                  0, 0, 0]
        if run is not None:
            if type(run) is not AnytimeRecorder or run.counter is not self.model or run.budget_cpu is not None \
                    or run.time_limit != float("inf"):
                return None
            limits[stream.HAS_RUN:] = [1, 2**62 if run.budget_checks is None else run.budget_checks,
                                       run.end is not None]
        return np.array(limits, dtype=np.int64)

    def _next_compiled(self, limits: np.ndarray) -> np.ndarray | None:
        counters = np.zeros(stream.COUNTERS, dtype=np.int64)
        counters[[stream.NEXT, stream.ROWS, stream.CANDIDATES, stream.CHECKED, stream.REPAIRED, stream.STATES]] = \
            [self._next, len(self._block), self.candidates, self.checked, self.repaired, len(self.states)]
        run = self._run if self._run is not None else getattr(self.model, "run", None)
        counters[stream.RUN_SPENT] = run.checks() if run is not None else 0
        block = np.empty((self.settings.batch, len(self.problem.start)))
        block[:len(self._block)] = self._block
        valid = np.zeros(self.settings.batch, dtype=np.bool_)
        valid[:len(self._valid)] = self._valid
        state = compiled_piece(stream.next_state, self.rng, block, valid, counters, limits, self.problem.lower,
                               self.problem.upper, *self._tables)
        rows = int(counters[stream.ROWS])
        self._block, self._valid, self._next = block[:rows], valid[:rows], int(counters[stream.NEXT])
        self.candidates, self.checked = int(counters[stream.CANDIDATES]), int(counters[stream.CHECKED])
        self.repaired, self._budget_spent = int(counters[stream.REPAIRED]), bool(counters[stream.BUDGET_SPENT])
        if type(self.model) is CheckCounter:
            self.model.checks += int(counters[stream.SPENT])
        if counters[stream.CUT] and not self.cut_by_run:
            self.cut_by_run = True
            run.expired()  # as the Python search asked it at the refused check (it records why the run ended)
        if not len(state):
            return None
        self.states.append(state.copy())
        return state.copy()

    # -- finding states -----------------------------------------------------------
    def _spend(self, states: int) -> bool:
        """Charge ``states`` checks to the budget; False (and the stream ends) when it does not hold them."""
        if self.checked + states > self.settings.budget:
            self._budget_spent = True
            return False
        # Bound explicitly, or through the check counter the run's recorder announced itself on.
        run = self._run if self._run is not None else getattr(self.model, "run", None)
        if run is not None and (run.expired() or
                                (run.budget_checks is not None and run.checks() + states > run.budget_checks)):
            self.cut_by_run = True
            return False
        self.checked += states
        return True

    def _draw_block(self) -> bool:
        batch = self.settings.batch
        if not self._spend(batch):
            return False
        lower, upper = self.problem.lower, self.problem.upper
        block = lower + (upper - lower) * self.rng.random((batch, len(lower)))
        block[:, self.goal_columns] = self.goal_values
        self._block = np.ascontiguousarray(block)
        self._valid = self.model.check_prepared(self._block)
        self._next = 0
        return True

    def _conflicts(self, state: np.ndarray) -> set[tuple[str, str]] | None:
        """The colliding object pairs at ``state`` (one checked state), or None over budget."""
        if not self._spend(1):
            return None
        return self.model.colliding_objects(state[None, :])

    def _conflicts_each(self, draws: np.ndarray) -> list[set[tuple[str, str]]] | None:
        """:meth:`_conflicts` of each of ``draws`` in turn, or None when the budget ends before the last;
        on our collision model the states are paid one by one as before, then tested in one compiled call
        (the same pair test: the same sets)."""
        counter = self.model if type(self.model) is CheckCounter else None
        real = counter._model if counter is not None else self.model
        if type(real) is not CollisionModel:
            found = []
            for draw in draws:
                conflicts = self._conflicts(draw)
                if conflicts is None:
                    return None
                found.append(conflicts)
            return found
        for _ in range(len(draws)):
            if not self._spend(1):
                return None
            if counter is not None:
                counter.checks += 1  # as the counter charges one state's colliding pairs
        return real.colliding_objects_each(draws)

    def _repair(self, state: np.ndarray) -> np.ndarray | None:
        """Min-conflicts repair of an invalid candidate; None when it fails or the budget ends."""
        settings = self.settings
        lower, upper = self.problem.lower, self.problem.upper
        state = state.copy()
        pairs = self._conflicts(state)
        for _ in range(settings.repair_rounds):
            if pairs is None:
                return None
            involved = sorted({name for pair in pairs for name in pair if name in self.free})
            if not involved:
                return None  # only pinned goal joints or static parts collide: no repair can help
            columns = self.free[involved[int(self.rng.integers(len(involved)))]]
            draws = np.repeat(state[None, :], settings.repair_draws, axis=0)
            span = upper[columns] - lower[columns]
            draws[:, columns] = lower[columns] + span * self.rng.random((settings.repair_draws, len(columns)))
            if not self._spend(settings.repair_draws):
                return None
            valid = self.model.check_prepared(draws)
            if valid.any():
                return draws[int(np.argmax(valid))]
            found = self._conflicts_each(draws)
            if found is None:
                return None
            best = min(range(len(found)), key=lambda k: len(found[k]))
            if len(found[best]) <= len(pairs):  # sideways moves too: plateaus are common
                state, pairs = draws[best], found[best]
        return None
