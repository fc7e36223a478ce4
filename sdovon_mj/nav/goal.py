"""Goal reconstruction and view point inference for the final point-goal navigation (FN).

`Reconstruct` (paper eq. 1-2): the detected mask's depth pixels are back-projected to world points;
pixels clipped at the sensor's near limit carry no range and are dropped (when every pixel is
clipped there, the object is closer than the near limit: the mask's ray at that range stands in).
Pixels clipped at the far limit carry no range either: a goal seen only beyond the depth range has
no position (`goal_points` returns none), and the agent walks along its bearing (`mask_bearing`) and
looks again.

FN then needs a place to STOP. Success is judged against the episode's view points: navigable
cells on a `step` lattice (anchored to the map grid) within `radius` of the object's footprint from
which the agent camera sees the object (episodes/viewpoints.py). The agent infers the same set from
what it knows: lattice cells of its own planning map within `radius` of the reconstructed points'
footprint, ranked by path length from where it stands; it verifies each by looking (detector).
"""

from __future__ import annotations

import numpy as np

from ..sim.camera import backproject
from ..grid import GridFrame, nearest_true
from ..gridgraph import GeodesicField


def goal_points(depth: np.ndarray, mask: np.ndarray, K: np.ndarray, T_cam: np.ndarray, depth_min: float,
                depth_max: float) -> np.ndarray:
    """Return world points (N, 3) of a detection mask; none when it is seen only beyond the depth range.

    Pixels with range give their points. Without any, pixels clipped at the near limit give the mask's ray at
    that range (the object is closer than it); pixels clipped at the far limit give nothing (the object lies
    farther than the sensor reaches: `mask_bearing` says where).

    Parameters
    ----------
    depth : ndarray
        (H, W) or (H, W, 1) depth image, metres, clipped to the sensor range.
    mask : ndarray
        (H, W) bool detection mask.
    K : ndarray
        (3, 3) intrinsics.
    T_cam : ndarray
        (4, 4) camera pose (world <- OpenCV camera).
    depth_min, depth_max : float
        The sensor's range, metres.
    """
    d = np.asarray(depth, dtype=np.float64)
    if d.ndim == 3:
        d = d[..., 0]
    m = np.asarray(mask, dtype=bool)
    pts = backproject(d, K, T_cam, mask=m, depth_min=depth_min + 1e-3, depth_max=depth_max - 1e-3)
    if len(pts) or not m.any():
        return pts
    near = m & (d <= depth_min + 1e-3)
    if not near.any():
        return np.zeros((0, 3))
    return backproject(np.full_like(d, depth_min), K, T_cam, mask=near, depth_min=0.0)


def mask_bearing(mask: np.ndarray, K: np.ndarray, T_cam: np.ndarray) -> np.ndarray:
    """Return the unit world direction (3,) from the camera through a mask's median pixel."""
    rows, cols = np.nonzero(np.asarray(mask, dtype=bool))
    u, v = float(np.median(cols)), float(np.median(rows))
    ray = np.array([(u + 0.5 - K[0, 2]) / K[0, 0], (v + 0.5 - K[1, 2]) / K[1, 1], 1.0])
    w = np.asarray(T_cam, float)[:3, :3] @ ray
    return w / np.linalg.norm(w)


def object_centre(points: np.ndarray) -> np.ndarray:
    """Return a robust centre (3,) of an object's points (median)."""
    return np.median(np.asarray(points, float), axis=0)


def footprint(points: np.ndarray, trim: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Return the XY box (lo, hi) of an object's points, trimming `trim` percent outliers per side."""
    p = np.asarray(points, float)[:, :2]
    if len(p) < 20:
        return p.min(axis=0), p.max(axis=0)
    return np.percentile(p, trim, axis=0), np.percentile(p, 100.0 - trim, axis=0)


def footprint_distance(position: np.ndarray, points: np.ndarray) -> float:
    """Return the XY distance (m) from a position to the `footprint` of an object's points (0 inside it).

    The footprint of the points an agent saw of an object lies within the object's own box (up to depth noise), so a
    place within ``r`` of the footprint lies within ``r`` of the object: what FN needs to know of a place it may stop at.
    """
    lo, hi = footprint(points)
    p = np.asarray(position, float)[:2]
    return float(np.linalg.norm(np.maximum(np.maximum(lo - p, 0.0), p - hi)))


def lattice_cells(mask: np.ndarray, frame: GridFrame, lo: np.ndarray, hi: np.ndarray, radius: float,
                  step: float) -> np.ndarray:
    """Return True cells (K, 2) of `mask` on a `step` lattice anchored to the grid within `radius` of box lo..hi.

    Parameters
    ----------
    mask : ndarray (H, W) bool
        Cells that may be returned.
    frame : GridFrame
        The mask's frame.
    lo, hi : ndarray
        The box's corners (world XY, metres).
    radius : float
        Metres around the box.
    step : float
        The lattice's spacing in metres (rounded to whole cells).
    """
    stride = max(1, int(round(step / frame.resolution)))
    h, w = mask.shape
    rc_lo = frame.to_cell((np.asarray(lo, float)[:2] - radius)[None])[0]
    rc_hi = frame.to_cell((np.asarray(hi, float)[:2] + radius)[None])[0]
    r0 = max(0, int(np.ceil(rc_lo[0] / stride)) * stride)
    c0 = max(0, int(np.ceil(rc_lo[1] / stride)) * stride)
    rows = np.arange(r0, min(h - 1, rc_hi[0]) + 1, stride)
    cols = np.arange(c0, min(w - 1, rc_hi[1]) + 1, stride)
    if len(rows) == 0 or len(cols) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    rr, cc = np.meshgrid(rows, cols, indexing="ij")
    cells = np.stack([rr.ravel(), cc.ravel()], axis=1)
    cells = cells[mask[cells[:, 0], cells[:, 1]]]
    xy = frame.to_world(cells)
    dx = np.maximum(np.maximum(lo[0] - xy[:, 0], 0.0), xy[:, 0] - hi[0])
    dy = np.maximum(np.maximum(lo[1] - xy[:, 1], 0.0), xy[:, 1] - hi[1])
    return cells[np.hypot(dx, dy) <= radius]


def reachable_field(traversable: np.ndarray, frame: GridFrame, position: np.ndarray) -> tuple[GeodesicField, np.ndarray] | None:
    """Return the geodesic field from an agent position and that position (world XY) on the planning map.

    An agent standing off its map (at its rim) starts from the nearest traversable cell; None when there is none.
    """
    pos = np.asarray(position, float)[:2]
    rc = frame.to_cell(pos[None])[0]
    if not (frame.inside(rc[None])[0] and traversable[rc[0], rc[1]]):
        near = nearest_true(traversable, rc)
        if near is None:
            return None
        pos = frame.to_world(near[None])[0]
    return GeodesicField(traversable, frame, pos[None]), pos


def infer_view_points(points: np.ndarray, traversable: np.ndarray, frame: GridFrame, position: np.ndarray,
                      radius: float = 1.0, step: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """Return candidate view points (K, 2) around an object's points, nearest by path first, and path lengths (K,).

    Parameters
    ----------
    points : ndarray (N, 3)
        The object's points (world, metres).
    traversable : ndarray (H, W) bool
        Where the agent may stand.
    frame : GridFrame
        The mask's frame.
    position : ndarray
        The agent's position (paths are measured from it; unreachable candidates are left out).
    radius : float
        Metres around the object's footprint.
    step : float
        The candidates' lattice spacing in metres.
    """
    lo, hi = footprint(points)
    cells = lattice_cells(traversable, frame, lo, hi, radius, step)
    if len(cells) == 0:
        return np.zeros((0, 2)), np.zeros(0)
    reach = reachable_field(traversable, frame, position)
    if reach is None:
        return np.zeros((0, 2)), np.zeros(0)
    field, pos = reach
    xy = frame.to_world(cells)
    d = field.field[cells[:, 0], cells[:, 1]] + np.linalg.norm(xy - pos, axis=1) * 1e-6
    ok = np.isfinite(d)
    xy, d = xy[ok], d[ok]
    order = np.lexsort((xy[:, 1], xy[:, 0], d))
    return xy[order], d[order]


def approach_point(target: np.ndarray, traversable: np.ndarray, frame: GridFrame, position: np.ndarray) -> np.ndarray | None:
    """Return the reachable traversable cell (world XY) nearest to a target, from an agent position (None: none).

    What Navigate(p_g | eps_nav) drives to when p_g itself stands on furniture: the closest point the agent
    can reach on its own map by a path no longer than its straight distance to the target now.
    """
    reach = reachable_field(traversable, frame, position)
    if reach is None:
        return None
    field, pos = reach
    cells = np.argwhere(np.isfinite(field.field))
    if len(cells) == 0:
        return None
    xy = frame.to_world(cells)
    d = np.linalg.norm(xy - np.asarray(target, float)[None, :2], axis=1)
    # no detour longer than the way the agent is from the target: it closes in, it does not wander off
    here = float(np.linalg.norm(pos - np.asarray(target, float)[:2]))
    near = field.field[cells[:, 0], cells[:, 1]] <= here
    if not near.any():
        return None
    k = int(np.argmin(np.where(near, d, np.inf)))
    return xy[k]
