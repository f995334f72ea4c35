"""The puzzles of a PhyRoGen environment and their compiled planning problems (:mod:`phyrogen.env`).

A puzzle comes from a folder, a dataset root, an in-memory puzzle or a generator and seeds; each
becomes a :class:`Task`: its planning problem (:func:`solver.planning.problem.problem_for_chain`)
plus every array a step needs, precomputed. :class:`Catalog` holds an environment's puzzles, checks
its options and makes its spaces.
"""

from __future__ import annotations

import math
import multiprocessing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from phyrogen_core.chain import JointType, KinematicChain
from phyrogen_core.puzzle import Goal
from solver.collision.model import CollisionModel
from solver.planning.problem import (
    GOAL_SLACK,
    LOCKED_WIDTH,
    Problem,
    problem_factors,
    problem_for_chain,
)

ENV_ID = "PhyRoGen/Puzzle-v0"

OBSERVATION_BLOCKS = ("position", "goal", "goal_mask", "object", "kind")
"""The observation's blocks, each ``size`` values long (one per joint column), in this order."""

STEP_LIMIT = 500
"""Steps before ``truncated``, by default (through ``gym.make``: its TimeLimit wrapper). At the default
``max_move`` the certificates of the paper's 24 puzzles take 8 to 239 steps (Move N Times 4 the most)."""
REWARDS = ("sparse", "shaped", "guided")
OBSERVATIONS = ("vector", "raster", "geometry")
RASTER_SIZE = 32
"""Cells along each side of the raster observation, by default."""
DEFAULT_PUZZLE_SEED = 1
"""The puzzle ``generator=`` makes when no ``puzzle_seed`` is given: the paper's first seed."""
ACTION_MODES = ("continuous", "discrete")
ON_COLLISION = ("stop", "reject")
KIND_PRISMATIC, KIND_REVOLUTE = 1.0, 2.0


RASTER_CHANNELS = ("fixed", "target", "movable", "goal")
"""The raster observation's channels, in this order: the shapes that never move (walls, frames), the
target object, every other movable object, and the target at its goal."""


def check_options(options: Any) -> None:
    """``reset(options=...)`` must be a mapping or None (Gymnasium's type); anything else is refused by value."""
    if options is not None and not isinstance(options, Mapping):
        raise ValueError(f"reset options must be a dict or None, got {type(options).__name__} {options!r}")


# -- puzzles and their compiled planning problems ------------------------------------
@dataclass(frozen=True)
class Source:
    """One puzzle as the environment needs it: certificate in the chain's joint order."""

    name: str
    chain: KinematicChain
    goal: Goal
    certificate: tuple[tuple[float, ...], ...]

    def free_joints(self) -> list[str]:
        """The joints the problem keeps (zero-width joints are locked, as in :func:`problem_for_chain`)."""
        return [j.name for j in self.chain.active_joints if j.upper - j.lower >= LOCKED_WIDTH]


class Task:
    """A puzzle's planning problem plus everything a step needs, precomputed.

    Arrays named ``*_padded`` have the environment's ``size`` columns (the
    puzzle's ``d`` columns, then zeros); the others have ``d``.
    """

    def __init__(self, source: Source, size: int, max_move: float, resolution: float):
        problem: Problem = problem_for_chain(source.chain, source.goal)
        model: CollisionModel = problem.model
        self.name, self.source = source.name, source
        self.views: dict[Any, Any] = {}  # rasters, images and the certificate guide, made on first use
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


def _as_sources(puzzle: Any, generator: str | None, puzzle_seed: Any, params: Any) -> list[Source]:
    """The puzzles an environment is built from (see :class:`PuzzleEnv` for the accepted inputs)."""
    if generator is not None:
        if puzzle is not None:
            raise ValueError("give either puzzle=(folder, folders, Puzzle) or generator= with puzzle_seed=, not both")
        return _generated(generator, puzzle_seed, params)
    if puzzle_seed is not None or params is not None:
        raise ValueError("puzzle_seed= and params= need generator=; a puzzle folder already fixes its puzzle")
    if puzzle is None:
        raise ValueError("no puzzle: give puzzle=<puzzle folder | dataset root | list of folders> "
                         "or generator=<name> (with puzzle_seed=<int or list of ints>)")
    items = [puzzle] if isinstance(puzzle, str | Path) or not isinstance(puzzle, Sequence) else list(puzzle)
    if not items:
        raise ValueError("puzzle= is an empty list: give at least one puzzle folder")
    out: list[Source] = []
    for item in items:
        out += _sources_of(item)
    return out


def _sources_of(item: Any) -> list[Source]:
    from phyrogen_core.export import read_puzzle_dir
    from phyrogen_core.export.reader import LoadedPuzzle
    from phyrogen_core.folder import PuzzleFolder, find_puzzle_folders
    from phyrogen_core.puzzle import Puzzle

    if isinstance(item, Puzzle):
        return [source_of_puzzle(item)]
    if isinstance(item, LoadedPuzzle):
        column = {n: i for i, n in enumerate(item.joint_order)}
        certificate = tuple(tuple(s[column[n]] for n in item.chain.joint_order) for s in item.certificate)
        return [Source(item.name, item.chain, item.goal, certificate)]
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


def _generated(generator: str, puzzle_seed: Any, params: Any) -> list[Source]:
    from phyrogen_core.registry import all_generators
    from solver.pipelines.generation import Job, _run_job, run_jobs

    known = all_generators()
    if generator not in known:
        raise ValueError(f"unknown generator {generator!r}; valid: {', '.join(known)}")
    if puzzle_seed is None:
        puzzle_seed = DEFAULT_PUZZLE_SEED
    seeds = [puzzle_seed] if isinstance(puzzle_seed, int | np.integer) else puzzle_seed
    if seeds is None or isinstance(seeds, str) or not isinstance(seeds, Sequence | range) or not seeds or not all(
            isinstance(s, int | np.integer) and not isinstance(s, bool) for s in seeds):
        raise ValueError(f"puzzle_seed must be an int or a non-empty list of ints, got {puzzle_seed!r}")
    if params is None or isinstance(params, Mapping):
        overrides = {str(k): str(v) for k, v in (params or {}).items()}
        jobs = [Job(generator, int(s), overrides) for s in seeds]
    else:  # the generator's parameter dataclass
        jobs = [Job(generator, int(s), {}, params) for s in seeds]
    if multiprocessing.current_process().daemon:
        # A daemonic process (a worker of Gymnasium's AsyncVectorEnv, of a multiprocessing.Pool) may not
        # start processes: generate here, one puzzle after another. Each puzzle seeds every random
        # source it uses, so it is the same puzzle as a worker process makes.
        reports = [_run_job(job, None) for job in jobs]
    else:
        reports = list(run_jobs(jobs, workers=min(2, len(jobs))))
    failed = [f"seed {r.seed}: {r.error.splitlines()[0]}" for r in reports if r.error is not None or r.puzzle is None]
    if failed:
        raise ValueError(f"generator {generator!r} failed: {'; '.join(failed)}")
    return [source_of_puzzle(r.puzzle) for r in reports]


def source_of_puzzle(puzzle: Any) -> Source:
    """A generated :class:`~phyrogen_core.puzzle.Puzzle` as an environment's puzzle."""
    return Source(puzzle.name, puzzle.planning_chain, puzzle.goal, tuple(puzzle.certificate))


class Catalog:
    """The puzzles of an environment, their shared spaces, and their tasks (compiled on first use)."""

    def __init__(self, puzzle: Any, generator: str | None, puzzle_seed: Any, params: Any, *, reward: str,
                 action_mode: str, on_collision: str, max_episode_steps: int | None, max_move: float, resolution: float,
                 max_joints: int | None, observation: str = "vector", raster_size: int = RASTER_SIZE,
                 max_objects: int | None = None):
        for label, value, valid in (("reward", reward, REWARDS), ("action_mode", action_mode, ACTION_MODES),
                                    ("on_collision", on_collision, ON_COLLISION),
                                    ("observation", observation, OBSERVATIONS)):
            if value not in valid:
                raise ValueError(f"{label} must be one of {', '.join(map(repr, valid))}, got {value!r}")
        if max_episode_steps is not None and (isinstance(max_episode_steps, bool) or not isinstance(
                max_episode_steps, int | np.integer) or max_episode_steps < 1):
            raise ValueError(f"max_episode_steps must be an int >= 1 or None (no limit), got {max_episode_steps!r}")
        for label, value in (("max_move", max_move), ("resolution", resolution)):
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{label} must be a finite number of metres > 0, got {value!r}")
        if isinstance(raster_size, bool) or not isinstance(raster_size, int | np.integer) \
                or not 4 <= raster_size <= 512:
            raise ValueError(f"raster_size must be an int from 4 to 512 cells, got {raster_size!r}")
        self.observation, self.raster_size = observation, int(raster_size)
        self.sources = _as_sources(puzzle, generator, puzzle_seed, params)
        self.names = [s.name for s in self.sources]
        needed = max(len(s.free_joints()) for s in self.sources)
        if max_joints is not None and (not isinstance(max_joints, int) or max_joints < needed):
            raise ValueError(f"max_joints must be an int >= {needed} (the largest puzzle's joints), got {max_joints!r}")
        self.size = needed if max_joints is None else max_joints
        self.objects = max(len({s.chain.object_of_joint(j) for j in s.free_joints()}) for s in self.sources)
        if max_objects is not None:  # a curriculum's spaces hold the puzzles of its largest level
            self.objects = max(self.objects, int(max_objects))
        self.reward, self.action_mode, self.on_collision = reward, action_mode, on_collision
        # No limit: a step count no episode reaches.
        self.step_limit = np.iinfo(np.int64).max if max_episode_steps is None else int(max_episode_steps)
        self.max_move, self.resolution = float(max_move), float(resolution)
        self._tasks: dict[int, Task] = {}

    def task(self, index: int) -> Task:
        task = self._tasks.get(index)
        if task is None:
            task = self._tasks[index] = Task(self.sources[index], self.size, self.max_move, self.resolution)
        return task

    def observation_space(self) -> spaces.Space:
        """The space of :data:`OBSERVATIONS` mode ``self.observation``."""
        if self.observation == "vector":
            return self.vector_space()
        raster = spaces.Box(0.0, 1.0, (len(RASTER_CHANNELS), self.raster_size, self.raster_size), dtype=np.float32)
        if self.observation == "raster":
            return raster
        return spaces.Dict({"raster": raster, "vector": self.vector_space()})

    def vector_space(self) -> spaces.Box:
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
        check_options(options)
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

