"""A top-down occupancy raster of a planar chain, drawn from the collision model's own shapes.

The collision model (:mod:`solver.collision.model`) holds every collision shape as a convex outline
(or circle) in its link frame; a state fixes every link's planar pose. A raster cell is occupied by a
shape when the cell's centre lies in the shape's outline at that pose: the same outlines and poses
the collision checks use, so the raster needs no mesh and no renderer. The z extent is dropped: the
raster is the view from above (a shape under a lid and the lid share cells).

Drawing one state costs a pass over each shape's bounding square of cells, compiled (tens of
microseconds for a Grid World at 32 x 32 cells), so an environment can draw one per step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from solver.collision import kernels as _kernels
from solver.collision.model import CollisionModel


@dataclass(frozen=True)
class RasterFrame:
    """Where the raster lies in the world: ``size`` x ``size`` square cells of ``cell`` metres, the
    lower-left corner at (``x0``, ``y0``). Row 0 is the top (largest y), column 0 the left (smallest x),
    as an image is shown."""

    x0: float
    y0: float
    cell: float
    size: int

    def centre(self, row: int, column: int) -> tuple[float, float]:
        """The world (x, y) of a cell's centre."""
        return self.x0 + (column + 0.5) * self.cell, self.y0 + (self.size - row - 0.5) * self.cell


class ChainRaster:
    """Draws the shapes of a :class:`CollisionModel` at joint states into raster channels.

    ``shape_objects`` names each shape's object and ``shape_moves`` says whether it can move; a
    caller picks each shape's channel from them (-1: not drawn) and passes the choice to :meth:`draw`.
    """

    def __init__(self, model: CollisionModel, frame: RasterFrame):
        self.model, self.frame = model, frame
        # The model's compiled arrays, read as they are (one source of geometry for checks and raster).
        self._kin_int, self._kin_float = model._kin_int, model._kin_float
        self._links = len(model._links)
        self._shapes = (model._shape_link, model._shape_nv, model._shape_center, model._shape_radius,
                        model._shape_verts, model._shape_normals, model._shape_extent)
        self.shape_objects: tuple[str, ...] = tuple(o.obj for o in model._outlines)
        self.shape_moves = np.array([o.link in model._moving for o in model._outlines], dtype=np.bool_)

    def draw(self, state: np.ndarray, channel_of_shape: np.ndarray, out: np.ndarray) -> None:
        """Mark (set to 1) the cells each shape covers at ``state`` (the model's joint order) in its channel of
        ``out`` (C, size, size), float32 or uint8; nothing is cleared first."""
        poses = _kernels.fixed_poses(np.ascontiguousarray(state, dtype=np.float64), self._kin_int, self._kin_float,
                                     self._links)
        f = self.frame
        _draw(poses, np.ascontiguousarray(channel_of_shape, dtype=np.int64), *self._shapes, f.x0, f.y0, f.cell, out)


def frame_around(model: CollisionModel, states: Sequence[np.ndarray], size: int, margin: float = 0.05) -> RasterFrame:
    """The square frame that holds every shape at each of ``states`` (the bounding circles, so any
    turn of them too), widened by ``margin`` of its side on every edge."""
    if isinstance(size, bool) or not isinstance(size, int) or size < 4:
        raise ValueError(f"raster size must be an int >= 4 cells, got {size!r}")
    low = np.full(2, np.inf)
    high = np.full(2, -np.inf)
    for state in states:
        poses = _kernels.fixed_poses(np.ascontiguousarray(state, dtype=np.float64), model._kin_int,
                                     model._kin_float, len(model._links))
        links = model._shape_link
        c, s = poses[2, links], poses[3, links]
        cx, cy = model._shape_center[:, 0], model._shape_center[:, 1]
        x = poses[0, links] + c * cx - s * cy
        y = poses[1, links] + s * cx + c * cy
        r = model._shape_radius
        low = np.minimum(low, [np.min(x - r), np.min(y - r)])
        high = np.maximum(high, [np.max(x + r), np.max(y + r)])
    side = float(max(high - low)) * (1.0 + 2.0 * margin)
    if not math.isfinite(side) or side <= 0.0:
        raise ValueError("the chain has no collision shape to frame")
    middle = (low + high) / 2.0
    return RasterFrame(float(middle[0] - side / 2), float(middle[1] - side / 2), side / size, size)


@njit(cache=True, nogil=True)
def _draw(poses, channel_of_shape, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
          shape_extent, x0, y0, cell, out):
    size = out.shape[1]
    for k in range(shape_link.shape[0]):
        channel = channel_of_shape[k]
        if channel < 0:
            continue
        link = shape_link[k]
        px, py, c, s = poses[0, link], poses[1, link], poses[2, link], poses[3, link]
        # The shape's bounding circle in the world bounds the cells to test.
        wx = px + c * shape_center[k, 0] - s * shape_center[k, 1]
        wy = py + s * shape_center[k, 0] + c * shape_center[k, 1]
        r = shape_radius[k]
        col_lo = max(int(math.floor((wx - r - x0) / cell - 0.5)), 0)
        col_hi = min(int(math.ceil((wx + r - x0) / cell - 0.5)), size - 1)
        row_lo = max(size - 1 - int(math.ceil((wy + r - y0) / cell - 0.5)), 0)
        row_hi = min(size - 1 - int(math.floor((wy - r - y0) / cell - 0.5)), size - 1)
        nv = shape_nv[k]
        for row in range(row_lo, row_hi + 1):
            y = y0 + (size - row - 0.5) * cell - py
            for col in range(col_lo, col_hi + 1):
                x = x0 + (col + 0.5) * cell - px
                # The cell centre in the link frame.
                lx = c * x + s * y
                ly = -s * x + c * y
                if nv == 0:
                    dx = lx - shape_center[k, 0]
                    dy = ly - shape_center[k, 1]
                    inside = dx * dx + dy * dy <= r * r
                else:
                    inside = True
                    for e in range(nv):
                        if shape_normals[k, e, 0] * lx + shape_normals[k, e, 1] * ly > shape_extent[k, e]:
                            inside = False
                            break
                if inside:
                    out[channel, row, col] = 1
