"""Render time per image of the gallery's look (a floor, shadows, cavity, 520x390) against the flat look before.

Both looks render the same puzzles (the paper's six generators, seed 1), in one
process, alternating which goes first from repeat to repeat: the three default
stills (per image: wall and CPU seconds of this process, Mesa's rendering
threads included; each look's shaders warmed up first) and the solution
animation (per frame). Prints a table with the ratio new / old, the load
average before and after, and writes the oblique stills side by side.

    python benchmarks/render_look.py [--out DIR] [--repeats N] [--side-by-side docs/gallery-look.png]

``FLAT`` is the look of commit 47884db and before, as ``setup_stage`` set it
then (480x360, 5 Workbench samples, a white floor under a bright grey world,
shadows at Blender's default strength from a light above, no cavity).
Runs in the project's Python (the bpy wheel; Workbench needs OpenGL, here Mesa through EGL).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from machine_load import load_average

from blender_addon import render
from blender_addon.render import GROUND, Look
from blender_addon.views import DEFAULT_VIEWS, STILL_SIZE

FLAT = Look(floor_color=(1.0, 1.0, 1.0, 1.0), world_color=(0.9, 0.92, 0.95), exposure=0.0,
            light_direction=(0.35, -0.45, 0.82), shadow_intensity=0.5, shadow_focus=0.0, cavity=None,
            valley_factor=1.0, still_aa="5")
"""The look before (commit 47884db): ``shadow_intensity`` and ``shadow_focus`` were Blender's defaults."""
LOOKS = {"flat": (FLAT, (480, 360)), "ground": (GROUND, STILL_SIZE)}
SHEET = ("grid_world_1", "lockbox_random_1", "move_n_times_1")
"""The puzzles of the side-by-side sheet (all six made it 1.6 MB)."""
PUZZLES = (("simple_slider", 1), ("continuous_space", 1), ("grid_world", 1), ("lockbox_random", 1),
           ("move_n_times", 1), ("rooms", 1))


def make_puzzles(root: Path) -> list[Path]:
    from phyrogen_core.export import write_puzzle
    from solver.pipelines.generation import generate_puzzle

    return [write_puzzle(generate_puzzle(generator, seed), root) for generator, seed in PUZZLES]


def time_stills(scene, collection, look: str, folder: Path, name: str) -> tuple[float, float]:
    """Wall and CPU seconds per still of the default views in ``look``."""
    chosen, size = LOOKS[look]
    render.setup_stage(scene, collection, "WORKBENCH", size, chosen)
    wall, cpu = time.perf_counter(), time.process_time()
    render.render_views(scene, collection, folder, name, DEFAULT_VIEWS)
    count = len(DEFAULT_VIEWS)
    return (time.perf_counter() - wall) / count, (time.process_time() - cpu) / count


def time_animation(scene, built, loaded, look: str, path: Path) -> tuple[float, float, int]:
    """Wall and CPU seconds per frame of the solution animation in ``look``, and its frames."""
    from blender_addon.animation import frames_per_action_for, keyframe_solution
    from phyrogen_core.actions import count_actions

    chosen, size = LOOKS[look]
    render.setup_stage(scene, built.collection, "WORKBENCH", size, chosen)
    timing = keyframe_solution(built, loaded.certificate, loaded.chain, fps=render.ANIMATION_FPS,
                               hold_frames=round(render.ANIMATION_HOLD_SECONDS * render.ANIMATION_FPS),
                               frames_per_action=frames_per_action_for(
                                   count_actions(loaded.certificate, loaded.chain.factors),
                                   render.ANIMATION_SECONDS, render.ANIMATION_FPS))
    held = int(timing.frames[-1] + 0.999)
    wall, cpu = time.perf_counter(), time.process_time()
    render.render_animation(scene, built.collection, path, (timing.frame_start, timing.frame_end), timing.fps,
                            timing.frames, held_from=held)
    frames = held - timing.frame_start + 1
    return (time.perf_counter() - wall) / frames, (time.process_time() - cpu) / frames, frames


def side_by_side(rows: list[tuple[str, Path, Path]], numbers: dict[str, str], target: Path) -> None:
    """Each puzzle's oblique still, the flat look's beside the new one's, at their own sizes."""
    from PIL import Image, ImageDraw

    old_w, old_h = LOOKS["flat"][1]
    new_w, new_h = LOOKS["ground"][1]
    header, gap = 22, 6
    sheet = Image.new("RGB", (old_w + new_w + 3 * gap, header + len(rows) * (new_h + gap) + gap), "white")
    draw = ImageDraw.Draw(sheet)
    draw.text((gap, 5), f"before: {numbers['flat']}", fill=(0, 0, 0))
    draw.text((2 * gap + old_w, 5), f"now: {numbers['ground']}", fill=(0, 0, 0))
    for index, (_, old, new) in enumerate(rows):
        top = header + index * (new_h + gap)
        sheet.paste(Image.open(old).convert("RGB"), (gap, top + (new_h - old_h) // 2))
        sheet.paste(Image.open(new).convert("RGB"), (2 * gap + old_w, top))
    sheet.save(target, optimize=True)


def _aa(setting: str) -> str:
    return f"{setting} samples" if setting.isdigit() else setting


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="where the puzzles and images go (default: a temp dir)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--side-by-side", type=Path, default=None, help="write the comparison sheet here (PNG)")
    parser.add_argument("--ground-size", default=None, help="WIDTHxHEIGHT of the new look (default: the stills')")
    args = parser.parse_args(argv)
    if args.ground_size:
        LOOKS["ground"] = (GROUND, tuple(int(v) for v in args.ground_size.split("x")))
    import bpy

    from blender_addon.scene import build_puzzle_folder
    from phyrogen_core.export import read_puzzle_dir

    out = args.out or Path(tempfile.mkdtemp(prefix="phyrogen-render-look-"))
    load_before = load_average()
    folders = make_puzzles(out / "puzzles")
    stills: dict[str, list[tuple[float, float]]] = {look: [] for look in LOOKS}
    frames: dict[str, list[tuple[float, float]]] = {look: [] for look in LOOKS}
    rows = []
    print(f"{'puzzle':<20} {'flat s/still':>12} {'ground s/still':>14} {'ratio':>6} "
          f"{'flat s/frame':>12} {'ground s/frame':>14} {'ratio':>6}")
    for folder in folders:
        loaded = read_puzzle_dir(folder)
        bpy.ops.wm.read_factory_settings(use_empty=True)
        scene = bpy.context.scene
        built = build_puzzle_folder(folder, scene)
        mine: dict[str, list[tuple[float, float]]] = {look: [] for look in LOOKS}
        for look in LOOKS:  # warm-up: each look's shaders compiled once, not timed
            time_stills(scene, built.collection, look, out / "warm" / look, folder.name)
        for repeat in range(args.repeats):
            order = list(LOOKS) if repeat % 2 == 0 else list(reversed(LOOKS))
            for look in order:
                mine[look].append(time_stills(scene, built.collection, look, out / look, folder.name))
        per_frame = {}
        for look in LOOKS:
            wall, cpu, _ = time_animation(scene, built, loaded, look, out / look / f"{folder.name}_solution.webp")
            per_frame[look] = (wall, cpu)
            frames[look].append((wall, cpu))
        for look in LOOKS:
            stills[look].extend(mine[look])
        flat = statistics.median(w for w, _ in mine["flat"])
        ground = statistics.median(w for w, _ in mine["ground"])
        print(f"{folder.name:<20} {flat:12.3f} {ground:14.3f} {ground / flat:6.2f} {per_frame['flat'][0]:12.3f} "
              f"{per_frame['ground'][0]:14.3f} {per_frame['ground'][0] / per_frame['flat'][0]:6.2f}")
        if folder.name in SHEET:
            rows.append((folder.name, out / "flat" / f"{folder.name}_01.png",
                         out / "ground" / f"{folder.name}_01.png"))
    summary = {}
    for look in LOOKS:
        wall = statistics.median(w for w, _ in stills[look])
        cpu = statistics.median(c for _, c in stills[look])
        frame_wall = statistics.median(w for w, _ in frames[look])
        frame_cpu = statistics.median(c for _, c in frames[look])
        summary[look] = (wall, cpu, frame_wall, frame_cpu)
    flat, ground = summary["flat"], summary["ground"]
    print(f"median per still: flat {flat[0]:.3f} s wall / {flat[1]:.3f} s CPU, ground {ground[0]:.3f} s wall / "
          f"{ground[1]:.3f} s CPU; ratio {ground[0] / flat[0]:.2f} wall, {ground[1] / flat[1]:.2f} CPU "
          f"({len(stills['flat'])} stills each)")
    print(f"median per animation frame: flat {flat[2]:.3f} s wall / {flat[3]:.3f} s CPU, ground {ground[2]:.3f} s "
          f"wall / {ground[3]:.3f} s CPU; ratio {ground[2] / flat[2]:.2f} wall, {ground[3] / flat[3]:.2f} CPU")
    print(f"load average before {load_before[0]:.1f}, after {load_average()[0]:.1f}; images in {out}")
    if args.side_by_side is not None:
        numbers = {look: f"{LOOKS[look][1][0]}x{LOOKS[look][1][1]}, {_aa(LOOKS[look][0].still_aa)}, "
                         f"{summary[look][0]:.2f} s wall / {summary[look][1]:.2f} s CPU per still" for look in LOOKS}
        side_by_side(rows, numbers, args.side_by_side)
        print(f"side by side: {args.side_by_side}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
