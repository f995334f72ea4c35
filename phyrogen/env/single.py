"""One puzzle per episode: :class:`PuzzleEnv`, ``PhyRoGen/Puzzle-v0`` (see :mod:`phyrogen.env`)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.error import ResetNeeded

from phyrogen.env.puzzles import RASTER_SIZE, STEP_LIMIT, Catalog
from phyrogen.env.views import IMAGE_SIZE, guide, raster_view
from solver.planning.problem import DEFAULT_RESOLUTION

_STEP_DTYPES = (np.dtype(np.float32), np.dtype(np.float64))


class PuzzleEnv(gym.Env):
    """One PhyRoGen puzzle per episode, as a Gymnasium environment (``PhyRoGen/Puzzle-v0``).

    **Puzzles.** ``puzzle`` is a puzzle folder, a dataset root (every
    ``<root>/<generator>/<name>/`` under it), a list of folders, or in-memory
    :class:`~phyrogen_core.puzzle.Puzzle` / :class:`~phyrogen_core.export.reader.LoadedPuzzle`
    objects; or ``generator`` with ``puzzle_seed`` (an int or a list of ints,
    generated once, deterministically, in worker processes; seed 1 when not given; ``params`` are the
    generator's overrides). With several puzzles, ``reset(seed=...)`` draws
    the episode's puzzle from the seeded ``np_random``;
    ``reset(options={"puzzle": name_or_index})`` chooses one.

    **State.** The planning problem's joint vector (:attr:`joint_order`: the
    chain's active joints without zero-width ones; an SE(2) object has x, y
    and yaw columns), starting at the puzzle's start state. ``size`` is the
    largest such vector over the puzzles (or ``max_joints``); a smaller
    puzzle's columns are followed by padding.

    **Observation** (``Box(float32, 5 * size)``), blocks of ``size`` values,
    in :data:`OBSERVATION_BLOCKS` order:

    - ``position``: each joint normalised to [-1, 1] over its limits;
    - ``goal``: the goal value of each goal joint, normalised alike (0 elsewhere);
    - ``goal_mask``: 1 for the target's goal joints, else 0;
    - ``object``: 1 + the index of the object a joint moves (objects in chain
      order; the target is the object of the goal joints), 0 for padding;
    - ``kind``: 1 prismatic (metres), 2 revolute (radians), 0 padding.

    Only ``position`` changes within an episode. This is ``observation="vector"``, the default;
    ``observation="raster"`` is a top-down raster of the puzzle as it stands instead,
    ``Box(float32 0/1, (4, raster_size, raster_size))`` with channels
    :data:`~phyrogen.env.puzzles.RASTER_CHANNELS` (fixed shapes, the target, the other movable
    objects, the target at its goal; drawn from the collision model's shapes, row 0 the largest y), and
    ``observation="geometry"`` is ``Dict(raster=..., vector=...)``, both.

    **Actions.** ``action_mode="continuous"``: ``Box(-1, 1, (size,))``, a
    displacement per joint in units of :attr:`max_step`, the per-joint step
    that moves no collision point more than ``max_move`` metres (0.25 by
    default); values outside [-1, 1] are clipped, padding columns ignored,
    non-finite values rejected with ValueError. ``action_mode="discrete"``:
    ``Discrete(2 * size)``, action ``2 j`` moves joint ``j`` one full step up,
    ``2 j + 1`` one step down (a padding joint: no move); fit for search and
    DQN-style agents. Every move is clipped to the joint limits, then checked
    with the exact collision model (:class:`solver.collision.model.CollisionModel`)
    at samples along the straight joint-space motion no more than
    ``resolution`` metres apart (0.02, the planners' resolution). A colliding
    move stops at its last collision-free sample (``on_collision="stop"``, the
    default) or does not happen (``"reject"``); ``info["collided"]`` says so.
    The state is therefore always collision-free.

    **Reward.** ``"sparse"``: 1 on the step that reaches the goal region
    (every goal joint within the puzzle's tolerance, as the planners and
    certificates test it), else 0. ``"shaped"``: the sparse reward plus the
    decrease of :func:`solver.planning.problem.goal_distance` over the step, divided by
    the start's goal distance (so an episode's shaping sums to 1 when it ends
    at the goal). ``"guided"``: the sparse reward plus the change of the episode's progress along the
    stored certificate (:class:`~phyrogen.env.views.CertificateGuide`: 0 at the start, 1 at its end;
    ``info["progress"]``), which pays moving the blockers in the certificate's order.
    ``terminated`` at the goal; ``truncated`` once ``max_episode_steps`` steps
    (:data:`STEP_LIMIT`; None: no limit) have been taken. Through
    ``gym.make`` the limit is Gymnasium's TimeLimit wrapper instead (the same as
    registered, or ``gym.make(..., max_episode_steps=n)``), since gym.make
    keeps that keyword for itself. Once an episode has ended (terminated, or truncated by the
    environment's own count), ``step()`` raises :class:`gymnasium.error.ResetNeeded` until
    ``reset()`` (or :meth:`set_state`), as Gymnasium's convention asks.

    **Info.** ``puzzle`` (name), ``goal_distance``, ``collided``,
    ``is_success``. ``render_mode="ansi"`` renders text, ``"rgb_array"`` a
    (256, 256, 3) uint8 image of the raster in colour (Gymnasium's RecordVideo takes it), before the
    first ``reset()`` too (the first puzzle at its start).
    For search: :attr:`state` / :meth:`set_state`,
    :attr:`certificate` (the stored solution in :attr:`joint_order`) and
    :meth:`action_towards`.
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}

    def __init__(self, puzzle: Any = None, *, generator: str | None = None, puzzle_seed: Any = None,
                 params: Any = None, reward: str = "sparse", action_mode: str = "continuous",
                 on_collision: str = "stop", max_episode_steps: int | None = STEP_LIMIT, max_move: float = 0.25,
                 resolution: float = DEFAULT_RESOLUTION, max_joints: int | None = None,
                 render_mode: str | None = None, observation: str = "vector", raster_size: int = RASTER_SIZE,
                 max_objects: int | None = None):
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}")
        self._catalog = Catalog(
            puzzle, generator, puzzle_seed, params, reward=reward, action_mode=action_mode,
            on_collision=on_collision, max_episode_steps=max_episode_steps, max_move=max_move,
            resolution=resolution, max_joints=max_joints, observation=observation, raster_size=raster_size,
            max_objects=max_objects)
        catalog = self._catalog
        self.render_mode = render_mode
        self.observation_space = catalog.observation_space()
        self.action_space = catalog.action_space()
        self.size = catalog.size
        self._discrete = catalog.action_mode == "discrete"
        self._stop = catalog.on_collision == "stop"
        self._shaped = catalog.reward == "shaped"
        self._guided = catalog.reward == "guided"
        self._mode = catalog.observation
        self._limit = catalog.step_limit
        self._load(0)  # usable before the first reset

    # -- episode state --------------------------------------------------------
    def _load(self, index: int) -> None:
        task = self._task = self._catalog.task(index)
        self._state = task.start.copy()
        self._spare = np.empty_like(self._state)
        self._distance = task.goal_distance(self._state)
        self._elapsed = 0
        self._ended = False
        # The observation is kept in float64 and cast on return (cheaper than writing float32 in place).
        obs = np.zeros(5 * self.size, dtype=np.float64)
        obs[self.size:] = task.static_obs
        self._obs = obs
        self._position = obs[: task.d]
        self._write_position()
        if self._guided:
            self._cursor = np.zeros(1, dtype=np.int64)
            self._progress = float(guide(task).track(self._state, self._cursor)[0])

    def _observation(self):
        """The observation of the current state in this environment's mode."""
        if self._mode == "vector":
            return self._obs.astype(np.float32)
        raster = raster_view(self._task, self._catalog.raster_size).observe(self._state)
        if self._mode == "raster":
            return raster
        return {"raster": raster, "vector": self._obs.astype(np.float32)}

    def _write_position(self) -> None:
        np.multiply(self._state - self._task.center, self._task.inv_half, out=self._position)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        self._load(self._catalog.pick(self.np_random, options))
        return self._observation(), {"puzzle": self._task.name, "goal_distance": self._distance}

    def step(self, action):
        if self._ended:
            # Gymnasium leaves a step after the episode's end undefined; here it would report the goal
            # (reward 1, terminated) once more, which a training loop would count twice.
            raise ResetNeeded("PuzzleEnv.step() after the episode ended (terminated at the goal or truncated): "
                              "call reset() first")
        task = self._task
        state = self._state
        # The new state goes into the spare buffer, which then swaps with the old state: no array is
        # made per step.
        reached = self._spare
        if self._discrete:
            target = self._discrete_target(action)
            collided = task.model.motion_stop(state, target, task.steps, self._stop, reached) >= 0.0
            np.subtract(reached, task.center, out=self._position)
            np.multiply(self._position, task.inv_half, out=self._position)
        else:
            act = action
            # float32 (the action space's) and float64 arrays go to the compiled step as they are.
            if type(act) is not np.ndarray or act.dtype not in _STEP_DTYPES or not act.flags.c_contiguous:
                act = np.ascontiguousarray(action, dtype=np.float64)
            if act.shape != (self.size,):
                raise ValueError(f"action must have shape ({self.size},), got {act.shape}")
            # Clipping, the motion check, where a colliding move stops and the observed position:
            # one compiled call.
            hit = task.model.joint_step(state, act, task.step_table, self._stop, reached, self._position)
            if hit < -1.5:
                raise ValueError(f"action holds a value that is not a finite number: {action!r}")
            collided = hit >= 0.0
        self._state, self._spare = reached, state
        target = reached
        previous = self._distance
        distance = self._distance = task.goal_distance(target)
        terminated = distance <= task.tolerance
        reward = 1.0 if terminated else 0.0
        if self._shaped:
            reward += (previous - distance) * task.shaping_scale
        elif self._guided:
            progress = float(guide(task).track(target, self._cursor)[0])
            reward += progress - self._progress
            self._progress = progress
        self._elapsed += 1
        truncated = self._elapsed >= self._limit
        self._ended = terminated or truncated
        info = {"puzzle": task.name, "goal_distance": distance, "collided": collided, "is_success": terminated}
        if self._guided:
            info["progress"] = self._progress
        return self._observation(), reward, terminated, truncated, info

    def _discrete_target(self, action) -> np.ndarray:
        if isinstance(action, np.ndarray) and action.shape == ():
            action = action.item()
        if isinstance(action, bool) or not isinstance(action, int | np.integer) or not 0 <= action < 2 * self.size:
            raise ValueError(f"action must be an int in [0, {2 * self.size}), got {action!r}")
        task = self._task
        target = self._state.copy()
        joint = int(action) >> 1
        if joint < task.d:
            step = task.max_step[joint]
            value = target[joint] - step if action & 1 else target[joint] + step
            target[joint] = min(max(value, task.lower[joint]), task.upper[joint])
        return target

    # -- for search and for replaying solutions -------------------------------
    @property
    def puzzle_name(self) -> str:
        return self._task.name

    @property
    def puzzle_names(self) -> tuple[str, ...]:
        """Every puzzle of this environment, in the order ``options["puzzle"]`` indexes."""
        return tuple(self._catalog.names)

    @property
    def joint_order(self) -> tuple[str, ...]:
        """The current puzzle's state columns by joint name."""
        return self._task.joint_order

    @property
    def objects(self) -> tuple[str, ...]:
        """The current puzzle's movable objects; the observation's ``object`` block is 1 + an index into this."""
        return self._task.objects

    @property
    def max_step(self) -> np.ndarray:
        """Per state column: the joint displacement of an action value of 1."""
        return self._task.max_step.copy()

    @property
    def state(self) -> np.ndarray:
        """The joint vector (:attr:`joint_order`), a copy."""
        return self._state.copy()

    def set_state(self, state) -> np.ndarray:
        """Put the puzzle in ``state`` (within the limits and collision-free, else ValueError); its observation.

        Keeps the step count; the next step's shaped reward counts from here. An episode that had
        ended may go on from the new state (search: expand any state), so step() is allowed again.
        """
        task = self._task
        values = np.array(state, dtype=np.float64).reshape(-1)
        if values.shape != (task.d,) or not np.isfinite(values).all():
            raise ValueError(f"state must be {task.d} finite numbers ({', '.join(task.joint_order)}), got {state!r}")
        if (values < task.lower).any() or (values > task.upper).any():
            raise ValueError(f"state {values.tolist()} leaves the joint limits [{task.lower.tolist()}, "
                             f"{task.upper.tolist()}]")
        if not task.model.is_valid(values):
            raise ValueError(f"state {values.tolist()} is in collision")
        self._state = values
        self._distance = task.goal_distance(values)
        self._ended = False
        self._write_position()
        if self._guided:
            self._cursor = np.array([guide(task).nearest(values)], dtype=np.int64)
            self._progress = float(guide(task).track(values, self._cursor)[0])
        return self._observation()

    @property
    def certificate(self) -> np.ndarray:
        """The puzzle's stored solution (start to goal), states in :attr:`joint_order`."""
        return self._task.certificate.copy()

    def action_towards(self, state) -> np.ndarray | int:
        """The continuous action that moves straight towards ``state`` (:attr:`joint_order`), as far as one
        step allows: following it step by step retraces a piecewise-linear path such as the certificate."""
        if self._discrete:
            raise ValueError("action_towards needs action_mode='continuous'")
        task = self._task
        wanted = (np.asarray(state, dtype=np.float64) - self._state) / task.max_step
        largest = float(np.abs(wanted).max(initial=0.0))
        action = np.zeros(self.size, dtype=np.float64)
        action[: task.d] = wanted / largest if largest > 1.0 else wanted
        return action

    def render(self) -> str | np.ndarray | None:
        if self.render_mode == "rgb_array":
            return raster_view(self._task, IMAGE_SIZE).image(self._state)
        if self.render_mode != "ansi":
            return None
        task = self._task
        lines = [f"{task.name}: step {self._elapsed}, goal distance {self._distance:.4f}"]
        goal = dict(task.goal_pairs)
        for i, name in enumerate(task.joint_order):
            wanted = f"  (goal {goal[i]:.4f})" if i in goal else ""
            lines.append(f"  {name:>14} = {self._state[i]: .4f}  [{task.lower[i]:.3f}, {task.upper[i]:.3f}]{wanted}")
        return "\n".join(lines)

