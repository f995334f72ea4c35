"""A puzzle: a chain, its start state, the goal of its target, and provenance."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .chain import GOAL_GREEN, Geometry, Joint, JointType, KinematicChain, Link, Role, joint_motion, pose_matrix
from .difficulty import Difficulty
from .objects import Motion, PuzzleObject, build_chain
from .provenance import Provenance

GOAL_TOLERANCE = 1e-3
"""Half-width of a goal interval on each target joint (metres or radians)."""


@dataclass(frozen=True)
class Goal:
    """Target joint values that solve the puzzle; every other joint is free.

    ``values`` maps each constrained joint name to its goal value; a state
    is in the goal region when every such joint is within ``tolerance``.
    """

    target: str
    values: Mapping[str, float]
    tolerance: float = GOAL_TOLERANCE

    def region(self) -> dict[str, tuple[float, float]]:
        return {j: (v - self.tolerance, v + self.tolerance) for j, v in self.values.items()}

    def is_reached(self, state_by_name: Mapping[str, float]) -> bool:
        return all(abs(state_by_name[j] - v) <= self.tolerance + 1e-12 for j, v in self.values.items())


def paper_goal(target: PuzzleObject, rng: np.random.Generator | None = None) -> Goal:
    """The paper's goal rule for a one-joint target.

    Prismatic: the opposite end of its limits. Revolute: a 90 degree turn, in
    the direction its limits allow (the rng picks when both do).
    SE(2) targets have generator-specific goals (see the generators).
    """
    name = target.joint_names[0]
    lower, upper = target.limits[0]
    if target.motion is Motion.PRISMATIC:
        value = upper if abs(upper) >= abs(lower) else lower
        return Goal(target.name, {name: value})
    if target.motion is Motion.REVOLUTE:
        quarter = math.pi / 2
        options = [v for v in (quarter, -quarter) if lower - 1e-9 <= v <= upper + 1e-9]
        if not options:
            raise ValueError(f"revolute target {target.name!r} limits ({lower}, {upper}) exclude a 90 degree turn")
        value = options[0] if len(options) == 1 or rng is None else options[int(rng.integers(len(options)))]
        return Goal(target.name, {name: value})
    raise ValueError(f"paper_goal needs a prismatic or revolute target, got {target.motion.value}")


@dataclass(frozen=True)
class Puzzle:
    """A generated puzzle. ``chain`` is the single source of truth for geometry.

    ``objects`` are the generator's objects the chain was built from (kept so
    that collision models and exports can name objects). ``dependencies``
    lists (blocker, blocked) object-name pairs found while building.
    ``certificate`` is a joint-space path (joint order) from start to goal.
    ``margins`` maps each movable object but the target to its measured
    interlock margin (metres; see :mod:`phyrogen_core.maker`), ``necessity`` how each of those
    was shown needed (:data:`phyrogen_core.maker.NECESSITY_KINDS`; empty when unknown). ``provenance``
    says where an imported puzzle came from and who certified it (empty for a
    generated one: generator, parameters and seed say it all). ``difficulty`` is measured only on
    request (``phyrogen generate --difficulty``; :mod:`solver.benchmark.difficulty`).
    """

    objects: tuple[PuzzleObject, ...]
    goal: Goal
    generator: str
    seed: int
    parameters: Mapping[str, Any] = field(default_factory=dict)
    dependencies: tuple[tuple[str, str], ...] = ()
    certificate: tuple[tuple[float, ...], ...] = ()
    margins: Mapping[str, float] = field(default_factory=dict)
    provenance: Provenance = field(default_factory=Provenance)
    necessity: Mapping[str, str] = field(default_factory=dict)
    difficulty: Difficulty | None = None

    @property
    def name(self) -> str:
        return f"{self.generator}_{self.seed}"

    @property
    def chain(self) -> KinematicChain:
        """The chain including the goal marker (visual only, fixed)."""
        return build_chain(self.objects, self.name, *self._goal_marker())

    @property
    def planning_chain(self) -> KinematicChain:
        return build_chain(self.objects, self.name)

    @property
    def joint_order(self) -> tuple[str, ...]:
        return self.planning_chain.joint_order

    @property
    def start(self) -> tuple[float, ...]:
        return tuple(0.0 for _ in self.joint_order)

    @property
    def target(self) -> PuzzleObject:
        return next(o for o in self.objects if o.name == self.goal.target)

    def with_certificate(self, path) -> Puzzle:
        return replace(self, certificate=tuple(tuple(float(v) for v in s) for s in path))

    def _goal_marker(self) -> tuple[list[Link], list[Joint]]:
        """A translucent copy of the target at its goal pose, named ``goal``."""
        chain = build_chain(self.objects)
        values = {j: 0.0 for j in chain.joint_order}
        values.update(self.goal.values)
        pose = _link_transform(chain, values, self.goal.target)
        target = self.target
        visuals = tuple(Geometry(g.shape, g.origin, GOAL_GREEN, g.name) for g in target.visuals)
        marker = Link("goal", visuals, (), Role.GOAL_MARKER, "goal", mass=0.01)
        from .chain import rotation_to_rpy  # local import keeps the public surface small

        origin = rotation_to_rpy(pose)
        return [marker], [Joint("goal", JointType.FIXED, chain.root, "goal", origin)]


def _link_transform(chain: KinematicChain, values: Mapping[str, float], link: str) -> np.ndarray:
    """``chain.link_transforms(values)[link]``: the same products, along the link's ancestors alone."""
    joints = []
    while link != chain.root:
        joint = chain.parent_joint(link)
        assert joint is not None
        joints.append(joint)
        link = joint.parent
    world = np.eye(4)
    for joint in reversed(joints):
        t = world @ pose_matrix(joint.origin)
        q = float(values.get(joint.name, 0.0)) if joint.is_active else 0.0
        world = t @ joint_motion(joint, q)
    return world
