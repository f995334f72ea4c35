"""The solution the robot executes.

The preferred input is the lowest-cost LA-RRT solution stored beside the
puzzle (``solutions/la_rrt_best.json``: ``joint_order`` and ``path``); a
puzzle without one falls back to its certificate from ``puzzle.json``.
Either path is split into single-object actions by
:func:`solver.actions.split_actions`, the rule the planners count actions by:
a segment that moves several objects becomes one move per object (in factor
order), and consecutive moves of the same object form one action.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from phyrogen_core.folder import BEST_SOLUTION


@dataclass(frozen=True)
class Solution:
    path: np.ndarray
    source: str
    """Where the path came from: the solution file's path, or ``certificate``."""


def load_solution(folder: Path, joint_order: Sequence[str], certificate: Sequence[Sequence[float]]) -> Solution:
    """The LA-RRT best solution of the puzzle in ``folder`` if there is one, else its certificate."""
    file = Path(folder) / BEST_SOLUTION
    if not file.exists():
        if len(certificate) < 2:
            raise ValueError(f"{folder}: no {BEST_SOLUTION} and the certificate has {len(certificate)} states; "
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
