"""The solution the robot executes.

The preferred input is the lowest-cost LA-RRT solution stored beside the
puzzle (``solutions/la_rrt_best.json``: ``joint_order`` and ``path``); a
puzzle without one falls back to its certificate from ``puzzle.json``.
Either path is split into single-object actions by
:func:`phyrogen_core.actions.split_actions`, the rule the planners count actions by:
a segment that moves several objects becomes one move per object (in factor
order), and consecutive moves of the same object form one action.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from phyrogen_core.export.reader import MAX_MAGNITUDE
from phyrogen_core.folder import BEST_SOLUTION, PuzzleFormatError, read_folder_json


@dataclass(frozen=True)
class Solution:
    path: np.ndarray
    source: str
    """Where the path came from: the solution file's path, or ``certificate``."""


def load_solution(folder: Path, joint_order: Sequence[str], certificate: Sequence[Sequence[float]]) -> Solution:
    """The LA-RRT best solution of the puzzle in ``folder`` if there is one, else its certificate.

    The solution file is read by the puzzle folder's rule
    (:func:`phyrogen_core.folder.read_folder_json`: inside the folder, a
    regular file of bounded size, finite numbers); its path must hold at
    least 2 states of finite joint values within ``MAX_MAGNITUDE``. Raises
    :class:`~phyrogen_core.folder.PuzzleFormatError` naming the file and the field.
    """
    folder = Path(folder)
    file = folder / BEST_SOLUTION
    if not os.path.lexists(file):
        if len(certificate) < 2:
            raise ValueError(f"{folder}: no {BEST_SOLUTION} and the certificate has {len(certificate)} states; "
                             "a path needs at least 2")
        path = np.asarray(certificate, dtype=float)
        if not np.isfinite(path).all():
            raise PuzzleFormatError(f"{folder}: the certificate holds a value that is not a finite number")
        return Solution(path, "certificate")
    data = read_folder_json(file, folder, f"{file}: solution file")
    return Solution(_reorder(data, joint_order, file), str(file))


def _reorder(data: object, joint_order: Sequence[str], file: Path) -> np.ndarray:
    if not isinstance(data, Mapping) or "path" not in data or "joint_order" not in data:
        raise PuzzleFormatError(f"{file}: expected an object with 'joint_order' and 'path'")
    order = data["joint_order"]
    if (not isinstance(order, list) or not all(isinstance(name, str) for name in order)
            or sorted(order) != sorted(joint_order)):
        raise PuzzleFormatError(f"{file}: joint_order {_show(order)} does not match the puzzle's joints "
                                f"{list(joint_order)} (each once)")
    rows = data["path"]
    if not isinstance(rows, list) or len(rows) < 2:
        raise PuzzleFormatError(f"{file}: path must be a list of at least 2 states, got {_show(rows)}")
    for i, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != len(order):
            raise PuzzleFormatError(f"{file}: path[{i}] must be a list of {len(order)} numbers, got {_show(row)}")
        for j, value in enumerate(row):
            if (isinstance(value, bool) or not isinstance(value, int | float)
                    or not -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE):
                raise PuzzleFormatError(f"{file}: path[{i}][{j}] = {_show(value)} must be a finite number "
                                        f"within +-{MAX_MAGNITUDE:g}")
    path = np.asarray(rows, dtype=float)
    return path[:, [order.index(name) for name in joint_order]]


def _show(value: object, width: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."
