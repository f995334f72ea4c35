"""The records of an execution: its settings, the reports of actions, attempts and puzzles, the
recording of the simulation, the scene a renderer rebuilds, and the errors that end an action."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from phyrogen_core.chain import KinematicChain

from .following import FollowSettings
from .ik import IkSettings
from .physics import PuzzleMaterial
from .placement import Placement
from .reaching import REACH_BUDGET
from .robot import RobotSpec
from .scene import Contact
from .source import ShortBenchmark


class ExecutionError(RuntimeError):
    """The robot could not execute an action (no grasp, no motion, too many regrasps)."""


class UnplannedContactError(ExecutionError):
    """Physics found a contact the plan did not allow: the run stops at the first one."""

    def __init__(self, contact: Contact):
        super().__init__("unplanned contact: " + contact.describe())
        self.contact = contact


@dataclass(frozen=True)
class ExecutionSettings:
    scale: float | None = None
    """Scene metres per puzzle metre; None: the generator's physical scale
    (:func:`~manipulation.placement.physical_scale`)."""
    robot: RobotSpec = RobotSpec()
    follow: FollowSettings = FollowSettings()
    ik: IkSettings = IkSettings()
    reach_budget: int = REACH_BUDGET
    """Validity checks BIT* may spend on one motion (a count, not seconds: the same answer on any machine)."""
    max_regrasps_per_action: int = 12
    record_every: int = 8
    """Record the scene for frames and video every this many physics steps."""
    material: PuzzleMaterial = PuzzleMaterial()
    """Density and joint friction of the puzzle's pieces (masses from their volume)."""
    short_benchmark: ShortBenchmark | None = ShortBenchmark()
    """On a puzzle with no best solution and no benchmark runs given, solve it first with these runs,
    in memory (:func:`manipulation.source.solved_runs`; nothing is written); None: execute the
    certificate then."""
    check_solutions: bool = True
    """Whether every solution is checked at 2 mm (as ``phyrogen check`` checks a certificate) before
    physics, a refuted one refused (False: each goes to the simulation as it is; the negative controls
    that must fail in physics, docs/manipulation/README.md#solution-source)."""
    puzzle_self_collision: bool = True
    """Whether the puzzle's objects and walls collide with each other (False: the scene as it was
    before they did, where an invalid path executed; kept as a negative control)."""


@dataclass(frozen=True)
class ActionReport:
    object_name: str
    regrasps: int
    stops: tuple[str, ...]
    final_error: float
    """Largest joint error (puzzle units) of the object at the end of the action."""


@dataclass(frozen=True)
class AttemptReport:
    """One solution executed from the puzzle's start, in fresh worlds."""

    solution: str
    """Which solution ran (:attr:`~manipulation.solution.Solution.label`)."""
    scale: float
    actions: int
    regrasps: int
    planning_seconds: float
    execution_seconds: float
    simulated_seconds: float
    success: bool
    target_at_goal: bool
    max_penetration: float
    message: str
    action_reports: tuple[ActionReport, ...] = ()
    contact: Contact | None = None
    """The unplanned contact that stopped the run, if one did."""


@dataclass(frozen=True)
class ManipulationReport:
    """The puzzle's outcome: the numbers of the solution that ran last (the one that succeeded, or
    the last one tried), with wall times summed over every attempt, and each attempt's report."""

    puzzle: str
    generator: str
    seed: int
    scale: float
    solution: str
    """Which solution the numbers are of: ``certificate`` or ``benchmark...: <planner> run <n>``."""
    solutions_tried: int
    actions: int
    regrasps: int
    planning_seconds: float
    execution_seconds: float
    simulated_seconds: float
    success: bool
    target_at_goal: bool
    max_penetration: float
    message: str
    attempts: tuple[AttemptReport, ...] = ()
    """Every solution tried, in order, each with its per-action reports."""
    contact: Contact | None = None
    """The unplanned contact that stopped the last attempt, if one did."""
    benchmark_seconds: float = 0.0
    """Wall time of the short benchmark run first for a solution (0: none ran)."""

    @classmethod
    def of_attempts(cls, puzzle: str, generator: str, seed: int,
                    attempts: Sequence[AttemptReport]) -> ManipulationReport:
        last = attempts[-1]
        message = last.message
        if not last.success and len(attempts) > 1:
            message = f"none of {len(attempts)} solutions executed; the last, {last.solution}: {message}"
        return cls(puzzle, generator, seed, last.scale, last.solution, len(attempts), last.actions, last.regrasps,
                   sum(a.planning_seconds for a in attempts), sum(a.execution_seconds for a in attempts),
                   last.simulated_seconds, last.success, last.target_at_goal, last.max_penetration, message,
                   tuple(attempts), last.contact)


@dataclass
class Recording:
    """Snapshots of the simulation: robot joints, puzzle joints (scene units), action index."""

    robot: list[np.ndarray] = field(default_factory=list)
    puzzle: list[np.ndarray] = field(default_factory=list)
    action: list[int] = field(default_factory=list)
    fingers: list[np.ndarray] = field(default_factory=list)
    """The gripper's two finger joints (0 open)."""
    holding: list[bool] = field(default_factory=list)
    """Whether the fingers held the handle (a grip, neither slipped nor lost)."""


@dataclass(frozen=True)
class SceneSetup:
    """What a renderer needs to rebuild the scene: the scaled chain and its placement."""

    chain: KinematicChain
    placement: Placement
    robot: RobotSpec
