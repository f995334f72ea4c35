"""Feasibility of a friction grasp: what each movable part of a puzzle weighs in the manipulation
scene, and the force the gripper's pads must pass to it, against what a Robotiq 2F-85 holds.

    .venv/bin/python scripts/grip_feasibility.py                # the paper's 24
    .venv/bin/python scripts/grip_feasibility.py output/rooms   # or every puzzle folder under the paths

A measurement of the scene as it is (masses from manipulation/physics.py's plywood at the generator's
physical scale), not of a grasp: no simulation runs. The force per part and the bound it must keep
(a quarter of what the pads hold) are manipulation/feasibility.py's.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from manipulation.feasibility import ACCELERATION, grip_bound, grip_hold, part_forces  # noqa: E402
from manipulation.placement import physical_scale  # noqa: E402
from manipulation.robot import GripperSpec  # noqa: E402


def _puzzles(paths: list[str]):
    if paths:
        from manipulation.execution import puzzle_identity
        from phyrogen_core.export import read_puzzle_dir
        from phyrogen_core.folder import find_in_paths

        for found in find_in_paths(paths):
            folder = Path(getattr(found, "path", found))
            loaded = read_puzzle_dir(folder)
            yield puzzle_identity(loaded, folder)[0], loaded
        return
    from phyrogen_core.registry import get_generator, paper_generators
    from solver.pipelines.generation import generate_here

    for generator in paper_generators():
        for seed in range(1, 5):
            yield generator, generate_here(generator, seed, get_generator(generator).parse_params({}))


def main(argv: list[str] | None = None) -> int:
    import subprocess

    paths = sys.argv[1:] if argv is None else argv
    gripper = GripperSpec()
    hold, bound = grip_hold(gripper), grip_bound(gripper)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).parent).stdout.strip()
    print(f"commit {commit}; hold by friction: {hold:.0f} N (2 pads at {gripper.grip_force:.0f} N, friction "
          f"{gripper.pad_friction:g}); bound {bound:.0f} N; a = {ACCELERATION:g} m/s^2")
    print()
    print(f"| puzzle | scale | parts | heaviest part kg | largest force N (part, joint) | parts over {bound:.0f} N |")
    print("|---|---|---|---|---|---|")
    over = parts = 0
    heaviest_all = largest = 0.0
    for generator, puzzle in _puzzles(paths):
        forces = part_forces(generator, puzzle.chain, puzzle.certificate[0])
        heaviest = max(mass for mass, _, _ in forces.values())
        part, (_, force, joint) = max(forces.items(), key=lambda item: item[1][1])
        n_over = sum(f > bound for _, f, _ in forces.values())
        parts, over = parts + len(forces), over + n_over
        heaviest_all, largest = max(heaviest_all, heaviest), max(largest, force)
        print(f"| {puzzle.chain.name} | {physical_scale(generator):g} | {len(forces)} | {heaviest:.1f} | "
              f"{force:.0f} ({part}, {joint}) | {n_over} |")
    print()
    print(f"parts: {parts}; heaviest {heaviest_all:.1f} kg; largest force {largest:.0f} N; "
          f"over the bound ({bound:.0f} N): {over}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
