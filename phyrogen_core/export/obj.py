"""Wavefront OBJ text for one convex piece of a :class:`~phyrogen_core.geometry.ConvexPrism`.

URDF has no prism primitive, and URDF loaders (PyBullet among them) turn a
collision mesh into the convex hull of its vertices. A non-convex prism such
as the slot disc is therefore written as one closed mesh per convex piece.
"""

from __future__ import annotations

import functools
import math

from ..geometry import Point2
from ..sizes import PRISM_VERTICES
from .formatting import number


def prism_piece_obj(piece: tuple[Point2, ...], height: float, name: str) -> str:
    """A closed prism over the counter-clockwise polygon ``piece``, z in [-height/2, height/2].

    Vertices: the bottom ring, then the top ring, each in the piece's order.
    Faces are triangles (fans, valid because the piece is convex) wound
    counter-clockwise seen from outside, so every normal points outwards.
    """
    header, body = _prism_text(tuple(map(tuple, piece)), height)
    return f"{header}\no {name}\n{body}"


@functools.lru_cache(maxsize=256)
def _prism_text(piece: tuple[Point2, ...], height: float) -> tuple[str, str]:
    """The piece's OBJ text around its ``o`` line: a visual and its collision are the same prism (equal
    numbers write the same: :func:`~phyrogen_core.export.formatting.number` writes floats, -0.0 as 0)."""
    n = len(piece)
    half = height / 2
    lines = [f"# convex prism piece, {n} sides, height {number(height)}"]
    for z in (-half, half):
        lines += [f"v {number(x)} {number(y)} {number(z)}" for x, y in piece]
    bottom = [1 + i for i in range(n)]
    top = [1 + n + i for i in range(n)]
    # Top seen from +z is counter-clockwise; the bottom, seen from -z, must be reversed.
    lines += [f"f {top[0]} {top[i]} {top[i + 1]}" for i in range(1, n - 1)]
    lines += [f"f {bottom[0]} {bottom[i + 1]} {bottom[i]}" for i in range(1, n - 1)]
    for i in range(n):
        j = (i + 1) % n
        lines.append(f"f {bottom[i]} {bottom[j]} {top[j]}")
        lines.append(f"f {bottom[i]} {top[j]} {top[i]}")
    return lines[0], "".join(line + "\n" for line in lines[1:])


def read_prism_piece(text: str, limit: float = math.inf) -> tuple[tuple[Point2, ...], float]:
    """The (piece, height) of a prism mesh: its distinct (x, y) ring, counter-clockwise.

    Raises ValueError when the mesh is not a prism centred on z = 0 over a
    convex polygon, or a vertex coordinate is not a finite number within
    +-``limit``.
    """
    vertices: list[tuple[float, float, float]] = []
    for number_, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields or fields[0] != "v":
            continue
        if len(fields) < 4:
            raise ValueError(f"line {number_}: vertex needs x y z, got {_show(line)}")
        try:
            vertex = (float(fields[1]), float(fields[2]), float(fields[3]))
        except ValueError:
            raise ValueError(f"line {number_}: vertex coordinates must be numbers, got {_show(line)}") from None
        if not all(-limit <= c <= limit for c in vertex):  # also false for NaN
            raise ValueError(f"line {number_}: vertex coordinates must be finite numbers"
                             + (f" within +-{limit:g}" if limit < math.inf else "") + f", got {_show(line)}")
        vertices.append(vertex)
    too_many = PRISM_VERTICES.problem(len(vertices))  # before the corners are sorted and tested
    if too_many is not None:
        raise ValueError(f"the mesh {too_many}")
    if len(vertices) < 6:
        raise ValueError(f"a prism needs at least 6 vertices, found {len(vertices)}")
    low = min(v[2] for v in vertices)
    high = max(v[2] for v in vertices)
    if high <= low or abs(low + high) > 1e-9 * max(1.0, high):
        raise ValueError(f"a prism must span z in [-h/2, h/2] with h > 0, found z in [{low!r}, {high!r}]")
    ring: list[Point2] = []
    seen: set[Point2] = set()
    for x, y, _ in vertices:
        if (x, y) not in seen:
            seen.add((x, y))
            ring.append((x, y))
    if len(ring) < 3:
        raise ValueError(f"a prism needs at least 3 distinct (x, y) corners, found {len(ring)}")
    if not _is_convex_ccw(ring):
        # Written by another tool: order the corners by angle about their centroid.
        cx = sum(p[0] for p in ring) / len(ring)
        cy = sum(p[1] for p in ring) / len(ring)
        ring.sort(key=lambda p: math.atan2(p[1] - cy, p[0] - cx))
        if not _is_convex_ccw(ring):
            raise ValueError(f"the (x, y) corners do not form a convex polygon: {ring}")
    return tuple(ring), high - low


def _show(line: str, width: int = 80) -> str:
    text = repr(line)
    return text if len(text) <= width else text[:width - 3] + "..."


def _is_convex_ccw(ring: list[Point2]) -> bool:
    """True when ``ring`` walks once, counter-clockwise, around a convex polygon.

    Collinear corners are allowed (clipped outlines have them); the turning
    angles must sum to one full turn, which excludes star-shaped walks.
    """
    n = len(ring)
    scale = max(max(abs(x), abs(y)) for x, y in ring) or 1.0
    turning = 0.0
    for i in range(n):
        (ax, ay), (bx, by), (cx, cy) = ring[i], ring[(i + 1) % n], ring[(i + 2) % n]
        cross = (bx - ax) * (cy - by) - (by - ay) * (cx - bx)
        if cross < -1e-12 * scale * scale:
            return False
        dot = (bx - ax) * (cx - bx) + (by - ay) * (cy - by)
        turning += math.atan2(cross, dot)
    return abs(turning - 2 * math.pi) < 1e-6
