"""``certify``: one seeded planner run on a puzzle folder, its path checked at fine resolution, in memory."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Count, StageRequest, StageResult


@dataclass(frozen=True)
class CertifyRequest(StageRequest):
    STAGE = "certify"

    folder: str
    """The puzzle folder (read, never written)."""
    budget_checks: int
    """Collision checks the run may spend (a motion charged by its length): the same path on any machine."""
    planner: str = "la_rrt_push"
    """A planner's registry name (``phyrogen benchmark --planners``)."""
    run: int = 0
    """The run index: seeded as run ``run`` of ``phyrogen benchmark --budget-checks`` on the same puzzle."""
    seed: int = 0
    """The base seed (``benchmark --seed``)."""


@dataclass(frozen=True)
class CertifyResult(StageResult):
    """The path found (empty when the budget ran out first) and the problems a fine check finds in it."""

    STAGE = "certify"

    puzzle: str
    planner: str
    title: str
    """The planner's title, as reports print it."""
    run: Count
    budget_checks: Count
    solved: bool
    checks: Count
    end: str
    """Why the run ended: ``solved``, ``budget``, or ``clock`` only when the backstop did."""
    joint_order: tuple[str, ...]
    path: tuple[tuple[float, ...], ...]
    """States in ``joint_order`` from the start to a goal state; empty when not solved."""
    action_cost: Count | None
    problems: tuple[str, ...]
    """What the fine check (``phyrogen check``'s) finds wrong with the path; empty when it certifies the puzzle."""

    @property
    def certified(self) -> bool:
        return self.solved and not self.problems

    @property
    def exit_code(self) -> int:
        return 0 if self.certified else 1

    def problem(self) -> str | None:
        if self.solved != bool(self.path) or any(len(state) != len(self.joint_order) for state in self.path):
            return "a solved run has a path of one value per joint, an unsolved one none"
        return None
