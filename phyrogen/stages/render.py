"""The render stage: images (and solution animations) of every puzzle folder under ``out``, and its gallery."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from phyrogen.stage_checks import check_workers
from phyrogen.usage import UsageError
from phyrogen_core.stage_records.render import RenderRequest, RenderResult


def run(request: RenderRequest, *, on_start: Callable[[int], None] | None = None,
        on_done: Callable[[], None] | None = None) -> RenderResult:
    """Render every puzzle folder under ``out`` and write ``<out>/index.html``. Once every folder is read and
    checked, ``on_start`` gets their number (before any Blender starts); ``on_done`` is called per puzzle."""
    from blender_addon.gallery import check_gallery_target, write_gallery
    from blender_addon.render_worker import parse_size
    from blender_addon.rendering import RenderError, check_render_folders, render_puzzles
    from blender_addon.views import parse_views
    from phyrogen_core.folder import find_puzzle_folders, require_writable_dir

    views = parse_views(request.views)
    size = None if request.gallery_only else parse_size(request.size)
    check_workers(request.workers)
    if request.blender is not None:
        _use_blender_binary(request.blender)
    out = require_writable_dir(request.out, "render output folder")  # index.html goes there
    check_gallery_target(out)  # a user's own index.html is refused before any render
    try:
        found = [f.path for f in find_puzzle_folders(out)]
    except FileNotFoundError:
        if not request.gallery_only:
            raise
        found = []  # an empty gallery
    # Every folder is read and checked before any Blender starts (and before the progress bar):
    # a broken one is bad input naming the folder, not a failed render worker.
    folders = check_render_folders(found, writable=size is not None)
    if size is None:
        return _nothing_rendered((0, 0), gallery=str(write_gallery(Path(request.out), views)), error=None)
    if on_start is not None:
        on_start(len(folders))
    try:
        report = render_puzzles(folders, request.engine, size, views, request.workers,
                                on_done=lambda _: on_done() if on_done is not None else None,
                                animation=request.animation)
    except RenderError as exc:
        return _nothing_rendered(size, gallery=None, error=str(exc))
    return RenderResult(puzzles=len(report.rendered), images=report.images, width=size[0], height=size[1],
                        engines=tuple(sorted({r.engine for r in report.rendered})), seconds=report.seconds,
                        animations=report.animations, animation_seconds=report.animation_seconds,
                        gallery=str(write_gallery(Path(request.out), views)), error=None)


def _nothing_rendered(size: tuple[int, int], gallery: str | None, error: str | None) -> RenderResult:
    return RenderResult(puzzles=0, images=0, width=size[0], height=size[1], engines=(), seconds=0.0, animations=0,
                        animation_seconds=0.0, gallery=gallery, error=error)


def _use_blender_binary(text: str) -> None:
    """``blender``: the render workers run in that Blender binary, whose version then writes the ``.blend``
    files (blender_addon.environment.render_worker_command)."""
    import shutil

    from blender_addon.environment import BLENDER_VARIABLE

    found = shutil.which(text)
    if found is None:
        raise UsageError(f"--blender {text!r}: no such executable")
    os.environ[BLENDER_VARIABLE] = str(Path(found).resolve())
