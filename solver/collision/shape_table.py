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
from dataclasses import dataclass

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

    def kept_pairs(self, moving_links: np.ndarray, tolerance: float) -> np.ndarray:
        """Indices of the pairs a model keeps: one of its shapes on a link that ``moving_links`` (a boolean
        per link) marks, z extents overlapping by more than ``tolerance``."""
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        moving = moving_links[self.link]
        keep = (moving[a] | moving[b]) & ~(self.overlap <= tolerance)
        return np.flatnonzero(keep)


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
