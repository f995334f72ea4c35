"""Solve a puzzle through the Gymnasium environment with its stored certificate's actions.

    python docs/examples/solve_with_env.py                          # generates grid_world seed 7
    python docs/examples/solve_with_env.py --generator rooms --seed 3
    python docs/examples/solve_with_env.py --folder output/grid_world/grid_world_7

The certificate is a piecewise-linear joint path; ``action_towards`` turns
"go to the next waypoint" into one bounded action at a time (closed loop, so
rounding never accumulates), and the environment checks every move with the
exact collision model. The episode ends ``terminated`` with reward 1.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import phyrogen.env  # noqa: F401  (registers PhyRoGen/Puzzle-v0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generator", default="grid_world")
    parser.add_argument("--seed", type=int, default=7, help="the puzzle's seed (generation)")
    parser.add_argument("--folder", help="read this puzzle folder instead of generating")
    args = parser.parse_args()
    source = {"puzzle": args.folder} if args.folder else {"generator": args.generator, "puzzle_seed": args.seed}
    env = gym.make("PhyRoGen/Puzzle-v0", max_episode_steps=2000, **source)
    puzzle = env.unwrapped  # PuzzleEnv: certificate, state, action_towards
    obs, info = env.reset(seed=0)
    print(f"{info['puzzle']}: {len(puzzle.joint_order)} joints {puzzle.joint_order}, "
          f"{len(puzzle.certificate) - 1} certificate segments, goal distance {info['goal_distance']:.3f}")
    steps, total, terminated, truncated = 0, 0.0, False, False
    for waypoint in puzzle.certificate[1:]:
        while not (terminated or truncated) and np.abs(puzzle.state - waypoint).max() > 1e-9:
            obs, reward, terminated, truncated, info = env.step(puzzle.action_towards(waypoint))
            steps += 1
            total += reward
    print(f"steps {steps}, reward {total}, terminated {terminated}, truncated {truncated}, "
          f"goal distance {info['goal_distance']:.2e}")
    if not terminated:
        raise SystemExit("the certificate did not reach the goal through the environment")


if __name__ == "__main__":  # importable without running (the workers themselves never run this file)
    main()
