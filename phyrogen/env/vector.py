"""Many copies of a puzzle environment stepped together: :class:`PuzzleVectorEnv` (see :mod:`phyrogen.env`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from phyrogen.env.puzzles import STEP_LIMIT, Catalog, check_options
from phyrogen.env.views import guide
from solver.planning.problem import DEFAULT_RESOLUTION


class PuzzleVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`PuzzleEnv` stepped together (``gym.make_vec(..., vectorization_mode=
    "vector_entry_point")``).

    The same spaces, rewards and rules as :class:`PuzzleEnv` (every keyword is
    passed on), and the same results on the same actions and seeds as a
    ``SyncVectorEnv`` of them: ``reset(seed=s)`` seeds copy ``i`` with
    ``s + i``, and a copy that ended is reset on its next step (next-step
    autoreset; that step's action is ignored). A step checks every copy's
    motion in one call of the batched collision kernel per puzzle in play, so
    it is fastest when the copies share few puzzles. Its observation is the vector
    (``observation="vector"``); for the raster modes use ``gym.make_vec(..., vectorization_mode="sync")``
    or ``"async"``.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    _moves = "motion_ends"
    """The collision model's batched move: ``motion_ends``, or ``motion_stops`` (the same states, found
    by testing every sample), kept for comparisons (tests, ``benchmarks/env_speed.py --old-kernel``)."""

    def __init__(self, num_envs: int = 8, puzzle: Any = None, *, generator: str | None = None,
                 puzzle_seed: Any = None, params: Any = None, reward: str = "sparse", action_mode: str = "continuous",
                 on_collision: str = "stop", max_episode_steps: int | None = STEP_LIMIT, max_move: float = 0.25,
                 resolution: float = DEFAULT_RESOLUTION, max_joints: int | None = None,
                 render_mode: str | None = None, observation: str = "vector"):
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be an int >= 1, got {num_envs!r}")
        if render_mode is not None:
            raise ValueError("PuzzleVectorEnv does not render; use PuzzleEnv(render_mode='ansi' or 'rgb_array')")
        if observation != "vector":
            raise ValueError(f"PuzzleVectorEnv observes the vector only, got observation={observation!r}: use "
                             "gym.make_vec(..., vectorization_mode='sync' or 'async') for the raster modes")
        catalog = self._catalog = Catalog(
            puzzle, generator, puzzle_seed, params, reward=reward, action_mode=action_mode,
            on_collision=on_collision, max_episode_steps=max_episode_steps, max_move=max_move,
            resolution=resolution, max_joints=max_joints)
        self.num_envs = num_envs
        self.render_mode = None
        self.single_observation_space = catalog.observation_space()
        self.single_action_space = catalog.action_space()
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.size = size = catalog.size
        self._discrete = catalog.action_mode == "discrete"
        self._stop = catalog.on_collision == "stop"
        self._shaped = catalog.reward == "shaped"
        self._guided = catalog.reward == "guided"
        self._progress = np.zeros(num_envs)
        self._cursor = np.zeros(num_envs, dtype=np.int64)
        self._limit = catalog.step_limit
        self._rngs: list[np.random.Generator | None] = [None] * num_envs
        self._states = np.zeros((num_envs, size))
        self._task_of = np.zeros(num_envs, dtype=np.int64)
        self._elapsed = np.zeros(num_envs, dtype=np.int64)
        self._distance = np.zeros(num_envs)
        self._obs = np.zeros((num_envs, 5 * size), dtype=np.float32)
        self._autoreset = np.zeros(num_envs, dtype=np.bool_)
        for i in range(num_envs):
            self._load(i, 0)  # usable before the first reset

    def _load(self, i: int, index: int) -> None:
        task = self._catalog.task(index)
        self._task_of[i] = index
        self._states[i] = 0.0
        self._states[i, : task.d] = task.start
        self._elapsed[i] = 0
        self._distance[i] = task.goal_distance(task.start)
        self._obs[i] = 0.0
        self._obs[i, self.size:] = task.static_obs
        self._obs[i, : task.d] = (task.start - task.center) * task.inv_half
        if self._guided:
            self._cursor[i] = 0
            self._progress[i] = guide(task).track(task.start, self._cursor[i: i + 1])[0]

    def _reset_one(self, i: int, seed: int | None, options: Mapping[str, Any] | None) -> None:
        if seed is not None or self._rngs[i] is None:
            self._rngs[i], _ = seeding.np_random(seed)
        self._load(i, self._catalog.pick(self._rngs[i], options))

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options: dict[str, Any] | None = None):
        check_options(options)
        seeds = [None] * self.num_envs if seed is None else (
            [seed + i for i in range(self.num_envs)] if isinstance(seed, int | np.integer) else list(seed))
        if len(seeds) != self.num_envs:
            raise ValueError(f"seed must be None, an int or {self.num_envs} seeds, got {len(seeds)}")
        for i, s in enumerate(seeds):
            self._reset_one(i, s, options)
        self._autoreset[:] = False
        names = np.array([self._catalog.names[k] for k in self._task_of], dtype=object)
        every = np.ones(self.num_envs, dtype=np.bool_)
        return self._obs.copy(), {"puzzle": names, "_puzzle": every, "goal_distance": self._distance.copy(),
                                  "_goal_distance": every.copy()}

    def step(self, actions):
        n, size = self.num_envs, self.size
        if self._discrete:
            acts = np.asarray(actions)
            if acts.shape != (n,) or not np.issubdtype(acts.dtype, np.integer) or (acts < 0).any() \
                    or (acts >= 2 * size).any():
                raise ValueError(f"actions must be {n} ints in [0, {2 * size}), got {actions!r}")
        else:
            acts = np.asarray(actions, dtype=np.float64)
            if acts.shape != (n, size):
                raise ValueError(f"actions must have shape ({n}, {size}), got {acts.shape}")
            if not np.isfinite(acts).all():
                raise ValueError("actions hold a value that is not a finite number")
        rewards = np.zeros(n)
        terminated = np.zeros(n, dtype=np.bool_)
        truncated = np.zeros(n, dtype=np.bool_)
        collided = np.zeros(n, dtype=np.bool_)
        restart = np.flatnonzero(self._autoreset)
        for i in restart:
            self._reset_one(int(i), None, None)
        stepping = ~self._autoreset
        task_of = self._task_of
        kinds = np.unique(task_of[stepping]) if stepping.any() else ()
        for index in kinds:
            task = self._catalog.task(int(index))
            rows = np.flatnonzero(stepping & (task_of == index)) if len(kinds) > 1 or restart.size else slice(None)
            d = task.d
            start = np.ascontiguousarray(self._states[rows, :d])
            if self._discrete:
                target = start.copy()
                chosen = acts[rows]
                joint = chosen >> 1
                moving = np.flatnonzero(joint < d)
                if moving.size:
                    j = joint[moving]
                    values = target[moving, j]
                    step = task.max_step[j]
                    values = np.where(chosen[moving] & 1, values - step, values + step)
                    target[moving, j] = np.minimum(np.maximum(values, task.lower[j]), task.upper[j])
            else:
                target = np.minimum(acts[rows, :d], 1.0)
                np.maximum(target, -1.0, out=target)
                target *= task.max_step
                target += start
                np.minimum(target, task.upper, out=target)
                np.maximum(target, task.lower, out=target)
            reached, fraction = getattr(task.model, self._moves)(start, np.ascontiguousarray(target), task.steps,
                                                                 self._stop)
            hit = fraction >= 0.0
            self._states[rows, :d] = reached
            self._obs[rows, :d] = (reached - task.center) * task.inv_half
            previous = self._distance[rows].copy()
            distance = np.abs(reached[:, task.goal_index] - task.goal_value).max(axis=1, initial=0.0)
            self._distance[rows] = distance
            done = distance <= task.tolerance
            reward = done.astype(np.float64)
            if self._shaped:
                reward += (previous - distance) * task.shaping_scale
            elif self._guided:
                cursor = self._cursor[rows]  # a copy (rows may be an index array): written back
                progress = guide(task).track(reached, cursor)
                self._cursor[rows] = cursor
                reward += progress - self._progress[rows]
                self._progress[rows] = progress
            rewards[rows], terminated[rows], collided[rows] = reward, done, hit
        self._elapsed[stepping] += 1
        truncated[stepping] = self._elapsed[stepping] >= self._limit
        self._autoreset = terminated | truncated
        # As SyncVectorEnv reports them: a copy reset on this step has no step keys.
        info = {"goal_distance": self._distance.copy(), "_goal_distance": np.ones(n, dtype=np.bool_),
                "collided": collided, "_collided": stepping.copy(), "is_success": terminated.copy(),
                "_is_success": stepping.copy()}
        return self._obs.copy(), rewards, terminated, truncated, info

    @property
    def states(self) -> np.ndarray:
        """Every copy's joint vector, padded to ``size`` columns (a copy)."""
        return self._states.copy()

