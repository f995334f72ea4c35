"""A dataset manifest's row as one typed record (:class:`ManifestRow`), checked wherever one is made.

The builder makes each row as this record (:mod:`solver.pipelines.dataset.manifest`), and every
reader of a manifest reads its rows back through :func:`manifest_rows`, which refuses, with one
line naming the file and the row, what no ``phyrogen dataset`` writes: a column missing or
unknown, a value of another type, a non-finite number, a path that leaves the dataset, a status
other than ``ok`` or ``failed``, an ok row without its puzzle's columns or a failed one with them.
The fields are the manifest's columns (:data:`~solver.pipelines.dataset.manifest.COLUMNS`), in order.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import Literal

from phyrogen_core.stage_records.base import Count, Record

_HASH = re.compile(r"[0-9a-f]{64}")
_PUZZLE_COLUMNS = ("path", "content_hash", "canonical_hash", "movable_objects", "actions", "depth", "branching",
                   "shape")
"""The columns an ok row has and a failed row lacks (besides ``error``, the other way round)."""
_DIFFICULTY_COLUMNS = ("difficulty_runs", "difficulty_budget_checks", "difficulty_success_rate",
                       "difficulty_success_low", "difficulty_success_high")
"""Measured together or not at all (the median checks is null also when no run solved)."""


@dataclass(frozen=True)
class ManifestRow(Record):
    """One dataset entry, ok or failed; see :data:`~solver.pipelines.dataset.manifest.COLUMNS` for each column."""

    index: Count
    generator: str
    name: str
    seed: int
    parameters: str
    shard: Count
    path: str | None
    status: Literal["ok", "failed"]
    error: str | None
    content_hash: str | None
    canonical_hash: str | None
    movable_objects: Count | None
    actions: Count | None
    depth: Count | None
    branching: Count | None
    shape: Literal["none", "chain", "tree"] | None
    interlock_margin: float | None
    necessity: str | None
    validation_checks: Count | None
    generation_seconds: float | None
    difficulty_runs: Count | None
    difficulty_budget_checks: Count | None
    difficulty_success_rate: float | None
    difficulty_success_low: float | None
    difficulty_success_high: float | None
    difficulty_median_checks: float | None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def problem(self) -> str | None:
        from phyrogen_core.maker import NECESSITY_KINDS

        if self.name != f"{self.generator}_{self.seed}":
            return f"'name' is {self.name!r}, not <generator>_<seed> ({self.generator}_{self.seed})"
        try:
            parameters = json.loads(self.parameters)
        except ValueError:
            parameters = None
        if not isinstance(parameters, dict):
            return f"'parameters' is not a JSON object: {self.parameters[:60]!r}"
        given = [name for name in _PUZZLE_COLUMNS if getattr(self, name) is not None]
        if self.ok and (len(given) < len(_PUZZLE_COLUMNS) or self.error is not None):
            wrong = next((n for n in _PUZZLE_COLUMNS if n not in given), "error")
            return f"an ok row with {'an error' if wrong == 'error' else f'no {wrong!r}'}"
        if not self.ok and (given or self.error is None):
            return f"a failed row with {repr(given[0]) if given else 'no error'}"
        if self.path is not None and not _inside(self.path):
            return f"'path' {self.path!r} is not a folder inside the dataset"
        for name in ("content_hash", "canonical_hash"):
            value = getattr(self, name)
            if value is not None and not _HASH.fullmatch(value):
                return f"{name!r} is not a sha256 in hex: {value[:70]!r}"
        if self.necessity is not None and self.necessity not in NECESSITY_KINDS:
            return f"'necessity' is {self.necessity!r}, not one of {', '.join(map(repr, NECESSITY_KINDS))}"
        if self.generation_seconds is not None and self.generation_seconds < 0:
            return f"'generation_seconds' is negative: {self.generation_seconds}"
        measured = [getattr(self, name) is not None for name in _DIFFICULTY_COLUMNS]
        if any(measured) and not all(measured):
            return f"a difficulty measured in part: {_DIFFICULTY_COLUMNS[measured.index(False)]!r} is null"
        if all(measured) and not (0.0 <= self.difficulty_success_low <= self.difficulty_success_rate
                                  <= self.difficulty_success_high <= 1.0):
            return (f"difficulty success rate {self.difficulty_success_rate} and its interval "
                    f"[{self.difficulty_success_low}, {self.difficulty_success_high}] are not rates in order")
        return None


def _inside(path: str) -> bool:
    """Whether ``path`` names a place inside the dataset: relative, POSIX, without ``..``, ``.`` or empty parts."""
    parts = path.split("/")
    return (bool(path) and "\\" not in path and "\0" not in path and not PurePosixPath(path).is_absolute()
            and all(part not in ("", ".", "..") for part in parts))
