"""``replan``: a new certificate for a puzzle folder as it is now."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Count, StageRequest, StageResult


@dataclass(frozen=True)
class ReplanRequest(StageRequest):
    STAGE = "replan"

    folder: str
    budget: int | None = None
    """Collision queries each planner may spend (None: the default)."""
    seed: int = 0


@dataclass(frozen=True)
class ReplanResult(StageResult):
    """``planner``, ``queries``, ``states`` and ``dependencies`` are those of the new certificate, None when
    none was found (``solved`` false)."""

    STAGE = "replan"

    puzzle: str
    folder: str
    solved: bool
    budget: Count
    seed: int
    planner: str | None
    queries: Count | None
    states: Count | None
    dependencies: Count | None
    notices: tuple[str, ...]

    @property
    def exit_code(self) -> int:
        return 0 if self.solved else 1

    def problem(self) -> str | None:
        found = {"planner": self.planner, "queries": self.queries, "states": self.states,
                 "dependencies": self.dependencies}
        for key, value in found.items():
            if value is None and self.solved:
                return f"{key!r}: expected a value, got null (the re-plan is solved)"
            if value is not None and not self.solved:
                return f"{key!r}: expected null, got {value!r} (the re-plan is not solved)"
        return None
