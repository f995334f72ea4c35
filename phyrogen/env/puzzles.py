"""PhyRoGen puzzles as a Gymnasium environment: ``PhyRoGen/Puzzle-v0``.

Importing this module registers the id (and a vector entry point), so either
of these works; the ``module:id`` form imports the module itself::

    import gymnasium as gym
    env = gym.make("phyrogen.env:PhyRoGen/Puzzle-v0", puzzle="output/grid_world/grid_world_7")
    env = gym.make("phyrogen.env:PhyRoGen/Puzzle-v0", generator="grid_world", puzzle_seed=7)
    envs = gym.make_vec("phyrogen.env:PhyRoGen/Puzzle-v0", num_envs=64, puzzle="output")  # PuzzleVectorEnv

The environment is the planning problem the puzzle was certified on
(:func:`solver.planning.problem.problem_for_chain`), made steppable: the state is the
joint vector, an action moves joints by a bounded displacement, and every
move is checked with the exact planar collision model along the motion, as
the planners check theirs. :class:`PuzzleEnv` documents the spaces and the
rewards; :class:`PuzzleVectorEnv` steps many copies with one call into the
batched collision kernel. ``docs/interop.md`` has a training-loop skeleton
and measured speeds (``benchmarks/env_speed.py``).

Generating puzzles (``generator=...``) runs in worker processes that do not
run the calling script again: no ``if __name__ == "__main__":`` guard is
needed (:mod:`solver.parallel.pool`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from phyrogen_core.chain import JointType, KinematicChain
from phyrogen_core.puzzle import Goal
from solver.collision.model import CollisionModel
from solver.planning.problem import (
    DEFAULT_RESOLUTION,
    GOAL_SLACK,
    LOCKED_WIDTH,
    Problem,
    problem_factors,
    problem_for_chain,
)

__all__ = ["ENV_ID", "OBSERVATION_BLOCKS", "STEP_LIMIT", "PuzzleEnv", "PuzzleVectorEnv"]

ENV_ID = "PhyRoGen/Puzzle-v0"

OBSERVATION_BLOCKS = ("position", "goal", "goal_mask", "object", "kind")
"""The observation's blocks, each ``size`` values long (one per joint column), in this order."""

STEP_LIMIT = 500
"""Steps before ``truncated``, by default (through ``gym.make``: its TimeLimit wrapper). At the default
``max_move`` the certificates of the paper's 24 puzzles take 8 to 239 steps (Move N Times 4 the most)."""
REWARDS = ("sparse", "shaped")
ACTION_MODES = ("continuous", "discrete")
ON_COLLISION = ("stop", "reject")
KIND_PRISMATIC, KIND_REVOLUTE = 1.0, 2.0
_STEP_DTYPES = (np.dtype(np.float32), np.dtype(np.float64))


# -- puzzles and their compiled planning problems ------------------------------------
@dataclass(frozen=True)
class _Source:
    """One puzzle as the environment needs it: certificate in the chain's joint order."""

    name: str
    chain: KinematicChain
    goal: Goal
    certificate: tuple[tuple[float, ...], ...]

    def free_joints(self) -> list[str]:
        """The joints the problem keeps (zero-width joints are locked, as in :func:`problem_for_chain`)."""
        return [j.name for j in self.chain.active_joints if j.upper - j.lower >= LOCKED_WIDTH]


class _Task:
    """A puzzle's planning problem plus everything a step needs, precomputed.

    Arrays named ``*_padded`` have the environment's ``size`` columns (the
    puzzle's ``d`` columns, then zeros); the others have ``d``.
    """

    def __init__(self, source: _Source, size: int, max_move: float, resolution: float):
        problem: Problem = problem_for_chain(source.chain, source.goal)
        model: CollisionModel = problem.model
        self.name = source.name
        self.problem, self.model = problem, model
        self.joint_order = model.joint_order
        d = self.d = len(model.joint_order)
        self.lower = np.ascontiguousarray(problem.lower, dtype=np.float64)
        self.upper = np.ascontiguousarray(problem.upper, dtype=np.float64)
        self.start = np.ascontiguousarray(problem.start, dtype=np.float64)
        self.steps = np.ascontiguousarray(model.motion_steps(resolution), dtype=np.float64)
        self.max_step = np.ascontiguousarray(model.motion_steps(max_move), dtype=np.float64)
        self.center = (self.lower + self.upper) / 2.0
        self.inv_half = 2.0 / (self.upper - self.lower)
        self.tolerance = problem.tolerance + GOAL_SLACK
        self.goal_pairs = tuple(sorted(problem.goal_columns.items()))
        self.goal_index = np.array([i for i, _ in self.goal_pairs], dtype=np.int64)
        self.goal_value = np.array([v for _, v in self.goal_pairs], dtype=np.float64)
        self.objects = tuple(problem_factors(problem))
        column_object = {c: k for k, columns in enumerate(problem_factors(problem).values()) for c in columns}
        chain_column = {n: i for i, n in enumerate(source.chain.joint_order)}
        self.chain_columns = np.array([chain_column[n] for n in model.joint_order], dtype=np.int64)
        certificate = np.asarray(source.certificate, dtype=np.float64).reshape(-1, len(source.chain.joint_order))
        self.certificate = np.ascontiguousarray(certificate[:, self.chain_columns])
        self.start_distance = self.goal_distance(self.start)
        self.shaping_scale = 1.0 / self.start_distance if self.start_distance > 0 else 0.0
        # What the observation says besides the positions: goal, goal mask, object index, joint kind.
        static = np.zeros((4, size), dtype=np.float32)
        for i, value in self.goal_pairs:
            static[0, i] = np.clip((value - self.center[i]) * self.inv_half[i], -1.0, 1.0)
            static[1, i] = 1.0
        for i, name in enumerate(model.joint_order):
            static[2, i] = column_object[i] + 1
            kind = model.chain.joint(name).type
            static[3, i] = KIND_PRISMATIC if kind is JointType.PRISMATIC else KIND_REVOLUTE
        self.static_obs = static.reshape(-1)

        def padded(values: np.ndarray) -> np.ndarray:
            out = np.zeros(size, dtype=np.float64)
            out[:d] = values
            return out

        self.lower_padded, self.upper_padded = padded(self.lower), padded(self.upper)
        self.max_step_padded, self.center_padded = padded(self.max_step), padded(self.center)
        self.inv_half_padded = padded(self.inv_half)
        self.step_table = CollisionModel.step_table(self.max_step, self.lower, self.upper, self.steps, self.center,
                                                    self.inv_half)

    def goal_distance(self, state) -> float:
        """:func:`solver.planning.problem.goal_distance`: the largest distance of a goal joint from its value."""
        distance = 0.0
        for i, value in self.goal_pairs:
            off = abs(float(state[i]) - value)
            if off > distance:
                distance = off
        return distance


def _as_sources(puzzle: Any, generator: str | None, puzzle_seed: Any, params: Any) -> list[_Source]:
    """The puzzles an environment is built from (see :class:`PuzzleEnv` for the accepted inputs)."""
    if generator is not None:
        if puzzle is not None:
            raise ValueError("give either puzzle=(folder, folders, Puzzle) or generator= with puzzle_seed=, not both")
        return _generated(generator, puzzle_seed, params)
    if puzzle_seed is not None or params is not None:
        raise ValueError("puzzle_seed= and params= need generator=; a puzzle folder already fixes its puzzle")
    if puzzle is None:
        raise ValueError("no puzzle: give puzzle=<puzzle folder | dataset root | list of folders> "
                         "or generator=<name> with puzzle_seed=<int or list of ints>")
    items = [puzzle] if isinstance(puzzle, str | Path) or not isinstance(puzzle, Sequence) else list(puzzle)
    if not items:
        raise ValueError("puzzle= is an empty list: give at least one puzzle folder")
    out: list[_Source] = []
    for item in items:
        out += _sources_of(item)
    return out


def _sources_of(item: Any) -> list[_Source]:
    from phyrogen_core.export import read_puzzle_dir
    from phyrogen_core.export.reader import LoadedPuzzle
    from phyrogen_core.folder import PuzzleFolder, find_puzzle_folders
    from phyrogen_core.puzzle import Puzzle

    if isinstance(item, Puzzle):
        return [_Source(item.name, item.planning_chain, item.goal, tuple(item.certificate))]
    if isinstance(item, LoadedPuzzle):
        column = {n: i for i, n in enumerate(item.joint_order)}
        certificate = tuple(tuple(s[column[n]] for n in item.chain.joint_order) for s in item.certificate)
        return [_Source(item.name, item.chain, item.goal, certificate)]
    if isinstance(item, PuzzleFolder):
        item = item.path
    if not isinstance(item, str | Path):
        raise ValueError(f"cannot make a puzzle of {type(item).__name__} {item!r}: give a puzzle folder, a dataset "
                         "root, a Puzzle or a LoadedPuzzle")
    try:
        folders = find_puzzle_folders(item)
    except FileNotFoundError as exc:
        raise ValueError(str(exc)) from None
    return [s for folder in folders for s in _sources_of(read_puzzle_dir(folder.path))]


def _generated(generator: str, puzzle_seed: Any, params: Any) -> list[_Source]:
    from phyrogen_core.registry import all_generators
    from solver.pipelines.generation import Job, run_jobs

    known = all_generators()
    if generator not in known:
        raise ValueError(f"unknown generator {generator!r}; valid: {', '.join(known)}")
    seeds = [puzzle_seed] if isinstance(puzzle_seed, int | np.integer) else puzzle_seed
    if seeds is None or isinstance(seeds, str) or not isinstance(seeds, Sequence | range) or not seeds or not all(
            isinstance(s, int | np.integer) and not isinstance(s, bool) for s in seeds):
        raise ValueError(f"generator= needs puzzle_seed=<int or non-empty list of ints>, got {puzzle_seed!r}")
    if params is None or isinstance(params, Mapping):
        overrides = {str(k): str(v) for k, v in (params or {}).items()}
        jobs = [Job(generator, int(s), overrides) for s in seeds]
    else:  # the generator's parameter dataclass
        jobs = [Job(generator, int(s), {}, params) for s in seeds]
    reports = list(run_jobs(jobs, workers=min(2, len(jobs))))
    failed = [f"seed {r.seed}: {r.error.splitlines()[0]}" for r in reports if r.error is not None or r.puzzle is None]
    if failed:
        raise ValueError(f"generator {generator!r} failed: {'; '.join(failed)}")
    return [_Source(r.puzzle.name, r.puzzle.planning_chain, r.puzzle.goal, tuple(r.puzzle.certificate))
            for r in reports]


class _Catalog:
    """The puzzles of an environment, their shared spaces, and their tasks (compiled on first use)."""

    def __init__(self, puzzle: Any, generator: str | None, puzzle_seed: Any, params: Any, *, reward: str,
                 action_mode: str, on_collision: str, max_episode_steps: int | None, max_move: float, resolution: float,
                 max_joints: int | None):
        for label, value, valid in (("reward", reward, REWARDS), ("action_mode", action_mode, ACTION_MODES),
                                    ("on_collision", on_collision, ON_COLLISION)):
            if value not in valid:
                raise ValueError(f"{label} must be one of {', '.join(map(repr, valid))}, got {value!r}")
        if max_episode_steps is not None and (isinstance(max_episode_steps, bool) or not isinstance(
                max_episode_steps, int | np.integer) or max_episode_steps < 1):
            raise ValueError(f"max_episode_steps must be an int >= 1 or None (no limit), got {max_episode_steps!r}")
        for label, value in (("max_move", max_move), ("resolution", resolution)):
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{label} must be a finite number of metres > 0, got {value!r}")
        self.sources = _as_sources(puzzle, generator, puzzle_seed, params)
        self.names = [s.name for s in self.sources]
        needed = max(len(s.free_joints()) for s in self.sources)
        if max_joints is not None and (not isinstance(max_joints, int) or max_joints < needed):
            raise ValueError(f"max_joints must be an int >= {needed} (the largest puzzle's joints), got {max_joints!r}")
        self.size = needed if max_joints is None else max_joints
        self.objects = max(len({s.chain.object_of_joint(j) for j in s.free_joints()}) for s in self.sources)
        self.reward, self.action_mode, self.on_collision = reward, action_mode, on_collision
        # No limit: a step count no episode reaches.
        self.step_limit = np.iinfo(np.int64).max if max_episode_steps is None else int(max_episode_steps)
        self.max_move, self.resolution = float(max_move), float(resolution)
        self._tasks: dict[int, _Task] = {}

    def task(self, index: int) -> _Task:
        task = self._tasks.get(index)
        if task is None:
            task = self._tasks[index] = _Task(self.sources[index], self.size, self.max_move, self.resolution)
        return task

    def observation_space(self) -> spaces.Box:
        n = self.size
        low = np.zeros(5 * n, dtype=np.float32)
        high = np.ones(5 * n, dtype=np.float32)
        low[: 2 * n] = -1.0
        high[3 * n: 4 * n] = self.objects
        high[4 * n:] = KIND_REVOLUTE
        return spaces.Box(low, high, dtype=np.float32)

    def action_space(self) -> spaces.Space:
        if self.action_mode == "discrete":
            return spaces.Discrete(2 * self.size)
        return spaces.Box(-1.0, 1.0, (self.size,), dtype=np.float32)

    def pick(self, rng: np.random.Generator, options: Mapping[str, Any] | None) -> int:
        """The puzzle of an episode: ``options["puzzle"]`` (index or name) or drawn from ``rng``."""
        if options and options.get("puzzle") is not None:
            chosen = options["puzzle"]
            if isinstance(chosen, str):
                if chosen not in self.names:
                    raise ValueError(f"options['puzzle']={chosen!r} is not a puzzle of this environment; "
                                     f"valid: {', '.join(self.names[:10])}{' ...' if len(self.names) > 10 else ''}")
                return self.names.index(chosen)
            if isinstance(chosen, bool) or not isinstance(chosen, int | np.integer) \
                    or not 0 <= chosen < len(self.sources):
                raise ValueError(f"options['puzzle'] must be a name or an index in [0, {len(self.sources)}), "
                                 f"got {chosen!r}")
            return int(chosen)
        return int(rng.integers(len(self.sources))) if len(self.sources) > 1 else 0


# -- the environment ------------------------------------------------------------------
class PuzzleEnv(gym.Env):
    """One PhyRoGen puzzle per episode, as a Gymnasium environment (``PhyRoGen/Puzzle-v0``).

    **Puzzles.** ``puzzle`` is a puzzle folder, a dataset root (every
    ``<root>/<generator>/<name>/`` under it), a list of folders, or in-memory
    :class:`~phyrogen_core.puzzle.Puzzle` / :class:`~phyrogen_core.export.reader.LoadedPuzzle`
    objects; or ``generator`` with ``puzzle_seed`` (an int or a list of ints,
    generated once, deterministically, in worker processes; ``params`` are the
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

    Only ``position`` changes within an episode.

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
    at the goal). ``terminated`` at the goal; ``truncated`` once
    ``max_episode_steps`` steps (:data:`STEP_LIMIT`; None: no limit) have been taken. Through
    ``gym.make`` the limit is Gymnasium's TimeLimit wrapper instead (the same as
    registered, or ``gym.make(..., max_episode_steps=n)``), since gym.make
    keeps that keyword for itself. Once an episode has ended (terminated, or truncated by the
    environment's own count), ``step()`` raises :class:`gymnasium.error.ResetNeeded` until
    ``reset()`` (or :meth:`set_state`), as Gymnasium's convention asks.

    **Info.** ``puzzle`` (name), ``goal_distance``, ``collided``,
    ``is_success``. For search: :attr:`state` / :meth:`set_state`,
    :attr:`certificate` (the stored solution in :attr:`joint_order`) and
    :meth:`action_towards`.
    """

    metadata = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(self, puzzle: Any = None, *, generator: str | None = None, puzzle_seed: Any = None,
                 params: Any = None, reward: str = "sparse", action_mode: str = "continuous",
                 on_collision: str = "stop", max_episode_steps: int | None = STEP_LIMIT, max_move: float = 0.25,
                 resolution: float = DEFAULT_RESOLUTION, max_joints: int | None = None,
                 render_mode: str | None = None):
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}")
        self._catalog = _Catalog(
            puzzle, generator, puzzle_seed, params, reward=reward, action_mode=action_mode,
            on_collision=on_collision, max_episode_steps=max_episode_steps, max_move=max_move,
            resolution=resolution, max_joints=max_joints)
        catalog = self._catalog
        self.render_mode = render_mode
        self.observation_space = catalog.observation_space()
        self.action_space = catalog.action_space()
        self.size = catalog.size
        self._discrete = catalog.action_mode == "discrete"
        self._stop = catalog.on_collision == "stop"
        self._shaped = catalog.reward == "shaped"
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

    def _write_position(self) -> None:
        np.multiply(self._state - self._task.center, self._task.inv_half, out=self._position)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        self._load(self._catalog.pick(self.np_random, options))
        return self._obs.astype(np.float32), {"puzzle": self._task.name, "goal_distance": self._distance}

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
        self._elapsed += 1
        truncated = self._elapsed >= self._limit
        self._ended = terminated or truncated
        info = {"puzzle": task.name, "goal_distance": distance, "collided": collided, "is_success": terminated}
        return self._obs.astype(np.float32), reward, terminated, truncated, info

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
        return self._obs.astype(np.float32)

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

    def render(self) -> str | None:
        if self.render_mode != "ansi":
            return None
        task = self._task
        lines = [f"{task.name}: step {self._elapsed}, goal distance {self._distance:.4f}"]
        goal = dict(task.goal_pairs)
        for i, name in enumerate(task.joint_order):
            wanted = f"  (goal {goal[i]:.4f})" if i in goal else ""
            lines.append(f"  {name:>14} = {self._state[i]: .4f}  [{task.lower[i]:.3f}, {task.upper[i]:.3f}]{wanted}")
        return "\n".join(lines)


# -- many copies, one kernel call per step ------------------------------------------
class PuzzleVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`PuzzleEnv` stepped together (``gym.make_vec(..., vectorization_mode=
    "vector_entry_point")``).

    The same spaces, rewards and rules as :class:`PuzzleEnv` (every keyword is
    passed on), and the same results on the same actions and seeds as a
    ``SyncVectorEnv`` of them: ``reset(seed=s)`` seeds copy ``i`` with
    ``s + i``, and a copy that ended is reset on its next step (next-step
    autoreset; that step's action is ignored). A step checks every copy's
    motion in one call of the batched collision kernel per puzzle in play, so
    it is fastest when the copies share few puzzles.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    _moves = "motion_ends"
    """The collision model's batched move: ``motion_ends``, or ``motion_stops`` (the same states, found
    by testing every sample), kept for comparisons (tests, ``benchmarks/env_speed.py --old-kernel``)."""

    def __init__(self, num_envs: int = 8, puzzle: Any = None, *, generator: str | None = None,
                 puzzle_seed: Any = None, params: Any = None, reward: str = "sparse", action_mode: str = "continuous",
                 on_collision: str = "stop", max_episode_steps: int | None = STEP_LIMIT, max_move: float = 0.25,
                 resolution: float = DEFAULT_RESOLUTION, max_joints: int | None = None,
                 render_mode: str | None = None):
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be an int >= 1, got {num_envs!r}")
        if render_mode is not None:
            raise ValueError("PuzzleVectorEnv does not render; use PuzzleEnv(render_mode='ansi')")
        catalog = self._catalog = _Catalog(
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

    def _reset_one(self, i: int, seed: int | None, options: Mapping[str, Any] | None) -> None:
        if seed is not None or self._rngs[i] is None:
            self._rngs[i], _ = seeding.np_random(seed)
        self._load(i, self._catalog.pick(self._rngs[i], options))

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options: dict[str, Any] | None = None):
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


# -- registration ---------------------------------------------------------------------
def _make_registered(**kwargs: Any) -> PuzzleEnv:
    """``gym.make``'s entry point. gym.make takes ``max_episode_steps`` for its own TimeLimit wrapper
    and never passes it on, so the environment keeps no step limit of its own there."""
    kwargs.setdefault("max_episode_steps", None)
    return PuzzleEnv(**kwargs)


_make_registered.metadata = PuzzleEnv.metadata  # type: ignore[attr-defined]  # gym.make reads render modes here

if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point=_make_registered, vector_entry_point=PuzzleVectorEnv,
                 max_episode_steps=STEP_LIMIT)
