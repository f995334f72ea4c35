"""Train the reference learner (Stable-Baselines3 PPO) on PhyRoGen puzzles and evaluate it on held-out seeds.

The protocol of docs/learning.md, Procgen-style: every arm trains on the same fixed set of puzzle seeds
at the training sizes (``--arms fixed``: geometry raster + vector; ``vector``: the vector alone, the
negative control without geometry; ``curriculum``: PhyRoGen/Curriculum-v0 over the same seeds, from the
size below the training sizes up), then plays each held-out seed once at the training sizes and at one
size beyond, beside a random agent and LA-RRT. Everything is drawn from ``--seed``: the same command
gives the same numbers on the same machine (PyTorch on one thread).

    .venv/bin/python scripts/train.py --out output/learning              # the protocol (docs/learning.md)
    .venv/bin/python scripts/train.py --arms fixed --steps 20000 --out output/quick

Writes ``<out>/results.json`` (every outcome, the curves, CPU seconds), ``<out>/table.md`` and
``<out>/curves.png``. Needs the ``learning`` extra (``pip install -e .[learning]``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

ARMS = ("fixed", "vector", "curriculum")


class _Parser(argparse.ArgumentParser):
    """argparse, but a bad argument is one line on stderr and exit 2 (the project's contract), not the usage too."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}\n")


def parse(argv: list[str] | None) -> argparse.Namespace:
    p = _Parser(prog="scripts/train.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="folder for results.json, table.md and curves.png")
    p.add_argument("--generator", default="grid_world")
    p.add_argument("--knob", default="n_objects", help="the generator's size parameter")
    p.add_argument("--train-sizes", type=int, nargs="+", default=[2, 3])
    p.add_argument("--train-seeds", type=int, default=200, help="N: puzzle seeds trained on (per size)")
    p.add_argument("--heldout-seeds", type=int, default=100, help="held-out seeds evaluated (per size)")
    p.add_argument("--steps", type=int, default=150_000, help="environment steps per arm")
    p.add_argument("--arms", default=",".join(ARMS), help=f"comma-separated, of {', '.join(ARMS)}")
    p.add_argument("--evals", type=int, default=6, help="points of each learning curve")
    p.add_argument("--curve-puzzles", type=int, default=40, help="held-out puzzles of each curve point")
    p.add_argument("--planner-checks", type=int, default=20_000, help="LA-RRT's budget per puzzle (checks)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--envs", type=int, default=8, help="environment copies per PPO rollout")
    p.add_argument("--raster-size", type=int, default=24)
    p.add_argument("--policy", choices=("cnn", "mlp"), default="cnn",
                   help="the geometry arms' raster encoder: a small CNN, or SB3's flatten + MLP")
    args = p.parse_args(argv)
    bad = [a for a in args.arms.split(",") if a not in ARMS]
    counts = {"--train-seeds": args.train_seeds, "--heldout-seeds": args.heldout_seeds, "--steps": args.steps,
              "--evals": args.evals, "--envs": args.envs, "--curve-puzzles": args.curve_puzzles}
    if bad:
        p.error(f"unknown arm {bad[0]!r}; valid: {', '.join(ARMS)}")
    for flag, value in counts.items():
        if value < 1:
            p.error(f"{flag} must be >= 1, got {value}")
    if min(args.train_sizes) < 1 or args.steps > 10_000_000:
        p.error("--train-sizes must be >= 1 and --steps at most 10,000,000")
    from phyrogen_core.registry import all_generators

    if args.generator not in all_generators():
        p.error(f"unknown generator {args.generator!r}; valid: {', '.join(all_generators())}")
    if not args.out:
        p.error("--out is empty: name a folder")
    if Path(args.out).exists() and not Path(args.out).is_dir():
        p.error(f"--out {args.out!r} is a file")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    import numpy as np
    import torch

    from phyrogen.learning import EnvSettings, evaluate, generate_set, planner_outcomes, random_policy, success_row

    torch.set_num_threads(1)  # reproducible, and fair to a shared machine
    cpu0 = time.process_time()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sizes = sorted(set(args.train_sizes))
    beyond = sizes[-1] + 1
    train_seeds = list(range(1000, 1000 + args.train_seeds))
    heldout_seeds = list(range(50_000, 50_000 + args.heldout_seeds))
    say(f"generating {len(sizes) * len(train_seeds)} training and {(len(sizes) + 1) * len(heldout_seeds)} "
        f"held-out puzzles ({args.generator}, {args.knob} {sizes} and {beyond})")
    train = generate_set(args.generator, args.knob, sizes, train_seeds, say)
    heldout = generate_set(args.generator, args.knob, [*sizes, beyond], heldout_seeds, say)
    every = [p for ps in (*train.values(), *heldout.values()) for p in ps]
    max_joints = max(len(p.planning_chain.active_joints) for p in every)
    settings = EnvSettings(raster_size=args.raster_size, max_joints=max_joints)
    train_list = [p for s in sizes for p in train[s]]
    # The curve's puzzles: held-out ones at the training sizes, alternating sizes.
    curve_set = [p for pair in zip(*(heldout[s] for s in sizes), strict=False) for p in pair][:args.curve_puzzles]
    results = {"commit": commit(), "args": vars(args), "settings": asdict(settings), "sizes": sizes,
               "beyond": beyond, "generated": {"train": {s: len(v) for s, v in train.items()},
                                              "heldout": {s: len(v) for s, v in heldout.items()}},
               "arms": {}, "rows": {}}

    def size(p):
        return int(getattr(p.parameters, args.knob))

    for arm in args.arms.split(","):
        arm_settings = replace(settings, observation="vector") if arm == "vector" else settings
        started = time.process_time()
        policy, curve = train_arm(arm, args, arm_settings, train_list, curve_set, size, sizes)
        outcomes = {"train": evaluate(policy, [p for s in sizes for p in train[s][: args.heldout_seeds]], size,
                                             arm_settings),
                    "heldout": evaluate(policy, [p for s in (*sizes, beyond) for p in heldout[s]], size,
                                        arm_settings)}
        results["arms"][arm] = {"curve": curve, "cpu_seconds": time.process_time() - started,
                                "outcomes": {k: [asdict(o) for o in v] for k, v in outcomes.items()}}
        report(arm, outcomes, sizes, beyond, success_row)
    heldout_all = [p for s in (*sizes, beyond) for p in heldout[s]]
    say("random agent")
    rows = {"random": evaluate(random_policy(args.seed), heldout_all, size, settings)}
    say(f"LA-RRT (paper settings, {args.planner_checks} checks per puzzle)")
    rows["LA-RRT"] = planner_outcomes(heldout_all, size, args.planner_checks, args.seed)
    for name, outcomes in rows.items():
        results["rows"][name] = [asdict(o) for o in outcomes]
        report(name, {"heldout": outcomes}, sizes, beyond, success_row)
    results["cpu_seconds"] = time.process_time() - cpu0 + children_cpu()
    write_whole(out / "results.json", json.dumps(results, indent=1) + "\n")
    write_whole(out / "table.md", table(results, success_row, np) + "\n")
    plot(results, out / "curves.png")
    say(f"wrote {out}/results.json, table.md, curves.png; CPU {results['cpu_seconds']:.0f} s")
    return 0


def train_arm(arm, args, settings, train_list, curve_set, size, sizes):
    """PPO on one arm; (the trained policy, its learning curve [(steps, held-out successes, runs, level)])."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import DummyVecEnv

    from phyrogen.env import CurriculumEnv, PuzzleEnv
    from phyrogen.learning import evaluate

    if arm == "curriculum":
        levels = tuple(sorted({max(1, sizes[0] - 1), *sizes}))
        seeds = sorted({p.seed for p in train_list})

        def make():
            return CurriculumEnv(args.generator, knob=args.knob, levels=levels, puzzle_seed=seeds,
                                 observation=settings.observation, raster_size=settings.raster_size,
                                 reward=settings.reward, action_mode=settings.action_mode,
                                 max_episode_steps=settings.max_episode_steps, max_joints=settings.max_joints)
    else:
        def make():
            return PuzzleEnv(list(train_list), **settings.kwargs())

    venv = DummyVecEnv([make] * args.envs)
    policy_name = "MultiInputPolicy" if settings.observation == "geometry" else "MlpPolicy"
    kwargs = {}
    if settings.observation == "geometry" and args.policy == "cnn":
        kwargs["policy_kwargs"] = {"features_extractor_class": raster_cnn(), "features_extractor_kwargs": {}}
    model = PPO(policy_name, venv, n_steps=256, batch_size=512, n_epochs=4, learning_rate=3e-4, gamma=0.99,
                ent_coef=0.01, seed=args.seed, device="cpu", verbose=0, **kwargs)

    def act(obs, _env):
        # Sampled, as Procgen evaluates: a deterministic policy loops on the first move it cannot make.
        action, _ = model.predict(obs, deterministic=False)
        return int(action) if settings.action_mode == "discrete" else action

    curve = []
    every = max(args.steps // args.evals, args.envs * 256)

    class Progress(BaseCallback):
        def __init__(self):
            super().__init__()
            self.wins, self.episodes, self.next_eval = 0, 0, 0

        def _on_step(self) -> bool:
            for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
                if done:
                    self.episodes += 1
                    self.wins += bool(info.get("is_success"))
            if self.num_timesteps >= self.next_eval:
                self.next_eval += every
                got = evaluate(act, curve_set, size, settings)
                wins = sum(o.success for o in got)
                level = [e.level for e in venv.envs] if arm == "curriculum" else None
                curve.append((self.num_timesteps, wins, len(got), level))
                say(f"{arm}: {self.num_timesteps} steps, training episodes {self.wins}/{self.episodes} solved, "
                    f"held-out {wins}/{len(got)}" + (f", levels {level}" if level else "")
                    + f", CPU {time.process_time():.0f} s")
                self.wins, self.episodes = 0, 0
            return True

    model.learn(args.steps, callback=Progress())
    got = evaluate(act, curve_set, size, settings)
    curve.append((model.num_timesteps, sum(o.success for o in got), len(got),
                  [e.level for e in venv.envs] if arm == "curriculum" else None))
    return act, curve


def raster_cnn():
    """A small convolutional encoder of the raster beside the vector (SB3 features extractor class)."""
    import torch
    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

    class RasterCnn(BaseFeaturesExtractor):
        def __init__(self, observation_space, features: int = 128):
            raster, vector = observation_space["raster"], observation_space["vector"]
            super().__init__(observation_space, features + vector.shape[0])
            channels = raster.shape[0]
            self.cnn = torch.nn.Sequential(
                torch.nn.Conv2d(channels, 16, 3, padding=1), torch.nn.ReLU(),
                torch.nn.Conv2d(16, 32, 3, stride=2, padding=1), torch.nn.ReLU(),
                torch.nn.Conv2d(32, 32, 3, stride=2, padding=1), torch.nn.ReLU(), torch.nn.Flatten())
            with torch.no_grad():
                flat = self.cnn(torch.zeros(1, *raster.shape)).shape[1]
            self.head = torch.nn.Sequential(torch.nn.Linear(flat, features), torch.nn.ReLU())

        def forward(self, observations):
            return torch.cat([self.head(self.cnn(observations["raster"])), observations["vector"]], dim=1)

    return RasterCnn


def report(name, outcomes, sizes, beyond, success_row) -> None:
    for split, got in outcomes.items():
        parts = []
        for label, chosen in (("train sizes", sizes), (f"size {beyond}", [beyond])):
            picked = [o for o in got if o.size in chosen]
            if picked:
                wins, runs, low, high = success_row(picked)
                parts.append(f"{label} {wins}/{runs} [{low:.2f}, {high:.2f}]")
        say(f"{name} {split}: " + "; ".join(parts))


def table(results, success_row, np) -> str:
    from phyrogen.learning import Outcome

    sizes, beyond = results["sizes"], results["beyond"]
    lines = [f"| agent | training seeds, sizes {'/'.join(map(str, sizes))} | held-out, sizes "
             f"{'/'.join(map(str, sizes))} | held-out, size {beyond} | CPU s |", "|---|---|---|---|---|"]

    def cell(got, chosen):
        picked = [o for o in got if o.size in chosen]
        if not picked:
            return "-"
        wins, runs, low, high = success_row(picked)
        return f"{wins}/{runs} = {wins / runs:.0%} [{low:.0%}, {high:.0%}]"

    names = {"fixed": "PPO, geometry + vector, fixed seeds", "vector": "PPO, vector only (no geometry)",
             "curriculum": "PPO, geometry + vector, curriculum"}
    for arm, data in results["arms"].items():
        got = {k: [Outcome(**o) for o in v] for k, v in data["outcomes"].items()}
        lines.append(f"| {names[arm]} | {cell(got['train'], sizes)} | {cell(got['heldout'], sizes)} | "
                     f"{cell(got['heldout'], [beyond])} | {data['cpu_seconds']:.0f} |")
    for name, rows in results["rows"].items():
        got = [Outcome(**o) for o in rows]
        checks = results["args"]["planner_checks"]
        label = "random actions" if name == "random" else f"LA-RRT (paper settings, {checks:,} checks)"
        lines.append(f"| {label} | - | {cell(got, sizes)} | {cell(got, [beyond])} | - |")
    return "\n".join(lines)


def plot(results, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    for arm, data in results["arms"].items():
        steps = [c[0] for c in data["curve"]]
        rate = [c[1] / c[2] for c in data["curve"]]
        ax.plot(steps, rate, marker="o", label=arm)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("held-out success (training sizes)")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title(f"PPO on {results['args']['generator']}, {results['args']['train_seeds']} training seeds per size")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=100)
    os.replace(tmp, path)


def write_whole(path: Path, text: str) -> None:
    """Write ``text`` beside ``path`` and rename it into place: an interrupted run leaves no torn file."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def children_cpu() -> float:
    """CPU seconds of the finished worker processes (puzzle generation)."""
    usage = os.times()
    return usage.children_user + usage.children_system


def say(text: str) -> None:
    print(f"[train] {text}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
