"""The planar footprint of a triangle mesh: convex pieces of an extruded prism, or a hull prism.

Every PhyRoGen shape is a vertical prism. A mesh that is one already (an
outline extruded along z, such as the prototype's slot disc) becomes the
same prism exactly: the triangles of its top face are merged into convex
pieces (Hertel and Mehlhorn: drop a diagonal whenever both pieces it joins
stay convex), which is what :class:`~phyrogen_core.geometry.ConvexPrism`
holds. Any other mesh (a droid, a capsule) becomes the prism over the convex
hull of its outline, from its lowest to its highest point: it covers the
mesh, so a puzzle solved with it is solvable with the mesh, not always the
other way round. :attr:`Footprint.exact` tells which.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import Point2

MAX_PIECES = 32
"""More convex pieces than this (a finely tessellated, very concave outline) and the hull is used:
every piece is one more shape in every collision query."""


@dataclass(frozen=True)
class Footprint:
    """A vertical prism: counter-clockwise convex ``pieces`` (x, y) between ``z_low`` and ``z_high``."""

    pieces: tuple[tuple[Point2, ...], ...]
    z_low: float
    z_high: float
    exact: bool  # True: the mesh is this prism; False: the prism is the mesh's hull (it covers the mesh)
    why: str = ""  # when not exact, why not


def footprint(triangles: np.ndarray) -> Footprint:
    """The footprint of ``triangles`` (``(n, 3, 3)``, in the frame whose z is vertical)."""
    corners = triangles.reshape(-1, 3)
    low, high = corners.min(axis=0), corners.max(axis=0)
    extent = float(np.max(high - low))
    if not extent > 0:
        raise ValueError("the mesh has no extent (all its vertices coincide)")
    tolerance = 1e-5 * extent + 1e-7 * float(np.max(np.abs(corners)))
    z_low, z_high = float(low[2]), float(high[2])
    if z_high - z_low <= tolerance:
        raise ValueError(f"the mesh is flat (height {z_high - z_low:.3g}); a puzzle shape needs a height")
    z = triangles[:, :, 2]
    at_low, at_high = np.abs(z - z_low) <= tolerance, np.abs(z - z_high) <= tolerance
    why = _not_extruded(triangles, at_low, at_high, tolerance, extent)
    if not why:
        top = triangles[at_high.all(axis=1)][:, :, :2]
        pieces = convex_pieces(top, tolerance)
        if len(pieces) <= MAX_PIECES:
            return Footprint(pieces, z_low, z_high, True)
        why = f"its outline needs {len(pieces)} convex pieces, more than {MAX_PIECES}"
    return Footprint((convex_hull(corners[:, :2], tolerance),), z_low, z_high, False, why)


def _not_extruded(triangles: np.ndarray, at_low: np.ndarray, at_high: np.ndarray, tolerance: float,
                  extent: float) -> str:
    """Why the mesh is no outline extruded along z ('' when it is one)."""
    if not (at_low | at_high).all():
        return "it has vertices between its lowest and highest level (a 3D shape)"
    top, bottom = at_high.all(axis=1), at_low.all(axis=1)
    side = ~(top | bottom)
    if np.any(np.abs(_areas(triangles[side][:, :, :2])) > tolerance * extent):
        return "a side face is not vertical"
    top_area = np.abs(_areas(triangles[top][:, :, :2])).sum()
    bottom_area = np.abs(_areas(triangles[bottom][:, :, :2])).sum()
    if not top_area > 0 or abs(top_area - bottom_area) > 1e-6 * top_area + tolerance * extent:
        return "its top and bottom faces differ"
    return ""


def _areas(triangles: np.ndarray) -> np.ndarray:
    """Signed areas of 2D triangles ``(n, 3, 2)`` (positive: counter-clockwise)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def convex_pieces(triangles: np.ndarray, tolerance: float) -> tuple[tuple[Point2, ...], ...]:
    """Convex pieces covering the union of the 2D ``triangles`` ``(n, 3, 2)`` (a triangulation of
    one outline: no two overlap), by merging neighbours while the result stays convex."""
    keys = np.round(triangles.reshape(-1, 2) / (10 * tolerance)).astype(np.int64)
    ids: dict[tuple[int, int], int] = {}
    points: list[Point2] = []
    for key, point in zip(map(tuple, keys.tolist()), triangles.reshape(-1, 2).tolist(), strict=True):
        if key not in ids:
            ids[key] = len(points)
            points.append((float(point[0]), float(point[1])))
    corner_ids = np.array([ids[tuple(k)] for k in keys.tolist()]).reshape(-1, 3)
    xy = np.array(points)
    pieces: dict[int, list[int]] = {}
    for a, b, c in corner_ids.tolist():
        if len({a, b, c}) < 3:
            continue
        if _cross(xy[a], xy[b], xy[c]) < 0:
            b, c = c, b
        if _cross(xy[a], xy[b], xy[c]) <= tolerance * tolerance:
            continue  # a sliver of no area
        pieces[len(pieces)] = [a, b, c]
    owner = {(p[i], p[(i + 1) % len(p)]): key for key, p in pieces.items() for i in range(len(p))}
    # One pass over the diagonals suffices: merging only widens the angles at a piece's
    # corners, so a diagonal that cannot be dropped now never can.
    for edge in sorted(owner):
        a, b = edge
        if edge not in owner or (b, a) not in owner or owner[edge] == owner[(b, a)]:
            continue
        first, second = owner[edge], owner[(b, a)]
        merged = _merge(pieces[first], pieces[second], a, b)
        if len(set(merged)) != len(merged):
            continue  # the two pieces also meet elsewhere (around a hole)
        if not all(_convex_at(xy, merged, merged.index(v), tolerance) for v in (a, b)):
            continue
        del owner[edge], owner[(b, a)]
        del pieces[second]
        pieces[first] = merged
        for i in range(len(merged)):
            pair = (merged[i], merged[(i + 1) % len(merged)])
            if pair in owner:
                owner[pair] = first
    out = []
    for key in sorted(pieces):
        ring = _drop_collinear(xy, pieces[key], tolerance)
        out.append(tuple((float(xy[i][0]) + 0.0, float(xy[i][1]) + 0.0) for i in ring))
    return tuple(out)


def _merge(first: list[int], second: list[int], a: int, b: int) -> list[int]:
    """The polygon of two counter-clockwise polygons sharing the edge a->b (in ``first``) / b->a."""
    i = first.index(b)
    head = first[i:] + first[:i]  # b ... a
    j = second.index(a)
    tail = second[j:] + second[:j]  # a ... b
    return head + tail[1:-1]


def _cross(a, b, c) -> float:
    return float((b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]))


def _convex_at(xy: np.ndarray, ring: list[int], index: int, tolerance: float) -> bool:
    a, b, c = xy[ring[index - 1]], xy[ring[index]], xy[ring[(index + 1) % len(ring)]]
    # A straight corner (within the coordinates' noise) counts as convex.
    return _cross(a, b, c) >= -tolerance * float(np.linalg.norm(b - a) + np.linalg.norm(c - b))


def _drop_collinear(xy: np.ndarray, ring: list[int], tolerance: float) -> list[int]:
    out = list(ring)
    changed = True
    while changed and len(out) > 3:
        changed = False
        for k in range(len(out)):
            a, b, c = xy[out[k - 1]], xy[out[k]], xy[out[(k + 1) % len(out)]]
            if abs(_cross(a, b, c)) <= tolerance * max(float(np.linalg.norm(c - a)), tolerance):
                del out[k]
                changed = True
                break
    return out


def convex_hull(points: np.ndarray, tolerance: float = 0.0) -> tuple[Point2, ...]:
    """The counter-clockwise convex hull of 2D ``points`` (Andrew's monotone chain), without
    collinear corners."""
    unique = sorted(set(map(tuple, np.asarray(points, dtype=float).tolist())))
    if len(unique) < 3:
        raise ValueError("the outline has fewer than 3 distinct corners")

    def chain(sequence):
        out: list[tuple[float, float]] = []
        for p in sequence:
            while len(out) >= 2 and _cross(out[-2], out[-1], p) <= tolerance * tolerance:
                out.pop()
            out.append(p)
        return out

    lower, upper = chain(unique), chain(reversed(unique))
    hull = lower[:-1] + upper[:-1]
    if len(hull) < 3:
        raise ValueError("the outline has no area")
    return tuple((float(x) + 0.0, float(y) + 0.0) for x, y in hull)
