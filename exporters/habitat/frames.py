"""MuJoCo (Z-up, +X heading 0) -> Habitat (Y-up, agent looks along -Z) frame conversion.

Positions: (x, y, z)_mj -> (x, z, -y)_hab, i.e. p' = C p with C = R_x(-90 deg).
Body rotations: R' = C R C^T (render assets are written with C applied to their vertices).
Agent headings: MuJoCo yaw psi (from +X, CCW about +Z) -> Habitat yaw theta = psi - 90 deg about +Y,
written [0, sin(theta/2), 0, cos(theta/2)] (xyzw). Scene instances use wxyz, episodes xyzw.
"""

from __future__ import annotations

import math

import numpy as np

import mujoco

C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def position(p: np.ndarray) -> list[float]:
    """Return a MuJoCo world point in the Habitat frame."""
    return [float(v) for v in C @ np.asarray(p, dtype=float)]


def quat_to_mat(q_wxyz: np.ndarray) -> np.ndarray:
    """Return the 3x3 rotation of a wxyz quaternion."""
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, np.asarray(q_wxyz, dtype=float) / np.linalg.norm(q_wxyz))
    return m.reshape(3, 3)


def mat_to_quat(R: np.ndarray) -> np.ndarray:
    """Return the wxyz quaternion (w >= 0) of a 3x3 rotation."""
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.asarray(R, dtype=float).ravel())
    return q if q[0] >= 0 else -q


def body_rotation_wxyz(q_wxyz_mj: np.ndarray) -> list[float]:
    """Return a MuJoCo body orientation as a Habitat scene-instance rotation (wxyz)."""
    return [float(v) for v in mat_to_quat(C @ quat_to_mat(q_wxyz_mj) @ C.T)]


def yaw_deg_of(q_wxyz: np.ndarray) -> float:
    """Return the heading (deg, about +Z from +X) of a wxyz quaternion."""
    w, x, y, z = (float(v) for v in q_wxyz)
    return math.degrees(math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


def agent_rotation_xyzw(q_wxyz_mj: np.ndarray) -> list[float]:
    """Return a MuJoCo agent heading quaternion as a Habitat agent rotation (xyzw, yaw only)."""
    theta = math.radians(yaw_deg_of(q_wxyz_mj) - 90.0)
    return [0.0, math.sin(theta / 2.0), 0.0, math.cos(theta / 2.0)]
