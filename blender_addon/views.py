"""The camera views a puzzle is rendered from (no bpy: the gallery needs them too)."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class View:
    """A camera direction: ``azimuth`` about z from +x, ``elevation`` above the floor (degrees).

    An elevation of 90 degrees is the orthographic top view.
    """

    name: str
    title: str
    azimuth: float
    elevation: float


_PAPER_TILT = 90.0 - math.degrees(0.96)
"""The paper's oblique cameras are tilted 0.96 rad from the vertical: 35 degrees above the floor."""

VIEWS: dict[str, View] = {
    "top": View("top", "top", -90.0, 90.0),
    "oblique": View("oblique", "oblique", -55.0, _PAPER_TILT),
    "oblique_back": View("oblique_back", "oblique, from behind", 125.0, _PAPER_TILT),
    "side": View("side", "side", -90.0, 12.0),
}
DEFAULT_VIEWS: tuple[str, ...] = ("top", "oblique", "oblique_back")
STILL_SIZE = (520, 390)
"""The stills' default width and height (480x360 before the floor and shadows came; in no more time per
still, see ``blender_addon.render.GROUND``)."""
GALLERY_VIEW = "oblique"
"""The view shown in the gallery's table; the others are linked."""


def parse_views(text: str) -> tuple[str, ...]:
    """'top,oblique' -> ('top', 'oblique'); raises ValueError naming an unknown view."""
    names = tuple(v.strip() for v in text.split(",") if v.strip())
    unknown = [v for v in names if v not in VIEWS]
    if unknown or not names:
        raise ValueError(f"unknown views {unknown or text!r}; valid: {', '.join(VIEWS)} (comma-separated)")
    return names


def image_name(puzzle_name: str, index: int) -> str:
    """The file name of a puzzle's ``index``-th rendered view."""
    return f"{puzzle_name}_{index:02d}.png"


def animation_name(puzzle_name: str) -> str:
    """The file name of a puzzle's solution animation (beside its images)."""
    return f"{puzzle_name}_solution.webp"
