"""The paper's action cost: how many times the solver switches which object it moves."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

MOVE_TOLERANCE = 1e-6
"""A joint whose value changes by less than this along a segment does not move."""


def action_labels(path: Sequence[Sequence[float]], factors: Mapping[str, Sequence[int]],
                  tolerance: float = MOVE_TOLERANCE) -> list[str]:
    """The object moved by each single-object move of ``path``.

    A segment that moves several objects at once is split into one move per
    object (in factor order); segments that move nothing are dropped.
    """
    states = np.asarray(path, dtype=float)
    labels: list[str] = []
    for a, b in zip(states[:-1], states[1:], strict=True):
        moved = np.abs(b - a) > tolerance
        labels += [name for name, columns in factors.items() if moved[list(columns)].any()]
    return labels


def count_actions(path: Sequence[Sequence[float]], factors: Mapping[str, Sequence[int]],
                  tolerance: float = MOVE_TOLERANCE) -> int:
    """Number of actions: maximal runs of consecutive moves of the same object."""
    labels = action_labels(path, factors, tolerance)
    return sum(1 for i, label in enumerate(labels) if i == 0 or labels[i - 1] != label)
