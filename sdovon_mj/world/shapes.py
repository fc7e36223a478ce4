"""Pure-numpy mesh primitives (metres, Z up) shared by the furniture and object generators.

A mesh here is a plain ``(vertices (N, 3) float64, faces (M, 3) int64)`` tuple. Every closed
primitive is returned with outward (counter-clockwise seen from outside) winding, so the
concatenation of closed primitives is watertight in the edge sense.
"""

from __future__ import annotations

import numpy as np
import trimesh

Mesh = tuple[np.ndarray, np.ndarray]

# unit-cube corner order: bit 0 = x, bit 1 = y, bit 2 = z
_BOX_FACES = np.array(
    [
        [0, 2, 3], [0, 3, 1],  # -z
        [4, 5, 7], [4, 7, 6],  # +z
        [0, 1, 5], [0, 5, 4],  # -y
        [2, 6, 7], [2, 7, 3],  # +y
        [0, 4, 6], [0, 6, 2],  # -x
        [1, 3, 7], [1, 7, 5],  # +x
    ],
    dtype=np.int64,
)


def box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> Mesh:
    """Return an axis-aligned box between corners `lo` and `hi` (12 triangles)."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    bits = np.array([[(i >> k) & 1 for k in range(3)] for i in range(8)], dtype=np.float64)
    v = lo + bits * (hi - lo)
    return v, _BOX_FACES.copy()


def signed_volume(mesh: Mesh) -> float:
    """Return the signed volume of a closed mesh (positive for outward winding)."""
    v, f = mesh
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def orient_outward(mesh: Mesh) -> Mesh:
    """Flip a consistently wound closed mesh so that its signed volume is positive."""
    v, f = mesh
    if signed_volume(mesh) < 0:
        f = f[:, ::-1].copy()
    return v, f


def hull(points: np.ndarray) -> Mesh:
    """Return the convex hull of `points` as an outward-wound triangle mesh."""
    m = trimesh.convex.convex_hull(np.asarray(points, dtype=np.float64))
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


_HULL_CACHE: dict[tuple, np.ndarray] = {}


def _hull_faces(key: tuple, points: np.ndarray) -> np.ndarray:
    """Return hull faces for a point layout whose hull topology depends only on `key` (cached)."""
    f = _HULL_CACHE.get(key)
    if f is None:
        m = trimesh.convex.convex_hull(points)
        # map hull vertices back to the input points (the hull keeps every point: all are extreme)
        order = np.lexsort(points.T[::-1])
        hv = np.asarray(m.vertices)
        horder = np.lexsort(hv.T[::-1])
        if len(hv) != len(points):
            raise ValueError("hull dropped points")
        idx = np.empty(len(hv), dtype=np.int64)
        idx[horder] = order
        f = idx[np.asarray(m.faces, dtype=np.int64)]
        _HULL_CACHE[key] = f
    return f.copy()


def _chamfer_points(lo: np.ndarray, hi: np.ndarray, bevel: float) -> np.ndarray:
    """Return the 24 corner points of a chamfered box."""
    pts = []
    for i in range(8):
        corner = np.where([(i >> k) & 1 for k in range(3)], hi, lo)
        inward = np.where([(i >> k) & 1 for k in range(3)], -bevel, bevel)
        for axis in range(3):
            p = corner + inward
            p[axis] = corner[axis]
            pts.append(p)
    return np.array(pts)


def chamfer_box(lo: tuple[float, float, float], hi: tuple[float, float, float], bevel: float) -> Mesh:
    """Return a box with bevelled edges; its top face is flat and inset by `bevel`."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    bevel = float(min(bevel, 0.45 * float(np.min(hi - lo))))
    f = _hull_faces(("chamfer",), _chamfer_points(np.zeros(3), np.array([1.0, 1.3, 1.7]), 0.2))
    return _chamfer_points(lo, hi, bevel), f


def _octant_dirs(seg: int) -> np.ndarray:
    """Return unit directions covering the positive octant of a sphere (seg steps per arc)."""
    dirs = []
    for i in range(seg + 1):
        phi = 0.5 * np.pi * i / seg
        n = seg - i
        for j in range(n + 1 if n else 1):
            th = 0.5 * np.pi * (j / n if n else 0.0)
            dirs.append([np.cos(phi) * np.cos(th), np.cos(phi) * np.sin(th), np.sin(phi)])
    return np.array(dirs)


def _rounded_points(lo: np.ndarray, hi: np.ndarray, radius: float, seg: int) -> np.ndarray:
    """Return the corner-sphere sample points of a rounded box."""
    d = _octant_dirs(seg)
    pts = []
    for i in range(8):
        s = np.array([1.0 if (i >> k) & 1 else -1.0 for k in range(3)])
        centre = np.where(s > 0, hi - radius, lo + radius)
        pts.append(centre + radius * d * s)
    return np.concatenate(pts)


def rounded_box(lo: tuple[float, float, float], hi: tuple[float, float, float], radius: float, seg: int = 3) -> Mesh:
    """Return a box with all edges and corners rounded by `radius` (convex hull of corner spheres)."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    radius = float(min(radius, 0.45 * float(np.min(hi - lo))))
    f = _hull_faces(("rounded", seg), _rounded_points(np.zeros(3), np.array([1.0, 1.3, 1.7]), 0.2, seg))
    return _rounded_points(lo, hi, radius, seg), f


def _grid_surface(rings: np.ndarray, first_pole: bool, last_pole: bool, loop: bool = False) -> Mesh:
    """Triangulate stacked closed rings (k, s, 3); pole rings collapse to their first point."""
    k, s, _ = rings.shape
    verts: list[np.ndarray] = []
    idx = np.zeros((k, s), dtype=np.int64)
    n = 0
    for i in range(k):
        pole = (i == 0 and first_pole) or (i == k - 1 and last_pole)
        if pole:
            verts.append(rings[i, :1])
            idx[i, :] = n
            n += 1
        else:
            verts.append(rings[i])
            idx[i, :] = np.arange(n, n + s)
            n += s
    v = np.concatenate(verts)
    faces = []
    pairs = [(i, i + 1) for i in range(k - 1)]
    if loop:
        pairs.append((k - 1, 0))
    j = np.arange(s)
    j1 = (j + 1) % s
    for i0, i1 in pairs:
        a, b, c, d = idx[i0, j], idx[i0, j1], idx[i1, j1], idx[i1, j]
        t = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
        keep = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])
        faces.append(t[keep])
    return orient_outward((v, np.concatenate(faces)))


def revolve(profile: list[tuple[float, float]] | np.ndarray, segments: int = 24, closed: bool = False) -> Mesh:
    """Revolve an (r, z) profile about the Z axis; an open profile must start and end on the axis."""
    p = np.asarray(profile, dtype=np.float64)
    keep = np.ones(len(p), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(p, axis=0)) > 1e-12, axis=1)
    p = p[keep]
    ang = 2.0 * np.pi * np.arange(segments) / segments
    x = p[:, 0:1] * np.cos(ang)[None, :]
    y = p[:, 0:1] * np.sin(ang)[None, :]
    z = np.repeat(p[:, 1:2], segments, 1)
    rings = np.stack([x, y, z], -1)
    if closed:
        return _grid_surface(rings, False, False, loop=True)
    return _grid_surface(rings, bool(p[0, 0] <= 1e-12), bool(p[-1, 0] <= 1e-12))


def cylinder(radius: float, z0: float, z1: float, segments: int = 24, centre: tuple[float, float] = (0.0, 0.0)) -> Mesh:
    """Return a closed vertical cylinder of `radius` from z0 to z1.

    Parameters
    ----------
    radius : float
        Radius, metres.
    z0, z1 : float
        Bottom and top heights, metres.
    segments : int
        Segments around the axis.
    centre : tuple of float
        XY of the axis, metres.
    """
    v, f = revolve([(0.0, z0), (radius, z0), (radius, z1), (0.0, z1)], segments)
    v = v + np.array([centre[0], centre[1], 0.0])
    return v, f


def superellipsoid(
    lo: tuple[float, float, float], hi: tuple[float, float, float], e1: float = 0.3, e2: float = 0.3, nu: int = 10, nv: int = 20
) -> Mesh:
    """Return a superellipsoid filling the box lo..hi (small exponents -> cushion-like).

    Parameters
    ----------
    lo, hi : tuple of float
        Corners of the box filled, metres.
    e1 : float
        Exponent along latitude (small: flat top and bottom).
    e2 : float
        Exponent along longitude (small: square in plan).
    nu : int
        Latitude steps.
    nv : int
        Longitude steps.
    """
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    c = 0.5 * (lo + hi)
    r = 0.5 * (hi - lo)

    def sp(x: np.ndarray, e: float) -> np.ndarray:
        return np.sign(x) * np.abs(x) ** e

    eta = np.linspace(-0.5 * np.pi, 0.5 * np.pi, nu + 1)
    om = 2.0 * np.pi * np.arange(nv) / nv
    ce, se = sp(np.cos(eta), e1), sp(np.sin(eta), e1)
    co, so = sp(np.cos(om), e2), sp(np.sin(om), e2)
    x = r[0] * ce[:, None] * co[None, :]
    y = r[1] * ce[:, None] * so[None, :]
    z = r[2] * np.repeat(se[:, None], nv, 1)
    rings = np.stack([x, y, z], -1) + c
    return _grid_surface(rings, True, True)


def ellipsoid(centre: tuple[float, float, float], radii: tuple[float, float, float], nu: int = 8, nv: int = 14) -> Mesh:
    """Return an ellipsoid with semi-axes `radii` around `centre`."""
    c = np.asarray(centre, dtype=np.float64)
    r = np.asarray(radii, dtype=np.float64)
    return superellipsoid(tuple(c - r), tuple(c + r), 1.0, 1.0, nu, nv)


def _frames(path: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return parallel-transport frames (T, N, B) along a polyline."""
    t = np.gradient(path, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    ref = np.array([0.0, 0.0, 1.0]) if abs(t[0, 2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    n0 = np.cross(t[0], ref)
    n0 /= np.linalg.norm(n0)
    ns = [n0]
    for i in range(1, len(path)):
        n = ns[-1] - np.dot(ns[-1], t[i]) * t[i]
        n /= np.linalg.norm(n)
        ns.append(n)
    nrm = np.array(ns)
    return t, nrm, np.cross(t, nrm)


def sweep(
    path: np.ndarray, radii: np.ndarray | float, segments: int = 12, aspect: float = 1.0
) -> Mesh:
    """Sweep a circle (or ellipse with `aspect` = minor/major) along `path`, capped at both ends."""
    path = np.asarray(path, dtype=np.float64)
    r = np.broadcast_to(np.asarray(radii, dtype=np.float64), (len(path),))
    t, nrm, bin_ = _frames(path)
    ang = 2.0 * np.pi * np.arange(segments) / segments
    ca, sa = np.cos(ang), np.sin(ang) * aspect
    rings = path[:, None, :] + r[:, None, None] * (ca[None, :, None] * nrm[:, None, :] + sa[None, :, None] * bin_[:, None, :])
    rings = np.concatenate([np.repeat(path[:1, None, :], segments, 1), rings, np.repeat(path[-1:, None, :], segments, 1)])
    return _grid_surface(rings, True, True)


def icosphere(centre: tuple[float, float, float], radius: float, subdivisions: int = 1) -> Mesh:
    """Return an icosphere (subdivisions 1 -> 80 faces, 2 -> 320 faces)."""
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return np.asarray(m.vertices) + np.asarray(centre, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


def rot_x(a: float) -> np.ndarray:
    """Return the 3x3 rotation about X by `a` radians."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> np.ndarray:
    """Return the 3x3 rotation about Y by `a` radians."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> np.ndarray:
    """Return the 3x3 rotation about Z by `a` radians."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def transform(mesh: Mesh, rot: np.ndarray | None = None, shift: tuple[float, float, float] | np.ndarray | None = None,
              scale: tuple[float, float, float] | np.ndarray | float | None = None) -> Mesh:
    """Return the mesh scaled, then rotated, then shifted (winding fixed for mirroring scales)."""
    v, f = mesh
    v = np.array(v, dtype=np.float64)
    if scale is not None:
        s = np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,))
        v = v * s
        if np.prod(s) < 0:
            f = f[:, ::-1]
    if rot is not None:
        v = v @ np.asarray(rot, dtype=np.float64).T
    if shift is not None:
        v = v + np.asarray(shift, dtype=np.float64)
    return v, np.asarray(f, dtype=np.int64).copy()


def concat(meshes: list[Mesh]) -> Mesh:
    """Concatenate meshes into one (vertex indices offset)."""
    vs, fs, n = [], [], 0
    for v, f in meshes:
        vs.append(np.asarray(v, dtype=np.float64))
        fs.append(np.asarray(f, dtype=np.int64) + n)
        n += len(v)
    if not vs:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return np.concatenate(vs), np.concatenate(fs)


def torus_arc(centre: tuple[float, float, float], major: float, minor: float, a0: float, a1: float,
              plane: str = "xz", steps: int = 12, segments: int = 10) -> Mesh:
    """Return a capped tube along a circular arc (a mug or teapot handle) in the given plane.

    Parameters
    ----------
    centre : tuple of float
        Centre of the arc, metres.
    major : float
        Radius of the arc, metres.
    minor : float
        Radius of the tube, metres.
    a0, a1 : float
        Start and end angles of the arc, radians.
    plane : str
        Plane of the arc: "xz" or "xy".
    steps : int
        Segments along the arc.
    segments : int
        Segments around the tube.
    """
    a = np.linspace(a0, a1, steps + 1)
    c = np.asarray(centre, dtype=np.float64)
    if plane == "xz":
        path = np.stack([c[0] + major * np.cos(a), np.full_like(a, c[1]), c[2] + major * np.sin(a)], 1)
    else:
        path = np.stack([c[0] + major * np.cos(a), c[1] + major * np.sin(a), np.full_like(a, c[2])], 1)
    return sweep(path, minor, segments)
