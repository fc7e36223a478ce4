"""Uniform sampling in convex polygons (paper appendix B) and the polygon helpers placement needs.

Kept local to the place stage (stages never import each other's internals); the perceive stage has
its own `receptacles/polygon.py`, and the lead may unify the two later.
"""

from __future__ import annotations

import numpy as np


def polygon_area(polygon: np.ndarray) -> float:
    """Return the signed area of a polygon (positive when counter-clockwise)."""
    p = np.asarray(polygon, dtype=float)
    if len(p) < 3:
        return 0.0
    x, y = p[:, 0], p[:, 1]
    return float(0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def convex_hull_ccw(points: np.ndarray) -> np.ndarray:
    """Return the CCW convex hull (M, 2) of 2D points (monotone chain), collinear points removed."""
    pts = sorted({(float(x), float(y)) for x, y in np.asarray(points, dtype=float)[:, :2]})
    if len(pts) < 3:
        return np.array(pts, dtype=float).reshape(-1, 2)

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 1e-12:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 1e-12:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1], dtype=float)


def triangle_fan(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the fan triangles (T, 3, 2) from the first vertex and their areas (T,) (algorithm 2, step 1)."""
    p = np.asarray(polygon, dtype=float)
    if len(p) < 3:
        return np.zeros((0, 3, 2)), np.zeros(0)
    a = np.repeat(p[:1], len(p) - 2, axis=0)
    tris = np.stack([a, p[1:-1], p[2:]], axis=1)
    v, w = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    areas = 0.5 * np.abs(v[:, 0] * w[:, 1] - v[:, 1] * w[:, 0])
    return tris, areas


def sample_in_polygon(polygon: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Return n points (n, 2) uniformly distributed in a convex polygon (paper appendix B)."""
    tris, areas = triangle_fan(polygon)
    total = float(areas.sum())
    if n <= 0 or total <= 0.0:
        return np.zeros((0, 2))
    # Roulette-wheel selection of a triangle with probability S_t / S.
    idx = np.searchsorted(np.cumsum(areas) / total, rng.random(n), side="right")
    idx = np.minimum(idx, len(areas) - 1)
    r = rng.random((n, 2))
    flip = r.sum(axis=1) > 1.0
    r[flip] = 1.0 - r[flip]
    t = tris[idx]
    return t[:, 0] + r[:, :1] * (t[:, 1] - t[:, 0]) + r[:, 1:] * (t[:, 2] - t[:, 0])


def inset_convex_polygon(polygon: np.ndarray, distance: float) -> np.ndarray:
    """Return a convex CCW polygon shrunk inward by `distance` (empty (0, 2) when nothing is left)."""
    p = convex_hull_ccw(np.asarray(polygon, dtype=float))
    if len(p) < 3:
        return np.zeros((0, 2))
    if distance <= 0:
        return p
    # Intersect the half-planes of every edge moved inward (clip a big box against each).
    out = np.array([[-1e6, -1e6], [1e6, -1e6], [1e6, 1e6], [-1e6, 1e6]])
    for i in range(len(p)):
        a, b = p[i], p[(i + 1) % len(p)]
        e = b - a
        nrm = np.array([-e[1], e[0]]) / np.linalg.norm(e)  # inward normal of a CCW edge
        out = _clip(out, a + nrm * distance, nrm)
        if len(out) < 3:
            return np.zeros((0, 2))
    if polygon_area(out) <= 1e-10:
        return np.zeros((0, 2))
    return convex_hull_ccw(out)


def _clip(poly: np.ndarray, point: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Clip a convex polygon to the half-plane dot(x - point, normal) >= 0 (Sutherland-Hodgman)."""
    out = []
    d = (poly - point) @ normal
    for i in range(len(poly)):
        j = (i + 1) % len(poly)
        if d[i] >= 0:
            out.append(poly[i])
        if (d[i] >= 0) != (d[j] >= 0):
            t = d[i] / (d[i] - d[j])
            out.append(poly[i] + t * (poly[j] - poly[i]))
    return np.array(out) if out else np.zeros((0, 2))


def points_in_convex_polygon(polygon: np.ndarray, xy: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """Return whether points (N, 2) lie inside a CCW convex polygon (within `tol` metres outside)."""
    p = np.asarray(polygon, dtype=float)
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    if len(p) < 3:
        return np.zeros(len(xy), dtype=bool)
    ok = np.ones(len(xy), dtype=bool)
    for i in range(len(p)):
        a, b = p[i], p[(i + 1) % len(p)]
        e = b - a
        nrm = np.array([-e[1], e[0]]) / np.linalg.norm(e)
        ok &= (xy - a) @ nrm >= -tol
    return ok
