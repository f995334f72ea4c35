"""Collision checks per CPU second: the prototype's PyBullet way vs. ours, per paper puzzle and generator.

The calibration behind ``--budget-from-paper`` (:data:`solver.benchmark.paper_budgets.PAPER_CHECKS_PER_SECOND`).
The paper's harness checked a state the prototype's way: load the URDF in PyBullet (DIRECT), reset
every joint, ask for closest points at distance 0 between every moving link and every other link
(parent-child pairs excluded; ``benchmarks/collision_speed.py``'s ``prototype_checker``). Both
checkers see the same uniform random states of each puzzle, one state at a time as a planner asks;
rates are states per CPU second of this process (``time.process_time``), so another process on the
machine slows neither. Prints a row per puzzle, then per generator the median rates, their ratio and
the median over all puzzles, which the calibration constant takes.

    python benchmarks/pybullet_check_rate.py [PUZZLES_ROOT] [--states N]

PUZZLES_ROOT holds the 24 paper puzzles (default: output/, ``phyrogen generate --generator all
--seeds 1-4 --out output``). Cost: about N x 24 x (60-150 us + 10 us) CPU, 5-10 s at the default N.
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import pybullet as pb
from collision_speed import prototype_checker  # benchmarks/ is on sys.path when this file is run

from phyrogen_core.export import read_puzzle_dir
from solver.collision.model import CollisionModel


def rates(folder: Path, states: int, seed: int = 0, valid: bool = False) -> tuple[float, float, float]:
    """(PyBullet checks per CPU second, ours, the share of equal verdicts) on ``states`` random states;
    with ``valid`` only states our model finds valid (drawn by rejection from up to 200 x ``states``):
    a valid state costs PyBullet every pair, a colliding one ends at its first colliding pair."""
    chain = read_puzzle_dir(folder).chain
    rng = np.random.default_rng(seed)
    model = CollisionModel(chain)
    drawn = rng.uniform(chain.lower_limits, chain.upper_limits, (states * (200 if valid else 1),
                                                                 len(chain.joint_order)))
    model.is_valid(drawn[0])  # compile outside the timing
    if valid:
        drawn = drawn[np.asarray(model.check(drawn), dtype=bool)][:states]
        if len(drawn) < 2:
            return math.nan, math.nan, math.nan
    check, client = prototype_checker(folder, chain)
    try:
        check(drawn[0])
        started = time.process_time()
        theirs = [check(s) for s in drawn]
        pybullet_seconds = time.process_time() - started
    finally:
        pb.disconnect(client)
    started = time.process_time()
    ours = [model.is_valid(s) for s in drawn]
    our_seconds = time.process_time() - started
    agree = float(np.mean(np.array(theirs) == np.array(ours)))
    return len(drawn) / pybullet_seconds, len(drawn) / our_seconds, agree


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", nargs="?", default="output")
    parser.add_argument("--states", type=int, default=2000, help="random states per puzzle (default 2000)")
    parser.add_argument("--valid", action="store_true",
                        help="valid states only (every pair checked, as on most states a planner keeps)")
    args = parser.parse_args()
    if args.states < 1:
        print(f"pybullet_check_rate: --states must be at least 1, got {args.states}", file=sys.stderr)
        return 2
    folders = sorted(p.parent for p in Path(args.root).glob("*/*/puzzle.json"))
    if not folders:
        print(f"pybullet_check_rate: no puzzle folders under {args.root!r}; generate the paper's 24 first",
              file=sys.stderr)
        return 2
    print(f"{platform.node()} {platform.machine()} {platform.processor()}, load average "
          f"{' '.join(f'{v:.2f}' for v in _load())}, {args.states} {'valid' if args.valid else 'random'} states "
          "per puzzle, CPU-time rates")
    print(f"{'puzzle':22s} {'PyBullet/s':>11s} {'ours/s':>9s} {'ratio':>6s} {'agree':>7s}")
    by_generator: dict[str, list[tuple[float, float, float]]] = {}
    for folder in folders:
        row = rates(folder, args.states, valid=args.valid)
        by_generator.setdefault(folder.parent.name, []).append(row)
        print(f"{folder.name:22s} {row[0]:11.0f} {row[1]:9.0f} {row[1] / row[0]:6.1f} {row[2]:7.1%}")
    print(f"\n{'generator (median)':22s} {'PyBullet/s':>11s} {'ours/s':>9s} {'ratio':>6s}")
    for generator, rows in by_generator.items():
        theirs, ours = statistics.median(r[0] for r in rows), statistics.median(r[1] for r in rows)
        print(f"{generator:22s} {theirs:11.0f} {ours:9.0f} {ours / theirs:6.1f}")
    every = [r for rows in by_generator.values() for r in rows if not math.isnan(r[0])]
    theirs, ours = statistics.median(r[0] for r in every), statistics.median(r[1] for r in every)
    print(f"{'all puzzles':22s} {theirs:11.0f} {ours:9.0f} {ours / theirs:6.1f}   "
          f"(range of PyBullet rates {min(r[0] for r in every):.0f}-{max(r[0] for r in every):.0f}/s)")
    print(f"load average at the end {' '.join(f'{v:.2f}' for v in _load())}")
    return 0


def _load() -> tuple[float, ...]:
    try:
        import os

        return os.getloadavg()
    except OSError:
        return ()


if __name__ == "__main__":
    sys.exit(main())
