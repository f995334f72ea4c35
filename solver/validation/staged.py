"""The staged judge: a cheap deterministic try at a rung both searching judges failed.

A budgeted search can miss a path that a person would try first: move the blockers out of the way one at a
time, each as far as it goes, then the target straight to its goal. In Continuous Space seed 4410009 (obj_03
fixed, shrink 0.01) LA-RRT missed obj_02 to -0.0205, obj_01 to 0.7995, the target to its goal, and the puzzle
recorded obj_03 as necessary at a rung where it was not: such a path threads a sliver that random states
seldom land in, but a move that stops where it first collides lands there by construction.

:func:`staged_path` tries, breadth first (fewest motions first), sequences of at most :data:`STAGED_MOVES`
moves of distinct free joints other than the target's, each towards its lower or its upper limit, stopping at
the last free sample before its first colliding one (or at the limit); after each prefix the target's joints
go straight to their goal values. It draws no random numbers, so a judge that runs it after the searches
failed leaves every other run's draws as they were. Each path it returns holds at
:data:`~solver.planning.problem.FINE_RESOLUTION` (checked whole before it is returned) and at the first
judge's resolution, as a carried path must (:func:`solver.validation.judge.attempt_carried`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from phyrogen_core.chain import KinematicChain
from phyrogen_core.puzzle import Goal
from solver.planning.problem import (
    FINE_RESOLUTION,
    Path,
    Problem,
    UnreachableGoalError,
    chain_path,
    in_goal,
    problem_for_chain,
)

STAGED = "staged"
"""The name of the staged judge in a verdict's attempts."""
STAGED_MOVES = 3
"""Moves of other joints before the target's at most: 4410009 needs 2; the survey's misses 1-3."""
STAGED_NODES = 256
"""Prefixes (sequences of moves) tried at most, breadth first: with many free joints (Lockbox, Rooms) the
number of sequences grows as (2 n)^moves, and the try must stay cheap next to the searches it follows."""
STOP_RESOLUTION = FINE_RESOLUTION / 4
"""The samples of a move, in metres of motion: a move ends at its last free sample, so a finer spacing ends it
closer to contact, where the sliver is (the whole path is then checked at both judges' resolutions)."""


def staged_path(problem: Problem, resolutions: Sequence[float] = (FINE_RESOLUTION,)) -> tuple[np.ndarray | None, int]:
    """A staged path of ``problem`` (its joint order, from its start to a goal state), valid at every resolution of
    ``resolutions``, or None; and the collision queries spent (a batch of moves, a path checked: one each)."""
    model = problem.model
    start = np.ascontiguousarray(problem.start, dtype=np.float64)
    goal_columns = list(problem.goal_columns)
    others = [j for j in range(len(start)) if j not in problem.goal_columns]
    stop_steps = model.motion_steps(STOP_RESOLUTION)
    checks = [model.motion_steps(r) for r in resolutions]
    goal_values = np.array([problem.goal_columns[j] for j in goal_columns], dtype=np.float64)
    queries = 0
    # A prefix: the states so far (from the start) and the joints moved.
    layer: list[tuple[np.ndarray, frozenset[int]]] = [(start[None, :], frozenset())]
    tried = 0
    for depth in range(STAGED_MOVES + 1):
        grown: list[tuple[np.ndarray, frozenset[int]]] = []
        for states, moved in layer:
            if tried >= STAGED_NODES:
                return None, queries
            tried += 1
            last = states[-1]
            final = last.copy()
            final[goal_columns] = goal_values
            path = np.ascontiguousarray(np.vstack([states, final[None, :]]))
            if in_goal(problem, final) and np.all((final >= problem.lower) & (final <= problem.upper)):
                queries += 1
                if all(model.path_free(path, steps) for steps in checks):
                    return path, queries
            if depth == STAGED_MOVES:
                continue
            moves = [(j, bound[j]) for j in others if j not in moved for bound in (problem.lower, problem.upper)
                     if bound[j] != last[j]]
            if not moves:
                continue
            ends = np.repeat(last[None, :], len(moves), axis=0)
            for row, (j, value) in enumerate(moves):
                ends[row, j] = value
            stops, _ = model.motion_ends(np.ascontiguousarray(np.repeat(last[None, :], len(moves), axis=0)),
                                         np.ascontiguousarray(ends), stop_steps, True)
            queries += 1
            for row, (j, _value) in enumerate(moves):
                if stops[row, j] != last[j]:  # a move that goes nowhere adds nothing
                    grown.append((np.vstack([states, stops[row][None, :]]), moved | {j}))
        layer = grown
    return None, queries


def staged_solution(chain: KinematicChain, goal: Goal, fixed: Sequence[str], shrink: float,
                    resolutions: Sequence[float] = (FINE_RESOLUTION,)) -> tuple[Path, int]:
    """:func:`staged_path` for ``chain`` with ``fixed`` held at their start pose and every shape shrunk by
    ``shrink``, in ``chain``'s joint order (fixed joints at their start value; () where none is found), and the
    queries spent. :func:`solver.validation.judge.attempt_staged` makes it a judge's attempt."""
    try:
        problem = problem_for_chain(chain, goal, fixed=tuple(fixed), shrink=shrink)
    except UnreachableGoalError:  # the target itself is fixed
        return (), 0
    path, queries = staged_path(problem, resolutions)
    return (() if path is None else chain_path(problem, path)), queries
