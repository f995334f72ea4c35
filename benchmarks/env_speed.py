"""Environment steps per second on one core: PuzzleEnv, SyncVectorEnv of it, and the batched PuzzleVectorEnv.

    python benchmarks/env_speed.py [--seconds 2] [--num-envs 256] [--seed 1] [--figure env_speed.png]

For Grid World, Continuous Space and Rooms (puzzle ``--seed`` of each, with
default parameters) it runs uniformly random actions for ``--seconds`` each:

- ``single``: one :class:`phyrogen.env.PuzzleEnv`, continuous actions (the goal: 50,000 steps per CPU
  second on Grid World);
- ``single, discrete``: the same with ``action_mode="discrete"`` (one joint per step);
- ``SyncVectorEnv``: Gymnasium's own vectorization of ``--sync-envs`` PuzzleEnvs;
- ``batched``: :class:`phyrogen.env.PuzzleVectorEnv` with ``--num-envs`` copies, one kernel call per step
  (the goal: 500,000 steps per CPU second on Grid World);
- ``every sample``: the same with the collision model's earlier batched move, which tests every sample
  of every move (``motion_stops``; the same states, bit for bit), for the ratio ``batch/every``
  measured in the same run;

and prints env steps per CPU second (a vector step of N copies counts N; the
process's CPU time, so other work on the machine changes it little), the
batched form's ratio to ``single`` measured in the same run, the share of
single-env steps that collided, and the collision model's single-state
checks per CPU second (``is_valid``) for scale; then the same rates per wall-clock
second, and the load: the load average before and after, the share of the
cores other work used, and BUSY when that share was above a quarter
(``benchmarks/machine_load.py``). Each figure runs for ``--seconds`` of CPU
time; ``--repeat`` keeps the best of several. After generating the puzzles the process pins
itself to one core.
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from machine_load import Measurement, measure, print_load_summary

from phyrogen.env import PuzzleEnv, PuzzleVectorEnv

GENERATORS = ("grid_world", "continuous_space", "rooms")
GOAL = {("grid_world", "single"): 50_000, ("grid_world", "batched"): 500_000}
"""Steps per CPU second on one core."""


@dataclass
class Rate:
    """The best of several runs of one figure: steps per CPU second and per wall second."""

    cpu: float
    wall: float
    measurements: list[Measurement]


def best_of(repeat: int, run) -> tuple[Rate, object]:
    """``run()`` -> (steps, measurement, extra) ``repeat`` times; the run with the most steps per CPU second."""
    best, extra, parts = None, None, []
    for _ in range(repeat):
        steps, taken, more = run()
        parts.append(taken)
        cpu, wall = taken.rates(steps)
        if best is None or cpu > best.cpu:
            best, extra = Rate(cpu, wall, parts), more
    return best, extra


def single_rate(env: PuzzleEnv, actions, seconds: float):
    """(steps, measurement, share of steps that collided)."""
    env.reset(seed=0)
    steps = collided = 0
    with measure() as taken:
        started = time.process_time()
        while time.process_time() - started < seconds:
            for action in actions:
                _, _, terminated, truncated, info = env.step(action)
                collided += info["collided"]
                if terminated or truncated:
                    env.reset()
            steps += len(actions)
    return steps, taken, collided / steps


def vector_rate(envs, actions, seconds: float):
    envs.reset(seed=0)
    steps = 0
    with measure() as taken:
        started = time.process_time()
        while time.process_time() - started < seconds:
            for action in actions:
                envs.step(action)
            steps += len(actions) * envs.num_envs
    return steps, taken, None


def state_checks_rate(env: PuzzleEnv, seconds: float):
    model, state = env.unwrapped._task.model, env.state
    count = 0
    with measure() as taken:
        started = time.process_time()
        while time.process_time() - started < seconds:
            for _ in range(1000):
                model.is_valid(state)
            count += 1000
    return count, taken, None


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
    ax.axhline(GOAL[("grid_world", "single")], color="grey", linestyle="--", linewidth=0.8,
               label="goal for Grid World, single")
    ax.set_ylim(0, 1.35 * max(max(r.values()) for r in results.values()))
    ax.set_xticks(x, [g.replace("_", " ") for g in results])
    ax.set_ylabel("env steps / CPU s (one core)")
    ax.set_title("PhyRoGen/Puzzle-v0, random actions", fontsize=10)
    ax.legend(fontsize=7, loc="upper left", ncols=3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="CPU seconds per measurement")
    parser.add_argument("--repeat", type=int, default=1, help="measurements per figure; the best is kept")
    parser.add_argument("--num-envs", type=int, default=256, help="copies in the batched vector env")
    parser.add_argument("--sync-envs", type=int, default=16, help="copies in the SyncVectorEnv")
    parser.add_argument("--seed", type=int, default=1, help="each generator's puzzle seed")
    parser.add_argument("--figure", help="write a PNG bar chart here (steps per CPU second)")
    args = parser.parse_args()

    import phyrogen

    puzzles = {g: phyrogen.generate(g, args.seed) for g in GENERATORS}  # worker processes: before pinning
    print(f"{pin_to_one_core()}; {args.seconds:g} CPU s per figure, best of {args.repeat}; random actions in [-1, 1]")
    rng = np.random.default_rng(0)
    results: dict[str, dict[str, Rate]] = {}
    parts: list[Measurement] = []
    header = (f"{'generator':<17} {'joints':>6} {'single':>9} {'collided':>8} {'discrete':>9} "
              f"{'sync x' + str(args.sync_envs):>10} {'batch x' + str(args.num_envs):>11} {'batch/single':>12} "
              f"{'every sample':>12} {'batch/every':>11} {'states/s':>9}")
    for name, puzzle in puzzles.items():
        env = PuzzleEnv(puzzle)
        size = env.size
        single, collided = best_of(args.repeat, lambda e=env, s=size: single_rate(
            e, rng.uniform(-1, 1, (4096, s)).astype(np.float32), args.seconds))
        discrete_env = PuzzleEnv(puzzle, action_mode="discrete")
        discrete, _ = best_of(args.repeat, lambda e=discrete_env, s=size: single_rate(
            e, rng.integers(0, 2 * s, 4096), args.seconds))
        sync = gym.vector.SyncVectorEnv([lambda p=puzzle: PuzzleEnv(p) for _ in range(args.sync_envs)])
        sync_rate, _ = best_of(args.repeat, lambda s=size, v=sync: vector_rate(
            v, rng.uniform(-1, 1, (64, args.sync_envs, s)).astype(np.float32), args.seconds))
        batch = PuzzleVectorEnv(args.num_envs, puzzle)
        batch_rate, _ = best_of(args.repeat, lambda s=size, v=batch: vector_rate(
            v, rng.uniform(-1, 1, (16, args.num_envs, s)).astype(np.float32), args.seconds))
        every = PuzzleVectorEnv(args.num_envs, puzzle)
        every._moves = "motion_stops"
        every_rate, _ = best_of(args.repeat, lambda s=size, v=every: vector_rate(
            v, rng.uniform(-1, 1, (16, args.num_envs, s)).astype(np.float32), args.seconds))
        states, _ = best_of(args.repeat, lambda e=env: state_checks_rate(e, args.seconds / 2))
        results[name] = {"single": single, "discrete": discrete, "sync": sync_rate, "batched": batch_rate,
                         "every": every_rate, "states": states, "collided": collided, "size": size}
        for rate in (single, discrete, sync_rate, batch_rate, every_rate, states):
            parts += rate.measurements
    for clock in ("cpu", "wall"):
        print(f"per {'CPU' if clock == 'cpu' else 'wall-clock'} second:")
        print(header)
        for name, r in results.items():
            v = {k: getattr(r[k], clock) for k in ("single", "discrete", "sync", "batched", "every", "states")}
            print(f"{name:<17} {r['size']:>6} {v['single']:>9,.0f} {r['collided']:>8.0%} {v['discrete']:>9,.0f} "
                  f"{v['sync']:>10,.0f} {v['batched']:>11,.0f} {v['batched'] / v['single']:>11.1f}x "
                  f"{v['every']:>12,.0f} {v['batched'] / v['every']:>10.2f}x {v['states']:>9,.0f}")
    print_load_summary(parts)
    for (name, kind), goal in GOAL.items():
        rate = results[name][kind].cpu
        verdict = "meets" if rate >= goal else "MISSES"
        print(f"{name}: {kind} {rate:,.0f} steps per CPU second {verdict} the {goal:,} goal")
    if args.figure:
        write_figure(args.figure, {g: {k: r[k].cpu for k in ("single", "discrete", "sync", "batched")}
                                   for g, r in results.items()}, args.num_envs, args.sync_envs)
        print(f"figure: {args.figure}")


if __name__ == "__main__":  # generation runs in worker processes, which re-import this file
    main()
