"""Environment steps per second on one core: PuzzleEnv, SyncVectorEnv of it, and the batched PuzzleVectorEnv.

    python benchmarks/env_speed.py [--seconds 2] [--num-envs 256] [--seed 1] [--figure env_speed.png]

For Grid World, Continuous Space and Rooms (puzzle ``--seed`` of each, with
default parameters) it runs uniformly random actions for ``--seconds`` each:

- ``single``: one :class:`phyrogen.env.PuzzleEnv`, continuous actions (the goal: 20,000 steps/s on Grid World);
- ``single, discrete``: the same with ``action_mode="discrete"`` (one joint per step);
- ``SyncVectorEnv``: Gymnasium's own vectorization of ``--sync-envs`` PuzzleEnvs;
- ``batched``: :class:`phyrogen.env.PuzzleVectorEnv` with ``--num-envs`` copies, one kernel call per step;

and prints env steps per second (a vector step of N copies counts N), the
batched form's ratio to ``single`` measured in the same run, the share of
single-env steps that collided, and the collision model's single-state
checks per second (``is_valid``) for scale. After generating the puzzles the process pins itself to one core.
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import numpy as np

from phyrogen.env import PuzzleEnv, PuzzleVectorEnv

GENERATORS = ("grid_world", "continuous_space", "rooms")
GOAL = {"grid_world": 20_000}


def single_rate(env: PuzzleEnv, actions, seconds: float) -> tuple[float, float]:
    """Steps per second and the share of steps that collided."""
    env.reset(seed=0)
    steps = collided = 0
    started = time.perf_counter()
    while True:
        for action in actions:
            _, _, terminated, truncated, info = env.step(action)
            collided += info["collided"]
            if terminated or truncated:
                env.reset()
        steps += len(actions)
        elapsed = time.perf_counter() - started
        if elapsed >= seconds:
            return steps / elapsed, collided / steps


def vector_rate(envs, actions, seconds: float) -> float:
    envs.reset(seed=0)
    steps = 0
    started = time.perf_counter()
    while True:
        for action in actions:
            envs.step(action)
        steps += len(actions) * envs.num_envs
        elapsed = time.perf_counter() - started
        if elapsed >= seconds:
            return steps / elapsed


def state_checks_rate(env: PuzzleEnv, seconds: float) -> float:
    model, state = env.unwrapped._task.model, env.state
    count = 0
    started = time.perf_counter()
    while time.perf_counter() - started < seconds:
        for _ in range(1000):
            model.is_valid(state)
        count += 1000
    return count / (time.perf_counter() - started)


def pin_to_one_core() -> str:
    if not hasattr(os, "sched_setaffinity"):
        return "not pinned (no sched_setaffinity here)"
    core = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    return f"pinned to core {core}"


def write_figure(path: str, results: dict[str, dict[str, float]], num_envs: int, sync_envs: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = [("single", "PuzzleEnv"), ("discrete", "PuzzleEnv, discrete"),
             ("sync", f"SyncVectorEnv ({sync_envs})"), ("batched", f"PuzzleVectorEnv ({num_envs})")]
    fig, ax = plt.subplots(figsize=(7.0, 3.6))
    width = 0.8 / len(kinds)
    x = np.arange(len(results))
    for k, (key, label) in enumerate(kinds):
        values = [results[g][key] for g in results]
        bars = ax.bar(x + (k - (len(kinds) - 1) / 2) * width, values, width, label=label)
        ax.bar_label(bars, labels=[f"{v / 1000:.0f}k" for v in values], fontsize=7)
    ax.axhline(GOAL["grid_world"], color="grey", linestyle="--", linewidth=0.8,
               label="goal for Grid World, single")
    ax.set_ylim(0, 1.35 * max(max(r.values()) for r in results.values()))
    ax.set_xticks(x, [g.replace("_", " ") for g in results])
    ax.set_ylabel("env steps / s (one core)")
    ax.set_title("PhyRoGen/Puzzle-v0, random actions", fontsize=10)
    ax.legend(fontsize=7, loc="upper left", ncols=3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="per measurement")
    parser.add_argument("--num-envs", type=int, default=256, help="copies in the batched vector env")
    parser.add_argument("--sync-envs", type=int, default=16, help="copies in the SyncVectorEnv")
    parser.add_argument("--seed", type=int, default=1, help="each generator's puzzle seed")
    parser.add_argument("--figure", help="write a PNG bar chart here")
    args = parser.parse_args()

    import phyrogen

    puzzles = {g: phyrogen.generate(g, args.seed) for g in GENERATORS}  # worker processes: before pinning
    print(f"{pin_to_one_core()}; {args.seconds:g} s per figure; random actions in [-1, 1]")
    rng = np.random.default_rng(0)
    results: dict[str, dict[str, float]] = {}
    header = (f"{'generator':<17} {'joints':>6} {'single':>9} {'collided':>8} {'discrete':>9} "
              f"{'sync x' + str(args.sync_envs):>10} {'batch x' + str(args.num_envs):>11} {'batch/single':>12} "
              f"{'states/s':>9}")
    print(header)
    for name, puzzle in puzzles.items():
        env = PuzzleEnv(puzzle)
        size = env.size
        single, collided = single_rate(env, rng.uniform(-1, 1, (4096, size)).astype(np.float32), args.seconds)
        discrete_env = PuzzleEnv(puzzle, action_mode="discrete")
        discrete, _ = single_rate(discrete_env, rng.integers(0, 2 * size, 4096), args.seconds)
        sync = gym.vector.SyncVectorEnv([lambda p=puzzle: PuzzleEnv(p) for _ in range(args.sync_envs)])
        sync_rate = vector_rate(sync, rng.uniform(-1, 1, (64, args.sync_envs, size)).astype(np.float32), args.seconds)
        batch = PuzzleVectorEnv(args.num_envs, puzzle)
        batch_rate = vector_rate(batch, rng.uniform(-1, 1, (16, args.num_envs, size)).astype(np.float32),
                                 args.seconds)
        states = state_checks_rate(env, args.seconds / 2)
        results[name] = {"single": single, "discrete": discrete, "sync": sync_rate, "batched": batch_rate}
        print(f"{name:<17} {size:>6} {single:>9,.0f} {collided:>8.0%} {discrete:>9,.0f} {sync_rate:>10,.0f} "
              f"{batch_rate:>11,.0f} {batch_rate / single:>11.1f}x {states:>9,.0f}")
    for name, goal in GOAL.items():
        verdict = "meets" if results[name]["single"] >= goal else "MISSES"
        print(f"{name}: single env {results[name]['single']:,.0f} steps/s {verdict} the {goal:,} steps/s goal")
    if args.figure:
        write_figure(args.figure, results, args.num_envs, args.sync_envs)
        print(f"figure: {args.figure}")


if __name__ == "__main__":  # generation runs in worker processes, which re-import this file
    main()
