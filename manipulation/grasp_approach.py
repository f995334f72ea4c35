"""Reaching a grasp: the robot lifts off the last handle, plans (BIT*, or tuck, drive and untuck)
to a well-conditioned grasp of the object as it stands, drives there and comes straight down.

The look-ahead keeps a new grasp well-conditioned for the object's next positions; a grasp whose
base cannot be reached gives way to the next best, its base avoided.
"""

from __future__ import annotations

import time

import numpy as np

from .execution_records import ExecutionError
from .floor import FloorMap, floor_map
from .following import drive_along
from .grasp import GraspPoint
from .ik import GRASP_CLEARANCE, best_grasp_configuration, solve_at
from .reaching import ReachingError, continuous_motion, plan_motion
from .robot import ARM_TUCKED
from .run_state import RunState
from .scene import COLLISION_MARGIN
from .transforms import inverse, matrix

LOOKAHEAD_SECONDS = (0.4, 0.8, 1.6)
"""How far ahead along the object's path a new grasp must stay well-conditioned."""
LIFT_HEIGHTS = (0.03, 0.06, 0.1)
"""Metres the tool may rise straight up after a release, to clear the planning margin."""
REACH_TRIES = 3
"""Grasp configurations tried, best first, before the robot gives up reaching an object."""
DIRECT_REACH = 1.0
"""Metres: a base move up to this long is first tried as one BIT* search over all joints."""
APPROACH_HEIGHT = 0.05
"""Metres the tool rises straight up off a handle after a release, and comes straight down onto
the next (the fingertips start 3 cm above the knob)."""
APPROACH_LEAST = 0.025
"""Metres the tool must rise straight up at least (the fingertips 5 mm above the knob's top)."""
APPROACH_STEP = 0.001
"""Radians (or metres) per physics step, at most, of each joint while the tool rises or descends."""


class GraspApproach(RunState):
    """A run that can reach a grasp (:meth:`grasp_here`) on top of :class:`~manipulation.run_state.RunState`."""

    def grasp_here(self, grasp: GraspPoint, trajectory, t: float, failed_base: np.ndarray | None) -> None:
        """Plan to and drive to a grasp of the object as it stands now, the fingers open around the
        handle."""
        started = time.perf_counter()
        now = self.sim.puzzle_state()
        self.planner.set_puzzle(now)
        link_now = self.link_world(grasp.link, now)
        point = (link_now @ np.array([*grasp.point, 1.0]))[:3]
        futures = [trajectory.state_at(t + dt) for dt in LOOKAHEAD_SECONDS]

        def lookahead(pose: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
            offset = inverse(link_now) @ pose
            return [(self.link_world(grasp.link, s) @ offset, s) for s in futures]

        link_yaw = float(np.arctan2(link_now[1, 0], link_now[0, 0]))

        def align(yaw: float) -> float:
            return grasp.tool_yaw(link_yaw, yaw)

        here = self.sim.robot_state()[:2]
        floor = floor_map(self.planner, self.placement.half_extent, here, self.settings.robot)

        def base_ok(xy: np.ndarray) -> bool:
            return floor.nearest_reachable(xy) is not None

        start = self.sim.robot_state()
        try:
            lift = self.lift_off(start)
        except ReachingError as exc:
            raise ExecutionError(f"reaching the grasp on {grasp.link}: {exc}") from None
        # A grasp whose base the robot cannot get to gives way to the next best, its base avoided.
        unreachable: list[np.ndarray] = []
        error: ReachingError | None = None
        for _ in range(REACH_TRIES):
            # Shorter look-aheads, then a smaller clearance, only when nothing better exists.
            failed = unreachable + ([] if failed_base is None else [failed_base])
            tiers = ((len(futures), failed, GRASP_CLEARANCE), (1, failed, GRASP_CLEARANCE),
                     (0, unreachable, GRASP_CLEARANCE), (0, unreachable, COLLISION_MARGIN))
            for count, avoid, clearance in tiers:
                solution = best_grasp_configuration(self.planner, point, lambda pose, n=count: lookahead(pose)[:n],
                                                    self.settings.ik, avoid, here, clearance, base_ok, align)
                if solution is not None and solution.score > 0:
                    break
            if solution is None and unreachable:
                raise ExecutionError(f"reaching the grasp on {grasp.link}: {error}; no other grasp there")
            if solution is None:
                raise ExecutionError(f"no collision-free IK solution at the grasp point of {grasp.link} "
                                     f"({np.round(point, 3).tolist()})")
            try:
                try:
                    descent = self.vertical(solution.q)[::-1]
                except ReachingError:
                    # No room to come straight down (an arm link meets the puzzle above the knob):
                    # the planned motion ends at the grasp itself, as it did before the approach.
                    descent = solution.q[None, :]
                path = self.reach(lift[-1], descent[0], floor)
                break
            except ReachingError as exc:
                error = exc
                unreachable.append(solution.q[:2])
        else:
            raise ExecutionError(f"reaching the grasp on {grasp.link} ({REACH_TRIES} grasps tried): {error}")
        self.planning += time.perf_counter() - started
        started = time.perf_counter()
        self.phase = "driving"
        # Straight up off the last handle, over to above this one, straight down around it: the
        # open fingers never sweep sideways past a knob (a planned motion passing beside it, tracked
        # by torque-limited motors, brushed it with a finger).
        drive_along(self.sim, lift, self.on_step, max_step=APPROACH_STEP)
        drive_along(self.sim, path, self.on_step)
        drive_along(self.sim, descent, self.on_step, max_step=APPROACH_STEP)
        self.phase = "holding"
        self.execution += time.perf_counter() - started

    def vertical(self, q: np.ndarray) -> np.ndarray:
        """A joint path from ``q`` raising the tool straight up by :data:`APPROACH_HEIGHT` (the base
        still), every state clear of the puzzle by the planning margin, in the planning world;
        ReachingError if IK or the margin fails on the way."""
        self.planner.set_robot(q)
        pose = matrix(*self.planner.tool_pose())
        states = [np.asarray(q, dtype=float)]
        count = int(np.ceil(APPROACH_HEIGHT / 0.005))
        for k in range(1, count + 1):
            above = pose.copy()
            above[2, 3] += APPROACH_HEIGHT * k / count
            # Damped Newton steps from the state below, not PyBullet's IK: its answer may lie on
            # another branch (a joint 1 rad away), and the joint-space motion between two such
            # states, which the robot drives, swept a finger 11 mm through the knob (Lockbox Random 1).
            nxt = solve_at(self.planner, above, states[-1], iterations=0, fixed_base=True)
            # Each state keeps the planning margin (as before); the motion between two, 5 mm
            # apart, must not touch (a released robot may start inside the margin).
            if nxt is None or not continuous_motion(self.planner, states[-1], nxt, margin=0.0):
                if APPROACH_HEIGHT * (k - 1) / count >= APPROACH_LEAST:
                    break  # high enough: the fingertips are off the knob
                raise ReachingError(f"the tool cannot rise {APPROACH_LEAST * 100:.1f} cm straight up "
                                    "from the grasp, clear of the puzzle")
            states.append(nxt)
        return np.array(states)

    def reach(self, start: np.ndarray, goal: np.ndarray, floor: FloorMap) -> np.ndarray:
        """A collision-free robot path from ``start`` to the grasp ``goal``: one BIT* search when
        the base moves little, else (or when that fails) tuck the arm, drive over the free floor,
        untuck."""
        budget, area = self.settings.reach_budget, self.placement.half_extent
        if np.linalg.norm(goal[:2] - start[:2]) <= DIRECT_REACH:
            try:
                return plan_motion(self.planner, start, goal, budget, area)
            except ReachingError:
                pass
        there = floor.nearest_reachable(goal[:2])
        if there is None:
            raise ReachingError("the base cannot drive from where it stands to the grasp")
        route = floor.route(floor.start_towards(there), there)
        tucked_here = np.array([*route[0], start[2], *ARM_TUCKED])
        drive = np.array([[*xy, start[2], *ARM_TUCKED] for xy in route] + [[*route[-1], goal[2], *ARM_TUCKED]])
        tuck = plan_motion(self.planner, start, tucked_here, budget, area)
        untuck = plan_motion(self.planner, drive[-1], goal, budget, area)
        return np.vstack([tuck, drive[1:], untuck[1:]])

    def lift_off(self, start: np.ndarray) -> np.ndarray:
        """The released robot's way off: the tool straight up by :data:`APPROACH_HEIGHT` (the open
        fingers rise off the handle they held); where that fails, a short straight lift clear of the
        planning margin when the robot is closer to the puzzle than it; else just ``start``."""
        try:
            return self.vertical(start)
        except ReachingError:
            pass
        self.planner.set_robot(start)
        if not self.planner.in_collision():
            return start[None, :]
        tool = matrix(*self.sim.tool_pose())
        for height in LIFT_HEIGHTS:
            above = tool.copy()
            above[2, 3] += height
            q = solve_at(self.planner, above, start)
            # The way up may begin inside the margin (that is why it is taken), but never touches.
            if q is not None and continuous_motion(self.planner, start, q, max_joint_step=None, margin=0.0):
                return np.array([start, q])
        raise ReachingError("the released robot is closer to the puzzle than the planning margin "
                            "and cannot lift its tool clear")
