"""``certify``: one seeded planner run on a puzzle folder, its path checked at fine resolution, in memory."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Count, Record, StageResult
from .shared import FolderRequest


class CertifyRequest(FolderRequest, stage="certify"):
    """``folder``: the puzzle folder (read, never written)."""

    budget_checks: int
    """Collision checks the run may spend (a motion charged by its length): the same path on any machine."""
    planner: str = "la_rrt_push"
    """A planner's registry name (``phyrogen benchmark --planners``)."""
    run: int = 0
    """The run index: seeded as run ``run`` of ``phyrogen benchmark --budget-checks`` on the same puzzle."""
    seed: int = 0
    """The base seed (``benchmark --seed``)."""


@dataclass(frozen=True)
class PlannerRun(Record):
    """One seeded planner run on a puzzle (the solve stage's, :func:`solver.planning.solve.solve`): what
    identifies it and the path it found."""

    puzzle: str
    planner: str
    """The planner's registry name."""
    title: str
    """The planner's title, as reports print it."""
    run: Count
    budget_checks: Count
    solved: bool
    checks: Count
    end: str
    """Why the run ended (:data:`~solver.planning.anytime.END_REASONS`): ``solved``, ``budget``, or ``clock``
    only when the backstop did."""
    joint_order: tuple[str, ...]
    path: tuple[tuple[float, ...], ...]
    """States in ``joint_order`` from the start to a goal state; empty when not solved."""
    action_cost: Count | None

    def problem(self) -> str | None:
        if self.solved != bool(self.path) or any(len(state) != len(self.joint_order) for state in self.path):
            return "a solved run has a path of one value per joint, an unsolved one none"
        return None


class CertifyResult(PlannerRun, StageResult, stage="certify"):
    """The path found (empty when the budget ran out first) and the problems a fine check finds in it."""

    problems: tuple[str, ...]
    """What the fine check (``phyrogen check``'s) finds wrong with the path; empty when it certifies the puzzle."""

    @property
    def certified(self) -> bool:
        return self.solved and not self.problems

    def done(self) -> bool:
        return self.certified
