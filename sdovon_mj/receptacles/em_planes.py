"""EM plane detection on receptacle point clouds (paper algorithm 1) and the convex projected hull.

For every height slab [h, h + eps_t], h stepped by eps_t / 2 over the receptacle's height range, a
slab with at least rho_min points seeds an EM loop: fit a plane (SVD), collect the points within
+-eps_t of it along its normal, and stop once at least eps_c of the current inliers are collected
again. Each converged inlier set is split into XY-connected parts (two armrests at one height are
two surfaces, not one polygon spanning the seat), then duplicate planes from overlapping slabs are
merged, and planes are rejected that are tilted, too small, mostly empty inside their hull (a slab
cutting table legs or shelf walls), covered by the receptacle's own points right above them (the
underside of a thick top), or not seen from above (the underside of a closed box such as a wall cabinet:
its inside is never seen, so nothing covers it, but an up-facing surface can only be observed by a camera
above it; `seen_from_above` reads the instance's per-point view heights recorded by perceive).
"""

from __future__ import annotations

import math

import numpy as np

from ..config import ReceptacleConfig
from ..geometry import axis_bounds, boxes_apart, convex_hull_ccw, in_box, points_in_polygon, polygon_area, shapely_polygon
from ..records import Instance, ReceptaclePlane


def fit_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the centroid and unit normal (pointing up, +Z side) of the least-squares plane."""
    p = np.asarray(points, dtype=float)
    c = p.mean(axis=0)
    _u, _s, vt = np.linalg.svd(p - c, full_matrices=False)
    n = vt[-1]
    if n[2] < 0:
        n = -n
    return c, n / np.linalg.norm(n)


def em_plane(points: np.ndarray, seed_idx: np.ndarray, cfg: ReceptacleConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the EM loop from a slab's point indices; return (inlier indices, centroid, normal)."""
    cur = np.asarray(seed_idx)
    c, n = fit_plane(points[cur])
    for _ in range(int(cfg.max_em_iterations)):
        dist = np.abs((points - c) @ n)
        new = np.nonzero(dist <= cfg.eps_t)[0]
        kept = np.intersect1d(new, cur, assume_unique=True).size
        if kept >= cfg.eps_c * cur.size or new.size < 3:
            break
        cur = new
        c, n = fit_plane(points[cur])
    return cur, c, n


def _xy_components(points: np.ndarray, cell: float) -> list[np.ndarray]:
    """Split points into groups whose XY occupancy cells are 8-connected; return index arrays."""
    from scipy import ndimage

    ij = np.floor(points[:, :2] / cell).astype(np.int64)
    lo = ij.min(axis=0)
    ij -= lo
    grid = np.zeros(ij.max(axis=0) + 1, dtype=bool)
    grid[ij[:, 0], ij[:, 1]] = True
    labels, count = ndimage.label(grid, structure=np.ones((3, 3), dtype=bool))
    lab = labels[ij[:, 0], ij[:, 1]]
    return [np.nonzero(lab == k)[0] for k in range(1, count + 1)]


def open_components(points_xy: np.ndarray, cell: float, min_width: float) -> list[np.ndarray]:
    """Split points into the 8-connected parts of their XY occupancy opened to min_width; return index arrays (narrower slivers dropped)."""
    from scipy import ndimage

    if len(points_xy) == 0:
        return []
    k = max(1, int(math.ceil(min_width / cell)))
    ij = np.floor(np.asarray(points_xy) / cell).astype(np.int64)
    ij -= ij.min(axis=0) - (k + 1)
    grid = np.zeros(ij.max(axis=0) + k + 2, dtype=bool)
    grid[ij[:, 0], ij[:, 1]] = True
    # Close one-cell holes of sparse sampling, then drop what a min_width square cannot cover: a line
    # of points seen through a gap, the strips around a sink; no object stands there.
    grid = ndimage.binary_closing(grid, structure=np.ones((3, 3), dtype=bool))
    if k > 1:
        grid = ndimage.binary_opening(grid, structure=np.ones((k, k), dtype=bool))
    labels, count = ndimage.label(grid, structure=np.ones((3, 3), dtype=bool))
    lab = labels[ij[:, 0], ij[:, 1]]
    return [np.nonzero(lab == c)[0] for c in range(1, count + 1)]


def _cells(points_xy: np.ndarray, cell: float) -> set[tuple[int, int]]:
    """Return the set of occupied XY grid cells."""
    ij = np.floor(np.asarray(points_xy) / cell).astype(np.int64)
    return set(map(tuple, np.unique(ij, axis=0).tolist()))


def hull_coverage(points_xy: np.ndarray, polygon: np.ndarray, cell: float) -> float:
    """Return the fraction of grid cells inside `polygon` that hold at least one point."""
    lo = polygon.min(axis=0)
    hi = polygon.max(axis=0)
    xs = np.arange(math.floor(lo[0] / cell), math.floor(hi[0] / cell) + 1)
    ys = np.arange(math.floor(lo[1] / cell), math.floor(hi[1] / cell) + 1)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    centres = np.stack([(gx.ravel() + 0.5) * cell, (gy.ravel() + 0.5) * cell], axis=1)
    inside = points_in_polygon(polygon, centres)
    if not inside.any():
        return 1.0
    occupied = _cells(points_xy, cell)
    cells_in = [(int(a), int(b)) for a, b in zip(gx.ravel()[inside], gy.ravel()[inside])]
    return float(sum(c in occupied for c in cells_in) / len(cells_in))


def free_above(all_points: np.ndarray, inliers: np.ndarray, height: float, cfg: ReceptacleConfig,
               low: float | None = None) -> np.ndarray:
    """Return which inlier points have no point of `all_points` above them (XY within clearance_radius, Z in (low, min_clearance], low defaults to eps_t).

    Parameters
    ----------
    all_points : (N, 3) float
        Every point of the instance, world metres.
    inliers : (K, 3) float
        The plane's inlier points, world metres.
    height : float
        Plane height, world metres.
    cfg : ReceptacleConfig
        Clearance radius and minimum clearance (metres).
    low : float, optional
        Points less than this above the plane do not block, metres (default: ``cfg.eps_t``).
    """
    from scipy.spatial import cKDTree

    z = all_points[:, 2]
    lo = cfg.eps_t if low is None else float(low)
    above = all_points[(z > height + lo) & (z <= height + cfg.min_clearance)]
    if len(above) == 0 or len(inliers) == 0:
        return np.ones(len(inliers), dtype=bool)
    d, _ = cKDTree(above[:, :2]).query(inliers[:, :2], k=1, distance_upper_bound=cfg.clearance_radius)
    return ~np.isfinite(d)


def seen_from_above(instance: Instance, cfg: ReceptacleConfig) -> np.ndarray | None:
    """Return per point whether a camera more than cfg.seen_above_margin above it observed it (unknown: True); None when not recorded."""
    vh = instance.view_height
    if vh is None:
        return None
    vh = np.asarray(vh, dtype=np.float64).reshape(-1)
    if len(vh) != len(instance.points):
        raise ValueError(f"instance {instance.id} ({instance.label}): {len(vh)} view heights for {len(instance.points)} points")
    return np.isnan(vh) | (vh > cfg.seen_above_margin)


def refine_plane(points: np.ndarray, idx: np.ndarray, centroid: np.ndarray, normal: np.ndarray,
                 band: float, iterations: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (inliers, centroid, normal) re-fitted to the densest `band`-thick layer of an EM plane's inliers.

    Parameters
    ----------
    points : (N, 3) float
        The instance's points, world metres.
    idx : (K,) int
        Indices of the plane's inliers in `points`.
    centroid : (3,) float
        The plane's centroid, metres (returned when nothing is refined).
    normal : (3,) float
        The plane's unit normal (returned when nothing is refined).
    band : float
        Thickness of the layer kept, metres.
    iterations : int
        Re-fits of the layer.
    """
    if band <= 0 or len(idx) < 3:
        return idx, centroid, normal
    # A horizontal surface stacks its points into one thin layer; vertical faces cut by the slab
    # (table edges, drawer fronts) spread over the whole slab and tilt a least-squares fit. Start
    # from the densest horizontal layer, then let the fit follow the surface's own tilt.
    z = points[idx, 2]
    step = 0.25 * band
    edges = np.arange(z.min(), z.max() + 2 * step, step)
    counts = np.histogram(z, bins=edges)[0]
    win = min(len(counts), max(1, int(round(band / step))))
    dens = np.convolve(counts, np.ones(win), mode="valid")
    # The top layer: of the layers nearly as dense as the densest, the highest (a thin board seen
    # from both sides has two; its top is the support surface), at its own density peak.
    top = int(np.nonzero(dens >= 0.5 * dens.max())[0][-1])
    k = max(0, top - win) + int(np.argmax(dens[max(0, top - win): top + 1]))
    c = np.array([*points[idx, :2].mean(axis=0), 0.5 * (edges[k] + edges[k + win])])
    n = np.array([0.0, 0.0, 1.0])
    cur = idx
    for _ in range(int(iterations)):
        sel = idx[np.abs((points[idx] - c) @ n) <= band]
        if sel.size < 3:
            break
        cur = sel
        c, n = fit_plane(points[cur])
    if cur is idx:
        return idx, centroid, normal
    return cur, c, n


def drop_covered_planes(planes: list[ReceptaclePlane], cfg: ReceptacleConfig) -> list[ReceptaclePlane]:
    """Drop planes with another plane of the same instance less than min_clearance above over most of their area (undersides of boards)."""
    def covers(q: ReceptaclePlane, p: ReceptaclePlane) -> bool:
        if q is p or q.instance_id != p.instance_id or not (cfg.fit_band < q.height - p.height <= cfg.min_clearance):
            return False
        a = shapely_polygon(p.polygon)
        return a.area > 0 and a.intersection(shapely_polygon(q.polygon)).area >= cfg.max_covered * a.area

    keep = []
    for p in planes:
        covered = any(covers(q, p) for q in planes)
        if not covered:
            keep.append(p)
    return keep


def convex_projected_hull(points: np.ndarray, centroid: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, float]:
    """Project points onto the plane, return their CCW XY convex hull and the plane height at its centroid."""
    d = (points - centroid) @ normal
    proj = points - d[:, None] * normal[None, :]
    poly = convex_hull_ccw(proj[:, :2])
    if len(poly) < 3:
        return poly, float(centroid[2])
    xy = poly.mean(axis=0)
    # Height of the plane n . (x - c) = 0 above the polygon's vertex centroid.
    h = centroid[2] - (normal[0] * (xy[0] - centroid[0]) + normal[1] * (xy[1] - centroid[1])) / max(normal[2], 1e-9)
    return poly, float(h)


def _candidates(points: np.ndarray, cfg: ReceptacleConfig) -> list[np.ndarray]:
    """Return inlier index sets of the EM planes grown from every height slab (algorithm 1)."""
    z = points[:, 2]
    order = np.argsort(z, kind="stable")
    zs = z[order]
    out: list[np.ndarray] = []
    h = float(zs[0])
    top = float(zs[-1])
    step = 0.5 * cfg.eps_t
    while h <= top + 1e-12:
        a = int(np.searchsorted(zs, h, side="left"))
        b = int(np.searchsorted(zs, h + cfg.eps_t, side="right"))
        if b - a >= cfg.rho_min:
            idx, c, n = em_plane(points, np.sort(order[a:b]), cfg)
            tilt = math.degrees(math.acos(min(1.0, abs(float(n[2])))))
            if tilt <= cfg.max_normal_tilt and idx.size >= cfg.rho_min:
                # One slab may cut several separate surfaces at one height: split them.
                for comp in _xy_components(points[idx], cfg.coverage_cell):
                    if comp.size >= cfg.rho_min:
                        out.append(idx[comp])
        h += step
    return out


def _merge(cands: list[np.ndarray], points: np.ndarray, cfg: ReceptacleConfig) -> list[np.ndarray]:
    """Merge inlier sets of the same surface found from overlapping slabs (union-find)."""
    if not cands:
        return []
    heights = [float(np.median(points[c, 2])) for c in cands]
    parent = list(range(len(cands)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(len(cands)):
        for j in range(i + 1, len(cands)):
            if abs(heights[i] - heights[j]) > cfg.merge_height_tol:
                continue
            inter = np.intersect1d(cands[i], cands[j], assume_unique=True).size
            if inter >= 0.5 * min(cands[i].size, cands[j].size):
                parent[find(j)] = find(i)
    groups: dict[int, list[int]] = {}
    for i in range(len(cands)):
        groups.setdefault(find(i), []).append(i)
    return [np.unique(np.concatenate([cands[i] for i in g])) for _, g in sorted(groups.items())]


def detect_planes(instance: Instance, cfg: ReceptacleConfig, first_id: int = 0,
                  obstacles: np.ndarray | None = None) -> list[ReceptaclePlane]:
    """Return the horizontal support planes of one receptacle instance, lowest first (obstacles: other instances' points, (n, 3))."""
    points = instance.world_points
    if len(points) < max(cfg.rho_min, 3):
        return []
    planes: list[ReceptaclePlane] = []
    seen = seen_from_above(instance, cfg) if cfg.min_seen_above > 0 else None
    for idx in _merge(_candidates(points, cfg), points, cfg):
        c, n = fit_plane(points[idx])
        tilt = math.degrees(math.acos(min(1.0, abs(float(n[2])))))
        if tilt > cfg.max_normal_tilt:
            continue
        # Only points with free space above belong to a support surface: this drops the underside of
        # a thick top, and the outer faces of taller parts (armrests, shelf walls) cut by the slab.
        free = free_above(points, points[idx], float(c[2]), cfg)
        if free.mean() < 1.0 - cfg.max_covered or free.sum() < cfg.rho_min:
            continue
        idx = idx[free]
        c, n = fit_plane(points[idx])
        idx, c, n = refine_plane(points, idx, c, n, cfg.fit_band)
        if idx.size < cfg.rho_min:
            continue
        if obstacles is not None and len(obstacles):
            # Other instances standing on the surface (a sink bowl, a hob) occupy it.
            idx = idx[free_above(obstacles, points[idx], float(c[2]), cfg, low=cfg.fit_band)]
        for comp in open_components(points[idx, :2], cfg.open_cell, cfg.min_width):
            sel = idx[comp]
            if sel.size < 3:
                continue
            if seen is not None and seen[sel].mean() < cfg.min_seen_above:
                continue  # no camera saw it from above: a downward face (a closed cabinet's bottom)
            cc, nn = fit_plane(points[sel])
            poly, h = convex_projected_hull(points[sel], cc, nn)
            if len(poly) < 3 or polygon_area(poly) < cfg.min_plane_area:
                continue
            if hull_coverage(points[sel, :2], poly, cfg.coverage_cell) < cfg.min_coverage:
                continue
            planes.append(ReceptaclePlane(id=0, instance_id=int(instance.id), label=instance.label, height=h,
                                          polygon=poly, normal=nn.astype(float), inliers=int(sel.size)))
    planes = drop_covered_planes(planes, cfg)
    planes.sort(key=lambda p: (p.height, -p.area))
    for k, p in enumerate(planes):
        p.id = first_id + k
    return planes


def _nearby_points(instances: list[Instance], inst: Instance, margin: float,
                   bounds: np.ndarray | None = None) -> np.ndarray:
    """Return the points of the other instances inside inst's box grown by margin (bounds: (N, 2, 3), each instance's box, computed when not given)."""
    if bounds is None:
        bounds = np.array([axis_bounds(o.world_points) for o in instances]).reshape(-1, 2, 3)
    own = axis_bounds(inst.world_points)
    lo, hi = own[0] - margin, own[1] + margin
    out = []
    boxes = np.asarray(bounds, dtype=float).reshape(-1, 2, 3)
    for k in np.flatnonzero(~boxes_apart(boxes[:, 0], boxes[:, 1], lo, hi)):  # the others in index order, as before
        other = instances[k]
        if other.id == inst.id:
            continue
        p = other.world_points
        out.append(p[in_box(p, lo, hi)])
    return np.concatenate(out) if out else np.zeros((0, 3))


def find_receptacle_planes(instances: list[Instance], cfg: ReceptacleConfig, labels: tuple[str, ...] | list[str] | None = None) -> list[ReceptaclePlane]:
    """Return the support planes of every receptacle instance (labels default to cfg.labels), ids 0..n-1."""
    from .identify import receptacle_instances

    recs = receptacle_instances(instances, cfg.labels if labels is None else labels)
    out: list[ReceptaclePlane] = []
    bounds = np.array([axis_bounds(o.world_points) for o in instances]).reshape(-1, 2, 3)  # once per scene (box tests)
    for inst in sorted(recs, key=lambda i: i.id):
        obstacles = _nearby_points(instances, inst, cfg.min_clearance, bounds)
        out.extend(detect_planes(inst, cfg, first_id=len(out), obstacles=obstacles))
    return out
