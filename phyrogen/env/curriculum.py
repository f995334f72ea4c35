"""A curriculum: each episode a fresh certified puzzle whose size follows the learner's recent success.

``PhyRoGen/Curriculum-v0`` (:class:`CurriculumEnv`) draws every episode's puzzle from a generator at
the current *level*, a value of one of the generator's size knobs (``n_objects`` of Grid World, ``n``
of Move N Times, ...). After each finished episode the level moves by
:class:`CurriculumSchedule`: up one when the success rate over the last ``window`` episodes at this level
is at or above ``raise_above``, down one when it is at or below ``lower_below`` (the paper's future work:
"online learning, where the difficulty of environments is adjusted based on the progress of the
robot"; a success-threshold rule, the simplest of the curricula PAIRED and ACCEL compare against).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from phyrogen.env.puzzles import RASTER_SIZE, check_options
from phyrogen.env.single import PuzzleEnv

CURRICULUM_ID = "PhyRoGen/Curriculum-v0"
GENERATION_TRIES = 16
"""Seeds a draw tries at one level before it gives up (a seed that cannot be generated is skipped)."""
CACHED_PUZZLES = 4096
"""Puzzles (compiled environments) a curriculum keeps; the oldest made is dropped beyond."""


@dataclass(frozen=True)
class CurriculumSchedule:
    """When the level moves: a pure rule over the outcomes of the episodes played at the current level."""

    levels: tuple[int, ...]
    window: int = 16
    raise_above: float = 0.7
    lower_below: float = 0.2

    def __post_init__(self) -> None:
        if not self.levels or not all(isinstance(v, int) and not isinstance(v, bool) for v in self.levels):
            raise ValueError(f"levels must be a non-empty sequence of ints (the knob's values), got {self.levels!r}")
        if isinstance(self.window, bool) or not isinstance(self.window, int) or self.window < 1:
            raise ValueError(f"window must be an int >= 1 (episodes), got {self.window!r}")
        if not 0.0 <= self.lower_below < self.raise_above <= 1.0:
            raise ValueError(f"need 0 <= lower_below < raise_above <= 1, got lower_below={self.lower_below!r}, "
                             f"raise_above={self.raise_above!r}")

    def next_level(self, level: int, outcomes: Sequence[bool]) -> int:
        """The level index after ``outcomes`` (successes, oldest first) at level index ``level``."""
        if len(outcomes) < self.window:
            return level
        rate = sum(outcomes[-self.window:]) / self.window
        if rate >= self.raise_above and level + 1 < len(self.levels):
            return level + 1
        if rate <= self.lower_below and level > 0:
            return level - 1
        return level


class CurriculumEnv(gym.Env):
    """Puzzles of ``generator`` whose ``knob`` follows the learner (``PhyRoGen/Curriculum-v0``).

    **Puzzles.** At every reset, a seed drawn from ``puzzle_seed`` (a list of ints: a fixed training set,
    Procgen's N levels; drawn from the environment's seeded ``np_random``) at the current level,
    ``params`` plus ``{knob: level}``. A puzzle is generated in this process by the certified pipeline
    (:func:`solver.pipelines.generation.generate_here`) the first time it is drawn and kept
    (:data:`CACHED_PUZZLES`): 0.04-0.05 CPU seconds for a Grid World of 1-3 objects on the 2-core
    development machine, more for large puzzles, so a reset that meets a new puzzle pauses its vector
    env's step that long. ``pregenerate=True`` makes every (level, seed) puzzle at construction
    instead. A seed whose generation fails (the generator refuses the size, or no certificate holds) is
    remembered and another is drawn, up to :data:`GENERATION_TRIES`; then the reset raises RuntimeError
    naming the level.

    **Spaces** are those of :class:`~phyrogen.env.single.PuzzleEnv` with ``observation``, padded to
    ``max_joints`` joints (default: the joints of the first puzzle of the largest level; a puzzle that
    needs more is skipped as a failed one) so that every level shares them.

    **Episodes** end at the goal (``terminated``, a success) or after ``max_episode_steps`` steps
    (``truncated``, a failure); then :class:`CurriculumSchedule` moves the level, and its outcomes
    restart. ``info`` adds ``level`` (the knob's value), ``level_index``, ``knob`` and
    ``generation_failures`` (seeds skipped so far). Each copy of a vector env keeps its own level.
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}

    def __init__(self, generator: str = "grid_world", *, knob: str = "n_objects", levels: Sequence[int] = (1, 2, 3),
                 puzzle_seed: Sequence[int] = range(100), params: Mapping[str, Any] | None = None,
                 window: int = 16, raise_above: float = 0.7, lower_below: float = 0.2, start_level: int = 0,
                 observation: str = "geometry", raster_size: int = RASTER_SIZE, reward: str = "guided",
                 action_mode: str = "continuous", on_collision: str = "stop", max_episode_steps: int = 100,
                 max_move: float = 0.25, max_joints: int | None = None, pregenerate: bool = False,
                 render_mode: str | None = None):
        from phyrogen_core.registry import all_generators

        self.schedule = CurriculumSchedule(tuple(levels), window, raise_above, lower_below)
        if generator not in all_generators():
            raise ValueError(f"unknown generator {generator!r}; valid: {', '.join(all_generators())}")
        seeds = list(puzzle_seed) if isinstance(puzzle_seed, Sequence) and not isinstance(puzzle_seed, str) else None
        if not seeds or not all(isinstance(s, int | np.integer) and not isinstance(s, bool) for s in seeds):
            raise ValueError(f"puzzle_seed must be a non-empty list of ints, got {puzzle_seed!r}")
        if isinstance(start_level, bool) or not isinstance(start_level, int) \
                or not 0 <= start_level < len(self.schedule.levels):
            raise ValueError(f"start_level must be an index into levels {self.schedule.levels}, got {start_level!r}")
        if isinstance(max_episode_steps, bool) or not isinstance(max_episode_steps, int) or max_episode_steps < 1:
            raise ValueError(f"max_episode_steps must be an int >= 1, got {max_episode_steps!r}")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.generator, self.knob, self.render_mode = generator, knob, render_mode
        self._seeds = [int(s) for s in seeds]
        self._params = {str(k): str(v) for k, v in (params or {}).items()}
        self._env_kwargs = dict(observation=observation, raster_size=raster_size, reward=reward,
                                action_mode=action_mode, on_collision=on_collision, max_episode_steps=None,
                                max_move=max_move, render_mode=render_mode)
        self._limit = max_episode_steps
        self._made: dict[tuple[int, int], PuzzleEnv] = {}
        self._failed: set[tuple[int, int]] = set()
        self.level_index = start_level
        self._outcomes: list[bool] = []
        self.max_joints = max_joints
        if max_joints is None:
            top = len(self.schedule.levels) - 1
            self.max_joints = self._first_working(top).size
        elif isinstance(max_joints, bool) or not isinstance(max_joints, int) or max_joints < 1:
            raise ValueError(f"max_joints must be an int >= 1 or None, got {max_joints!r}")
        if pregenerate:
            for level in range(len(self.schedule.levels)):
                for seed in self._seeds:
                    self._puzzle(level, seed)
        self._env = self._first_working(self.level_index)
        self.observation_space = self._env.observation_space
        self.action_space = self._env.action_space
        self._elapsed = 0
        self._ended = False

    # -- puzzles ----------------------------------------------------------------
    def _puzzle(self, level: int, seed: int) -> PuzzleEnv | None:
        """The environment of puzzle ``seed`` at level index ``level``, made once; None if it cannot be."""
        key = (level, seed)
        if key in self._failed:
            return None
        env = self._made.get(key)
        if env is not None:
            return env
        from phyrogen_core.maker import GenerationError
        from phyrogen_core.registry import ParameterError, get_generator
        from solver.pipelines.generation import generate_here

        overrides = {**self._params, self.knob: str(self.schedule.levels[level])}
        try:
            params = get_generator(self.generator).parse_params(overrides)
            puzzle = generate_here(self.generator, seed, params)
            env = PuzzleEnv(puzzle, max_joints=self.max_joints, max_objects=self.max_joints, **self._env_kwargs)
        except (GenerationError, ParameterError, ValueError):
            # ValueError: more joints than max_joints. The seed is skipped, as one that failed.
            self._failed.add(key)
            return None
        if len(self._made) >= CACHED_PUZZLES:
            self._made.pop(next(iter(self._made)))
        self._made[key] = env
        return env

    def _first_working(self, level: int) -> PuzzleEnv:
        for seed in self._seeds[:GENERATION_TRIES]:
            env = self._puzzle(level, seed)
            if env is not None:
                return env
        raise RuntimeError(f"{self.generator}: no puzzle at {self.knob}={self.schedule.levels[level]} among seeds "
                           f"{self._seeds[:GENERATION_TRIES]}")

    def _draw(self) -> PuzzleEnv:
        for _ in range(GENERATION_TRIES):
            seed = self._seeds[int(self.np_random.integers(len(self._seeds)))]
            env = self._puzzle(self.level_index, seed)
            if env is not None:
                return env
        raise RuntimeError(f"{self.generator}: {GENERATION_TRIES} draws at {self.knob}="
                           f"{self.schedule.levels[self.level_index]} gave no puzzle that could be generated")

    # -- the episode ------------------------------------------------------------
    @property
    def level(self) -> int:
        """The knob's current value."""
        return self.schedule.levels[self.level_index]

    @property
    def puzzle_env(self) -> PuzzleEnv:
        """The current puzzle's environment (for its certificate, :meth:`PuzzleEnv.action_towards`, state)."""
        return self._env

    def record(self, success: bool) -> None:
        """Count an episode's outcome at the current level and move the level as the schedule says."""
        self._outcomes.append(bool(success))
        level = self.schedule.next_level(self.level_index, self._outcomes)
        if level != self.level_index:
            self.level_index = level
            self._outcomes = []

    def _info(self, info: dict[str, Any]) -> dict[str, Any]:
        return {**info, "level": self.level, "level_index": self.level_index, "knob": self.knob,
                "generation_failures": len(self._failed)}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        check_options(options)
        self._env = self._draw()
        self._elapsed, self._ended = 0, False
        obs, info = self._env.reset(seed=int(self.np_random.integers(2**31)))
        return obs, self._info(info)

    def step(self, action):
        if self._ended:
            raise gym.error.ResetNeeded("CurriculumEnv.step() after the episode ended: call reset() first")
        obs, reward, terminated, _, info = self._env.step(action)
        self._elapsed += 1
        truncated = not terminated and self._elapsed >= self._limit
        info = self._info(info)  # the level the episode was played at
        if terminated or truncated:
            self._ended = True
            self.record(terminated)
        return obs, reward, terminated, truncated, info

    def render(self):
        return self._env.render()
