"""Convex polygons in world XY: CCW hulls, area, IoU, shrinking and uniform sampling (paper appendix B).

Shared geometry (like `records`): receptacle planes are detected as these polygons and objects are
placed by sampling in them, so the receptacles and place stages both use this one module.
"""

from __future__ import annotations

import numpy as np


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


def _shapely(polygon: np.ndarray):
    """Return a valid shapely Polygon for a vertex array."""
    from shapely.geometry import Polygon

    poly = Polygon(np.asarray(polygon, dtype=float).reshape(-1, 2))
    return poly if poly.is_valid else poly.buffer(0)


def polygon_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Return the intersection over union of two polygons (0 when either is degenerate)."""
    if len(a) < 3 or len(b) < 3:
        return 0.0
    pa, pb = _shapely(a), _shapely(b)
    union = pa.union(pb).area
    return float(pa.intersection(pb).area / union) if union > 0 else 0.0


def polygon_overlap(a: np.ndarray, b: np.ndarray) -> float:
    """Return the intersection area over the smaller polygon's area."""
    if len(a) < 3 or len(b) < 3:
        return 0.0
    pa, pb = _shapely(a), _shapely(b)
    small = min(pa.area, pb.area)
    return float(pa.intersection(pb).area / small) if small > 0 else 0.0


def shrink_polygon(polygon: np.ndarray, distance: float) -> np.ndarray:
    """Return a convex polygon inset by `distance` (CCW; empty (0, 2) when nothing is left)."""
    poly = _shapely(polygon).buffer(-float(distance), join_style="mitre")
    if poly.is_empty or poly.area <= 0:
        return np.zeros((0, 2))
    if poly.geom_type != "Polygon":
        poly = max(poly.geoms, key=lambda g: g.area)
    return ensure_ccw(np.asarray(poly.exterior.coords, dtype=float)[:-1])


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
