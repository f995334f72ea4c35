"""The benchmark's best-solution file (``solutions/la_rrt_best.json``) as one typed record with one strict reader.

The benchmark writes it (``format: phyrogen-solution``, ``format_version`` 1): the lowest-cost
path of the LA-RRT planners on the puzzle, its joint order, and where it came from. Every consumer
(the robot's executor, the Blender add-on's animation) reads it through :func:`read_solution_file`,
so the file means the same everywhere: inside the puzzle folder, a regular file of bounded size,
finite numbers (:func:`~phyrogen_core.folder_reads.read_folder_json`); no key the format does not
have; ``joint_order`` distinct names; ``path`` 2 to
:data:`~phyrogen_core.sizes.MAX_CERTIFICATE_STATES` states of one number per joint, each within
+-:data:`~phyrogen_core.record.MAX_MAGNITUDE`; the optional fields of the types the benchmark
writes. Errors are :class:`~phyrogen_core.errors.PuzzleFormatError`, one line naming the file and
the field.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import PuzzleFormatError
from .folder_reads import read_folder_json
from .record import MAX_MAGNITUDE
from .sizes import CERTIFICATE_STATES

FORMAT = "phyrogen-solution"
FORMAT_VERSION = 1
KEYS = ("format", "format_version", "puzzle", "planner", "seed", "run", "time_limit", "found_after",
        "action_cost", "object_sequence", "joint_order", "path")
"""Every key of the file, in the order the benchmark writes them."""
LABEL_LENGTH = 80
"""The longest ``<planner> run <n>`` a report prints of a file."""


@dataclass(frozen=True)
class SolutionFile:
    """One best-solution file. Only ``joint_order`` and ``path`` are required; the rest say where
    the path came from (None where a file leaves them out)."""

    joint_order: tuple[str, ...]
    path: tuple[tuple[float, ...], ...]
    """States in the file's ``joint_order`` (puzzle units)."""
    puzzle: str | None = None
    planner: str | None = None
    """The planner's title, as the benchmark's reports print it."""
    seed: int | None = None
    run: int | None = None
    time_limit: float | None = None
    found_after: float | None = None
    """Seconds into the run when this path was found."""
    action_cost: int | None = None
    object_sequence: tuple[str, ...] | None = None
    """The object moved by each action."""

    @classmethod
    def from_data(cls, data: object, label: str) -> SolutionFile:
        """The record of the parsed JSON ``data``; :class:`PuzzleFormatError` ``"<label>: ..."`` when it
        breaks the format (see the module's rules)."""
        if not isinstance(data, Mapping) or "path" not in data or "joint_order" not in data:
            raise PuzzleFormatError(f"{label}: expected an object with 'joint_order' and 'path'")
        unknown = sorted(set(data) - set(KEYS))
        if unknown:
            raise PuzzleFormatError(f"{label}: unknown key {_show(unknown[0])}; valid: {list(KEYS)}")
        if data.get("format", FORMAT) != FORMAT:
            raise PuzzleFormatError(f"{label}: format {_show(data['format'])} is not {FORMAT!r}")
        version = data.get("format_version", FORMAT_VERSION)
        if not _is_int(version) or version != FORMAT_VERSION:
            raise PuzzleFormatError(f"{label}: format_version {_show(version)} is not supported; "
                                    f"valid: {FORMAT_VERSION}")
        order = data["joint_order"]
        if (not isinstance(order, list) or not all(isinstance(name, str) for name in order)
                or len(set(order)) != len(order)):
            raise PuzzleFormatError(f"{label}: joint_order {_show(order)} must be a list of distinct joint names")
        return cls(tuple(order), _path(data["path"], len(order), label),
                   puzzle=_optional(data, "puzzle", label, str, "a string"),
                   planner=_optional(data, "planner", label, _is_name, "a printable string"),
                   seed=_optional(data, "seed", label, _is_int, "an integer"),
                   run=_optional(data, "run", label, lambda v: _is_int(v) and v >= 0, "an integer >= 0"),
                   time_limit=_optional(data, "time_limit", label, _is_number, "a finite number or null"),
                   found_after=_optional(data, "found_after", label, _is_number, "a finite number or null"),
                   action_cost=_optional(data, "action_cost", label, lambda v: _is_int(v) and v >= 0,
                                         "an integer >= 0"),
                   object_sequence=_sequence(data, label))

    def to_json(self) -> dict:
        """The file's JSON object, every key in the order the benchmark writes them (a field a file
        left out is written as null)."""
        return {"format": FORMAT, "format_version": FORMAT_VERSION, "puzzle": self.puzzle, "planner": self.planner,
                "seed": self.seed, "run": self.run, "time_limit": self.time_limit, "found_after": self.found_after,
                "action_cost": self.action_cost,
                "object_sequence": None if self.object_sequence is None else list(self.object_sequence),
                "joint_order": list(self.joint_order), "path": [list(state) for state in self.path]}

    def path_in(self, joint_order: Sequence[str], label: str) -> np.ndarray:
        """The path as an array with columns in ``joint_order`` (the puzzle's); :class:`PuzzleFormatError`
        ``"<label>: ..."`` when the file's joints are not exactly those."""
        if sorted(self.joint_order) != sorted(joint_order):
            raise PuzzleFormatError(f"{label}: joint_order {_show(list(self.joint_order))} does not match the "
                                    f"puzzle's joints {list(joint_order)} (each once)")
        path = np.asarray(self.path, dtype=float)
        return path[:, [self.joint_order.index(name) for name in joint_order]]

    @property
    def run_name(self) -> str:
        """``<planner> run <n>`` (``LA-RRT`` when the file names no planner), at most :data:`LABEL_LENGTH`."""
        parts = [self.planner if self.planner is not None else "LA-RRT"]
        if self.run is not None:
            parts.append(f"run {self.run}")
        return " ".join(parts)[:LABEL_LENGTH]


def read_solution_file(file: str | Path, root: str | Path, label: str | None = None) -> SolutionFile:
    """The solution file ``file`` of the puzzle folder ``root``, read by the folder's rule and the
    format's (:meth:`SolutionFile.from_data`). Raises :class:`PuzzleFormatError` naming the file."""
    label = f"{file}: solution file" if label is None else label
    return SolutionFile.from_data(read_folder_json(file, root, label), str(file))


def _path(rows: object, joints: int, label: str) -> tuple[tuple[float, ...], ...]:
    if not isinstance(rows, list) or len(rows) < 2:
        raise PuzzleFormatError(f"{label}: path must be a list of at least 2 states, got {_show(rows)}")
    too_long = CERTIFICATE_STATES.problem(len(rows))  # the certificate's bound: the robot's work grows with it
    if too_long is not None:
        raise PuzzleFormatError(f"{label}: path {too_long}")
    for i, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != joints:
            raise PuzzleFormatError(f"{label}: path[{i}] must be a list of {joints} numbers, got {_show(row)}")
        for j, value in enumerate(row):
            if not _is_number(value) or not -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE:
                raise PuzzleFormatError(f"{label}: path[{i}][{j}] = {_show(value)} must be a finite number "
                                        f"within +-{MAX_MAGNITUDE:g}")
    return tuple(tuple(float(value) for value in row) for row in rows)


def _optional(data: Mapping, key: str, label: str, valid, what: str):
    value = data.get(key)
    if value is None:
        return None
    if not valid(value):
        raise PuzzleFormatError(f"{label}: {key} = {_show(value)} must be {what}")
    return float(value) if valid is _is_number else value


def _sequence(data: Mapping, label: str) -> tuple[str, ...] | None:
    value = data.get("object_sequence")
    if value is None:
        return None
    if not isinstance(value, list) or not all(isinstance(name, str) for name in value):
        raise PuzzleFormatError(f"{label}: object_sequence = {_show(value)} must be a list of object names")
    return tuple(value)


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: object) -> bool:
    if not isinstance(value, int | float) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer beyond any float
        return False


def _is_name(value: object) -> bool:
    return isinstance(value, str) and value.isprintable()


def _show(value: object, width: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."
