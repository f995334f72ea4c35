"""Small dense linear algebra for the control loop, compiled.

The control loop solves one 6 x 6 system per physics step. LAPACK's
threaded solve costs milliseconds on a busy machine for a system this small
(thread wake-ups dominate); a compiled Cholesky takes microseconds.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _cholesky(a: np.ndarray) -> np.ndarray:
    n = a.shape[0]
    low = np.zeros_like(a)
    for i in range(n):
        for j in range(i + 1):
            s = a[i, j]
            for k in range(j):
                s -= low[i, k] * low[j, k]
            if i == j:
                low[i, i] = np.sqrt(max(s, 0.0))
            else:
                low[i, j] = s / low[j, j] if low[j, j] > 0.0 else 0.0
    return low


@njit(cache=True)
def damped_least_squares(jacobian: np.ndarray, weights: np.ndarray, damping: float,
                         twist: np.ndarray) -> np.ndarray:
    """q_dot = W^-1 J^T (J W^-1 J^T + damping^2 I)^-1 twist, W = diag(weights)."""
    rows, cols = jacobian.shape
    scaled = jacobian / weights.reshape(1, cols)  # J W^-1
    a = _outer_product(scaled, jacobian)
    for i in range(rows):
        a[i, i] += damping * damping
    low = _cholesky(a)
    y = np.zeros(rows)
    for i in range(rows):  # forward substitution
        s = twist[i]
        for k in range(i):
            s -= low[i, k] * y[k]
        y[i] = s / low[i, i]
    x = np.zeros(rows)
    for i in range(rows - 1, -1, -1):  # back substitution
        s = y[i]
        for k in range(i + 1, rows):
            s -= low[k, i] * x[k]
        x[i] = s / low[i, i]
    q_dot = np.zeros(cols)
    for j in range(cols):
        for i in range(rows):
            q_dot[j] += scaled[i, j] * x[i]
    return q_dot


@njit(cache=True)
def _outer_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b.T with plain loops (compiled matrix products would need SciPy's BLAS)."""
    out = np.zeros((a.shape[0], b.shape[0]))
    for i in range(a.shape[0]):
        for j in range(b.shape[0]):
            s = 0.0
            for k in range(a.shape[1]):
                s += a[i, k] * b[j, k]
            out[i, j] = s
    return out


@njit(cache=True)
def manipulability(jacobian: np.ndarray) -> float:
    """Yoshikawa's measure sqrt(det(J J^T)); zero at a singularity."""
    low = _cholesky(_outer_product(jacobian, jacobian))
    product = 1.0
    for i in range(low.shape[0]):
        product *= low[i, i]
    return product
