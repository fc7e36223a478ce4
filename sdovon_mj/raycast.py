"""Axis-aligned ray casts against a triangle mesh, the same bits on every CPU.

The stages cast rays along a coordinate axis only (straight down through grid cells for floors, support
height fields and collision floors; along +-X for solid interiors). Such a ray meets a triangle where its
two other coordinates fall inside the triangle's projection, so the cast is a 2-D point-in-triangle test
plus a barycentric interpolation: a handful of float64 products and sums per (ray, triangle) pair, done
element-wise by numpy, which rounds each operation the same way on every CPU and never fuses them.
A ray engine (Embree, through trimesh) picks SIMD kernels by the CPU (SSE, AVX2, AVX-512) and computes
in float32 with approximate reciprocals: on the same scene, an AVX-512 Xeon and an AVX2 EPYC reported other
triangles and hit heights in their last bits, so navigable maps and everything after them differed by machine.

Watertight by construction: each edge's side test is computed from its two end points in one canonical
order (lexicographic by coordinates) and negated for the triangle that runs it the other way, so the two
triangles sharing an edge get exactly opposite values; a ray through a shared edge hits both (closed
triangles) and never slips between them. Ties (several triangles at the same distance) go to the lowest
triangle index. Triangles seen edge-on (zero projected area) are not hit, as by a ray parallel to them.
"""

from __future__ import annotations

import numpy as np

# (ray, triangle) candidate pairs evaluated at once: bounds the memory of one chunk (~40 doubles a pair)
PAIRS_PER_CHUNK = 2_000_000


def _bins(points: np.ndarray, lo: np.ndarray, size: float, shape: tuple[int, int]) -> np.ndarray:
    """Return the flat bin index of 2-D points in a uniform grid (clipped to the grid)."""
    ij = np.floor((points - lo) / size).astype(np.int64)
    ij[:, 0] = np.clip(ij[:, 0], 0, shape[0] - 1)
    ij[:, 1] = np.clip(ij[:, 1], 0, shape[1] - 1)
    return ij[:, 0] * shape[1] + ij[:, 1]


def _edge(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Return the side of 2-D points p (N, 2) from edges a -> b (N, 2), antisymmetric in a and b bit for bit."""
    swap = (a[:, 0] > b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] > b[:, 1]))
    lo = np.where(swap[:, None], b, a)
    hi = np.where(swap[:, None], a, b)
    e = (hi[:, 0] - lo[:, 0]) * (p[:, 1] - lo[:, 1]) - (hi[:, 1] - lo[:, 1]) * (p[:, 0] - lo[:, 0])
    return np.where(swap, -e, e)


def first_hits(vertices: np.ndarray, faces: np.ndarray, origins: np.ndarray, axis: int,
               sign: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the first triangle each axis-aligned ray meets and where.

    Parameters
    ----------
    vertices : (V, 3) float
        Mesh vertices, metres.
    faces : (F, 3) int
        Triangles (vertex indices).
    origins : (N, 3) float
        Ray origins, metres.
    axis : int
        The coordinate the rays run along (0 = X, 1 = Y, 2 = Z).
    sign : int
        +1 or -1: the direction along that axis.

    Returns
    -------
    tri : (N,) int
        Index of the first triangle hit (distance >= 0 from the origin), -1 where none.
    coord : (N,) float
        The hit's coordinate along `axis` (NaN where none); the hit point is the origin with that coordinate.
    """
    if axis not in (0, 1, 2) or sign not in (-1, 1):
        raise ValueError(f"axis must be 0, 1 or 2 and sign +-1, got {axis}, {sign}")
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    n = len(o)
    best_t = np.full(n, np.inf)
    best_tri = np.full(n, -1, dtype=np.int64)
    best_h = np.full(n, np.nan)
    if n == 0 or len(f) == 0:
        return best_tri, best_h
    uw = [a for a in (0, 1, 2) if a != axis]
    tri = v[f]  # (F, 3 corners, 3)
    t2 = tri[:, :, uw]  # projected corners (F, 3, 2)
    p2 = o[:, uw]
    # rays that can be hit: bin the origins on a uniform grid about as fine as their spacing
    lo = p2.min(axis=0)
    extent = np.maximum(p2.max(axis=0) - lo, 1e-9)
    size = float(max(np.sqrt(extent[0] * extent[1] / n), extent.max() / 4096.0, 1e-6))
    shape = (int(extent[0] // size) + 1, int(extent[1] // size) + 1)
    ray_bin = _bins(p2, lo, size, shape)
    order = np.argsort(ray_bin, kind="stable")
    starts = np.searchsorted(ray_bin[order], np.arange(shape[0] * shape[1] + 1))
    # triangles: projected bounding boxes in bins; those outside the rays' extent or seen edge-on are dropped
    tlo, thi = t2.min(axis=1), t2.max(axis=1)
    area2 = _edge(t2[:, 0], t2[:, 1], t2[:, 2])
    keep = (area2 != 0) & np.all(thi >= lo, axis=1) & np.all(tlo <= lo + extent, axis=1)
    idx = np.nonzero(keep)[0]
    if not len(idx):
        return best_tri, best_h
    b0 = np.clip(np.floor((tlo[idx] - lo) / size).astype(np.int64), 0, np.array(shape) - 1)
    b1 = np.clip(np.floor((thi[idx] - lo) / size).astype(np.int64), 0, np.array(shape) - 1)
    # rays per triangle's bin box, from the per-bin counts' 2-D prefix sums
    counts = np.diff(starts).reshape(shape)
    cum = np.zeros((shape[0] + 1, shape[1] + 1), dtype=np.int64)
    cum[1:, 1:] = counts.cumsum(0).cumsum(1)
    per_tri = (cum[b1[:, 0] + 1, b1[:, 1] + 1] - cum[b0[:, 0], b1[:, 1] + 1] - cum[b1[:, 0] + 1, b0[:, 1]]
               + cum[b0[:, 0], b0[:, 1]])
    bounds = np.concatenate([[0], np.cumsum(per_tri)])
    k = 0
    while k < len(idx):
        stop = int(np.searchsorted(bounds, bounds[k] + PAIRS_PER_CHUNK, side="right")) - 1
        stop = max(stop, k + 1)
        _chunk(idx[k:stop], b0[k:stop], b1[k:stop], t2, tri[:, :, axis], p2, o[:, axis], sign, order, starts, shape,
               best_t, best_tri, best_h)
        k = stop
    return best_tri, best_h


def _chunk(tris: np.ndarray, b0: np.ndarray, b1: np.ndarray, t2: np.ndarray, ta: np.ndarray, p2: np.ndarray,
           oa: np.ndarray, sign: int, order: np.ndarray, starts: np.ndarray, shape: tuple[int, int],
           best_t: np.ndarray, best_tri: np.ndarray, best_h: np.ndarray) -> None:
    """Test the rays in each triangle's bins against it; keep each ray's nearest hit (in place)."""
    # (triangle, bin) pairs: every bin row of each triangle's bin box
    nrow = b1[:, 0] - b0[:, 0] + 1
    t_of_row = np.repeat(np.arange(len(tris)), nrow)
    row = b0[t_of_row, 0] + (np.arange(len(t_of_row)) - np.repeat(np.cumsum(nrow) - nrow, nrow))
    # the rays of one bin row's column span are contiguous in `order` (bins are row-major)
    first = starts[row * shape[1] + b0[t_of_row, 1]]
    last = starts[row * shape[1] + b1[t_of_row, 1] + 1]
    cnt = last - first
    pair_row = np.repeat(np.arange(len(row)), cnt)
    ray = order[first[pair_row] + (np.arange(len(pair_row)) - np.repeat(np.cumsum(cnt) - cnt, cnt))]
    t = tris[t_of_row[pair_row]]
    a, b, c = t2[t, 0], t2[t, 1], t2[t, 2]
    p = p2[ray]
    e0, e1, e2 = _edge(b, c, p), _edge(c, a, p), _edge(a, b, p)  # weights of a, b, c
    inside = ((e0 >= 0) & (e1 >= 0) & (e2 >= 0)) | ((e0 <= 0) & (e1 <= 0) & (e2 <= 0))
    total = e0 + e1 + e2
    inside &= total != 0
    if not inside.any():
        return
    ray, t, e0, e1, e2, total = ray[inside], t[inside], e0[inside], e1[inside], e2[inside], total[inside]
    h = (e0 * ta[t, 0] + e1 * ta[t, 1] + e2 * ta[t, 2]) / total
    dist = sign * (h - oa[ray])
    ahead = dist >= 0
    ray, t, h, dist = ray[ahead], t[ahead], h[ahead], dist[ahead]
    if not len(ray):
        return
    # the nearest hit per ray, ties to the lowest triangle index; then merge with what earlier chunks found
    srt = np.lexsort((t, dist, ray))
    ray, t, h, dist = ray[srt], t[srt], h[srt], dist[srt]
    head = np.ones(len(ray), dtype=bool)
    head[1:] = ray[1:] != ray[:-1]
    ray, t, h, dist = ray[head], t[head], h[head], dist[head]
    better = (dist < best_t[ray]) | ((dist == best_t[ray]) & (t < best_tri[ray]))
    ray, t, h, dist = ray[better], t[better], h[better], dist[better]
    best_t[ray], best_tri[ray], best_h[ray] = dist, t, h
