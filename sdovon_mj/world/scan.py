"""Make a clean apartment mesh look like a fused RGB-D scan (ScanNet style).

The clean triangles are re-meshed to a near-uniform edge length, fused into one mesh (vertices of
one instance merged), displaced along their normals by Gaussian noise, punched with small holes
and given per-vertex colours, instance ids and over-segmentation segment ids.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse

from .model import MATERIALS, Apartment

EDGE_CANDIDATES = (0.05, 0.055, 0.06, 0.065, 0.07, 0.075, 0.08, 0.09, 0.1, 0.11, 0.12, 0.14, 0.16, 0.2, 0.3)


@dataclass
class ScanMesh:
    """A fused scan mesh: Z-up metres, per-vertex colour, instance id and segment id."""

    vertices: np.ndarray  # (N, 3) float64
    faces: np.ndarray  # (M, 3) int64
    colors: np.ndarray  # (N, 4) uint8
    vertex_instance: np.ndarray  # (N,) int32
    segments: np.ndarray  # (N,) int64 segment id per vertex
    edge: float  # the re-meshing edge length used
    holes_faces: int  # faces removed by holes


def bisect_to_size(tri: np.ndarray, edge: float, max_iter: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Split triangles (M, 3, 3) at the midpoint of their longest edge until every edge is <= `edge`.

    Returns (triangles (K, 3, 3), index of the source triangle per output triangle); winding kept.
    Unlike 1-to-4 subdivision, long thin slivers (wall sides) become only ~2 L / edge triangles.
    """
    src = np.arange(len(tri))
    done_t, done_s = [], []
    for _ in range(max_iter):
        e = np.stack([np.linalg.norm(tri[:, 1] - tri[:, 0], axis=1), np.linalg.norm(tri[:, 2] - tri[:, 1], axis=1),
                      np.linalg.norm(tri[:, 0] - tri[:, 2], axis=1)], axis=1)
        k = np.argmax(e, axis=1)
        big = e[np.arange(len(tri)), k] > edge
        done_t.append(tri[~big])
        done_s.append(src[~big])
        tri, src, k = tri[big], src[big], k[big]
        if len(tri) == 0:
            break
        # rotate so the longest edge is (0, 1): corners (a, b, c) -> split at m = (a + b) / 2
        r = np.stack([(k + i) % 3 for i in range(3)], axis=1)
        t = tri[np.arange(len(tri))[:, None], r]
        mid = 0.5 * (t[:, 0] + t[:, 1])
        t1 = np.stack([t[:, 0], mid, t[:, 2]], axis=1)
        t2 = np.stack([mid, t[:, 1], t[:, 2]], axis=1)
        tri = np.concatenate([t1, t2])
        src = np.concatenate([src, src])
    done_t.append(tri)
    done_s.append(src)
    out_t, out_s = np.concatenate(done_t), np.concatenate(done_s)
    order = np.argsort(out_s, kind="stable")
    return out_t[order], out_s[order]


def find_quads(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Return indices i of face pairs (i, i+1) = (a, b, c), (a, c, d) forming a parallelogram a-b-c-d."""
    f0, f1 = f[:-1], f[1:]
    cand = (f1[:, 0] == f0[:, 0]) & (f1[:, 1] == f0[:, 2])
    a, b, c, d = v[f0[:, 0]], v[f0[:, 1]], v[f0[:, 2]], v[f1[:, 2]]
    scale = np.maximum(np.linalg.norm(c - a, axis=1), 1e-12)
    cand &= np.linalg.norm(a + c - b - d, axis=1) <= 1e-9 * np.maximum(scale, 1.0)
    out, last = [], -2
    for i in np.flatnonzero(cand):
        if i > last + 1:
            out.append(i)
            last = i
    return np.array(out, dtype=np.int64)


def _grid(na: int, nb: int) -> tuple[np.ndarray, np.ndarray]:
    """Return (s, t) grid parameters (P, 2) and triangles (2 na nb, 3) of a parallelogram grid."""
    s, t = np.meshgrid(np.arange(na + 1) / na, np.arange(nb + 1) / nb, indexing="ij")
    st = np.stack([s.ravel(), t.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(na), np.arange(nb), indexing="ij")
    p00 = (i * (nb + 1) + j).ravel()
    p10 = ((i + 1) * (nb + 1) + j).ravel()
    p11 = ((i + 1) * (nb + 1) + j + 1).ravel()
    p01 = (i * (nb + 1) + j + 1).ravel()
    tris = np.concatenate([np.stack([p00, p10, p11], 1), np.stack([p00, p11, p01], 1)])
    return st, tris


def remesh(v: np.ndarray, f: np.ndarray, edge: float) -> tuple[np.ndarray, np.ndarray]:
    """Re-mesh to cells of about `edge`: parallelogram face pairs become regular grids (shared edges
    get equal splits, so boxes stay conforming), other triangles are bisected. Returns the triangle
    soup (K, 3, 3) and the source face of every output triangle (winding kept)."""
    q = find_quads(v, f)
    is_q = np.zeros(len(f), dtype=bool)
    is_q[q] = True
    is_q[q + 1] = True
    a, b, d = v[f[q, 0]], v[f[q, 1]], v[f[q + 1, 2]]
    na = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / edge - 1e-9)).astype(np.int64)
    nb = np.maximum(1, np.ceil(np.linalg.norm(d - a, axis=1) / edge - 1e-9)).astype(np.int64)
    tris, srcs = [], []
    for ka, kb in sorted(set(zip(na.tolist(), nb.tolist()))):
        sel = np.flatnonzero((na == ka) & (nb == kb))
        st, gt = _grid(ka, kb)
        pa, ea, eb = a[sel], b[sel] - a[sel], d[sel] - a[sel]
        pts = pa[:, None, :] + st[None, :, 0:1] * ea[:, None, :] + st[None, :, 1:2] * eb[:, None, :]
        tris.append(pts[:, gt].reshape(-1, 3, 3))
        # the first half of the grid triangles lie in (a, b, c), the second in (a, c, d)
        half = len(gt) // 2
        srcs.append((q[sel][:, None] + np.r_[np.zeros(half, dtype=np.int64), np.ones(half, dtype=np.int64)][None, :]).ravel())
    rest = np.flatnonzero(~is_q)
    bt, bs = bisect_to_size(v[f[rest]], edge * np.sqrt(2.0))
    tris.append(bt)
    srcs.append(rest[bs])
    out_t, out_s = np.concatenate(tris), np.concatenate(srcs)
    order = np.argsort(out_s, kind="stable")
    return out_t[order], out_s[order]


def count_after_remesh(v: np.ndarray, f: np.ndarray, edge: float) -> int:
    """Return the (estimated) triangle count of `remesh` at this edge length."""
    q = find_quads(v, f)
    a, b, d = v[f[q, 0]], v[f[q, 1]], v[f[q + 1, 2]]
    na = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / edge - 1e-9))
    nb = np.maximum(1, np.ceil(np.linalg.norm(d - a, axis=1) / edge - 1e-9))
    rest = np.ones(len(f), dtype=bool)
    rest[q] = False
    rest[q + 1] = False
    tri = v[f[rest]]
    e = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    est = np.maximum(1.0, np.maximum(4.0 * area / edge ** 2, np.max(e, axis=1) / edge))
    return int(2 * np.sum(na * nb) + 2 * np.sum(est))


def choose_edge(v: np.ndarray, f: np.ndarray, max_faces: int) -> float:
    """Return the smallest candidate edge length keeping the re-meshed face count about <= max_faces."""
    for e in EDGE_CANDIDATES:
        if count_after_remesh(v, f, e) <= max_faces:
            return e
    return EDGE_CANDIDATES[-1]


def unique_rows(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return (index of the first row of each distinct row, inverse) with groups in sorted key order."""
    order = np.lexsort(keys.T[::-1])
    ks = keys[order]
    new = np.ones(len(ks), dtype=bool)
    new[1:] = np.any(ks[1:] != ks[:-1], axis=1)
    gid = np.cumsum(new) - 1
    inv = np.empty(len(ks), dtype=np.int64)
    inv[order] = gid
    first = order[new]
    return first, inv


def _vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Return area-weighted unit vertex normals (zero where undefined)."""
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    vn = np.zeros_like(v)
    for k in range(3):
        for c in range(3):
            vn[:, c] += np.bincount(f[:, k], weights=fn[:, c], minlength=len(v))
    ln = np.linalg.norm(vn, axis=1, keepdims=True)
    return np.divide(vn, ln, out=np.zeros_like(vn), where=ln > 0)


def visible_faces(apartment: Apartment) -> np.ndarray:
    """Return a face mask without the surfaces a scanner inside the rooms never sees.

    Dropped: undersides resting on a floor, slab sides and bottoms, ceiling tops, wall tops and
    the backs of wall slabs (faces looking away from their room), and window glass.
    """
    m = apartment.mesh
    inst = apartment.instances
    t = m.vertices[m.faces]
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, ln, out=np.zeros_like(n), where=ln > 0)
    c = t.mean(axis=1)
    fi = m.face_instance
    label = np.array([i.label for i in inst])[fi]
    z0 = np.array([apartment.floors[i.floor].height for i in inst])[fi]
    h = apartment.wall_height
    drop = (n[:, 2] < -0.9) & (c[:, 2] <= z0 + 0.005)
    drop |= (label == "floor") & (n[:, 2] < 0.9)
    drop |= (label == "ceiling") & (n[:, 2] > -0.9)
    wall = label == "wall"
    drop |= wall & (n[:, 2] > 0.9) & (c[:, 2] >= z0 + h - 0.005)
    centre = np.array([apartment.rooms[i.room].polygon.mean(axis=0) if i.room >= 0 else np.zeros(2) for i in inst])[fi]
    lo = np.full((len(inst), 2), np.inf)
    hi = np.full((len(inst), 2), -np.inf)
    np.minimum.at(lo, np.repeat(fi, 3), m.vertices[m.faces.ravel(), :2])
    np.maximum.at(hi, np.repeat(fi, 3), m.vertices[m.faces.ravel(), :2])
    thin = np.argmin(hi - lo, axis=1)[fi]
    along_thin = np.abs(n[np.arange(len(n)), thin]) > 0.9
    away = np.einsum("ij,ij->i", n[:, :2], centre - c[:, :2]) < 0
    drop |= wall & along_thin & away
    drop |= m.face_material == MATERIALS.index("glass")
    return ~drop


def make_scan(apartment: Apartment, noise_sigma: float = 0.003, max_faces: int = 300_000, hole_fraction: float = 0.01,
              hole_rings: int = 3, segment_size: float = 0.5) -> ScanMesh:
    """Return the scan-like version of an apartment's mesh (deterministic for its seed).

    Parameters
    ----------
    apartment : Apartment
        The generated apartment.
    noise_sigma : float
        Surface noise std along the normals, metres.
    max_faces : int
        About the most faces of the re-meshed scan.
    hole_fraction : float
        Fraction of faces removed as small holes.
    hole_rings : int
        Largest hole size, in face rings grown from a seed face.
    segment_size : float
        Voxel size of the over-segmentation, metres.
    """
    rng = np.random.default_rng([apartment.seed, 7])
    m = apartment.mesh
    seen = np.flatnonzero(visible_faces(apartment))
    edge = choose_edge(m.vertices, m.faces[seen], max_faces)
    tri, src = remesh(m.vertices, m.faces[seen], edge)
    src = seen[src]
    p = tri.reshape(-1, 3)
    inst_of_point = np.repeat(m.face_instance[src].astype(np.int64), 3)
    col_of_point = np.repeat(m.face_color[src], 3, axis=0)
    # fuse: merge coincident points of one instance
    q = np.round(p / 1e-5).astype(np.int64)
    keys = np.concatenate([inst_of_point[:, None], q], axis=1)
    first, inv = unique_rows(keys)
    verts = p[first]
    faces = inv.reshape(-1, 3)
    vinst = inst_of_point[first].astype(np.int32)
    vcol = col_of_point[first].astype(np.float64)
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    faces = faces[keep]
    # surface noise along the normals
    normals = _vertex_normals(verts, faces)
    verts = verts + normals * rng.normal(0.0, noise_sigma, (len(verts), 1))
    # holes: small patches grown from random seed faces
    nf = len(faces)
    inc = sparse.csr_matrix((np.ones(3 * nf), (np.repeat(np.arange(nf), 3), faces.ravel())), shape=(nf, len(verts)))
    # patch sizes vary: each seed grows 1..hole_rings rings (about 13, 37, 73 faces on a regular grid)
    sizes = np.array([1 + 6 * k * (k + 1) for k in range(1, hole_rings + 1)], dtype=np.float64)
    n_seeds = int(round(hole_fraction * nf / sizes.mean()))
    if hole_fraction > 0:
        n_seeds = max(1, n_seeds)
    seeds = rng.choice(nf, size=n_seeds, replace=False)
    rings = rng.integers(1, hole_rings + 1, n_seeds)
    mask = np.zeros(nf, dtype=bool)
    for k in range(1, hole_rings + 1):
        grow = np.zeros(nf, dtype=bool)
        grow[seeds[rings == k]] = True
        for _ in range(k):
            vm = (inc.T @ grow.astype(np.float64)) > 0
            grow = (inc @ vm.astype(np.float64)) > 0
        mask |= grow
    finst = vinst[faces[:, 0]]
    total = np.bincount(finst, minlength=len(apartment.instances))
    lost = np.bincount(finst[mask], minlength=len(apartment.instances))
    spare = lost > 0.3 * np.maximum(total, 1)
    mask &= ~spare[finst]
    faces = faces[~mask]
    used = np.zeros(len(verts), dtype=bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used) - 1
    faces = remap[faces]
    verts, vinst, vcol, normals = verts[used], vinst[used], vcol[used], normals[used]
    # colours: sensor noise
    vcol[:, :3] += rng.normal(0.0, 3.0, (len(vcol), 3))
    vcol[:, 3] = 255.0
    colors = np.clip(np.round(vcol), 0, 255).astype(np.uint8)
    # over-segmentation: instance x dominant normal direction x coarse voxel
    dom = np.argmax(np.abs(normals), axis=1) * 2 + (normals[np.arange(len(normals)), np.argmax(np.abs(normals), axis=1)] < 0)
    vox = np.floor(verts / segment_size).astype(np.int64)
    skeys = np.concatenate([vinst[:, None].astype(np.int64), dom[:, None], vox], axis=1)
    _, seg = unique_rows(skeys)
    return ScanMesh(verts, faces.astype(np.int64), colors, vinst, seg.astype(np.int64), edge, int(mask.sum()))
