"""The Maker (paper, Algorithm 1): one generic loop for every generator.

Inputs are three item sources (objects, joints, transformations), the number
of objects N and the seed. At iteration n the Maker draws an item from each
source (a finite set: the seeded rng picks one; a sequence: its n-th item),
lets the generator attach the new object to the puzzle built so far, and keeps
the candidate only if

1. the puzzle is NOT solvable with the new object fixed at its creation pose,
   even with every collision shape shrunk by ``interlock_margin`` (otherwise
   the object would be superfluous, or blocks by a sliver of slack only), and
2. the puzzle IS solvable with the object free.

Both questions are asked of a :class:`Validator` (the solver package provides
the OMPL and LA-RRT one), so the core stays free of planner imports. The
validator also measures how much shrink each new object withstands; the
result keeps it per object (``margins``). Objects with a fixed
joint (walls, corridors, rooms) have nothing to fix: for them only check 2
applies, otherwise Algorithm 1 would loop forever on them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from .objects import PuzzleObject, build_chain
from .puzzle import Goal
from .seeding import stable_rng


class GenerationError(RuntimeError):
    """A generator could not build a puzzle within its bounded number of tries."""


# -- item sources ------------------------------------------------------------
class ItemSource(Protocol):
    def get(self, n: int, rng: np.random.Generator) -> Any: ...


@dataclass(frozen=True)
class Choice:
    """A finite set: the seeded rng picks an item."""

    items: tuple

    def get(self, n: int, rng: np.random.Generator) -> Any:
        return self.items[int(rng.integers(len(self.items)))]


@dataclass(frozen=True)
class Uniform:
    """A continuous set, a box [low, high] per coordinate: the seeded rng draws a point."""

    low: tuple[float, ...]
    high: tuple[float, ...]

    def get(self, n: int, rng: np.random.Generator) -> tuple[float, ...]:
        return tuple(float(rng.uniform(lo, hi)) for lo, hi in zip(self.low, self.high, strict=True))


@dataclass(frozen=True)
class InfiniteSequence:
    """An infinite sequence: item n (1-based) is ``items[n-1]``; past the end the
    tail repeats cyclically from ``repeat_from`` (e.g. Cuboid, Disk, Cuboid, ...)."""

    items: tuple
    repeat_from: int = 0

    def get(self, n: int, rng: np.random.Generator) -> Any:
        i = n - 1
        if i >= len(self.items):
            period = len(self.items) - self.repeat_from
            i = self.repeat_from + (i - self.repeat_from) % period
        return self.items[i]


# -- validation interface ----------------------------------------------------
BY_GEOMETRY = "geometry"
"""A necessary verdict proven by geometry: with the objects fixed, no valid state with the target at
its goal can be reached (solver.validation.blocking)."""
BY_GOAL_SAMPLER = "goal sampler"
"""A necessary verdict on which the search found no valid goal state at all: the goal sampler's
search gave out (evidence that the goal itself is blocked, not a proof)."""
BY_SEARCH = "search"
"""A necessary verdict on which goal states were found but no search reached one within its budget."""
NECESSITY_KINDS = (BY_GEOMETRY, BY_GOAL_SAMPLER, BY_SEARCH)
"""How a necessary verdict can be reached, strongest first."""


@dataclass(frozen=True)
class Necessary:
    """A validator's verdict that fixed objects are necessary: their measured margin and how it was reached
    (one of :data:`NECESSITY_KINDS`)."""

    margin: float
    how: str


@dataclass(frozen=True)
class SolveResult:
    solved: bool
    path: tuple[tuple[float, ...], ...] = ()
    checks: int = 0


class Validator(Protocol):
    """Answers ValidatePuzzle: can the target reach its goal?"""

    def solve(self, objects: Sequence[PuzzleObject], goal: Goal, *, budget_scale: float = 1.0) -> SolveResult: ...

    def necessity(self, objects: Sequence[PuzzleObject], goal: Goal, fixed: Sequence[str], margin: float, *,
                  budget_scale: float = 1.0) -> float | Necessary | None:
        """The objects ``fixed`` held at their creation pose: None when the puzzle is then solvable
        with every shape shrunk by ``margin`` (they are superfluous), else the largest shrink
        measured at which it is not (at least ``margin``), with how that was found when the
        validator can tell (:class:`Necessary`)."""
        ...


# -- the algorithm -----------------------------------------------------------
def _contradicted(validator: Validator, objects: Sequence[PuzzleObject], goal: Goal,
                  path: Sequence[Sequence[float]], verdict: Any, names: Sequence[str]) -> bool:
    """Whether a search's "necessary" verdict on ``names`` is refuted by the solution ``path``: cleaned
    by the validator's optional ``clean(objects, goal, path)`` (a shorter path that still passes its
    checks), it keeps them all at their creation pose, so the puzzle is solvable with them fixed, at the
    exact geometry and so at any shrink. A budgeted search can miss such a path (seen in Continuous
    Space: the defragmented certificate held the "necessary" bar still and the audit found it
    superfluous); a geometric proof cannot, so it is not re-checked."""
    clean = getattr(validator, "clean", None)
    if not isinstance(verdict, Necessary) or verdict.how == BY_GEOMETRY or clean is None:
        return False
    return _holds_still(objects, clean(objects, goal, path), names)


def _holds_still(objects: Sequence[PuzzleObject], path: Sequence[Sequence[float]], names: Sequence[str]) -> bool:
    """Whether ``path`` (chain joint order) keeps every object in ``names`` at joint values 0 throughout."""
    columns = [i for i, joint in enumerate(build_chain(objects).joint_order)
               if any(joint in o.joint_names for o in objects if o.name in names)]
    return bool(columns) and len(path) > 0 and not np.any(np.asarray(path, dtype=float)[:, columns])


@dataclass(frozen=True)
class Draft:
    """The puzzle built so far plus whatever a generator needs to extend it."""

    objects: tuple[PuzzleObject, ...] = ()
    context: Any = None


Attach = Callable[[Draft, Any, Any, Any, int, np.random.Generator], Draft | None]
"""NewKinematicChain: (draft, object item, joint item, transformation item, n, rng)
-> the extended draft, or None when this combination cannot be placed."""


@dataclass(frozen=True)
class MakerInput:
    """A generator, defined as its input tuple to the Maker (paper Table I)."""

    objects: ItemSource
    joints: ItemSource
    transforms: ItemSource
    n_objects: int
    attach: Attach
    goal: Callable[[Draft], Goal]
    initial: Draft = field(default_factory=Draft)
    max_tries: int = 50  # candidates per iteration
    max_restarts: int = 10  # whole-puzzle restarts when an iteration runs out of tries
    fixed_budget_scale: float = 1.0  # scales the FixJoint judge's own budget (see the validator)
    interlock_margin: float = 0.01  # metres every shape is shrunk by when FixJoint asks if an object is needed
    budget_scale: float = 1.0  # harder families may give the validator's solve a larger search budget
    # The validator re-plans each new level along the target's route (nested corridors, Move N Times);
    # it finds other certificates than a whole-space search, so only a generator that asks gets it.
    routed_validation: bool = False


@dataclass(frozen=True)
class MakerResult:
    objects: tuple[PuzzleObject, ...]
    goal: Goal
    certificate: tuple[tuple[float, ...], ...]
    context: Any = None
    margins: dict[str, float] = field(default_factory=dict)  # object -> measured margin (metres)
    necessity: dict[str, str] = field(default_factory=dict)  # object -> how its verdict was reached, when told


def rng_for(generator: str, seed: int, stream: str = "maker") -> np.random.Generator:
    """A numpy Generator seeded from a stable hash of (generator, seed, stream)."""
    return stable_rng(generator, seed, stream)


def make(spec: MakerInput, seed: int, validator: Validator, generator: str = "generator",
         progress: Callable[[int, int], None] | None = None) -> MakerResult:
    """Run Algorithm 1. Raises :class:`GenerationError` when tries run out."""
    rng = rng_for(generator, seed)
    last_failure = ""
    for _ in range(spec.max_restarts):
        try:
            return _make_once(spec, rng, validator, generator, seed, progress)
        except _IterationExhaustedError as exc:
            last_failure = str(exc)
    raise GenerationError(
        f"generator {generator!r}, seed {seed}: gave up after {spec.max_restarts} restarts; last: {last_failure}"
    )


class _IterationExhaustedError(Exception):
    pass


def _make_once(spec: MakerInput, rng: np.random.Generator, validator: Validator, generator: str,
               seed: int, progress: Callable[[int, int], None] | None) -> MakerResult:
    draft = spec.initial
    path: tuple[tuple[float, ...], ...] = ()
    margins: dict[str, float] = {}
    necessity: dict[str, str] = {}
    for n in range(1, spec.n_objects + 1):
        for _ in range(spec.max_tries):
            obj_item = spec.objects.get(n, rng)
            joint_item = spec.joints.get(n, rng)
            tf_item = spec.transforms.get(n, rng)
            candidate = spec.attach(draft, obj_item, joint_item, tf_item, n, rng)
            if candidate is None:
                continue
            new_objects = candidate.objects[len(draft.objects):]
            goal = spec.goal(candidate)
            movable = [o.name for o in new_objects if o.is_movable]
            verdict = None
            if movable:
                verdict = validator.necessity(candidate.objects, goal, movable, spec.interlock_margin,
                                              budget_scale=spec.fixed_budget_scale)
                if verdict is None:
                    continue  # superfluous: solvable without moving it
            result = validator.solve(candidate.objects, goal)
            if not result.solved or _contradicted(validator, candidate.objects, goal, result.path, verdict, movable):
                continue
            draft, path = candidate, result.path
            if isinstance(verdict, Necessary):
                margins.update({name: verdict.margin for name in movable})
                necessity.update({name: verdict.how for name in movable})
            else:
                margins.update({name: verdict for name in movable})
            break
        else:
            raise _IterationExhaustedError(f"iteration {n}: no valid candidate in {spec.max_tries} tries")
        if progress:
            progress(n, spec.n_objects)
    return MakerResult(draft.objects, spec.goal(draft), path, draft.context, margins, necessity)
