"""Validity checks per second: our collision model vs. the prototype's PyBullet method.

The prototype loaded the URDF in PyBullet and, per state, reset every joint and
asked for closest points at distance 0 between every moving link and every
other link. We run both on the same random states of the same puzzles, in one
process, and print the ratio: per CPU second of this process (the goal, single
state checks at least 20 times the prototype's rate) and per wall-clock second,
with the load average before and after and a BUSY flag when other work used
over a quarter of the cores meanwhile (``benchmarks/machine_load.py``).

    python benchmarks/collision_speed.py [PUZZLES_ROOT] [--states N]

PUZZLES_ROOT holds exported puzzle folders (default: output/, as written by
the README's main command).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pybullet as pb
from machine_load import Measurement, measure, print_load_summary

from phyrogen_core.export import read_puzzle_dir
from solver.collision.model import CollisionModel

GOAL_SINGLE_RATIO = 20.0
"""Single-state checks per CPU second, as a multiple of the prototype's."""


def prototype_checker(folder: Path, chain, distance: float = 0.0, depth: float = 0.0):
    """The prototype's validity check (closest points at ``distance`` 0), as a closure over a
    loaded PyBullet scene. With a small positive ``distance`` and a ``depth`` threshold it
    becomes a corrected referee: at distance 0 PyBullet 3.2.7 misses deep penetrations
    between links made of several shapes."""
    client = pb.connect(pb.DIRECT)
    urdf = next((folder / "urdf").glob("*.urdf"))
    body = pb.loadURDF(str(urdf), useFixedBase=True, physicsClientId=client)
    joint_of, link_of = {}, {chain.root: -1}
    for i in range(pb.getNumJoints(body, physicsClientId=client)):
        info = pb.getJointInfo(body, i, physicsClientId=client)
        joint_of[info[1].decode()] = i
        link_of[info[12].decode()] = i
    joints = [joint_of[name] for name in chain.joint_order]
    parent = {j.child: j.parent for j in chain.joints}
    moving = [link for link in link_of if chain.link(link).collisions and any(
        chain.joint(n).child == link or _is_descendant(chain, link, chain.joint(n).child) for n in chain.joint_order)]
    others = [link for link in link_of if chain.link(link).collisions]
    pairs = sorted({tuple(sorted((a, b))) for a in moving for b in others
                    if a != b and parent.get(a) != b and parent.get(b) != a})
    pairs = [(link_of[a], link_of[b]) for a, b in pairs]

    def is_valid(state) -> bool:
        for index, value in zip(joints, state, strict=True):
            pb.resetJointState(body, index, float(value), physicsClientId=client)
        for a, b in pairs:
            points = pb.getClosestPoints(body, body, distance, a, b, physicsClientId=client)
            if any(p[8] < -depth for p in points):
                return False
        return True

    return is_valid, client


def _is_descendant(chain, link, ancestor) -> bool:
    while True:
        joint = chain.parent_joint(link)
        if joint is None:
            return False
        if joint.parent == ancestor:
            return True
        link = joint.parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", nargs="?", default="output")
    parser.add_argument("--states", type=int, default=2000, help="random states per puzzle")
    args = parser.parse_args()
    folders = sorted(p.parent for p in Path(args.root).glob("*/*/puzzle.json"))
    if not folders:
        print(f"no puzzle folders under {args.root!r}; run the README's main command first", file=sys.stderr)
        return 2
    rng = np.random.default_rng(0)
    print("checks per CPU second (per wall-clock second in brackets)")
    print(f"{'puzzle':22s} {'prototype/s':>20s} {'ours, one/s':>22s} {'ours, batch/s':>24s} "
          f"{'ratio one':>9s} {'ratio batch':>11s}")
    totals = np.zeros(3)
    wall_totals = np.zeros(3)
    parts: list[Measurement] = []
    for folder in folders:
        chain = read_puzzle_dir(folder).chain
        states = rng.uniform(chain.lower_limits, chain.upper_limits, (args.states, len(chain.joint_order)))
        model = CollisionModel(chain)
        model.check(states[:2])  # compile outside the timing
        model.is_valid(states[0])
        baseline, client = prototype_checker(folder, chain)
        n_slow = min(len(states), 500)
        with measure() as proto:
            expected = [baseline(s) for s in states[:n_slow]]
        pb.disconnect(client)
        referee, client = prototype_checker(folder, chain, distance=0.01, depth=1e-3)
        reference = [referee(s) for s in states[:n_slow]]
        pb.disconnect(client)
        with measure() as one:
            single = [model.is_valid(s) for s in states]
        with measure() as many:
            batch = model.check(states)
        parts += [proto, one, many]
        assert list(batch) == single
        agree = np.mean(np.array(expected) == batch[:n_slow])
        agree_referee = np.mean(np.array(reference) == batch[:n_slow])
        rates = [proto.rates(n_slow), one.rates(len(states)), many.rates(len(states))]
        cpu = np.array([r[0] for r in rates])
        wall = np.array([r[1] for r in rates])
        totals += cpu
        wall_totals += wall
        print(f"{folder.name:22s} {cpu[0]:10.0f} ({wall[0]:7.0f}) {cpu[1]:11.0f} ({wall[1]:8.0f}) "
              f"{cpu[2]:12.0f} ({wall[2]:9.0f}) {cpu[1] / cpu[0]:9.1f} {cpu[2] / cpu[0]:11.1f}   verdicts agree: "
              f"{agree:6.1%} with the prototype, {agree_referee:6.1%} with the corrected query")
    mean, wall_mean = totals / len(folders), wall_totals / len(folders)
    print(f"{'mean':22s} {mean[0]:10.0f} ({wall_mean[0]:7.0f}) {mean[1]:11.0f} ({wall_mean[1]:8.0f}) "
          f"{mean[2]:12.0f} ({wall_mean[2]:9.0f}) {mean[1] / mean[0]:9.1f} {mean[2] / mean[0]:11.1f}")
    print(f"per wall-clock second: ratio one {wall_mean[1] / wall_mean[0]:.1f}, "
          f"batch {wall_mean[2] / wall_mean[0]:.1f}")
    print_load_summary(parts)
    ratio = mean[1] / mean[0]
    verdict = "meets" if ratio >= GOAL_SINGLE_RATIO else "MISSES"
    print(f"single-state checks: {ratio:.1f}x the prototype's method per CPU second, {verdict} the "
          f"{GOAL_SINGLE_RATIO:.0f}x goal")
    return 0


if __name__ == "__main__":
    sys.exit(main())
