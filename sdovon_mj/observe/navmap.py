"""Navigable top-down map of one floor: floor presence, obstacles, erosion, components.

Obstacles. The paper slices the scene at ``h_map`` = 0.3 m above the floor. A single slice misses
everything that is thin at 0.3 m but blocks the agent higher up: a table whose legs are thin would
be "navigable" under its top, and so would a wall shelf or a bed frame on legs, although the agent
(0.88 m tall) cannot pass. Our default (``nav_slice = "band"``) therefore counts as obstacle every
triangle part inside the height band ``floor + [obstacle_min_height, obstacle_max_height]``
(0.1 m .. agent height 0.88 m): walls, furniture bodies, table tops and legs all block; the floor
itself, rugs and low thresholds (< 0.1 m) do not; door frames and ceilings above the agent do not.
``nav_slice = "plane"`` reproduces the paper's single slice at ``h_map``.

Floor presence: a ray cast straight down from 5 cm above the floor through every cell centre must
hit an upward-facing surface within ``floor_cluster_tol`` of the floor height. Free = floor and no
obstacle; navigable = free cells farther than ``agent_radius`` from every non-free cell, keeping the
connected components of at least ``min_component_area``.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from ..config import AgentConfig, ObserveConfig
from ..grid import GridFrame
from ..raycast import first_hits
from ..errors import StageError
from ..hints import FloorFigures
from ..records import Floor, NavMap
from ..store import atomic_write_bytes
from .floors import UP_COS, face_geometry

RAY_START = 0.05  # m above the floor where the downward floor-presence rays start
_SHIFT = 4  # cv2 sub-pixel bits


class OffFloorError(StageError, ValueError):
    """A point that lies on no floor's free area."""


class NoNavigableArea(StageError):
    """A floor with no navigable area; `figures` say how close it came (`sdovon_mj.hints.FloorFigures`)."""

    def __init__(self, message: str, figures: FloorFigures) -> None:
        super().__init__(message)
        self.figures = figures


def obstacle_band(floor: Floor, cfg: ObserveConfig, agent: AgentConfig = AgentConfig()) -> tuple[float, float]:
    """Return the world Z band whose geometry blocks the agent on this floor."""
    if cfg.nav_slice == "plane":
        return floor.height + cfg.h_map, floor.height + cfg.h_map
    if cfg.nav_slice != "band":
        raise StageError(f"observe.nav_slice must be 'band' or 'plane', got {cfg.nav_slice!r}")
    top = cfg.obstacle_max_height if cfg.obstacle_max_height > 0 else agent.height
    return floor.height + cfg.obstacle_min_height, floor.height + max(top, cfg.obstacle_min_height)


def _clip_z(poly: np.ndarray, z: float, keep_above: bool) -> np.ndarray:
    """Clip a polygon (K, 3) against the plane Z = z (Sutherland-Hodgman)."""
    out = []
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        ina = a[2] >= z if keep_above else a[2] <= z
        inb = b[2] >= z if keep_above else b[2] <= z
        if ina:
            out.append(a)
        if ina != inb:
            t = (z - a[2]) / (b[2] - a[2])
            out.append(a + t * (b - a))
    return np.array(out) if out else np.zeros((0, 3))


def _raster(grid: np.ndarray, xy: np.ndarray, origin: np.ndarray, res: float) -> None:
    """Mark the cells a projected convex polygon (K, 2) touches (edges included)."""
    pix = np.round(((xy - origin) / res - 0.5) * (1 << _SHIFT)).astype(np.int32)
    cv2.fillConvexPoly(grid, pix, 1, lineType=cv2.LINE_8, shift=_SHIFT)
    cv2.polylines(grid, [pix], True, 1, lineType=cv2.LINE_8, shift=_SHIFT)


def obstacle_grid(vertices: np.ndarray, faces: np.ndarray, z0: float, z1: float, origin: np.ndarray,
                  shape: tuple[int, int], res: float) -> np.ndarray:
    """Return a (H, W) bool grid of cells touched by mesh parts inside the Z band [z0, z1].

    Parameters
    ----------
    vertices : (N, 3) float
        Mesh vertices, world metres, Z up.
    faces : (M, 3) int
        Triangle vertex indices.
    z0, z1 : float
        Bottom and top of the Z band, world metres.
    origin : (2,) float
        World XY of the grid's lower-left corner, metres.
    shape : tuple of int
        Grid shape (H, W): rows along +Y, columns along +X.
    res : float
        Cell size, metres.
    """
    v = np.asarray(vertices, dtype=np.float64)
    tri = v[np.asarray(faces, dtype=np.int64)]
    z = tri[:, :, 2]
    zmin, zmax = z.min(axis=1), z.max(axis=1)
    hit = (zmax >= z0) & (zmin <= z1)
    xy_lo = origin - res
    xy_hi = origin + np.array([shape[1], shape[0]]) * res + res
    txy = tri[:, :, :2]
    hit &= np.all(txy.max(axis=1) >= xy_lo, axis=1) & np.all(txy.min(axis=1) <= xy_hi, axis=1)
    grid = np.zeros(shape, dtype=np.uint8)
    inside = hit & (zmin >= z0) & (zmax <= z1)
    for t in tri[inside]:
        _raster(grid, t[:, :2], origin, res)
    for t in tri[hit & ~inside]:
        p = _clip_z(t, z0, keep_above=True)
        if len(p):
            p = _clip_z(p, z1, keep_above=False)
        if len(p):
            _raster(grid, p[:, :2], origin, res)
    return grid.astype(bool)


def floor_presence(vertices: np.ndarray, faces: np.ndarray, floor: Floor, origin: np.ndarray,
                   shape: tuple[int, int], res: float, tol: float) -> np.ndarray:
    """Return a (H, W) bool grid of cells above an upward surface at the floor's height (ray casts).

    Parameters
    ----------
    vertices, faces, origin, shape, res : as in `obstacle_grid`
    floor : Floor
        The storey; rays start above its height.
    tol : float
        Largest height difference between the hit and the floor, metres.
    """
    normal, _area, centre = face_geometry(vertices, faces)
    # only faces near this floor can be hit first from RAY_START above it; cast against them alone
    near = (centre[:, 2] >= floor.height - tol - 0.5) & (centre[:, 2] <= floor.height + RAY_START + 0.5)
    if not near.any():
        return np.zeros(shape, dtype=bool)
    sub = np.asarray(faces)[near]
    h, w = shape
    jj, ii = np.meshgrid(np.arange(w), np.arange(h))
    x, y = GridFrame(np.asarray(origin, dtype=float), float(res), shape).to_world(np.stack([ii.ravel(), jj.ravel()], 1)).T
    origins = np.stack([x, y, np.full(x.shape, floor.height + RAY_START)], axis=1)
    tri, z = first_hits(vertices, sub, origins, axis=2, sign=-1)
    hit = tri >= 0
    ok = np.zeros(len(origins), dtype=bool)
    ok[hit] = (normal[near][tri[hit], 2] >= UP_COS) & (np.abs(z[hit] - floor.height) <= tol)
    return ok.reshape(shape)


def solid_interior(vertices: np.ndarray, faces: np.ndarray, z: float, origin: np.ndarray, res: float,
                   cells: np.ndarray) -> np.ndarray:
    """Return which cells (N, 2) lie inside a closed solid at height z (first hits along +-X are back faces).

    A wall or cabinet that spans the whole obstacle band has no horizontal face inside it; its
    vertical faces rasterise as outlines only, and this test fills the inside.

    Parameters
    ----------
    vertices, faces, origin, res : as in `obstacle_grid`
    z : float
        Height of the horizontal rays, world metres.
    cells : (K, 2) int
        Grid cells (row, column) to test.
    """
    out = np.zeros(len(cells), dtype=bool)
    if not len(cells):
        return out
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    tz = v[f][:, :, 2]
    span = (tz.min(axis=1) <= z) & (tz.max(axis=1) >= z)
    if not span.any():
        return out
    normal, _a, _c = face_geometry(v, f[span])
    xy = origin + (cells[:, ::-1] + 0.5) * res
    origins = np.column_stack([xy, np.full(len(xy), z)])
    inside = np.ones(len(cells), dtype=bool)
    for sign in (1, -1):
        tri, _x = first_hits(v, f[span], origins, axis=0, sign=sign)
        hit = tri >= 0
        back = np.zeros(len(cells), dtype=bool)
        back[hit] = sign * normal[tri[hit], 0] > 0
        inside &= back
    return inside


def grid_frame(vertices: np.ndarray, faces: np.ndarray, floor: Floor, cfg: ObserveConfig) -> tuple[np.ndarray, tuple[int, int]]:
    """Return the grid origin (2,) and shape (H, W) covering the floor's upward faces."""
    normal, _area, centre = face_geometry(vertices, faces)
    sel = (normal[:, 2] >= UP_COS) & (np.abs(centre[:, 2] - floor.height) <= cfg.floor_cluster_tol)
    if not sel.any():
        raise StageError(f"floor {floor.index} at z={floor.height:.3f} m: no upward-facing surface at that height")
    pts = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)[sel]].reshape(-1, 3)[:, :2]
    res = float(cfg.map_resolution)
    lo = np.floor(pts.min(axis=0) / res) * res - res
    hi = np.ceil(pts.max(axis=0) / res) * res + res
    w = int(round((hi[0] - lo[0]) / res))
    h = int(round((hi[1] - lo[1]) / res))
    if h * w > 50_000_000:
        raise StageError(f"floor {floor.index}: a {w}x{h} grid at {res} m/cell is too large (scene units wrong?)")
    return lo, (h, w)


def clearance(free: np.ndarray, res: float) -> np.ndarray:
    """Return each cell's distance (m) to the nearest non-free cell (0 on non-free cells)."""
    padded = np.pad(free.astype(np.uint8), 1)  # outside the grid counts as non-free
    d = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]
    return d.astype(np.float64) * res


def navigable_map(vertices: np.ndarray, faces: np.ndarray, floor: Floor, cfg: ObserveConfig,
                  agent: AgentConfig = AgentConfig()) -> NavMap:
    """Return the navigable map of one floor (StageError when nothing is navigable).

    Parameters
    ----------
    vertices, faces : as in `obstacle_grid`
    floor : Floor
        The storey mapped.
    cfg : ObserveConfig
        Map resolution, floor tolerance and smallest kept component.
    agent : AgentConfig
        The agent's body (radius, height) and camera (height, HFOV), metres and degrees.
    """
    res = float(cfg.map_resolution)
    origin, shape = grid_frame(vertices, faces, floor, cfg)
    present = floor_presence(vertices, faces, floor, origin, shape, res, cfg.floor_cluster_tol)
    z0, z1 = obstacle_band(floor, cfg, agent)
    blocked = obstacle_grid(vertices, faces, z0, z1, origin, shape, res)
    free = present & ~blocked
    cells = np.argwhere(free)
    free[tuple(cells[solid_interior(vertices, faces, (z0 + z1) / 2, origin, res, cells)].T)] = False
    nav = clearance(free, res) > agent.radius
    n, labels, stats, _c = cv2.connectedComponentsWithStats(nav.astype(np.uint8), connectivity=8)
    min_cells = cfg.min_component_area / (res * res)
    keep = np.zeros(n, dtype=bool)
    keep[1:] = stats[1:, cv2.CC_STAT_AREA] >= min_cells
    navigable = keep[labels]
    if not navigable.any():
        a = res * res
        fig = FloorFigures(floor=floor.index, floor_m2=float(present.sum()) * a, free_m2=float(free.sum()) * a,
                           eroded_m2=float(nav.sum()) * a,
                           largest_m2=float(stats[1:, cv2.CC_STAT_AREA].max()) * a if n > 1 else 0.0,
                           widest_m=float(clearance(free, res).max()) if free.any() else 0.0,
                           below_m=float(floor.height - np.asarray(vertices, dtype=np.float64)[:, 2].min()))
        raise NoNavigableArea(
            f"floor {floor.index} at z={floor.height:.3f} m: no navigable area (floor {fig.floor_m2:.2f} m^2, "
            f"free {fig.free_m2:.2f} m^2, after eroding by {agent.radius} m {fig.eroded_m2:.2f} m^2, largest component "
            f"{fig.largest_m2:.2f} m^2, none >= {cfg.min_component_area} m^2)", fig)
    return NavMap(floor=floor.index, height=float(floor.height), origin=np.asarray(origin, dtype=np.float64),
                  resolution=res, navigable=navigable, free=free)


def locate(navmaps: list[NavMap], point: np.ndarray, navigable: bool = False, storey: float = 1.8) -> NavMap:
    """Return the navmap of the floor a world point stands on (OffFloorError when on none)."""
    p = np.asarray(point, dtype=np.float64).ravel()
    if not navmaps:
        raise OffFloorError("no floors to locate a point on")
    cands = list(navmaps)
    if len(p) >= 3:  # the floor below the point, within a storey
        cands = [m for m in navmaps if m.height - 0.2 <= p[2] <= m.height + storey + 0.5]
    for m in sorted(cands, key=lambda m: -m.height):
        grid = m.navigable if navigable else m.free
        rc = m.frame.to_cell(p[:2])[0]
        if 0 <= rc[0] < grid.shape[0] and 0 <= rc[1] < grid.shape[1] and grid[rc[0], rc[1]]:
            return m
    what = "navigable" if navigable else "free"
    floors = ", ".join(f"{m.floor} (z={m.height:.2f})" for m in navmaps)
    raise OffFloorError(f"point {np.round(p, 3).tolist()} lies outside the {what} area of every floor [{floors}]")


def navmap_image(navmap: NavMap, coverage: np.ndarray | None = None, points: np.ndarray | None = None,
                 scale: int = 2) -> np.ndarray:
    """Return an RGB picture of a navmap (+Y up): navigable white, free grey, blocked dark; optional M_P and points."""
    h, w = navmap.navigable.shape
    img = np.full((h, w, 3), 40, dtype=np.uint8)
    img[navmap.free] = (150, 150, 150)
    img[navmap.navigable] = (255, 255, 255)
    if coverage is not None:
        c = np.clip(np.asarray(coverage, dtype=np.float64), 0.0, 1.0)
        m = navmap.navigable
        img[m, 0] = (255 * (1 - c[m])).astype(np.uint8)
        img[m, 1] = 255
        img[m, 2] = (255 * (1 - c[m])).astype(np.uint8)
    img = np.ascontiguousarray(img[::-1])  # row 0 is the lowest Y: flip so +Y points up
    if scale > 1:
        img = np.repeat(np.repeat(img, scale, axis=0), scale, axis=1)
    if points is not None and len(points):
        rc = navmap.frame.to_cell(np.asarray(points)[:, :2])
        for r, c in rc:
            cx, cy = int((c + 0.5) * scale), int((h - 1 - r + 0.5) * scale)
            cv2.circle(img, (cx, cy), max(2, int(math.ceil(0.1 / navmap.resolution * scale))), (220, 0, 0), -1)
    return img


def save_png(image: np.ndarray, path: str | Path) -> None:
    """Write an RGB uint8 image as PNG, atomically and deterministically."""
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(np.asarray(image)[..., ::-1]))
    if not ok:
        raise StageError(f"could not encode PNG for {path}")
    atomic_write_bytes(Path(path), buf.tobytes())
