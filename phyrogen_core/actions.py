"""A path split into single-object actions, and the paper's action cost.

``factors`` map each object to the state columns of its joints. A *move* is
one object's part of one path segment: a segment that moves several objects
at once is one move per object (in factor order), and a segment that moves
nothing is none. An *action* is a maximal run of consecutive moves of the
same object. Planners score paths with :func:`count_actions`, the benchmark
lists a path's actions with :func:`action_sequence`, and the robot executes
:func:`split_actions`: all three split a path by the same rule.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

MOVE_TOLERANCE = 1e-6
"""A joint whose value changes by less than this along a segment does not move."""

Factors = Mapping[str, Sequence[int]]


def factor_membership(factors: Factors, dimension: int) -> np.ndarray:
    """(dimension, factors) matrix: 1 where a state column belongs to a factor, else 0."""
    membership = np.zeros((dimension, len(factors)))
    for f, columns in enumerate(factors.values()):
        membership[list(columns), f] = 1.0
    return membership


def moved_factors(states: np.ndarray, membership: np.ndarray, tolerance: float = MOVE_TOLERANCE) -> np.ndarray:
    """(segments, factors) booleans: which factors each segment of ``states`` moves by more than ``tolerance``."""
    return ((np.abs(np.diff(states, axis=0)) > tolerance) @ membership) > 0


def _moves(states: np.ndarray, factors: Factors, tolerance: float) -> list[list[int]]:
    """Per segment of ``states``, the indices of the factors it moves, in factor order."""
    if len(states) < 2:
        return []
    moved = moved_factors(states, factor_membership(factors, states.shape[1]), tolerance)
    return [np.flatnonzero(row).tolist() for row in moved]


def action_labels(path: Sequence[Sequence[float]], factors: Factors, tolerance: float = MOVE_TOLERANCE) -> list[str]:
    """The object of each move of ``path``."""
    names = list(factors)
    return [names[f] for segment in _moves(np.asarray(path, dtype=float), factors, tolerance) for f in segment]


def action_sequence(path: Sequence[Sequence[float]], factors: Factors,
                    tolerance: float = MOVE_TOLERANCE) -> list[str]:
    """The object moved by each action of ``path``, in order."""
    labels = action_labels(path, factors, tolerance)
    return [label for i, label in enumerate(labels) if i == 0 or labels[i - 1] != label]


def count_actions(path: Sequence[Sequence[float]], factors: Factors, tolerance: float = MOVE_TOLERANCE) -> int:
    """Number of actions: maximal runs of consecutive moves of the same object."""
    return len(action_sequence(path, factors, tolerance))


@dataclass(frozen=True)
class Action:
    """One object moved along ``states`` (full states; only ``columns`` change between rows)."""

    object_name: str
    columns: tuple[int, ...]
    states: np.ndarray

    @property
    def start(self) -> np.ndarray:
        return self.states[0]

    @property
    def end(self) -> np.ndarray:
        return self.states[-1]


def split_actions(path: Sequence[Sequence[float]], factors: Factors,
                  tolerance: float = MOVE_TOLERANCE) -> list[Action]:
    """The actions of ``path``, one object each, as :func:`count_actions` counts them.

    A segment that moves several objects becomes a staircase: one move per
    object, in factor order, each setting that object's joints to their
    values at the segment's end. Consecutive actions join end to start.
    """
    states = np.asarray(path, dtype=float)
    names = list(factors)
    columns = [list(c) for c in factors.values()]
    runs: list[tuple[int, list[np.ndarray]]] = []
    if len(states) == 0:
        return []
    current = states[0].copy()
    for end, segment in zip(states[1:], _moves(states, factors, tolerance), strict=True):
        for f in segment:
            after = current.copy()
            after[columns[f]] = end[columns[f]]
            if runs and runs[-1][0] == f:
                runs[-1][1].append(after)
            else:
                runs.append((f, [current, after]))
            current = after
    return [Action(names[f], tuple(factors[names[f]]), np.array(rows)) for f, rows in runs]
