"""PhyRoGen puzzles as Gymnasium environments: ``PhyRoGen/Puzzle-v0`` and ``PhyRoGen/Curriculum-v0``.

Importing this package registers the ids (and a vector entry point), so either
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
needed (:mod:`solver.parallel.pool`); inside a daemonic process (a worker of
Gymnasium's ``AsyncVectorEnv``), which may not start processes, it runs in
the process itself.

Modules: :mod:`~phyrogen.env.puzzles` (puzzles, compiled tasks, spaces),
:mod:`~phyrogen.env.views` (raster observation, image, certificate guide),
:mod:`~phyrogen.env.single` (:class:`PuzzleEnv`), :mod:`~phyrogen.env.vector`
(:class:`PuzzleVectorEnv`), :mod:`~phyrogen.env.curriculum` (:class:`CurriculumEnv`).
``docs/learning.md`` has the observation modes, the curriculum and a reference learner.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from phyrogen.env.curriculum import CURRICULUM_ID, CurriculumEnv, CurriculumSchedule
from phyrogen.env.puzzles import (
    ENV_ID,
    OBSERVATION_BLOCKS,
    OBSERVATIONS,
    RASTER_CHANNELS,
    RASTER_SIZE,
    REWARDS,
    STEP_LIMIT,
)
from phyrogen.env.single import PuzzleEnv
from phyrogen.env.vector import PuzzleVectorEnv

__all__ = ["CURRICULUM_ID", "ENV_ID", "OBSERVATIONS", "OBSERVATION_BLOCKS", "RASTER_CHANNELS", "RASTER_SIZE",
           "REWARDS", "STEP_LIMIT", "CurriculumEnv", "CurriculumSchedule", "PuzzleEnv", "PuzzleVectorEnv"]


def _make_registered(**kwargs: Any) -> PuzzleEnv:
    """``gym.make``'s entry point. gym.make takes ``max_episode_steps`` for its own TimeLimit wrapper
    and never passes it on, so the environment keeps no step limit of its own there."""
    kwargs.setdefault("max_episode_steps", None)
    return PuzzleEnv(**kwargs)


_make_registered.metadata = PuzzleEnv.metadata  # type: ignore[attr-defined]  # gym.make reads render modes here

if ENV_ID not in gym.registry:
    # No OrderEnforcing wrapper: the environment is defined from construction (the first puzzle at its
    # start state), so render() before the first reset shows it, as RecordVideo and a first look want;
    # the environment itself raises ResetNeeded for a step after an episode's end.
    gym.register(id=ENV_ID, entry_point=_make_registered, vector_entry_point=PuzzleVectorEnv,
                 max_episode_steps=STEP_LIMIT, order_enforce=False)

if CURRICULUM_ID not in gym.registry:
    # The curriculum counts its own steps (an episode's end moves the level), so gym.make adds no TimeLimit.
    gym.register(id=CURRICULUM_ID, entry_point=CurriculumEnv)
