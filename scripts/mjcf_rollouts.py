"""MuJoCo rollouts of puzzles' MJCF files: the certificate driven through the servos, and the blocked push.

    .venv/bin/python scripts/mjcf_rollouts.py                 # the paper's 24 (six generators x seeds 1-4)
    .venv/bin/python scripts/mjcf_rollouts.py output/rooms    # or every puzzle folder under the paths
    .venv/bin/python scripts/mjcf_rollouts.py --seeds 8610-8619   # or those seeds of all six generators

Per puzzle (manipulation/mjcf_rollout.py says what each rollout does and passes on):

- drive: the certificate through the servos; steps, deepest contact between objects, goal error.
- push: the target pushed straight toward its goal for 2 s at 20 N, at the drive's pace; deepest contact, how far it
  stayed from its goal, how far the held parts moved.
- unpaced: the same push with the target's servos aimed at the goal at once (no speed limit:
  the target speeds up at 20 N where nothing stops it and meets the next blocker at speed).
- controls, each of which must fail where the push passes: the same push with contacts off (the
  target must travel: its contacts stopped it, not a weak servo); with MuJoCo's default contact
  softness (solref 0.02 s, the file's is 0.002 s: deeper contacts); and with the other parts'
  servos off (joint friction alone holds them: how far a blocker moves when nothing holds it).

Prints a markdown table and a summary; counts of simulation steps bound every rollout.
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import sys
from pathlib import Path

import mujoco

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from manipulation.mjcf_rollout import (  # noqa: E402
    BLOCKER_STILL,
    DRIVE_DEPTH,
    PUSH_DEPTH,
    drive_certificate,
    push_target,
)
from phyrogen_core.export import chain_to_mjcf  # noqa: E402


def _puzzles(paths: list[str], seeds: range):
    if paths:
        from phyrogen_core.export import read_puzzle_dir
        from phyrogen_core.folder import find_in_paths

        for found in find_in_paths(paths):
            yield read_puzzle_dir(getattr(found, "path", found))
        return
    from phyrogen_core.registry import get_generator, paper_generators
    from solver.pipelines.generation import generate_here

    for generator in paper_generators():
        for seed in seeds:
            # Two generators take their size from the seed (the paper's Seed + 1 sliders, n = Seed door
            # moves): a fresh seed gets the paper's sizes in turn, 1-4 as seeds 1-4 have them.
            paper_seed = (seed - seeds.start) % 4 + 1
            overrides = {"simple_slider": {"n_objects": paper_seed + 1}, "move_n_times": {"n": paper_seed}}
            params = overrides.get(generator, {}) if seeds != range(1, 5) else {}
            yield generate_here(generator, seed, get_generator(generator).parse_params(params))


def _default_softness(model, held) -> None:
    model.geom_solref[:] = (0.02, 1.0)


def _passive_others(model, held) -> None:
    for name in held:
        actuator = model.actuator(name).id
        model.actuator_gainprm[actuator, 0] = 0.0
        model.actuator_biasprm[actuator, 1:3] = 0.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("paths", nargs="*", help="puzzle folders or roots (default: the paper's 24, generated)")
    parser.add_argument("--seeds", default="1-4", help="FIRST-LAST: the seeds of every generator to generate "
                        "when no paths are given (default 1-4: the paper's puzzles)")
    args = parser.parse_args(argv)
    first, _, last = args.seeds.partition("-")
    if not (first.isdigit() and (last or first).isdigit()) or int(last or first) < int(first):
        parser.error(f"--seeds: expected FIRST-LAST, got {args.seeds!r}")
    seeds = range(int(first), int(last or first) + 1)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).parent).stdout.strip()
    print(f"mujoco {mujoco.__version__}, commit {commit}, {platform.machine()} {platform.processor() or ''}".strip())
    print()
    print("| puzzle | drive steps | drive deepest mm | drive goal error | push deepest mm | push goal error | "
          "held parts moved mm | unpaced push deepest mm | no-contact travel mm | default-softness deepest mm | "
          "passive others moved mm |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    drive_ok = push_ok = controls_failed = passive_moved = unpaced_deep = total = 0
    for puzzle in _puzzles(args.paths, seeds):
        chain, certificate, goal = puzzle.chain, puzzle.certificate, puzzle.goal
        xml = chain_to_mjcf(chain, certificate)
        drive = drive_certificate(xml, chain, certificate, goal)
        push = push_target(xml, chain, certificate, goal)
        free = push_target(xml, chain, certificate, goal, contacts=False)
        unpaced = push_target(xml, chain, certificate, goal, paced=False)
        soft = push_target(xml, chain, certificate, goal, edit=_default_softness)
        passive = push_target(xml, chain, certificate, goal, edit=_passive_others)
        total += 1
        drive_ok += drive.reached and drive.deepest < DRIVE_DEPTH
        push_passed = (push.touched and push.deepest < PUSH_DEPTH and not push.reached
                       and push.others_moved < BLOCKER_STILL)
        push_ok += push_passed
        # The push's evidence can fail: without contacts the target travels past where it stopped.
        controls_failed += free.target_moved > push.target_moved + 10 * PUSH_DEPTH
        passive_moved += passive.others_moved >= BLOCKER_STILL
        unpaced_deep += unpaced.deepest >= PUSH_DEPTH
        print(f"| {chain.name} | {drive.steps} | {drive.deepest * 1e3:.3f} | {drive.goal_error:.1e} | "
              f"{push.deepest * 1e3:.3f} | {push.goal_error:.3f} | {push.others_moved * 1e3:.3f} | "
              f"{unpaced.deepest * 1e3:.3f} | "
              f"{free.target_moved * 1e3:.0f} | {soft.deepest * 1e3:.3f} | {passive.others_moved * 1e3:.1f} |")
    print()
    print(f"drive reached the goal, no contact >= {DRIVE_DEPTH * 1e3:g} mm: {drive_ok}/{total}")
    print(f"push stopped short, touching, no contact >= {PUSH_DEPTH * 1e3:g} mm, held parts moved "
          f"< {BLOCKER_STILL * 1e3:g} mm: {push_ok}/{total}")
    print(f"control, contacts off: the target travelled past its stop in {controls_failed}/{total}")
    print(f"unpaced push: a contact >= {PUSH_DEPTH * 1e3:g} mm in {unpaced_deep}/{total}")
    print(f"finding, other servos off: a part moved >= {BLOCKER_STILL * 1e3:g} mm in {passive_moved}/{total}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
