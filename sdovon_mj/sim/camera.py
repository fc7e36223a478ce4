"""Pinhole cameras: intrinsics from a field of view, poses from position/yaw/pitch, frame changes."""

from __future__ import annotations

import math

import numpy as np

from ..grid import true_box

# OpenCV camera axes (x right, y down, z forward) expressed in MuJoCo camera axes (x right, y up,
# z backward): flip y and z.
CV_FROM_MJ = np.diag([1.0, -1.0, -1.0])


def vfov_from_hfov(hfov_deg: float, width: int, height: int) -> float:
    """Return the vertical field of view (deg) matching a horizontal one for an image size."""
    return math.degrees(2.0 * math.atan(math.tan(math.radians(hfov_deg) / 2.0) * height / width))


def intrinsics(width: int, height: int, hfov_deg: float) -> np.ndarray:
    """Return the 3x3 pinhole matrix K for square pixels and a centred principal point."""
    fx = (width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
    return np.array([[fx, 0.0, width / 2.0], [0.0, fx, height / 2.0], [0.0, 0.0, 1.0]])


def look_direction(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """Return the unit forward vector for a yaw about +Z (0 = +X) and pitch (negative = down)."""
    y, p = math.radians(yaw_deg), math.radians(pitch_deg)
    return np.array([math.cos(p) * math.cos(y), math.cos(p) * math.sin(y), math.sin(p)])


def pose_cv(position: np.ndarray, yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """Return T_cam (world <- OpenCV camera) for a camera at `position` looking along yaw/pitch."""
    f = look_direction(yaw_deg, pitch_deg)
    # right = f x up and down = f x right, written out in numpy.cross's operation order (same bits, no
    # per-call array machinery: this runs once per visibility test).
    f0, f1, f2 = float(f[0]), float(f[1]), float(f[2])
    right = np.array([f1 * 1.0 - f2 * 0.0, f2 * 0.0 - f0 * 1.0, f0 * 0.0 - f1 * 0.0])
    n = math.sqrt(right.dot(right))  # np.linalg.norm of a vector: sqrt(x.dot(x)) (same bits, less machinery)
    right = right / n if n > 1e-9 else np.array([math.sin(math.radians(yaw_deg)), -math.cos(math.radians(yaw_deg)), 0.0])
    r0, r1, r2 = float(right[0]), float(right[1]), float(right[2])
    T = np.zeros((4, 4))
    T[:3, 0] = right
    T[:3, 1] = (f1 * r2 - f2 * r1, f2 * r0 - f0 * r2, f0 * r1 - f1 * r0)
    T[:3, 2] = f
    T[:3, 3] = position
    T[3, 3] = 1.0
    return T


def valid_depth(depth: np.ndarray, depth_min: float = 0.0, depth_max: float = np.inf) -> np.ndarray:
    """Return the (H, W) bool mask of the depth pixels inside (depth_min, depth_max) metres (finite, > 0)."""
    return (depth > max(depth_min, 0.0)) & (depth < depth_max) & np.isfinite(depth)


def backproject(depth: np.ndarray, K: np.ndarray, T_cam: np.ndarray, mask: np.ndarray | None = None,
                depth_min: float = 0.0, depth_max: float = np.inf, valid: np.ndarray | None = None) -> np.ndarray:
    """Return world points (N, 3) of the valid depth pixels (optionally inside `mask`).

    Parameters
    ----------
    depth : (H, W) float
        Depth image, metres (0 or non-finite: invalid).
    K : (3, 3) float
        Camera intrinsics, pixels.
    T_cam : (4, 4) float
        Camera pose (world <- OpenCV camera), metres.
    mask : (H, W) bool, optional
        Pixels to keep.
    depth_min, depth_max : float
        Valid depth range (exclusive), metres.
    valid : (H, W) bool, optional
        `valid_depth(depth, depth_min, depth_max)` already computed (several masks of one image).
    """
    r0 = c0 = 0
    if mask is not None:  # only the mask's bounding box: every pixel outside it is masked out, the points are the same
        r0, r1, c0, c1 = true_box(mask) or (0, 0, 0, 0)
        win = (slice(r0, r1), slice(c0, c1))
        depth, mask = depth[win], np.asarray(mask)[win]
        valid = None if valid is None else valid[win]
    valid = valid_depth(depth, depth_min, depth_max) if valid is None else valid
    valid = valid & mask if mask is not None else valid
    v, u = np.nonzero(valid)
    z = depth[v, u].astype(np.float64)
    if r0 or c0:
        v, u = v + r0, u + c0
    x = (u + 0.5 - K[0, 2]) * z / K[0, 0]
    y = (v + 0.5 - K[1, 2]) * z / K[1, 1]
    pc = np.stack([x, y, z], axis=1)
    return pc @ T_cam[:3, :3].T + T_cam[:3, 3]


def project(points: np.ndarray, K: np.ndarray, T_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return pixel coordinates (N, 2) and camera depths (N,) of world points."""
    R, t = T_cam[:3, :3], T_cam[:3, 3]
    pc = (np.asarray(points, dtype=float) - t) @ R
    z = pc[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = K[0, 0] * pc[:, 0] / z + K[0, 2]
        v = K[1, 1] * pc[:, 1] / z + K[1, 2]
    return np.stack([u, v], axis=1), z
