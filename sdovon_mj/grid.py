"""The grid frame (grid <-> world) and grid helpers: lookups, free segments, erosion, dilation.

One frame for every top-down grid (navmaps, region maps, the agents' occupancy and planning maps):
cell (row i, col j) has its centre at origin + ((j + .5) * res, (i + .5) * res); rows grow with world
Y, columns with world X. `records.NavMap.frame` and `records.RegionMap.frame` return it. Geodesic
distances on these grids live in one place, `gridgraph` (`GeodesicField`, `cell_graph`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from . import native

NEIGHBOURS8 = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


@dataclass
class GridFrame:
    """Placement of a grid in the world: origin (world XY of the corner of cell (0, 0)), resolution (m/cell), shape (rows, cols)."""

    origin: np.ndarray
    resolution: float
    shape: tuple[int, int]

    def to_cell(self, xy: np.ndarray) -> np.ndarray:
        """Return (row, col) cells (N, 2) of world XY points (N, 2)."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        col = np.floor((xy[:, 0] - self.origin[0]) / self.resolution).astype(np.int64)
        row = np.floor((xy[:, 1] - self.origin[1]) / self.resolution).astype(np.int64)
        return np.stack([row, col], axis=1)

    def to_world(self, cells: np.ndarray) -> np.ndarray:
        """Return world XY centres (N, 2) of (row, col) cells."""
        c = np.atleast_2d(np.asarray(cells, dtype=float))
        return np.stack([self.origin[0] + (c[:, 1] + 0.5) * self.resolution,
                         self.origin[1] + (c[:, 0] + 0.5) * self.resolution], axis=1)

    def inside(self, cells: np.ndarray) -> np.ndarray:
        """Return whether cells (N, 2) lie on the grid."""
        c = np.atleast_2d(cells)
        return (c[:, 0] >= 0) & (c[:, 0] < self.shape[0]) & (c[:, 1] >= 0) & (c[:, 1] < self.shape[1])


def lookup(mask: np.ndarray, frame: GridFrame, xy: np.ndarray) -> np.ndarray:
    """Return mask values (N,) at world XY points; False off the grid."""
    rc = frame.to_cell(xy)
    ok = frame.inside(rc)
    out = np.zeros(len(rc), dtype=bool)
    out[ok] = mask[rc[ok, 0], rc[ok, 1]]
    return out


def segment_free(mask: np.ndarray, frame: GridFrame, a: np.ndarray, b: np.ndarray, step: float | None = None) -> bool:
    """Return whether every sample of the straight segment a -> b (world XY) lies on True cells.

    Parameters
    ----------
    mask : ndarray (H, W) bool
        The grid's cells.
    frame : GridFrame
        The grid's frame.
    a, b : ndarray
        The segment's ends (world XY, metres).
    step : float, optional
        Metres between samples (default: half a cell).
    """
    ax, ay, bx, by = float(a[0]), float(a[1]), float(b[0]), float(b[1])
    res = frame.resolution
    step = res / 2.0 if step is None else step
    n = max(1, int(math.ceil(math.hypot(bx - ax, by - ay) / step)))
    h, w = mask.shape
    lib = native.library()
    if lib is not None and mask.dtype == np.bool_ and mask.flags.c_contiguous:  # the same samples compiled
        return bool(lib.sdv_segment_free(mask.ctypes.data, h, w, ax, ay, bx, by, float(frame.origin[0]),
                                         float(frame.origin[1]), float(res), n))
    t = np.arange(n + 1, dtype=float) / n
    col = np.floor((ax + t * (bx - ax) - frame.origin[0]) / res).astype(np.intp)
    row = np.floor((ay + t * (by - ay) - frame.origin[1]) / res).astype(np.intp)
    if col.min() < 0 or row.min() < 0 or col.max() >= w or row.max() >= h:
        return False
    return bool(mask[row, col].all())


def true_box(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    """Return the half-open bounding box (row0, row1, col0, col1) of a 2-D array's nonzero cells; None when none is.

    The window work on a mask can be cut to without changing any result that only its nonzero cells decide."""
    m = np.asarray(mask)
    rows = np.flatnonzero(m.any(axis=1))
    if not len(rows):
        return None
    cols = np.flatnonzero(m.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def erode(mask: np.ndarray, radius: float, resolution: float) -> np.ndarray:
    """Return the cells whose disc of `radius` (m) lies inside `mask` (off-grid counts as blocked)."""
    blocked = ~np.asarray(mask, dtype=bool)
    padded = np.pad(blocked, 1, constant_values=True)
    dist = ndimage.distance_transform_edt(~padded)[1:-1, 1:-1] * resolution
    return dist > radius


def dilate(mask: np.ndarray, radius: float, resolution: float) -> np.ndarray:
    """Return the cells within `radius` (m) of a True cell."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return m.copy()
    return ndimage.distance_transform_edt(~m) * resolution <= radius


def nearest_true(mask: np.ndarray, cell: np.ndarray) -> np.ndarray | None:
    """Return the True cell nearest (Euclidean) to `cell`, or None when the mask is empty."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return None
    r, c = int(np.clip(cell[0], 0, m.shape[0] - 1)), int(np.clip(cell[1], 0, m.shape[1] - 1))
    if m[r, c]:
        return np.array([r, c])
    _, idx = ndimage.distance_transform_edt(~m, return_indices=True)
    return np.array([idx[0][r, c], idx[1][r, c]])
