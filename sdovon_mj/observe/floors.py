"""Distinct floors (storeys) of a scene mesh by clustering the heights of upward-facing area.

The paper clusters mesh vertices by height. Vertex counts depend on tessellation (a floor made of
two triangles has four vertices, a chair thousands), so we cluster *upward-facing surface area*
instead: every triangle whose normal is within ``UP_COS`` of +Z adds its area at its centroid
height. Peaks of the area-by-height histogram (window ``floor_cluster_tol``) with at least
``min_floor_area`` are floor candidates. Candidates are then accepted from the lowest up:

- the lowest candidate is a floor;
- a higher candidate must lie at least ``MIN_STOREY_HEIGHT`` above the last accepted floor (beds,
  counters and table tops are large horizontal areas too, but lie within a storey), and
- it must carry walls: vertical surface area in the band ``[h + 0.3, h + agent_height]`` standing on it
  (the top of a roof slab is a large upward area at storey spacing, but nothing stands on it), and
- its area must hold together: one connected patch of at least ``min_floor_area`` (`_free_patch`).

The last two are read on a 10 cm grid of the candidate's upward faces less the cells capped right above (a ceiling
slab's top under the next storey's floor slab); walls count where they stand on the rest, one cell in from its
edge. A house needs both: twenty door-frame heads and door leaves at 2.05 m add up to more than ``min_floor_area``
with the storey's walls rising past them, and the ceiling tops of its single-storey wings are large, uncapped and
surrounded by the upper storey's walls; taken as floors, either would hide the real storey above.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..config import AgentConfig, ObserveConfig
from ..errors import StageError
from ..records import Floor, NavMap

UP_COS = 0.9  # |angle to +Z| < ~25.8 deg counts as upward-facing (tolerates scan noise)
MIN_STOREY_HEIGHT = 1.8  # m: floors closer than this above the previous floor are furniture
MIN_WALL_AREA = 1.0  # m^2 of vertical surface above a higher floor candidate
BIN = 0.01  # m: histogram bin of the height clustering


class NoFloorFound(StageError):
    """A scene mesh with no storey; `largest_m2` is its largest upward-facing area at one height (None: none) and
    `above_m` how far that area lies above the mesh's lowest point."""

    def __init__(self, message: str, largest_m2: float | None, above_m: float = 0.0) -> None:
        super().__init__(message)
        self.largest_m2 = largest_m2
        self.above_m = above_m


def face_geometry(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return per-face unit normals (M, 3), areas (M,) and centroids (M, 3)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    n = np.cross(b - a, c - a)
    norm = np.linalg.norm(n, axis=1)
    area = 0.5 * norm
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(norm[:, None] > 0, n / np.maximum(norm[:, None], 1e-300), 0.0)
    return unit, area, (a + b + c) / 3.0


def _peaks(heights: np.ndarray, weights: np.ndarray, tol: float) -> list[tuple[float, float]]:
    """Greedy peaks of an area-by-height histogram: (height, area within +-tol/2), largest first."""
    lo = heights.min() - tol
    nb = int(np.ceil((heights.max() + tol - lo) / BIN)) + 1
    idx = np.clip(((heights - lo) / BIN).astype(np.int64), 0, nb - 1)
    hist = np.bincount(idx, weights=weights, minlength=nb)
    half = max(1, int(round(tol / 2 / BIN)))
    cs = np.concatenate([[0.0], np.cumsum(hist)])
    i = np.arange(nb)
    window = cs[np.minimum(i + half + 1, nb)] - cs[np.maximum(i - half, 0)]
    taken = np.zeros(nb, dtype=bool)
    out = []
    order = np.argsort(-window, kind="stable")
    for k in order:
        if taken[k] or window[k] <= 0:
            continue
        a, b = max(0, k - half), min(nb, k + half + 1)
        if taken[a:b].any():
            continue
        sel = (idx >= a) & (idx < b)
        w = weights[sel]
        h = heights[sel]
        # area-weighted median height of the cluster (robust to scan noise)
        o = np.argsort(h, kind="stable")
        cw = np.cumsum(w[o])
        med = float(h[o][np.searchsorted(cw, cw[-1] / 2.0)])
        out.append((med, float(w.sum())))
        taken[max(0, k - 2 * half): min(nb, k + 2 * half + 1)] = True
    return out


def find_floors(vertices: np.ndarray, faces: np.ndarray, cfg: ObserveConfig, agent: AgentConfig = AgentConfig()) -> list[Floor]:
    """Return the distinct floors of a scene mesh, lowest first (StageError when there is none)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise StageError(f"find_floors: expected vertices (N, 3) and faces (M, 3), got {v.shape} and {f.shape}")
    normal, area, centre = face_geometry(v, f)
    up = normal[:, 2] >= UP_COS
    if not up.any() or area[up].sum() <= 0:
        raise NoFloorFound("no floor found: the scene mesh has no upward-facing surface", None)
    tol = float(cfg.floor_cluster_tol)
    peaks = _peaks(centre[up, 2], area[up], tol)
    cands = sorted((h, a) for h, a in peaks if a >= cfg.min_floor_area)
    if not cands:
        top, best = max(peaks, key=lambda p: p[1])
        raise NoFloorFound(f"no floor found: the largest horizontal upward-facing area at one height is {best:.2f} m^2, "
                           f"below min_floor_area {cfg.min_floor_area} m^2", best, float(top - v[:, 2].min()))
    vertical = np.abs(normal[:, 2]) < 0.3
    down = normal[:, 2] <= -UP_COS
    floors: list[Floor] = []
    for h, a in cands:
        # the top of a ceiling slab under the next storey's floor slab is covered right above: not a floor
        sel = up & (np.abs(centre[:, 2] - h) <= tol / 2)
        pts = v[f[sel]].reshape(-1, 3)[:, :2]
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        lid = down & (centre[:, 2] > h + BIN) & (centre[:, 2] <= h + cfg.h_map) & np.all((centre[:, :2] >= lo) & (centre[:, :2] <= hi), axis=1)
        if area[lid].sum() >= 0.5 * a:
            continue
        if floors:
            if h - floors[-1].height < MIN_STOREY_HEIGHT:
                continue
            # one patch of floor, not capped right above, with walls standing on it
            free, gl, res = _free_patch(v, f, sel, down & (centre[:, 2] > h + BIN) & (centre[:, 2] <= h + cfg.h_map))
            if free.sum() * res * res < cfg.min_floor_area:
                continue
            z0, z1 = h + 0.3, h + max(agent.height, 0.6)
            band = vertical & _spans(v, f, z0, z1)
            cells = np.floor((v[f[band]][:, :, :2].mean(axis=1) - gl) / res).astype(int)
            inner = cv2.erode(free.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
            ok = (cells >= 0).all(axis=1) & (cells[:, 0] < free.shape[1]) & (cells[:, 1] < free.shape[0])
            on = np.zeros(len(cells), dtype=bool)
            on[ok] = inner[cells[ok, 1], cells[ok, 0]]
            band[np.flatnonzero(band)[~on]] = False
            if _band_area(v, f, band, z0, z1, np.full(2, -np.inf), np.full(2, np.inf)) < MIN_WALL_AREA:
                continue
        floors.append(Floor(index=len(floors), height=round(float(h), 4), area=round(float(a), 4)))
    return floors


def _raster(grid: np.ndarray, tri: np.ndarray, lo: np.ndarray, res: float) -> None:
    """Mark the cells of `grid` (rows along +Y) that triangles (K, 3, 3) cover: larger ones filled, smaller ones by
    their centroid (a scan's 5 cm triangles tile a 10 cm grid)."""
    xy = tri[:, :, :2]
    big = (xy.max(axis=1) - xy.min(axis=1)).max(axis=1) > res
    for t in xy[big]:
        cv2.fillConvexPoly(grid, np.round((t - lo) / res * 16).astype(np.int32), 1, lineType=cv2.LINE_8, shift=4)
    c = np.floor((xy[~big].mean(axis=1) - lo) / res).astype(int)
    ok = (c >= 0).all(axis=1) & (c[:, 0] < grid.shape[1]) & (c[:, 1] < grid.shape[0])
    grid[c[ok, 1], c[ok, 0]] = 1


def _free_patch(v: np.ndarray, f: np.ndarray, sel: np.ndarray, lid: np.ndarray,
                res: float = 0.1) -> tuple[np.ndarray, np.ndarray, float]:
    """Return the largest 8-connected patch (bool grid, rows along +Y) of the faces `sel` less the cells under the
    faces `lid`, the grid's origin (world XY) and its cell size."""
    tri = v[f[sel]]
    lo = tri[:, :, :2].reshape(-1, 2).min(axis=0) - res
    hi = tri[:, :, :2].reshape(-1, 2).max(axis=0) + res
    shape = np.ceil((hi - lo) / res).astype(int) + 1
    if shape[0] * shape[1] > 20_000_000:  # a scene this large at 10 cm: keep the candidate's own test only
        return np.ones((1, 1), dtype=bool), lo, float(np.sqrt(1e9))
    surf = np.zeros((shape[1], shape[0]), dtype=np.uint8)
    _raster(surf, tri, lo, res)
    cap = np.zeros_like(surf)
    if lid.any():
        _raster(cap, v[f[lid]], lo, res)
    free = (surf > 0) & (cap == 0)
    n, lab, stats, _c = cv2.connectedComponentsWithStats(free.astype(np.uint8), connectivity=8)
    if n <= 1:
        return np.zeros_like(free), lo, res
    return lab == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA])), lo, res


def _spans(v: np.ndarray, f: np.ndarray, z0: float, z1: float) -> np.ndarray:
    """Return which faces overlap the height band [z0, z1]."""
    z = v[f][:, :, 2]
    return (z.max(axis=1) >= z0) & (z.min(axis=1) <= z1)


def _band_area(v: np.ndarray, f: np.ndarray, sel: np.ndarray, z0: float, z1: float, lo: np.ndarray, hi: np.ndarray) -> float:
    """Approximate the area of selected (vertical) faces inside a height band and an XY box."""
    if not sel.any():
        return 0.0
    tri = v[f[sel]]
    z = tri[:, :, 2]
    zmin, zmax = z.min(axis=1), z.max(axis=1)
    # a vertical triangle's area scales with its height extent; keep the band's share of it
    frac = np.clip((np.minimum(zmax, z1) - np.maximum(zmin, z0)) / np.maximum(zmax - zmin, 1e-9), 0.0, 1.0)
    xy = tri[:, :, :2].mean(axis=1)
    inside = np.all((xy >= lo) & (xy <= hi), axis=1)
    _n, area, _c = face_geometry(tri.reshape(-1, 3), np.arange(len(tri) * 3).reshape(-1, 3))
    return float((area * frac * inside).sum())


def floor_below(height: float, navmaps: list[NavMap]) -> NavMap | None:
    """Return the navmap of the highest floor at or below a height (5 cm tolerance; None when below every floor)."""
    below = [nm for nm in navmaps if nm.height <= height + 0.05]
    return max(below, key=lambda nm: nm.height) if below else None
