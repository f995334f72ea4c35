"""The screen of :func:`solver.validation.judge.shift_repair`, compiled: which offsets keep every screened
point of a colliding run within the limits and collision-free.

In numpy the screen checked the run's middle point for every offset, then the rest a few points at a time
for the offsets still passing, every point of a piece even where the first one failed. Here each offset's
points are checked one by one, the middle one first, until one fails: an offset passes exactly when every
screened point does, so the offsets that pass are the same, at fewer state checks.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from solver.collision.kernels import _state_valid


@njit(cache=True, nogil=True)
def screen(points, offsets, lower, upper, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
           shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol):
    """Whether each offset (row of ``offsets``, (N, d)) added to every row of ``points`` (M, d) gives states
    within ``lower``..``upper`` and valid (:func:`~solver.collision.kernels.check_states`), the middle row
    (``M // 2``) tried first."""
    n, m, d = offsets.shape[0], points.shape[0], points.shape[1]
    passed = np.empty(n, dtype=np.bool_)
    x, y, c, s, yaws = np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links), np.empty(n_links)
    centres = np.empty((2, shape_link.shape[0]))
    q = np.empty(d)
    full = True  # (the fixed links' poses once: the same at every state)
    for i in range(n):
        passed[i] = True
        for r in range(m + 1):
            row = m // 2 if r == 0 else r - 1
            if r > 0 and row == m // 2:
                continue
            inside = True
            for j in range(d):
                q[j] = points[row, j] + offsets[i, j]
                if not (q[j] >= lower[j] and q[j] <= upper[j]):
                    inside = False
            if not inside:
                passed[i] = False
                break
            valid = _state_valid(q, kin_int, kin_float, x, y, c, s, yaws, centres, full, shape_link, shape_nv,
                                 shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol)
            full = False
            if not valid:
                passed[i] = False
                break
    return passed
