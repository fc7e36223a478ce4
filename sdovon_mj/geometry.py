"""Small shared geometry: convex polygons in world XY, point-in-polygon tests, axis-aligned boxes and quaternions.

One home for the geometry every stage uses (like `records`, it depends on numpy only; scipy, shapely,
matplotlib and mujoco are imported lazily by the functions that need them):

- Polygons are (M, 2) world XY vertex arrays, counter-clockwise (`records` convention): hulls,
  area, IoU, overlap, shrinking and the uniform sampling of the paper's appendix B, which the
  receptacles stage detects planes with and the place stage samples spawn points in.
- Point-in-polygon: `points_in_polygon` for any simple polygon (even-odd rule) and
  `points_in_convex_polygon` for convex ones with a distance tolerance.
- Quaternions are **wxyz** (MuJoCo order); yaw is degrees about +Z from +X.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from shapely.geometry import Polygon

# ----------------------------------------------------------------------------------------------
# Convex polygons


def polygon_area(polygon: np.ndarray) -> float:
    """Return the signed area of a polygon (positive when counter-clockwise)."""
    p = np.asarray(polygon, dtype=float).reshape(-1, 2)
    if len(p) < 3:
        return 0.0
    x, y = p[:, 0], p[:, 1]
    return float(0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def ensure_ccw(polygon: np.ndarray) -> np.ndarray:
    """Return the polygon's vertices in counter-clockwise order."""
    p = np.asarray(polygon, dtype=float).reshape(-1, 2)
    return p[::-1].copy() if polygon_area(p) < 0 else p.copy()


def convex_hull_ccw(points: np.ndarray) -> np.ndarray:
    """Return the convex hull of 2D points as CCW vertices (empty (0, 2) when degenerate)."""
    pts = np.unique(np.asarray(points, dtype=float).reshape(-1, 2), axis=0)
    if len(pts) < 3:
        return np.zeros((0, 2))
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(pts)
    except QhullError:
        return np.zeros((0, 2))
    return ensure_ccw(pts[hull.vertices])  # scipy's 2D hulls are CCW already; ensure_ccw is a guard


def shapely_polygon(polygon: np.ndarray) -> Polygon:
    """Return a valid shapely Polygon for a vertex array (M, 2) (repaired with buffer(0) when invalid)."""
    from shapely.geometry import Polygon

    poly = Polygon(np.asarray(polygon, dtype=float).reshape(-1, 2))
    return poly if poly.is_valid else poly.buffer(0)


def polygon_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Return the intersection over union of two polygons (0 when either is degenerate)."""
    if len(a) < 3 or len(b) < 3:
        return 0.0
    pa, pb = shapely_polygon(a), shapely_polygon(b)
    union = pa.union(pb).area
    return float(pa.intersection(pb).area / union) if union > 0 else 0.0


def polygon_overlap(a: np.ndarray, b: np.ndarray) -> float:
    """Return the intersection area over the smaller polygon's area."""
    if len(a) < 3 or len(b) < 3:
        return 0.0
    pa, pb = shapely_polygon(a), shapely_polygon(b)
    small = min(pa.area, pb.area)
    return float(pa.intersection(pb).area / small) if small > 0 else 0.0


def shrink_polygon(polygon: np.ndarray, distance: float) -> np.ndarray:
    """Return a convex polygon inset by `distance` (CCW; empty (0, 2) when nothing is left)."""
    poly = shapely_polygon(polygon).buffer(-float(distance), join_style="mitre")
    if poly.is_empty or poly.area <= 0:
        return np.zeros((0, 2))
    if poly.geom_type != "Polygon":
        poly = max(poly.geoms, key=lambda g: g.area)
    return ensure_ccw(np.asarray(poly.exterior.coords, dtype=float)[:-1])


def fan_triangles(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the fan triangulation (T, 3, 2) from the first vertex and the triangle areas (T,)."""
    p = ensure_ccw(polygon)
    if len(p) < 3:
        raise ValueError(f"a polygon needs at least 3 vertices, got {len(p)}")
    a = np.repeat(p[:1], len(p) - 2, axis=0)
    tri = np.stack([a, p[1:-1], p[2:]], axis=1)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    areas = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    return tri, areas


def sample_in_polygon(polygon: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Return `n` points (n, 2) drawn uniformly from a convex polygon (paper appendix B, algorithm 3)."""
    if int(n) <= 0:
        return np.zeros((0, 2))
    tri, areas = fan_triangles(polygon)
    total = float(areas.sum())
    if total <= 0:
        raise ValueError("cannot sample in a polygon of zero area")
    # Roulette-wheel choice of a triangle with probability S_t / S.
    idx = rng.choice(len(tri), size=int(n), p=areas / total)
    r = rng.random((int(n), 2))
    # Reflection trick: (r1, r2) with r1 + r2 > 1 maps to (1 - r1, 1 - r2), uniform on the unit triangle.
    flip = r.sum(axis=1) > 1.0
    r[flip] = 1.0 - r[flip]
    t = tri[idx]
    return t[:, 0] + r[:, :1] * (t[:, 1] - t[:, 0]) + r[:, 1:] * (t[:, 2] - t[:, 0])


# ----------------------------------------------------------------------------------------------
# Point in polygon


def points_in_polygon(polygon: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Return whether 2D points (N, 2) lie inside a simple polygon (M, 2), convex or not (even-odd rule).

    Matplotlib's crossing test (``Path.contains_points``, radius 0): a point exactly on an edge may
    count either way, so callers needing a boundary margin use `points_in_convex_polygon`'s `tol`.
    """
    from matplotlib.path import Path as MplPath

    q = np.asarray(points, dtype=float).reshape(-1, 2)
    return MplPath(np.asarray(polygon, dtype=float).reshape(-1, 2)).contains_points(q)


def points_in_convex_polygon(polygon: np.ndarray, points: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Return whether 2D points (N, 2) lie inside (or within `tol` metres outside) a convex polygon."""
    p = ensure_ccw(polygon)
    q = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(p) < 3:
        return np.zeros(len(q), dtype=bool)
    edge = np.roll(p, -1, axis=0) - p  # (M, 2)
    rel = q[:, None, :] - p[None, :, :]  # (N, M, 2)
    length = np.maximum(np.linalg.norm(edge, axis=1), 1e-12)[None, :]
    inward = (edge[None, :, 0] * rel[..., 1] - edge[None, :, 1] * rel[..., 0]) / length  # signed distance inside
    return np.all(inward >= -tol, axis=1)


# ----------------------------------------------------------------------------------------------
# Quaternions (wxyz)


def axis_bounds(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the per-axis min and max of (N, 3) points: the values of ``points.min(axis=0)`` and ``.max(axis=0)``,
    read along contiguous rows of the transpose (numpy reduces a 3-wide axis 0 an element at a time, some ten times
    slower). Min and max are exact, so the values are the same; only a zero's sign may differ where -0.0 and 0.0
    both occur: for box tests (comparisons, where the two are equal), not for bounds that are written out."""
    t = np.ascontiguousarray(np.asarray(points).reshape(-1, 3).T)
    return t.min(axis=1), t.max(axis=1)


def boxes_apart(lo: np.ndarray, hi: np.ndarray, box_lo: np.ndarray, box_hi: np.ndarray) -> np.ndarray:
    """Return, per box (rows of `lo` and `hi`, (F, 3) each), whether it lies wholly past the box (`box_lo`, `box_hi`)
    on some axis: ``np.any(lo > box_hi, axis=1) | np.any(hi < box_lo, axis=1)``, axis by axis (a 3-wide reduction
    is numpy's slow path)."""
    out = lo[:, 0] > box_hi[0]
    for d in range(3):
        if d:
            out |= lo[:, d] > box_hi[d]
        out |= hi[:, d] < box_lo[d]
    return out


def in_box(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Return, per (N, 3) point, whether ``lo <= p <= hi`` on every axis (``np.all(..., axis=1)``, axis by axis)."""
    out = (points[:, 0] >= lo[0]) & (points[:, 0] <= hi[0])
    for d in (1, 2):
        out &= (points[:, d] >= lo[d]) & (points[:, d] <= hi[d])
    return out


def axis_quat(axis: int, angle: float) -> np.ndarray:
    """Return the wxyz quaternion (4,) of a rotation by `angle` radians about world axis 0 (X), 1 (Y) or 2 (Z)."""
    q = np.array([math.cos(angle / 2), 0.0, 0.0, 0.0])
    q[1 + int(axis)] = math.sin(angle / 2)
    return q


def yaw_quat(yaw_deg: float) -> np.ndarray:
    """Return the wxyz quaternion (4,) of a rotation by `yaw_deg` degrees about +Z."""
    return axis_quat(2, math.radians(yaw_deg))


def quat_yaw(q: np.ndarray) -> float:
    """Return the yaw (deg, about +Z from +X) of a wxyz quaternion."""
    w, x, y, z = (float(v) for v in q)
    return math.degrees(math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return the wxyz quaternion product a * b (4,) (rotate by b, then by a)."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def quat_to_mat(q: np.ndarray, mujoco_arithmetic: bool = False) -> np.ndarray:
    """Return the 3x3 rotation matrix of a wxyz quaternion (normalised first).

    `mujoco_arithmetic` computes it with MuJoCo's own ``mju_quat2Mat``, whose rounding differs from
    the formula here in the last bits: exporters use it so converted poses match the simulator's
    (and the files they wrote before); the place stage's spawn poses use the default.
    """
    if mujoco_arithmetic:
        import mujoco

        m = np.zeros(9)
        mujoco.mju_quat2Mat(m, np.asarray(q, dtype=float) / np.linalg.norm(q))
        return m.reshape(3, 3)
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def mat_to_quat(R: np.ndarray) -> np.ndarray:
    """Return the wxyz quaternion (4,) with w >= 0 of a 3x3 rotation matrix (MuJoCo's ``mju_mat2Quat``)."""
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.asarray(R, dtype=float).ravel())
    return q if q[0] >= 0 else -q
