"""Refuted solution paths of a puzzle, the negative controls of the manipulation tests: the target
straight through its blockers, and the certificate with its first two actions swapped."""

from __future__ import annotations

import numpy as np

from phyrogen_core.actions import split_actions


def straight_through(loaded) -> np.ndarray:
    """The target straight from start to goal, through its blockers."""
    start = np.asarray(loaded.certificate[0], dtype=float)
    end = start.copy()
    for name, value in loaded.goal.values.items():
        end[loaded.joint_order.index(name)] = value
    return np.vstack([start, end])


def swapped(loaded) -> np.ndarray:
    """The certificate with its first two actions in each other's place (a valid path where the two
    are independent: check it)."""
    certificate = np.asarray(loaded.certificate, dtype=float)
    factors = {name: cols for name, cols in loaded.chain.factors.items() if name != "goal"}
    actions = split_actions(certificate, factors)
    assert len(actions) >= 2
    state, path = certificate[0].copy(), [certificate[0].copy()]
    for action in [actions[1], actions[0], *actions[2:]]:
        for row in action.states[1:]:
            state = state.copy()
            state[list(action.columns)] = row[list(action.columns)]
            path.append(state)
    return np.asarray(path)
