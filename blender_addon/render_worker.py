"""Render puzzle folders in this process: ``python -m blender_addon.render_worker``.

Started by :func:`blender_addon.rendering.render_puzzles` in a subprocess,
because Workbench aborts the process when no OpenGL context can be made.
For every folder it prints ``RENDERED <folder> <seconds> <images>`` once the
images (``images/``, replaced atomically) and ``<name>.blend`` are in place.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from .views import DEFAULT_VIEWS, parse_views


def render_folder(folder: Path, engine: str, size: tuple[int, int], views: tuple[str, ...]) -> int:
    """Build, render and save one puzzle folder (the render stage's entries); returns the number of images."""
    import bpy

    from phyrogen_core.folder import PuzzleFolder, atomic_directory

    from .render import render_views, setup_stage
    from .scene import build_puzzle_folder

    place = PuzzleFolder.open(folder)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    built = build_puzzle_folder(place.path, scene)
    setup_stage(scene, built.collection, engine, size)
    with atomic_directory(place.images) as images:
        paths = render_views(scene, built.collection, images, place.name, views)
    temporary = place.path / f".{place.name}.tmp.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(temporary), copy=True, compress=False)
    os.replace(temporary, place.blend)
    return len(paths)


def parse_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"bad image size {text!r}; valid: WIDTHxHEIGHT, e.g. 480x360") from None
    if width < 16 or height < 16:
        raise ValueError(f"image size {text!r} is too small; valid: at least 16x16")
    return width, height


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m blender_addon.render_worker", description=__doc__)
    parser.add_argument("--engine", choices=("WORKBENCH", "CYCLES"), default="WORKBENCH")
    parser.add_argument("--size", default="480x360")
    parser.add_argument("--views", default=",".join(DEFAULT_VIEWS))
    parser.add_argument("folders", nargs="+")
    args = parser.parse_args(argv)
    size, views = parse_size(args.size), parse_views(args.views)
    for folder in args.folders:
        started = time.perf_counter()
        count = render_folder(Path(folder), args.engine, size, views)
        print(f"RENDERED {folder} {time.perf_counter() - started:.3f} {count}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
