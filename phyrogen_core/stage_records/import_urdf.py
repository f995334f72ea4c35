"""``import``: a planar puzzle from a URDF file, certified by LA-RRT, as a puzzle folder."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Count, StageRequest, StageResult


@dataclass(frozen=True)
class ImportRequest(StageRequest):
    STAGE = "import"

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


@dataclass(frozen=True)
class ImportResult(StageResult):
    STAGE = "import"

    puzzle: str
    solved: bool
    """Certified within the budget; else nothing was written."""
    folder: str | None
    budget: Count
    seed: int
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
    notices: tuple[str, ...]
    """What writing the folder did beside (old outputs moved away)."""

    @property
    def exit_code(self) -> int:
        return 0 if self.solved else 1

    def problem(self) -> str | None:
        return None if self.solved == (self.folder is not None) else "a puzzle has a folder exactly when it is solved"
