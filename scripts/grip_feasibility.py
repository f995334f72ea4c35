"""Feasibility of a friction grasp: what each movable part of a puzzle weighs in the manipulation
scene, and the force the gripper's pads must pass to it, against what a Robotiq 2F-85 holds.

    .venv/bin/python scripts/grip_feasibility.py                # the paper's 24
    .venv/bin/python scripts/grip_feasibility.py output/rooms   # or every puzzle folder under the paths

A measurement of the scene as it is (masses from manipulation/physics.py's wood at the generator's
physical scale), not of a grasp: no simulation runs. Per movable part and joint, the force at the
grasp point (its knob's top) to overcome the joint's friction and accelerate the part at
``ACCELERATION``:

- a slide: ``mu m g + m a``;
- a hinge: ``mu m g r / R + I a / R^2`` (bearing radius r, grasp point R from the axis, I the
  moment of inertia about the axis);

the part's figure is the largest over its joints (an SE(2) part: x, y and yaw). Held by friction
alone, two pads pressed with ``F`` each pass at most ``2 mu_pad F``: 200 N at the scene's 100 N per
finger and pad friction 1, 470 N at the 2F-85's largest force (235 N).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from manipulation.grasp import grasp_point  # noqa: E402
from manipulation.physics import GRAVITY, PuzzleMaterial, with_masses  # noqa: E402
from manipulation.placement import joint_value_scale, physical_scale, scale_chain  # noqa: E402
from manipulation.robot import GripperSpec  # noqa: E402
from phyrogen_core.chain import JointType  # noqa: E402
from phyrogen_core.export.mjcf_dynamics import joint_loads  # noqa: E402

ACCELERATION = 1.0
"""m/s^2 at the grasp point: the arm bringing it to 0.5 m/s in half a second."""
MAX_GRIP_FORCE = 235.0
"""Newtons per finger: the 2F-85's largest grip force (datasheet, 20-235 N)."""


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


def part_forces(generator: str, chain, start, material: PuzzleMaterial | None = None) -> dict[str, tuple]:
    """Per movable part: (mass kg, force N at its grasp point, the joint that needs it)."""
    material = PuzzleMaterial() if material is None else material
    scale = physical_scale(generator)
    scaled = with_masses(scale_chain(chain, scale), material)
    state = np.asarray(start, dtype=float) * joint_value_scale(chain, scale)
    transforms = scaled.link_transforms(state)
    loads = joint_loads(scaled, state)
    out: dict[str, tuple] = {}
    for joint in scaled.active_joints:
        part = scaled.object_of_joint(joint.name)
        load = loads[joint.name]
        grasp = grasp_point(scaled, part)
        at = (transforms[grasp.link] @ np.array([*grasp.point, 1.0]))[:3]
        if joint.type is JointType.REVOLUTE:
            frame = transforms[joint.child]
            axis = frame[:3, :3] @ np.asarray(joint.axis, dtype=float)
            offset = at - frame[:3, 3]
            radius = float(np.linalg.norm(offset - (offset @ axis) * axis))
            if radius < 1e-6:  # a grasp on the axis turns the part by a torque of the pads, not a force
                continue
            force = (material.joint_friction * load.mass * GRAVITY * material.bearing_radius / radius
                     + load.moved * ACCELERATION / radius ** 2)
        else:
            force = material.joint_friction * load.mass * GRAVITY + load.mass * ACCELERATION
        part_mass = sum(link.mass for link in scaled.links if link.object_name == part)
        if part not in out or force > out[part][1]:
            out[part] = (part_mass, force, joint.name)
    return out


def main(argv: list[str] | None = None) -> int:
    import subprocess

    paths = sys.argv[1:] if argv is None else argv
    gripper = GripperSpec()
    hold = 2 * gripper.pad_friction * gripper.grip_force
    most = 2 * gripper.pad_friction * MAX_GRIP_FORCE
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).parent).stdout.strip()
    print(f"commit {commit}; hold by friction: {hold:.0f} N (scene), {most:.0f} N (2F-85 at {MAX_GRIP_FORCE:.0f} N); "
          f"a = {ACCELERATION:g} m/s^2")
    print()
    print("| puzzle | scale | parts | heaviest part kg | largest force N (part, joint) | parts over "
          f"{hold:.0f} N | over {most:.0f} N |")
    print("|---|---|---|---|---|---|---|")
    over = over_most = parts = 0
    for generator, puzzle in _puzzles(paths):
        forces = part_forces(generator, puzzle.chain, puzzle.certificate[0])
        heaviest = max(mass for mass, _, _ in forces.values())
        part, (_, force, joint) = max(forces.items(), key=lambda item: item[1][1])
        n_over = sum(f > hold for _, f, _ in forces.values())
        n_most = sum(f > most for _, f, _ in forces.values())
        parts, over, over_most = parts + len(forces), over + n_over, over_most + n_most
        print(f"| {puzzle.chain.name} | {physical_scale(generator):g} | {len(forces)} | {heaviest:.1f} | "
              f"{force:.0f} ({part}, {joint}) | {n_over} | {n_most} |")
    print()
    print(f"parts: {parts}; needing more than {hold:.0f} N: {over}; more than {most:.0f} N: {over_most}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
