"""The learning protocol's pieces that need no learning library: puzzle sets, environments, evaluation,
the random agent and the planner's row (``scripts/train.py`` adds Stable-Baselines3's PPO; see
``docs/learning.md``).

Procgen's protocol on PhyRoGen puzzles: train on a fixed set of puzzle seeds (or on a curriculum over
sizes), evaluate each policy once per held-out seed never trained on, at the training sizes and one
size beyond, and report success rates with Wilson 95 % intervals beside a random agent and a planner.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from phyrogen.env import PuzzleEnv

Policy = Callable[[Any, PuzzleEnv], Any]
"""An agent: (observation, environment) -> action."""


@dataclass(frozen=True)
class EnvSettings:
    """How every environment of one protocol run is made (training, evaluation and curriculum alike)."""

    observation: str = "geometry"
    raster_size: int = 24
    reward: str = "guided"
    action_mode: str = "discrete"
    max_episode_steps: int = 80
    max_joints: int = 4

    def kwargs(self) -> dict[str, Any]:
        """Keywords for :class:`PuzzleEnv` (spaces padded to ``max_joints`` joints and objects)."""
        return dict(observation=self.observation, raster_size=self.raster_size, reward=self.reward,
                    action_mode=self.action_mode, max_episode_steps=self.max_episode_steps,
                    max_joints=self.max_joints, max_objects=self.max_joints)


@dataclass(frozen=True)
class Outcome:
    """One evaluation episode."""

    puzzle: str
    size: int
    success: bool
    steps: int


def generate_set(generator: str, knob: str, sizes: Sequence[int], seeds: Sequence[int],
                 on_error: Callable[[str], None] | None = None) -> dict[int, list[Any]]:
    """Certified puzzles for every size and seed: {size: [Puzzle, ...]}. Made in this process, one after
    another (a Grid World of 2-4 objects takes 0.04-0.06 CPU seconds; a worker process per puzzle would
    cost more to start than to run); each is the same puzzle as ``phyrogen generate`` makes. A seed the
    generator cannot make at a size is left out of that size and passed to ``on_error``."""
    from phyrogen_core.maker import GenerationError
    from phyrogen_core.registry import ParameterError, get_generator
    from solver.pipelines.generation import generate_here

    spec = get_generator(generator)
    out: dict[int, list[Any]] = {size: [] for size in sizes}
    for size in sizes:
        params = spec.parse_params({knob: str(size)})
        for seed in seeds:
            try:
                out[size].append(generate_here(generator, int(seed), params))
            except (GenerationError, ParameterError) as exc:
                if on_error is not None:
                    on_error(f"{generator} seed {seed} at {knob}={size}: {str(exc).splitlines()[0]}")
    return out


def evaluate(policy: Policy, puzzles: Sequence[Any], size_of: Callable[[Any], int], settings: EnvSettings,
             seed: int = 0) -> list[Outcome]:
    """One episode of ``policy`` on each puzzle (in order), from its start; the environment's
    ``np_random`` seeded with ``seed`` (a stochastic policy draws from its own generator)."""
    if not puzzles:
        return []
    env = PuzzleEnv(list(puzzles), **settings.kwargs())
    outcomes = []
    for index, puzzle in enumerate(puzzles):
        obs, _ = env.reset(seed=seed + index, options={"puzzle": index})
        steps, success = 0, False
        while True:
            obs, _, terminated, truncated, _ = env.step(policy(obs, env))
            steps += 1
            if terminated or truncated:
                success = bool(terminated)
                break
        outcomes.append(Outcome(puzzle.name, size_of(puzzle), success, steps))
    return outcomes


def random_policy(seed: int) -> Policy:
    """Uniform random actions from the environment's action space, drawn from ``seed``."""
    rng = np.random.default_rng(seed)

    def act(_obs: Any, env: PuzzleEnv) -> Any:
        space = env.action_space
        if hasattr(space, "n"):
            return int(rng.integers(space.n))
        return rng.uniform(space.low, space.high).astype(space.dtype)

    return act


def planner_outcomes(puzzles: Sequence[Any], size_of: Callable[[Any], int], budget_checks: int,
                     seed: int = 0) -> list[Outcome]:
    """LA-RRT (the paper's settings) on each puzzle until its first solution or ``budget_checks``
    collision queries: the protocol's upper bound (it searches; the agents act once per step).
    ``steps`` holds the queries spent."""
    from solver.planning.la_rrt import PAPER_SETTINGS, la_rrt_within
    from solver.planning.problem import problem_for_chain

    outcomes = []
    for index, puzzle in enumerate(puzzles):
        problem = problem_for_chain(puzzle.planning_chain, puzzle.goal)
        result, queries = la_rrt_within(problem, budget_checks, np.random.default_rng(seed + index), PAPER_SETTINGS)
        outcomes.append(Outcome(puzzle.name, size_of(puzzle), result.solved, queries))
    return outcomes


def success_row(outcomes: Sequence[Outcome]) -> tuple[int, int, float, float]:
    """(successes, runs, Wilson 95 % low, high)."""
    from solver.benchmark.statistics import wilson_interval

    wins = sum(o.success for o in outcomes)
    interval = wilson_interval(wins, len(outcomes))
    return wins, len(outcomes), interval.low, interval.high
