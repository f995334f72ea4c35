"""``phyrogen render``: images (and solution animations) of every puzzle folder under ``--out``, and its gallery."""

from __future__ import annotations

import argparse
import sys

from phyrogen.options import add_quiet_option, add_workers_option, path_option
from phyrogen.progress import progress_bar
from phyrogen.stages import render
from phyrogen_core.stage_records.render import RenderRequest


def add_parser(sub) -> None:
    parser = sub.add_parser("render", help="render every puzzle folder under --out and write <out>/index.html")
    parser.add_argument("--out", type=path_option, default="output",
                         help="output folder holding the puzzles (default: output)")
    parser.add_argument("--engine", default="auto", choices=("auto", "workbench", "cycles"),
                         help="auto: Workbench, Cycles (CPU) where Workbench cannot run (default)")
    parser.add_argument("--size", type=image_size_option, default="520x390",
                         help="image size WIDTHxHEIGHT, each side 16..8192 (default 520x390)")
    parser.add_argument("--views", default="top,oblique,oblique_back",
                         help="comma-separated views: top, oblique, oblique_back, side")
    add_workers_option(parser, 1, "render processes")
    parser.add_argument("--no-animation", action="store_true",
                         help="no solution animation (images/<name>_solution.webp, about 3-4 s per puzzle)")
    parser.add_argument("--blender", metavar="PATH",
                         help="render and save each .blend with this Blender binary (e.g. blender, Blender 3.4+), "
                              "so that the .blend opens in that version; default: the bpy module, Blender 4.5, "
                              "whose .blend files Blender 3.x cannot open")
    parser.add_argument("--gallery-only", action="store_true", help="only (re)write index.html")
    add_quiet_option(parser)
    parser.set_defaults(func=run)


def run(args) -> int:
    request = RenderRequest(args.out, args.engine, args.size, args.views, args.workers, not args.no_animation,
                            args.blender, args.gallery_only)
    progress = None

    def on_start(count: int) -> None:
        nonlocal progress
        progress = progress_bar(count, args.quiet)

    try:
        result = render.run(request, on_start=on_start, on_done=lambda: progress.update(1))
    finally:
        if progress is not None:
            progress.close()
    if result.error is not None:
        print(f"phyrogen: render failed: {result.error}", file=sys.stderr)
        return result.exit_code
    if not args.gallery_only:
        print(f"{result.puzzles} puzzles, {result.images} images ({result.width}x{result.height}, "
              f"{', '.join(result.engines)}) in {result.seconds:.1f} s: {result.seconds_per_image:.2f} s per image, "
              f"with {args.workers} workers")
        if result.animations:
            print(f"{result.animations} solution animations, {result.animation_seconds / result.animations:.1f} s "
                  "each (worker time, included above)")
    print(f"gallery: {result.gallery}")
    return result.exit_code


def image_size_option(text: str) -> str:
    """The text itself, once :func:`blender_addon.render_worker.parse_size` accepts it."""
    from blender_addon.render_worker import parse_size

    try:
        parse_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text
