"""The solution the robot executes, split into single-object actions.

The preferred input is the lowest-cost LA-RRT solution stored beside the
puzzle (``solutions/la_rrt_best.json``: ``joint_order`` and ``path``); a
puzzle without one falls back to its certificate from ``puzzle.json``.
Either path is split the way :func:`solver.actions.action_labels` counts
actions: a segment that moves several objects becomes one move per object
(in factor order), and consecutive moves of the same object form one action.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from solver.actions import MOVE_TOLERANCE

SOLUTION_FILE = Path("solutions") / "la_rrt_best.json"


@dataclass(frozen=True)
class Action:
    """One object moved along ``states`` (full joint-order states; only ``columns`` change)."""

    object_name: str
    columns: tuple[int, ...]
    states: np.ndarray

    @property
    def start(self) -> np.ndarray:
        return self.states[0]

    @property
    def end(self) -> np.ndarray:
        return self.states[-1]


@dataclass(frozen=True)
class Solution:
    path: np.ndarray
    source: str
    """Where the path came from: the solution file's path, or ``certificate``."""


def load_solution(folder: Path, joint_order: Sequence[str], certificate: Sequence[Sequence[float]]) -> Solution:
    """The LA-RRT best solution of the puzzle in ``folder`` if there is one, else its certificate."""
    file = Path(folder) / SOLUTION_FILE
    if not file.exists():
        if len(certificate) < 2:
            raise ValueError(f"{folder}: no {SOLUTION_FILE} and the certificate has {len(certificate)} states; "
                             "a path needs at least 2")
        return Solution(np.asarray(certificate, dtype=float), "certificate")
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{file}: cannot read the solution: {exc}") from None
    return Solution(_reorder(data, joint_order, file), str(file))


def _reorder(data: Mapping, joint_order: Sequence[str], file: Path) -> np.ndarray:
    if not isinstance(data, Mapping) or "path" not in data or "joint_order" not in data:
        raise ValueError(f"{file}: expected an object with 'joint_order' and 'path'")
    order = list(data["joint_order"])
    if sorted(order) != sorted(joint_order):
        raise ValueError(f"{file}: joint_order {order} does not match the puzzle's joints {list(joint_order)}")
    path = np.asarray(data["path"], dtype=float)
    if path.ndim != 2 or path.shape[1] != len(order) or len(path) < 2:
        raise ValueError(f"{file}: path must be a list of at least 2 states of {len(order)} values, "
                         f"got shape {path.shape}")
    return path[:, [order.index(name) for name in joint_order]]


def split_actions(path: np.ndarray, factors: Mapping[str, Sequence[int]],
                  tolerance: float = MOVE_TOLERANCE) -> list[Action]:
    """Single-object actions of ``path`` (the same split :func:`solver.actions.count_actions` counts)."""
    path = np.asarray(path, dtype=float)
    actions: list[tuple[str, list[np.ndarray]]] = []
    current = path[0].copy()
    for b in path[1:]:
        moved = np.abs(b - current) > tolerance
        for name, columns in factors.items():
            columns = list(columns)
            if not moved[columns].any():
                continue
            after = current.copy()
            after[columns] = b[columns]
            if actions and actions[-1][0] == name:
                actions[-1][1].append(after)
            else:
                actions.append((name, [current.copy(), after]))
            current = after
    return [Action(name, tuple(factors[name]), np.array(states)) for name, states in actions]
