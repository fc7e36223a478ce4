"""Collision geometry for a region of a (visual-only) scene, for settling objects.

Never decompose a whole scene: a height field by ray casting, CoACD on a local crop with
preprocessing off (flat hulls dropped), and floors as thin boxes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sdovon_mj.config import ConvertConfig
from sdovon_mj.raycast import first_hits

from .hulls import clean_hulls


def heightfield_from_mesh(vertices: np.ndarray, faces: np.ndarray, region_xy_bounds: Any,
                          resolution: float = 0.01) -> tuple[np.ndarray, dict[str, Any]]:
    """Return top-surface heights (rows along Y, cols along X) over an XY box and a MuJoCo hfield spec."""
    x0, y0, x1, y1 = (float(b) for b in np.ravel(region_xy_bounds))
    nx = max(2, int(np.ceil((x1 - x0) / resolution)) + 1)
    ny = max(2, int(np.ceil((y1 - y0) / resolution)) + 1)
    xs = np.linspace(x0, x1, nx)
    ys = np.linspace(y0, y1, ny)
    gx, gy = np.meshgrid(xs, ys)
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    tri = v[f]
    tmin, tmax = tri.min(axis=1), tri.max(axis=1)
    sel = (tmax[:, 0] >= x0) & (tmin[:, 0] <= x1) & (tmax[:, 1] >= y0) & (tmin[:, 1] <= y1)
    base = float(v[:, 2].min()) if len(v) else 0.0
    heights = np.full(gx.shape, base)
    if sel.any():
        top = float(tri[sel][:, :, 2].max()) + 1.0
        origins = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, top)], axis=1)
        hit, z = first_hits(v, f[sel], origins, axis=2, sign=-1)
        flat = heights.ravel()
        flat[hit >= 0] = z[hit >= 0]
        heights = flat.reshape(gx.shape)
    zmin = float(heights.min())
    zmax = float(heights.max())
    elev = max(zmax - zmin, 1e-3)
    spec = {"nrow": ny, "ncol": nx, "pos": [(x0 + x1) / 2, (y0 + y1) / 2, zmin],
            "size": [(x1 - x0) / 2, (y1 - y0) / 2, elev, 0.05],
            "elevation": ((heights - zmin) / elev).astype(np.float32), "resolution": resolution}
    return heights, spec


def local_hulls(vertices: np.ndarray, faces: np.ndarray, box: Any,
                config: ConvertConfig | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Return CoACD hulls (preprocessing off, flat hulls dropped) of the faces inside a (2, 3) box."""
    import coacd

    cfg = config or ConvertConfig()
    lo, hi = np.asarray(box, dtype=np.float64)
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    c = v[f].mean(axis=1)
    keep = np.all((c >= lo) & (c <= hi), axis=1)
    if not keep.any():
        return []
    sub = f[keep]
    used = np.unique(sub)
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(v[used], remap[sub].astype(np.int32)), threshold=float(cfg.coacd_threshold),
                            max_convex_hull=int(cfg.coacd_max_hulls), preprocess_mode="off",
                            mcts_iterations=60, mcts_nodes=10, mcts_max_depth=2, resolution=1000,
                            seed=int(cfg.coacd_seed))
    return clean_hulls([(np.asarray(a), np.asarray(b)) for a, b in parts], int(cfg.coacd_max_hull_vertices))


def floor_boxes(floor_heights: list[float] | np.ndarray, xy_bounds: Any, thickness: float = 0.1,
                margin: float = 0.5) -> list[dict[str, list[float]]]:
    """Return one thin box (pos, size half-extents) per floor, its top face at the floor height."""
    x0, y0, x1, y1 = (float(b) for b in np.ravel(xy_bounds))
    hx, hy = (x1 - x0) / 2 + margin, (y1 - y0) / 2 + margin
    return [{"pos": [(x0 + x1) / 2, (y0 + y1) / 2, float(h) - thickness / 2], "size": [hx, hy, thickness / 2]}
            for h in floor_heights]
