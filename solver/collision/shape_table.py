"""The arrays of a chain's collision shapes that no locked joint and no tolerance changes.

A puzzle's collision models are built from one chain many times over, each locking other joints
(a judge's question holds some objects fixed) or with another tolerance (the interlock margin's
shrink): the shapes, and the pairs of shapes of different objects and links, are the same in all
of them. :func:`shape_table` builds them once; a model keeps the pairs that one of its shapes moves
and whose z extents overlap by more than its tolerance (:meth:`ShapeTable.kept_pairs`), in the order
the model always listed them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class ShapeTable:
    """Shapes in the model's order (their link, vertex count, bounding circle, farthest reach from the
    link's origin, padded vertices, edge normals and extents) and the candidate pairs."""

    link: np.ndarray
    nv: np.ndarray
    center: np.ndarray
    radius: np.ndarray
    rho: np.ndarray
    verts: np.ndarray
    normals: np.ndarray
    extent: np.ndarray
    pairs: np.ndarray  # (p, 2) shapes of different objects and links, i < j in triangle order, a circle second
    overlap: np.ndarray  # (p,) how far each pair's z extents overlap (negative: apart)
    # The kept pairs' arrays by moving links and tolerance: a puzzle's models hold the same objects fixed
    # again and again (each candidate's judges), and the table is shared by chains of the same shapes.
    _kept: dict[tuple[bytes, float], np.ndarray] = field(default_factory=dict, compare=False, repr=False)

    def kept_pairs(self, moving_links: np.ndarray, tolerance: float) -> np.ndarray:
        """Indices of the pairs a model keeps: one of its shapes on a link that ``moving_links`` (a boolean
        per link) marks, z extents overlapping by more than ``tolerance``."""
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        moving = moving_links[self.link]
        keep = (moving[a] | moving[b]) & ~(self.overlap <= tolerance)
        return np.flatnonzero(keep)

    @cached_property
    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """The shapes' part of a model's packed arrays (``CollisionModel._pack``): links and vertex counts,
        then centres, radii, vertices, normals and extents, flat."""
        ints = np.concatenate([self.link, self.nv]).astype(np.int64)
        floats = np.concatenate([self.center.ravel(), self.radius, self.verts.ravel(), self.normals.ravel(),
                                 self.extent.ravel()]).astype(np.float64)
        return ints, floats

    def kept(self, moving_links: np.ndarray, tolerance: float) -> np.ndarray:
        """The pairs :meth:`kept_pairs` keeps, as a C-contiguous (p, 2) array: the last few kept (the same
        numbers, so every model built from them is the same)."""
        key = (moving_links.tobytes(), tolerance)
        found = self._kept.get(key)
        if found is None:
            if len(self._kept) >= _KEPT_PAIRS:
                self._kept.clear()
            found = self._kept[key] = np.ascontiguousarray(self.pairs[self.kept_pairs(moving_links, tolerance)])
        return found


_KEPT_PAIRS = 64


def shape_table(outlines: Sequence) -> ShapeTable:
    """The table of a model's outlines (:class:`~solver.collision.model._Outline` records)."""
    k = max([len(o.vertices) for o in outlines if not o.is_circle] + [3])
    count = len(outlines)
    link = np.array([o.link for o in outlines], dtype=np.int64)
    nv = np.array([0 if o.is_circle else len(o.vertices) for o in outlines], dtype=np.int64)
    center = np.array([o.center for o in outlines], dtype=np.float64).reshape(count, 2)
    radius = np.array([o.radius for o in outlines], dtype=np.float64)
    # The farthest any point of a shape (and its bounding circle's centre) stands from its link's origin.
    rho = np.array([math.hypot(*o.center) + o.radius for o in outlines], dtype=np.float64)
    verts = np.zeros((count, k, 2))
    normals = np.zeros((count, k, 2))
    extent = np.zeros((count, k))
    for i, o in enumerate(outlines):
        if o.is_circle:
            continue
        v = o.vertices
        verts[i, : len(v)] = v
        normals[i, : len(v)] = o.normals
        extent[i, : len(v)] = o.extent
    obj_ids: dict[str, int] = {}
    obj = np.array([obj_ids.setdefault(o.obj, len(obj_ids)) for o in outlines], dtype=np.int64)
    circle = np.array([o.is_circle for o in outlines], dtype=np.bool_)
    z_low = np.array([o.z_low for o in outlines], dtype=np.float64)
    z_high = np.array([o.z_high for o in outlines], dtype=np.float64)
    first, second = np.triu_indices(count, 1)
    keep = (obj[first] != obj[second]) & (link[first] != link[second])
    first, second = first[keep], second[keep]
    overlap = np.minimum(z_high[first], z_high[second]) - np.maximum(z_low[first], z_low[second])
    swap = circle[first] & ~circle[second]
    pairs = np.column_stack([np.where(swap, second, first), np.where(swap, first, second)]).astype(np.int64)
    return ShapeTable(link, nv, center, radius, rho, verts, normals, extent, pairs.reshape(-1, 2), overlap)


_TABLES: dict[tuple[int, ...], tuple[list, ShapeTable]] = {}
_TABLES_KEPT = 64


def shared_shape_table(outlines: Sequence) -> ShapeTable:
    """``shape_table(outlines)``, kept by the outlines' identities: a model's outlines are kept objects
    (``solver.collision.model._PLACED``), so the chains of one puzzle's candidates (each a new chain, most of
    them of the same shapes) hand over the same outline objects, and their table is the one already built
    (the outlines are kept with it, so no other outline gets their ids while it is kept)."""
    key = tuple(map(id, outlines))
    found = _TABLES.get(key)
    if found is not None and all(a is b for a, b in zip(found[0], outlines, strict=True)):
        return found[1]
    table = shape_table(outlines)
    if len(_TABLES) >= _TABLES_KEPT:
        del _TABLES[next(iter(_TABLES))]
    _TABLES[key] = (list(outlines), table)
    return table


def descendants(chain, links: Sequence[str], link_index: Mapping[str, int]) -> dict[str, set[int]]:
    """Each link's index and those of every link below it (``links``: the chain's, parents first)."""
    out: dict[str, set[int]] = {}
    for name in reversed(links):
        mine = {link_index[name]}
        for joint in chain.joints:
            if joint.parent == name:
                mine |= out[joint.child]
        out[name] = mine
    return out


_REACHES: dict[tuple, tuple[list, float]] = {}
_REACHES_KEPT = 1024


def revolute_reach(outlines: Sequence, carried_links: set[int], rest: Mapping[str, np.ndarray], links: Sequence[str],
                   child: str) -> float:
    """The largest distance from a revolute joint's axis (its ``child`` link's rest origin) of any collision
    point of the links it carries (``carried_links``), at least 1 mm. Kept by the exact numbers it reads
    (each carried outline, by identity, and its link's rest pose): a puzzle's candidates are new chains of
    mostly the same objects at the same poses."""
    carried = [o for o in outlines if o.link in carried_links]
    key = (rest[child][:2, 3].tobytes(), *((id(o), rest[links[o.link]][:2].tobytes()) for o in carried))
    found = _REACHES.get(key)
    if found is not None and all(a is b for a, b in zip(found[0], carried, strict=True)):
        return found[1]
    axis_xy = rest[child][:2, 3]
    best = 0.0
    for o in carried:
        m = rest[links[o.link]]
        pts = o.vertices if not o.is_circle else o.center[None, :]
        world = pts @ m[:2, :2].T + m[:2, 3]
        extra = 0.0 if not o.is_circle else o.radius
        best = max(best, float(np.max(np.linalg.norm(world - axis_xy, axis=1))) + extra)
    if len(_REACHES) >= _REACHES_KEPT:
        _REACHES.clear()
    value = max(best, 1e-3)
    _REACHES[key] = (carried, value)  # the outlines kept with their key, so no other outline gets their ids
    return value
