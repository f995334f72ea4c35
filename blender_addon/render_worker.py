"""Render puzzle folders in this process: ``python -m blender_addon.render_worker``.

Started by :func:`blender_addon.rendering.render_puzzles` in a subprocess,
because Workbench aborts the process when no OpenGL context can be made.
For every folder it prints ``RENDERED <folder> <seconds> <images> <animation seconds or ->``
once the images and the solution animation (``images/``, replaced atomically)
and ``<name>.blend`` are in place.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from phyrogen_core.folder import PuzzleFormatError

from .views import DEFAULT_VIEWS, STILL_SIZE, parse_views


@dataclass(frozen=True)
class FolderRender:
    images: int
    animation_seconds: float | None
    """How long the solution animation took; None when none was made."""


def render_folder(folder: Path, engine: str, size: tuple[int, int], views: tuple[str, ...],
                  animation: bool = True) -> FolderRender:
    """Build, render and save one puzzle folder (the render stage's entries).

    With ``animation``, the certificate also becomes a short animated WebP
    beside the images (:func:`~blender_addon.render.render_animation`), and the
    saved scene carries it as keyframes (one second per action; press play).
    """
    import bpy

    from phyrogen_core.export import read_puzzle_dir
    from phyrogen_core.folder import PuzzleFolder, Stage, owned_directory, stage_owns

    from . import render
    from .animation import frames_per_action_for, keyframe_solution
    from .scene import build_puzzle_folder
    from .views import animation_name

    place = PuzzleFolder.open(folder)
    loaded = read_puzzle_dir(place.path)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    built = build_puzzle_folder(place.path, scene)
    render.setup_stage(scene, built.collection, engine, size)
    # An edited puzzle keeps its old certificate, marked unverified: it may not fit the puzzle any more.
    animation = animation and len(loaded.certificate) >= 2 and loaded.record.certificate_verified
    animation_seconds = None
    # Only the render stage's own images are replaced; a user's file in images/ stays.
    with owned_directory(place.images, lambda path: stage_owns(Stage.RENDER, place.name, f"images/{path}")) as images:
        paths = render.render_views(scene, built.collection, images, place.name, views)
        if animation:
            started = time.perf_counter()
            timing = keyframe_solution(built, loaded.certificate, loaded.chain, fps=render.ANIMATION_FPS,
                                       hold_frames=round(render.ANIMATION_HOLD_SECONDS * render.ANIMATION_FPS),
                                       frames_per_action=frames_per_action_for(
                                           _actions(loaded), render.ANIMATION_SECONDS, render.ANIMATION_FPS))
            render.render_animation(scene, built.collection, images / animation_name(place.name),
                             (timing.frame_start, timing.frame_end), timing.fps, timing.frames,
                             held_from=math.ceil(timing.frames[-1]))
            animation_seconds = time.perf_counter() - started
    if animation:
        keyframe_solution(built, loaded.certificate, loaded.chain)  # for Blender: 24 fps, a second per action
    temporary = place.path / f".{place.name}.tmp.blend"
    try:
        bpy.ops.wm.save_as_mainfile(filepath=str(temporary), copy=True, compress=False)
        os.replace(temporary, place.blend)
    except BaseException:  # a stop (SIGINT) while saving: no half-written scene stays behind
        temporary.unlink(missing_ok=True)
        raise
    return FolderRender(len(paths), animation_seconds)


def _actions(loaded) -> int:
    from phyrogen_core.actions import count_actions

    return count_actions(loaded.certificate, loaded.chain.factors)


MIN_IMAGE_SIDE = 16
MAX_IMAGE_SIDE = 8192
"""Largest image width and height: Workbench renders into an OpenGL framebuffer, which many
drivers cap at 8192 per side, and an 8192 x 8192 RGBA image is already 256 MiB per view."""


def parse_size(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` -> (width, height), each side in MIN_IMAGE_SIDE..MAX_IMAGE_SIDE."""
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"bad image size {text!r}; valid: WIDTHxHEIGHT, e.g. 520x390") from None
    if not (MIN_IMAGE_SIDE <= width <= MAX_IMAGE_SIDE and MIN_IMAGE_SIDE <= height <= MAX_IMAGE_SIDE):
        raise ValueError(f"image size {text!r} is out of range; valid: each side {MIN_IMAGE_SIDE}..{MAX_IMAGE_SIDE}")
    return width, height


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m blender_addon.render_worker", description=__doc__)
    parser.add_argument("--engine", choices=("WORKBENCH", "CYCLES"), default="WORKBENCH")
    parser.add_argument("--size", default="x".join(map(str, STILL_SIZE)))
    parser.add_argument("--views", default=",".join(DEFAULT_VIEWS))
    parser.add_argument("--no-animation", action="store_true", help="no solution animation")
    parser.add_argument("folders", nargs="+")
    args = parser.parse_args(argv)
    size, views = parse_size(args.size), parse_views(args.views)
    for folder in args.folders:
        started = time.perf_counter()
        try:
            done = render_folder(Path(folder), args.engine, size, views, animation=not args.no_animation)
        except (PuzzleFormatError, FileNotFoundError) as exc:
            # A folder broken after render_puzzles checked it: one line naming it, not a traceback.
            print(f"render_worker: {exc}", file=sys.stderr)
            return 2
        animation = "-" if done.animation_seconds is None else f"{done.animation_seconds:.3f}"
        print(f"RENDERED {folder} {time.perf_counter() - started:.3f} {done.images} {animation}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
