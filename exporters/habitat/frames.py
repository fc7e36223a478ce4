"""MuJoCo (Z-up, +X heading 0) -> Habitat (Y-up, agent looks along -Z) frame conversion.

Positions: (x, y, z)_mj -> (x, z, -y)_hab, i.e. p' = C p with C = R_x(-90 deg).
Body rotations: R' = C R C^T (render assets are written with C applied to their vertices).
URDF articulated objects (Z-up files, copied as they are): instance rotation C R_z(yaw), translation C p.
Agent headings: MuJoCo yaw psi (from +X, CCW about +Z) -> Habitat yaw theta = psi - 90 deg about +Y,
written [0, sin(theta/2), 0, cos(theta/2)] (xyzw). Scene instances use wxyz, episodes xyzw.
"""

from __future__ import annotations

import math

import numpy as np

from sdovon_mj.geometry import mat_to_quat, quat_to_mat, quat_yaw

C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def position(p: np.ndarray) -> list[float]:
    """Return a MuJoCo world point in the Habitat frame."""
    return [float(v) for v in C @ np.asarray(p, dtype=float)]


def body_rotation_wxyz(q_wxyz_mj: np.ndarray) -> list[float]:
    """Return a MuJoCo body orientation as a Habitat scene-instance rotation (wxyz)."""
    return [float(v) for v in mat_to_quat(C @ quat_to_mat(q_wxyz_mj, mujoco_arithmetic=True) @ C.T)]


def agent_rotation_xyzw(q_wxyz_mj: np.ndarray) -> list[float]:
    """Return a MuJoCo agent heading quaternion as a Habitat agent rotation (xyzw, yaw only)."""
    theta = math.radians(quat_yaw(q_wxyz_mj) - 90.0)
    return [0.0, math.sin(theta / 2.0), 0.0, math.cos(theta / 2.0)]


def urdf_rotation_wxyz(yaw_deg: float) -> list[float]:
    """Return the Habitat rotation (wxyz) of a Z-up URDF whose root frame has yaw `yaw_deg` about MuJoCo's +Z.

    The URDF's own coordinates are not converted, so the instance rotation carries the frame change: C R_z(yaw).
    """
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return [float(v) for v in mat_to_quat(C @ Rz)]


def urdf_rotation_matrix_wxyz(R_mj: np.ndarray) -> list[float]:
    """Return the Habitat rotation (wxyz) of a URDF frame with rotation `R_mj` in MuJoCo's world: C R (the URDF's
    coordinates are taken in Habitat's world as they are, as for `urdf_rotation_wxyz`)."""
    return [float(v) for v in mat_to_quat(C @ np.asarray(R_mj, dtype=float))]
