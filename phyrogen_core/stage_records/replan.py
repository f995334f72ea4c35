"""``replan``: a new certificate for a puzzle folder as it is now."""

from __future__ import annotations

from .base import Count
from .shared import FolderRequest, SearchResult


class ReplanRequest(FolderRequest, stage="replan"):
    budget: int | None = None
    """Collision queries each planner may spend (None: the default)."""
    seed: int = 0


class ReplanResult(SearchResult, stage="replan"):
    """``planner``, ``queries``, ``states`` and ``dependencies`` are those of the new certificate, None when
    none was found (``solved`` false)."""

    folder: str
    planner: str | None
    queries: Count | None
    states: Count | None
    dependencies: Count | None

    def problem(self) -> str | None:
        found = {"planner": self.planner, "queries": self.queries, "states": self.states,
                 "dependencies": self.dependencies}
        for key, value in found.items():
            if value is None and self.solved:
                return f"{key!r}: expected a value, got null (the re-plan is solved)"
            if value is not None and not self.solved:
                return f"{key!r}: expected null, got {value!r} (the re-plan is not solved)"
        return None
