"""``import``: a planar puzzle from a URDF file, certified by LA-RRT, as a puzzle folder."""

from __future__ import annotations

from .base import Count, StageRequest
from .shared import SearchResult


class ImportRequest(StageRequest, stage="import"):
    urdf: str
    out: str = "output"
    """The puzzle goes to ``<out>/imported/<name>``."""
    name: str | None = None
    """The puzzle's name (None: the URDF's robot name)."""
    target: str | None = None
    """A URDF joint or link (None: the object that fits the link named 'goal')."""
    goal: tuple[float, ...] | None = None
    """The target's goal in URDF joint values (None: read from the link named 'goal'); needs ``target``."""
    budget: int | None = None
    """Collision queries LA-RRT may spend to certify the puzzle (None: the default)."""
    seed: int = 0


class ImportResult(SearchResult, stage="import"):
    folder: str | None
    """None when not solved (certified within the budget): then nothing was written."""
    movable: Count
    static: Count
    joints: Count
    goal_source: str
    target: str
    queries: Count
    states: Count
    """States of the certificate (0 when not solved)."""
    actions: Count
    notes: tuple[str, ...]
    """What the import assumed of the URDF."""

    def problem(self) -> str | None:
        return None if self.solved == (self.folder is not None) else "a puzzle has a folder exactly when it is solved"
