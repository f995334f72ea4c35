"""``phyrogen render``: images (and solution animations) of every puzzle folder under ``--out``, and its gallery."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from phyrogen.options import add_quiet_option, add_workers_option, path_option
from phyrogen.progress import progress_bar
from phyrogen.usage import UsageError
from phyrogen_core.folder import find_puzzle_folders


def add_parser(sub) -> None:
    render = sub.add_parser("render", help="render every puzzle folder under --out and write <out>/index.html")
    render.add_argument("--out", type=path_option, default="output",
                        help="output folder holding the puzzles (default: output)")
    render.add_argument("--engine", default="auto", choices=("auto", "workbench", "cycles"),
                        help="auto: Workbench, Cycles (CPU) where Workbench cannot run (default)")
    render.add_argument("--size", type=image_size_option, default="520x390",
                        help="image size WIDTHxHEIGHT, each side 16..8192 (default 520x390)")
    render.add_argument("--views", default="top,oblique,oblique_back",
                        help="comma-separated views: top, oblique, oblique_back, side")
    add_workers_option(render, 1, "render processes")
    render.add_argument("--no-animation", action="store_true",
                        help="no solution animation (images/<name>_solution.webp, about 3-4 s per puzzle)")
    render.add_argument("--blender", metavar="PATH",
                        help="render and save each .blend with this Blender binary (e.g. blender, Blender 3.4+), "
                             "so that the .blend opens in that version; default: the bpy module, Blender 4.5, "
                             "whose .blend files Blender 3.x cannot open")
    render.add_argument("--gallery-only", action="store_true", help="only (re)write index.html")
    add_quiet_option(render)
    render.set_defaults(func=run)


def run(args) -> int:
    from blender_addon.gallery import check_gallery_target, write_gallery
    from blender_addon.render_worker import parse_size
    from blender_addon.rendering import RenderError, check_render_folders, render_puzzles
    from blender_addon.views import parse_views
    from phyrogen_core.folder import require_writable_dir

    views = parse_views(args.views)
    size = None if args.gallery_only else parse_size(args.size)
    if args.blender is not None:
        _use_blender_binary(args.blender)
    out = require_writable_dir(args.out, "render output folder")  # index.html goes there
    check_gallery_target(out)  # a user's own index.html is refused before any render
    try:
        found = [f.path for f in find_puzzle_folders(out)]
    except FileNotFoundError:
        if not args.gallery_only:
            raise
        found = []  # an empty gallery
    # Every folder is read and checked before any Blender starts (and before the progress bar):
    # a broken one is bad input naming the folder, not a failed render worker.
    folders = check_render_folders(found, writable=size is not None)
    if size is not None:
        progress = progress_bar(len(folders), args.quiet)
        try:
            report = render_puzzles(folders, args.engine, size, views, args.workers,
                                    on_done=lambda _: progress.update(1), animation=not args.no_animation)
        except RenderError as exc:
            print(f"phyrogen: render failed: {exc}", file=sys.stderr)
            return 1
        finally:
            progress.close()
        engines = sorted({r.engine for r in report.rendered})
        print(f"{len(report.rendered)} puzzles, {report.images} images ({size[0]}x{size[1]}, {', '.join(engines)}) "
              f"in {report.seconds:.1f} s: {report.seconds_per_image:.2f} s per image, with {args.workers} workers")
        if report.animations:
            print(f"{report.animations} solution animations, {report.animation_seconds / report.animations:.1f} s "
                  "each (worker time, included above)")
    print(f"gallery: {write_gallery(Path(args.out), views)}")
    return 0


def _use_blender_binary(text: str) -> None:
    """``render --blender PATH``: the render workers run in that Blender binary, whose version then writes
    the ``.blend`` files (blender_addon.environment.render_worker_command)."""
    import shutil

    from blender_addon.environment import BLENDER_VARIABLE

    found = shutil.which(text)
    if found is None:
        raise UsageError(f"--blender {text!r}: no such executable")
    os.environ[BLENDER_VARIABLE] = str(Path(found).resolve())


def image_size_option(text: str) -> str:
    """The text itself, once :func:`blender_addon.render_worker.parse_size` accepts it."""
    from blender_addon.render_worker import parse_size

    try:
        parse_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text
