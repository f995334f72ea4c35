"""Moving a grasped object along its path: damped-least-squares Jacobian control in physics.

Each simulation step the tool's desired pose comes from the object's path
(where the grasped link will be, times the grasp offset); the joint velocity
is the weighted damped least-squares answer to feed-forward twist plus a
proportional correction, and the joint motors track it. The puzzle joints
are never set: the object moves because the pads' friction pulls it.

A monitor watches for joint flips (an arm joint jumping), low arm
manipulability, arm joints at their limits, the puzzle coming too close and
the robot touching itself; any of them stops the motion so the caller can
regrasp.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import pybullet as pb

from solver.planning.problem import densify

from .linalg import damped_least_squares, manipulability
from .robot import speed_limits
from .scene import World
from .transforms import matrix, rotation_error

TIME_STEP = 1 / 240


@dataclass(frozen=True)
class FollowSettings:
    linear_speed: float = 0.25
    """Metres per second of the grasp point along the object's path (0.15 before the physical
    scale: at 0.25 the paper's 24 puzzles need 30 % fewer regrasps and 18 % less simulated time)."""
    angular_speed: float = 1.0
    """Radians per second of the object's rotation."""
    damping: float = 0.02
    base_weight: float = 1e6
    """How much costlier a base joint's motion is than an arm joint's. The default keeps the
    base still while the arm follows: a drifting base (weight 8 was tried) crept into the puzzle,
    since nothing in the control law keeps it clear. The base moves between grasps instead,
    on collision-free BIT* paths."""
    gain: float = 12.0
    """Per second: proportional correction of the tool pose error."""
    flip_step: float = 0.02
    """Radians an arm joint may move in one step before it counts as a flip."""
    min_manipulability: float = 1e-3
    limit_margin: float = 0.03
    settle_steps: int = 240
    """Steps allowed at the end for the object to settle on its final state."""
    integral_gain: float = 4.0
    """Per second: integral correction of the object's own joint error (grasp compliance, friction)."""
    clearance: float = 0.006
    """Metres: a robot link this close to the puzzle stops the motion (the moving object or a
    wall may come at the arm or the base on the way)."""
    hold_steps: int = 60
    """Steps the robot holds still, still grasping, before a release after a stop other than done (so
    the object stops moving)."""
    done_steps: int = 48
    """Steps (0.2 s) the object must stay at its final state, the follower still tracking it, before
    the action is done and the fingers let go."""
    ramp: float = 0.25
    """Seconds over which the object's path speeds up from rest and slows down to rest (at 0.25 m/s:
    1 m/s^2 at the grasp point, the acceleration scripts/grip_feasibility.py bounds the parts by); a
    follow resumed mid-path speeds up over the same time."""


class Stop(StrEnum):
    DONE = "done"
    FLIP = "joint flip"
    SINGULAR = "low manipulability"
    LIMIT = "joint limit"
    CONTACT = "near contact"
    SELF_CONTACT = "self contact"
    LOST_GRIP = "lost grip"
    WINDOW_ENDED = "settling window ended"
    """The path's end and its settling window passed without the object at its final state."""


@dataclass(frozen=True)
class FollowResult:
    stop: Stop
    time: float
    """Where along the trajectory (seconds) the motion stopped."""
    steps: int
    held: np.ndarray | None = None
    """The robot's last command, where it holds still now (None: where it stands)."""


@dataclass(frozen=True)
class Trajectory:
    """Desired grasped-link poses over time: ``times`` (seconds) and object states (scene units)."""

    times: np.ndarray
    states: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def state_at(self, t: float) -> np.ndarray:
        t = min(max(t, 0.0), self.duration)
        k = int(np.searchsorted(self.times, t, side="right")) - 1
        k = min(max(k, 0), len(self.times) - 2)
        span = self.times[k + 1] - self.times[k]
        u = 0.0 if span <= 0 else (t - self.times[k]) / span
        return self.states[k] + u * (self.states[k + 1] - self.states[k])


def time_trajectory(states: np.ndarray, grasp_positions: np.ndarray, revolute_columns: list[int],
                    settings: FollowSettings) -> Trajectory:
    """Time stamps for ``states`` so the grasp point and the object's rotation keep their speed limits."""
    times = [0.0]
    for k in range(1, len(states)):
        distance = float(np.linalg.norm(grasp_positions[k] - grasp_positions[k - 1]))
        turn = float(np.max(np.abs(states[k, revolute_columns] - states[k - 1, revolute_columns]), initial=0.0))
        times.append(times[-1] + max(distance / settings.linear_speed, turn / settings.angular_speed, TIME_STEP))
    return Trajectory(ramped(np.array(times), settings.ramp), np.asarray(states, dtype=float))


def ramped(times: np.ndarray, ramp: float) -> np.ndarray:
    """Time stamps of a path timed at constant speed, re-timed so that its speed rises linearly from
    rest over the first ``ramp`` seconds and falls to rest over the last (shorter ramps for a path
    shorter than ``ramp``). The pads hold a handle by friction alone: stopping a heavy part at once
    asks them for its momentum in one step."""
    total = float(times[-1])
    tau = min(ramp, total)
    if tau <= 0:
        return times
    out = np.empty_like(times)
    for k, t in enumerate(times):
        if t <= tau / 2:
            out[k] = np.sqrt(2 * tau * t)
        elif t <= total - tau / 2:
            out[k] = t + tau / 2
        else:
            d = min(t - (total - tau / 2), tau / 2)
            out[k] = total + tau - np.sqrt(max(tau * tau - 2 * tau * d, 0.0))
    return out


def follow(world: World, trajectory: Trajectory, tool_pose_at: Callable[[np.ndarray], np.ndarray],
           start_time: float, settings: FollowSettings, on_step: Callable[[], None],
           object_done: Callable[[], bool], object_state: Callable[[], np.ndarray],
           clearance_now: Callable[[float], float] = lambda up_to: up_to,
           touches_itself: Callable[[], bool] = lambda: False,
           holding: Callable[[], bool] = lambda: True,
           on_time: Callable[[float], None] = lambda t: None) -> FollowResult:
    """Track ``tool_pose_at(trajectory.state_at(t))`` from ``start_time`` to the end, stepping physics.

    ``on_step`` runs after every physics step (recording, contact checks);
    ``object_done`` says whether the object has reached its final state;
    ``object_state`` gives the puzzle's joint values now, whose lag behind
    the trajectory is integrated into the commanded object state;
    ``clearance_now(up_to)`` the robot's distance to the puzzle, capped at ``up_to``:
    the motion stops when it falls below ``settings.clearance``, or below half of
    what it was at the start when the grasp began closer than that (the base,
    held still, may stand a few millimetres from a wall);
    ``touches_itself()`` whether the robot touched itself in the last step: it stops the
    motion too, since the planner cannot start from a robot in self-collision;
    ``holding()`` whether the gripper still holds the object (a finger lost contact: stop);
    ``on_time(t)`` is told, before each step, where along the trajectory the step ends.
    Joint velocities are scaled down together to the robot's speed limits.
    Every stop ends with the robot held still for ``hold_steps``.
    """
    c = world.client
    joints = world.robot_joints
    arm = world.arm_columns
    weights = np.ones(len(joints))
    weights[:3] = settings.base_weight
    limits = np.asarray(speed_limits(world.spec))
    t = start_time
    q = world.robot_state()
    steps = 0
    end = trajectory.duration + settings.settle_steps * TIME_STEP
    bias = np.zeros(trajectory.states.shape[1])
    stop_distance = min(settings.clearance, 0.5 * clearance_now(settings.clearance))
    lower, upper = world.lower[arm], world.upper[arm]
    target = q
    ramp_steps = max(1, round(settings.ramp / TIME_STEP))
    done_for = 0
    while t < end:
        # Resumed mid-path, the object speeds up from rest (path time runs slow at first).
        dt = TIME_STEP * min(1.0, (steps + 1) / ramp_steps)
        t_next = t + dt
        on_time(t_next)
        bias += settings.integral_gain * TIME_STEP * (trajectory.state_at(t) - object_state())
        desired = tool_pose_at(trajectory.state_at(t_next) + bias)
        ahead = tool_pose_at(trajectory.state_at(t_next + dt) + bias)
        actual = matrix(*world.tool_pose())
        feed_forward = np.concatenate([(ahead[:3, 3] - desired[:3, 3]) / TIME_STEP,
                                       rotation_error(ahead[:3, :3], desired[:3, :3]) / TIME_STEP])
        error = np.concatenate([desired[:3, 3] - actual[:3, 3], rotation_error(desired[:3, :3], actual[:3, :3])])
        twist = feed_forward + settings.gain * error
        jacobian = world.jacobian(q)
        q_dot = damped_least_squares(jacobian, weights, settings.damping, twist)
        q_dot /= max(1.0, float(np.max(np.abs(q_dot) / limits)))
        target = np.clip(q + q_dot * TIME_STEP, world.lower, world.upper)
        command(world, target, q_dot)
        pb.stepSimulation(physicsClientId=c)
        steps += 1
        t = t_next
        on_step()
        q_new = world.robot_state()
        stop = None
        if np.max(np.abs(q_new[arm] - q[arm])) > settings.flip_step:
            stop = Stop.FLIP
        elif np.any(q_new[arm] < lower + settings.limit_margin) or np.any(q_new[arm] > upper - settings.limit_margin):
            stop = Stop.LIMIT
        elif manipulability(np.ascontiguousarray(jacobian[:, arm])) < settings.min_manipulability:
            stop = Stop.SINGULAR
        elif clearance_now(settings.clearance) < stop_distance:
            stop = Stop.CONTACT
        elif touches_itself():
            stop = Stop.SELF_CONTACT
        elif not holding():
            stop = Stop.LOST_GRIP
        elif t >= trajectory.duration and object_done():
            done_for += 1
            if done_for >= settings.done_steps:
                # Let go as it stands, still under control: a hold at a frozen command let the arm
                # relax off a handle held by friction (0.2 mm on a Lockbox slide, its whole tolerance).
                return FollowResult(Stop.DONE, t, steps, target)
        else:
            done_for = 0
        q = q_new
        if stop is not None:
            # Held at the last command, not at the measured state: the loaded arm sags off its command
            # (its servos are PD), and a command at the sagged state sags it once more (a Move N Times
            # target held there turned 0.8 mrad out of its tolerance of 1, at every regrasp).
            return FollowResult(stop, t, steps + hold(world, target, settings.hold_steps, on_step), target)
    return FollowResult(Stop.WINDOW_ENDED, t, steps + hold(world, target, settings.hold_steps, on_step), target)


def lift_tool(world: World, height: float, speed: float, settings: FollowSettings,
              on_step: Callable[[], None]) -> int:
    """Raise the tool straight up by ``height`` at ``speed`` (the base still, the tool's orientation
    kept), by the follower's control law; returns the steps taken."""
    start = matrix(*world.tool_pose())
    weights = np.ones(len(world.robot_joints))
    weights[:3] = settings.base_weight
    limits = np.asarray(speed_limits(world.spec))
    steps = max(1, int(np.ceil(height / speed / TIME_STEP)))
    for k in range(1, steps + 1):
        desired = start.copy()
        desired[2, 3] += height * k / steps
        actual = matrix(*world.tool_pose())
        error = np.concatenate([desired[:3, 3] - actual[:3, 3], rotation_error(desired[:3, :3], actual[:3, :3])])
        twist = np.concatenate([[0.0, 0.0, height / steps / TIME_STEP], np.zeros(3)]) + settings.gain * error
        q = world.robot_state()
        q_dot = damped_least_squares(world.jacobian(q), weights, settings.damping, twist)
        q_dot /= max(1.0, float(np.max(np.abs(q_dot) / limits)))
        command(world, np.clip(q + q_dot * TIME_STEP, world.lower, world.upper), q_dot)
        pb.stepSimulation(physicsClientId=world.client)
        on_step()
    return steps


def command(world: World, target: np.ndarray, velocity: np.ndarray | None = None) -> None:
    """One step's motor commands: the arm's joints by position (PyBullet's PD servo, each within
    its datasheet torque), the base's by velocity (its own gain, speed and force limits), toward
    ``target`` with feed-forward ``velocity`` (zero: hold)."""
    spec, c = world.spec, world.client
    velocity = np.zeros(len(target)) if velocity is None else np.asarray(velocity, dtype=float)
    q = world.robot_state()
    base = np.clip(velocity[:3] + spec.base_gain * (target[:3] - q[:3]),
                   -np.asarray(spec.base_speed), np.asarray(spec.base_speed))
    pb.setJointMotorControlArray(world.robot, world.robot_joints[:3], pb.VELOCITY_CONTROL,
                                 targetVelocities=base.tolist(), forces=list(spec.base_force), physicsClientId=c)
    pb.setJointMotorControlArray(world.robot, world.robot_joints[3:], pb.POSITION_CONTROL,
                                 targetPositions=target[3:].tolist(), targetVelocities=velocity[3:].tolist(),
                                 forces=list(spec.arm_torque), physicsClientId=c)


def hold(world: World, q: np.ndarray, steps: int, on_step: Callable[[], None]) -> int:
    """Hold the robot at ``q`` with zero velocity for ``steps`` physics steps."""
    for _ in range(steps):
        command(world, q)
        pb.stepSimulation(physicsClientId=world.client)
        on_step()
    return steps


def step_physics(world: World, steps: int, on_step: Callable[[], None]) -> int:
    """Step the simulation ``steps`` times, calling ``on_step`` after each; returns ``steps``."""
    for _ in range(steps):
        pb.stepSimulation(physicsClientId=world.client)
        on_step()
    return steps


def drive_along(world: World, path: np.ndarray, on_step: Callable[[], None], max_step: float = 0.004,
                settle_tolerance: float = 5e-4, settle_steps: int = 240) -> int:
    """Drive the (released) robot along a joint path, each joint at most ``max_step`` (and its
    speed limit) per physics step; returns steps taken."""
    c = world.client
    steps_per_joint = np.minimum(max_step, 0.9 * np.asarray(speed_limits(world.spec)) * TIME_STEP)
    waypoints = densify(path, steps_per_joint)
    steps = 0
    for previous, target in zip(waypoints, waypoints[1:], strict=False):
        command(world, target, (target - previous) / TIME_STEP)
        pb.stepSimulation(physicsClientId=c)
        on_step()
        steps += 1
    for _ in range(settle_steps):
        if np.max(np.abs(world.robot_state() - path[-1])) < settle_tolerance:
            break
        command(world, path[-1])
        pb.stepSimulation(physicsClientId=c)
        on_step()
        steps += 1
    return steps
