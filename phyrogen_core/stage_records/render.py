"""``render``: images (and solution animations) of every puzzle folder under ``out``, and its gallery."""

from __future__ import annotations

from typing import Literal

from .base import Count, StageRequest, StageResult


class RenderRequest(StageRequest, stage="render"):
    out: str = "output"
    """The output folder holding the puzzles; ``index.html`` goes there."""
    engine: Literal["auto", "workbench", "cycles"] = "auto"
    size: str = "520x390"
    """Image size WIDTHxHEIGHT, each side 16..8192."""
    views: str = "top,oblique,oblique_back"
    """Comma-separated views: top, oblique, oblique_back, side."""
    workers: int = 1
    animation: bool = True
    """Also each puzzle's solution animation (``images/<name>_solution.webp``)."""
    blender: str | None = None
    """Render and save each ``.blend`` with this Blender binary (None: the bpy module)."""
    gallery_only: bool = False
    """Only (re)write ``index.html``."""


class RenderResult(StageResult, stage="render"):
    """What was rendered (nothing with ``gallery_only``) and the gallery written."""

    puzzles: Count
    images: Count
    width: Count
    height: Count
    """Of every image (0 when nothing was rendered)."""
    engines: tuple[str, ...]
    seconds: float
    animations: Count
    animation_seconds: float
    """Worker time spent on solution animations, summed over puzzles (included in ``seconds``)."""
    gallery: str | None
    """``index.html``; None when the render failed (then nothing more is written)."""
    error: str | None
    """What failed in a render worker; None when everything was rendered."""

    @property
    def seconds_per_image(self) -> float:
        return self.seconds / self.images if self.images else 0.0

    def done(self) -> bool:
        return self.error is None

    def problem(self) -> str | None:
        return None if (self.gallery is None) != (self.error is None) else "a render has a gallery or an error"
