"""Convex decomposition with CoACD: hulls for one object, degenerate ones dropped."""

from __future__ import annotations

import numpy as np

from sdovon_mj.config import ConvertConfig

MIN_HULL_THICKNESS = 1e-4  # m: a hull thinner than this along its smallest principal axis is dropped
THIN_GROWTH = 0.12  # closed meshes that an offset surface would grow by more than this fraction go to CoACD as they are
CLOSE_HALF_STEPS = 1  # open meshes: holes up to about this many half grid steps are bridged before the inside is filled


def _convex(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Return the convex hull (vertices, outward faces) of points, or None when degenerate."""
    import trimesh

    try:
        hull = trimesh.convex.convex_hull(np.asarray(vertices, dtype=np.float64), qhull_options="QbB Pp QJ")
    except Exception:  # noqa: BLE001 - qhull refuses flat / collinear point sets
        return None
    if len(hull.faces) < 4 or hull.volume <= 0:
        return None
    return np.asarray(hull.vertices), np.asarray(hull.faces)


def thickness(vertices: np.ndarray) -> float:
    """Return the extent of a point set along its smallest principal axis."""
    v = np.asarray(vertices, dtype=np.float64)
    if len(v) < 4:
        return 0.0
    c = v - v.mean(axis=0)
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    proj = c @ vt[-1]
    return float(proj.max() - proj.min())


def clean_hulls(hulls: list[tuple[np.ndarray, np.ndarray]], max_vertices: int = 0,
                min_thickness: float = MIN_HULL_THICKNESS) -> list[tuple[np.ndarray, np.ndarray]]:
    """Re-hull each piece (outward faces), cap its vertex count, drop flat or empty ones."""
    out = []
    for v, _f in hulls:
        v = np.asarray(v, dtype=np.float64)
        if len(v) < 4 or not np.isfinite(v).all() or thickness(v) < min_thickness:
            continue
        h = _convex(v)
        if h is None:
            continue
        hv, hf = h
        if max_vertices and len(hv) > max_vertices:
            hv, hf = _decimate_hull(hv, max_vertices)
            h2 = _convex(hv)
            if h2 is None:
                continue
            hv, hf = h2
        if thickness(hv) < min_thickness:
            continue
        out.append((hv, hf))
    return out


def _decimate_hull(v: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Keep n hull vertices by farthest-point sampling (deterministic)."""
    chosen = [int(np.argmax(np.linalg.norm(v - v.mean(axis=0), axis=1)))]
    d = np.linalg.norm(v - v[chosen[0]], axis=1)
    while len(chosen) < n:
        i = int(np.argmax(d))
        chosen.append(i)
        d = np.minimum(d, np.linalg.norm(v - v[i], axis=1))
    return v[sorted(chosen)], np.zeros((0, 3), dtype=np.int64)


def decompose(vertices: np.ndarray, faces: np.ndarray, cfg: ConvertConfig | None = None,
              preprocess_mode: str = "auto") -> list[tuple[np.ndarray, np.ndarray]]:
    """Return CoACD convex hulls (vertices, faces) of a mesh, degenerate hulls dropped."""
    cfg = cfg or ConvertConfig()
    kwargs = _coacd_kwargs(cfg, preprocess_mode)
    if preprocess_mode != "auto":
        parts = _run_coacd(np.asarray(vertices), np.asarray(faces), kwargs)
    else:
        # a thin-walled closed manifold goes to CoACD as it is; anything else becomes the surface a fraction of a
        # grid step outside its triangles (exact distances, so thin walls stay thin); CoACD's own preprocessing
        # makes ~100k triangles that slow its search 2-4x and fattens thin walls by a voxel
        res, off = int(cfg.remesh_resolution), float(cfg.remesh_offset)
        kwargs["preprocess_mode"] = "off"
        v, f, how = solid_for_coacd(vertices, faces, res, off)
        parts = None
        if how == "closed":
            # CoACD on a raw shell can crash (a candle) or search for minutes (a lamp shade): it runs in a child
            # process with a time budget, and the offset surface is used when it fails
            parts = _run_isolated(v, f, kwargs, float(cfg.coacd_closed_budget_s))
            if parts is None:
                v, f, _how = solid_for_coacd(vertices, faces, res, off, allow_closed=False)
        if parts is None:
            parts = _run_coacd(v, f, kwargs)
    return clean_hulls([(np.asarray(v), np.asarray(f)) for v, f in parts], int(cfg.coacd_max_hull_vertices))


def _coacd_kwargs(cfg: ConvertConfig, preprocess_mode: str) -> dict[str, object]:
    """Return coacd.run_coacd keyword arguments from a convert config."""
    return dict(
        threshold=float(cfg.coacd_threshold),
        max_convex_hull=int(cfg.coacd_max_hulls),
        preprocess_mode=preprocess_mode,
        preprocess_resolution=int(cfg.coacd_preprocess_resolution),
        mcts_iterations=int(cfg.coacd_mcts_iterations),
        mcts_nodes=int(cfg.coacd_mcts_nodes),
        mcts_max_depth=int(cfg.coacd_mcts_max_depth),
        resolution=int(cfg.coacd_resolution),
        seed=int(cfg.coacd_seed),
    )


def _run_coacd(vertices: np.ndarray, faces: np.ndarray, kwargs: dict[str, object]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Run CoACD in this process; return its parts as (vertices, faces) arrays."""
    import coacd

    coacd.set_log_level("error")
    mesh = coacd.Mesh(np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int32))
    return [(np.asarray(v), np.asarray(f)) for v, f in coacd.run_coacd(mesh, **kwargs)]


def _run_isolated(vertices: np.ndarray, faces: np.ndarray, kwargs: dict[str, object],
                  budget_s: float) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """Run CoACD in a child interpreter (``python -m assets_convert.coacd_child``); return its parts, or None
    when it crashed or used more than budget_s seconds of processor time. A fresh interpreter, so no caller's
    main module is re-imported.

    The budget counts processor time on one thread (RLIMIT_CPU, ``OMP_NUM_THREADS=1``), not wall time: the
    outcome decides which surface the hulls come from, so it must not depend on how busy the machine is (a
    wall-clock budget gave a loaded machine other hulls than an idle one). Only a mesh whose search takes
    within the spread of CPU speeds of the budget can still end either way on two machines. A wall-clock
    limit of ten times the budget stays as a guard against a child that hangs without computing."""
    import json
    import os
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    if budget_s <= 0:
        return None
    with tempfile.TemporaryDirectory(prefix="sdovon-coacd-") as tmp:
        src, dst = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        np.savez(src, vertices=np.asarray(vertices, np.float64), faces=np.asarray(faces, np.int64))
        try:
            done = subprocess.run([sys.executable, "-m", "assets_convert.coacd_child", str(src), str(dst),
                                   json.dumps(kwargs), str(budget_s)], capture_output=True, timeout=10 * budget_s + 60,
                                  cwd=str(Path(__file__).resolve().parents[1]), env={**os.environ, "OMP_NUM_THREADS": "1"})
        except subprocess.TimeoutExpired:
            return None
        if done.returncode != 0 or not dst.exists():
            return None
        with np.load(dst) as z:
            n = int(z["count"])
            return [(np.array(z[f"v{k}"]), np.array(z[f"f{k}"])) for k in range(n)]


def hull_volume(hulls: list[tuple[np.ndarray, np.ndarray]]) -> float:
    """Return the summed volume of convex hulls (m^3)."""
    import trimesh

    return float(sum(trimesh.Trimesh(v, f, process=False).volume for v, f in hulls))


def mass_properties(hulls: list[tuple[np.ndarray, np.ndarray]], density: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Return (mass, centre of mass, 3x3 inertia about the centre of mass) of solid hulls."""
    import trimesh

    meshes = [trimesh.Trimesh(v, f, process=False) for v, f in hulls]
    mass = 0.0
    first = np.zeros(3)
    second = np.zeros((3, 3))  # sum over hulls of inertia about the world origin
    for m in meshes:
        m.density = density
        mm = float(m.mass)
        c = np.asarray(m.center_mass)
        i_c = np.asarray(m.moment_inertia)
        mass += mm
        first += mm * c
        second += i_c + mm * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
    if mass <= 0:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    com = first / mass
    inertia = second - mass * (np.dot(com, com) * np.eye(3) - np.outer(com, com))
    return mass, com, 0.5 * (inertia + inertia.T)


def solid_for_coacd(vertices: np.ndarray, faces: np.ndarray, resolution: int = 80,
                    offset: float = 0.45, allow_closed: bool = True) -> tuple[np.ndarray, np.ndarray, str]:
    """Return a watertight manifold (vertices, faces, how: 'closed' or 'offset') standing for a mesh's solid, for CoACD.

    Parameters
    ----------
    vertices : (N, 3) float
        Mesh vertices, metres.
    faces : (M, 3) int
        Triangle vertex indices.
    resolution : int
        Grid steps along the largest extent of the offset surface (at least 8).
    offset : float
        Offset of the surface outside the mesh, in grid steps.
    allow_closed : bool
        Pass a closed, thin-walled mesh through as it is instead of offsetting it.
    """
    import trimesh

    tm = trimesh.Trimesh(vertices, faces, process=True)
    # a closed mesh goes in as it is when the offset surface would thicken it noticeably (thin walls: bowls,
    # plates, chairs); chunky closed scans take the offset surface, whose even triangles CoACD cuts into
    # fewer hulls, much faster (a raw torus scan took CoACD > 5 min)
    step = float(tm.extents.max()) / max(int(resolution), 8)
    thin = tm.is_volume and offset * step * float(tm.area) > THIN_GROWTH * abs(float(tm.volume))
    if allow_closed and thin and tm.is_watertight and tm.is_winding_consistent:
        got = _closed_manifold(tm)
        if got is not None:
            return got[0], got[1], "closed"
    v, f = offset_remesh(np.asarray(tm.vertices), np.asarray(tm.faces), resolution, offset)
    return v, f, "offset"


def _closed_manifold(tm: object) -> tuple[np.ndarray, np.ndarray] | None:
    """Return a closed mesh as a valid manifold (outward faces), or None when it is not one."""
    import manifold3d

    v = np.asarray(tm.vertices, dtype=np.float64)  # type: ignore[attr-defined]
    f = np.asarray(tm.faces, dtype=np.int64)  # type: ignore[attr-defined]
    if float(tm.volume) < 0:  # type: ignore[attr-defined]
        f = f[:, ::-1]
    try:
        man = manifold3d.Manifold(manifold3d.Mesh(np.ascontiguousarray(v, dtype=np.float32),
                                                  np.ascontiguousarray(f, dtype=np.uint32)))
    except Exception:  # noqa: BLE001 - not a manifold
        return None
    if man.status() != manifold3d.Error.NoError or man.is_empty() or man.volume() <= 0:
        return None
    # not simplified: collapsing even a few edges of a thin-walled shell (the world's lamp shade, 8 of 592
    # triangles) sent CoACD into a search of > 5 min; the mesh as it is took 5 s
    mesh = man.to_mesh()
    out_v = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    out_f = np.asarray(mesh.tri_verts, dtype=np.int64)
    return (out_v, out_f) if len(out_f) >= 4 else None


def offset_remesh(vertices: np.ndarray, faces: np.ndarray, resolution: int = 80,
                  offset: float = 0.45, simplify: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Return the watertight surface `offset` grid steps outside any triangle soup (thin sheets become thin slabs).

    Parameters
    ----------
    vertices : (N, 3) float
        Triangle-soup vertices, metres.
    faces : (M, 3) int
        Triangle vertex indices.
    resolution : int
        Grid steps along the largest extent (at least 8).
    offset : float
        Offset of the surface outside the soup, in grid steps.
    simplify : float
        Simplification tolerance of the result, in grid steps.
    """
    import manifold3d
    import scipy.ndimage as ndi
    from scipy.spatial import cKDTree

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    lo0, hi0 = v.min(axis=0), v.max(axis=0)
    s = float((hi0 - lo0).max()) / max(int(resolution), 8)
    h = 0.5 * s
    lo = lo0 - 2 * s
    n = np.ceil((hi0 + 2 * s - lo) / s).astype(int)  # corner lattice: lo + i s, i in [0, n]
    # dense surface samples (spacing <= 0.4 grid step) give the occupied half-step voxels and the
    # unsigned distance near the surface; half-grid point g sits at lo + g h, and the body-centred lattice
    # that manifold's level set samples is its even points (cell corners) and odd points (cell centres)
    pts, pid = surface_samples(v, f, 0.4 * s)
    m2 = 2 * n + 1
    gidx = np.clip(np.floor((pts - lo) / h + 0.5).astype(np.int64), 0, m2 - 1)
    surf = np.zeros(tuple(m2), dtype=np.uint8)
    surf[gidx[:, 0], gidx[:, 1], gidx[:, 2]] = 1
    # close the shell by CLOSE_HALF_STEPS half steps before filling, so small holes do not leak the fill (a wider
    # closing fills concave gaps with voxel staircases that CoACD cuts endlessly: a torus took > 2 min)
    k = 2 * CLOSE_HALF_STEPS + 1
    closed = ndi.minimum_filter(ndi.maximum_filter(surf, size=k, mode="constant"), size=k, mode="constant")
    inside = ndi.binary_fill_holes(closed) & (surf == 0)
    near = ndi.maximum_filter(surf, size=9, mode="constant") > 0  # within 2 grid steps of the surface
    cell = np.floor((pts - lo) / (0.2 * s)).astype(np.int64)  # one sample per 0.2-step cell is enough for distances
    dims = cell.max(axis=0) + 1
    _, first = np.unique(np.ravel_multi_index(cell.T, dims), return_index=True)
    first = np.sort(first)
    tree = cKDTree(pts[first])
    tris = v[f]
    fields = []
    for par in (0, 1):  # distance near the surface, 3 grid steps elsewhere, positive inside
        sub = (slice(par, None, 2),) * 3
        ins, nr = inside[sub], near[sub]
        dist = np.full(ins.shape, 3.0 * s)
        q = lo + h * (2 * np.argwhere(nr) + par)
        if len(q):
            dist[nr] = _exact_distance(q, tree, pid[first], tris, 3.0 * s)
        fields.append(np.where(ins, dist, -dist))
    sc = fields[0].reshape(-1).tolist()
    sm = fields[1][:n[0], :n[1], :n[2]].reshape(-1).tolist()
    nc1, nc2 = int(n[1] + 1), int(n[2] + 1)
    nm1, nm2 = int(n[1]), int(n[2])
    ox, oy, oz = (float(x) for x in lo)
    inv = 1.0 / h
    far = -4.0 * s

    def sdf(x: float, y: float, z: float) -> float:
        gi, gj, gk = int((x - ox) * inv + 0.5), int((y - oy) * inv + 0.5), int((z - oz) * inv + 0.5)
        if gi & 1:
            i, j, k = gi >> 1, gj >> 1, gk >> 1
            if 0 <= i < n[0] and 0 <= j < nm1 and 0 <= k < nm2:
                return sm[(i * nm1 + j) * nm2 + k]
            return far
        i, j, k = gi >> 1, gj >> 1, gk >> 1
        if 0 <= i <= n[0] and 0 <= j < nc1 and 0 <= k < nc2:
            return sc[(i * nc1 + j) * nc2 + k]
        return far

    hi = lo + n * s
    man = manifold3d.Manifold.level_set(sdf, [*lo, *hi], s * (1 - 1e-7), -float(offset) * s)
    man = man.simplify(float(simplify) * s)
    out = man.to_mesh()
    ov = np.asarray(out.vert_properties, dtype=np.float64)[:, :3]
    of = np.asarray(out.tri_verts, dtype=np.int64)
    if len(of) < 4:
        return v, f
    return ov, of


def _exact_distance(q: np.ndarray, tree: object, tri_of: np.ndarray, tris: np.ndarray, cap: float) -> np.ndarray:
    """Return distances (capped) from points to the triangles of their 4 nearest surface samples."""
    from trimesh.triangles import closest_point

    d, nn = tree.query(q, k=4, distance_upper_bound=cap, workers=-1)  # type: ignore[attr-defined]
    out = np.full(len(q), cap)
    for c in range(nn.shape[1]):
        ok = np.isfinite(d[:, c])
        if not ok.any():
            continue
        cp = closest_point(tris[tri_of[nn[ok, c]]], q[ok])
        out[ok] = np.minimum(out[ok], np.linalg.norm(cp - q[ok], axis=1))
    return out


def surface_samples(vertices: np.ndarray, faces: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Return points covering every triangle on a barycentric lattice no coarser than `spacing`, and their triangles."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
    edge = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    steps = np.clip(np.ceil(edge / max(spacing, 1e-12)), 1, 512).astype(np.int64)
    out = [tri.reshape(-1, 3)]
    ids = [np.repeat(np.arange(len(tri)), 3)]
    for k in np.unique(steps):
        if k < 2:
            continue
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = i + j <= k
        b = np.stack([i[keep], j[keep]], axis=1).astype(np.float64) / k  # barycentric (u, v)
        sel = np.flatnonzero(steps == k)
        t = tri[sel]
        p = t[:, None, 0] + b[None, :, 0:1] * (t[:, None, 1] - t[:, None, 0]) + b[None, :, 1:2] * (t[:, None, 2] - t[:, None, 0])
        out.append(p.reshape(-1, 3))
        ids.append(np.repeat(sel, len(b)))
    return np.concatenate(out), np.concatenate(ids)


def nearly_convex(tm: Any, chull: Any, threshold: float, samples: int = 2000) -> bool:
    """Return whether the convex hull stays within CoACD's concavity threshold of the surface.

    A hull whose surface lies within threshold x half the largest extent of the mesh (CoACD normalises
    to [-1, 1]) everywhere (a can's
    recessed lid, a box's rounded edges) becomes the single collision hull without running CoACD.
    """
    import trimesh

    pts, _ = trimesh.sample.sample_surface(chull, samples, seed=0)
    pts = np.concatenate([pts, np.asarray(chull.vertices)])
    _closest, dist, _tri = trimesh.proximity.closest_point(tm, pts)
    return float(np.max(dist)) <= threshold * 0.5 * float(tm.extents.max())
