"""Rigid transforms as 4x4 matrices, and conversions to PyBullet's (position, quaternion)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pybullet as pb


def matrix(position: Sequence[float], quaternion: Sequence[float]) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = np.asarray(pb.getMatrixFromQuaternion(quaternion)).reshape(3, 3)
    m[:3, 3] = position
    return m


def quaternion(m: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, z, w) of the rotation part of ``m`` (Shepperd's method, numerically safe)."""
    r = m[:3, :3]
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        w, x, y, z = 0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        w, x, y, z = (r[2, 1] - r[1, 2]) / s, 0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s
    elif r[1, 1] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        w, x, y, z = (r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s
    else:
        s = 2.0 * math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        w, x, y, z = (r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s
    return (float(x), float(y), float(z), float(w))


def tool_down(position: Sequence[float], yaw: float) -> np.ndarray:
    """A tool pose at ``position`` pointing straight down (tool z = -world z), turned by ``yaw``."""
    return matrix(position, pb.getQuaternionFromEuler((math.pi, 0.0, yaw)))


def rotation_error(desired: np.ndarray, actual: np.ndarray) -> np.ndarray:
    """Axis-angle vector (world frame) that turns ``actual`` into ``desired`` (3x3 rotations)."""
    r = desired @ actual.T
    angle = math.acos(max(-1.0, min(1.0, (np.trace(r) - 1.0) / 2.0)))
    if angle < 1e-9:
        return np.zeros(3)
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    norm = np.linalg.norm(axis)
    if norm < 1e-9:  # a half turn: any axis of the symmetric part
        values, vectors = np.linalg.eigh((r + np.eye(3)) / 2)
        return vectors[:, int(np.argmax(values))] * angle
    return axis / norm * angle


def inverse(m: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = m[:3, :3].T
    out[:3, 3] = -m[:3, :3].T @ m[:3, 3]
    return out
