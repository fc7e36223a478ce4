"""Support collision for settling: the scene is visual-only, so objects land on geometry built here.

- Each receptacle plane becomes a thin convex prism (a mesh of its polygon at the plane height and
  `support_thickness` below; a box when the polygon is a rectangle, since analytic box contacts are
  far cheaper than mesh ones), so its top face is exactly at the detected height.
- Each floor becomes a box whose top is the floor height, covering the scene's extent.
- Optionally, where a plane is not flat in the scene mesh (cushions, scans), a heightfield from
  vertical ray casts on the scene mesh sidecar replaces the prism (`PlaceConfig.support_hfield`).

All support geoms are group 4 (not rendered), collide with objects, and carry rolling and torsional
friction (condim 6) so round objects come to rest instead of rolling for seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from ..config import PlaceConfig
from ..records import ReceptaclePlane, SceneAsset
from ..sim import GROUP_SUPPORT
from ..geometry import convex_hull_ccw
from ..raycast import first_hits

SUPPORT_FRICTION = (1.0, 0.02, 0.002)  # sliding, torsional, rolling
SUPPORT_CONDIM = 6
FLOOR_THICKNESS = 0.1
FLOOR_MARGIN = 1.0


def plane_geom_name(plane_id: int) -> str:
    """Return the support geom name of a receptacle plane."""
    return f"support_plane_{plane_id}"


def floor_geom_name(floor_index: int) -> str:
    """Return the support geom name of a floor."""
    return f"support_floor_{floor_index}"


@dataclass
class SupportInfo:
    """Names of the support geoms added to a spec, by plane id and floor index."""

    planes: dict[int, str] = field(default_factory=dict)
    floors: dict[int, str] = field(default_factory=dict)
    hfields: list[int] = field(default_factory=list)  # plane ids supported by a heightfield


_HULLS: dict[bytes, np.ndarray] = {}


def _hull(polygon: np.ndarray) -> np.ndarray:
    """Return convex_hull_ccw of a polygon (memoised: every variant of a scene brings the same planes)."""
    key = np.ascontiguousarray(polygon, dtype=float).tobytes()
    hit = _HULLS.get(key)
    if hit is None:
        if len(_HULLS) > 10_000:
            _HULLS.clear()
        hit = _HULLS[key] = convex_hull_ccw(np.asarray(polygon, dtype=float))
        hit.setflags(write=False)
    return hit


def prism_vertices(polygon: np.ndarray, top: float, thickness: float) -> np.ndarray:
    """Return the vertices (2M, 3) of a convex prism whose top face is `polygon` at height `top`."""
    p = _hull(polygon)
    upper = np.column_stack([p, np.full(len(p), top)])
    lower = np.column_stack([p, np.full(len(p), top - thickness)])
    return np.vstack([upper, lower])


def rectangle_box(polygon: np.ndarray, tol: float = 1e-4) -> tuple[tuple[float, float], tuple[float, float], float] | None:
    """Return (centre, half sizes, yaw) when a polygon is a rectangle (within tol metres), else None."""
    p = _hull(polygon)
    if len(p) != 4:
        return None
    e = np.roll(p, -1, axis=0) - p
    lengths = np.linalg.norm(e, axis=1)
    if lengths.min() <= tol:
        return None
    for i in range(4):
        if abs(float(np.dot(e[i], e[(i + 1) % 4]))) / lengths[(i + 1) % 4] > tol:
            return None
    c = p.mean(axis=0)
    yaw = float(np.arctan2(e[0][1], e[0][0]))
    return (float(c[0]), float(c[1])), (float(lengths[0] / 2), float(lengths[1] / 2)), yaw


def _support_geom(body: mujoco.MjsBody, name: str, condim: int = SUPPORT_CONDIM) -> mujoco.MjsGeom:
    """Add a support geom with the support contact settings."""
    g = body.add_geom()
    g.name = name
    g.group = GROUP_SUPPORT
    g.contype = 1
    g.conaffinity = 1
    g.condim = int(condim)
    g.friction = list(SUPPORT_FRICTION)
    g.rgba = [0.2, 0.8, 0.3, 0.4]
    return g


def floor_extent(scene: SceneAsset | None, planes: list[ReceptaclePlane], floor: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the XY min and max a floor box must cover."""
    pts = [np.asarray(p.polygon, float) for p in planes if p.floor == floor]
    if scene is not None:
        pts += [np.asarray(r.polygon, float) for r in scene.rooms if r.floor == floor]
        if scene.bounds is not None and (floor == 0 or not pts):
            b = np.asarray(scene.bounds, float)
            pts.append(b[:, :2])
    if not pts:
        return np.array([-5.0, -5.0]), np.array([5.0, 5.0])
    allp = np.vstack(pts)
    return allp.min(axis=0) - FLOOR_MARGIN, allp.max(axis=0) + FLOOR_MARGIN


def add_support(spec: mujoco.MjSpec, planes: list[ReceptaclePlane], scene: SceneAsset | None, cfg: PlaceConfig,
                store_root: str | Path | None = None) -> SupportInfo:
    """Add receptacle prisms (or heightfields) and floor boxes to `spec`'s worldbody.

    Parameters
    ----------
    spec : mujoco.MjSpec
        The model being built.
    planes : list of ReceptaclePlane
        Receptacle planes (polygon world XY, height world Z, metres).
    scene : SceneAsset or None
        The scene (its floors; its mesh for heightfield supports).
    cfg : PlaceConfig
        Support settings (thickness, contact dimensions, heightfields).
    store_root : str or Path, optional
        Store root the scene's mesh is relative to (heightfield supports only).
    """
    info = SupportInfo()
    wb = spec.worldbody
    floors = sorted({(f.index, f.height) for f in (scene.floors if scene is not None else [])})
    if not floors:
        floors = [(0, 0.0)]
    for index, height in floors:
        lo, hi = floor_extent(scene, planes, index)
        g = _support_geom(wb, floor_geom_name(index), cfg.support_condim)
        g.type = mujoco.mjtGeom.mjGEOM_BOX
        g.size = [(hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, FLOOR_THICKNESS / 2]
        g.pos = [(hi[0] + lo[0]) / 2, (hi[1] + lo[1]) / 2, height - FLOOR_THICKNESS / 2]
        info.floors[index] = g.name
    mesh_cache = None
    for plane in sorted(planes, key=lambda p: p.id):
        if len(_hull(plane.polygon)) < 3:
            continue
        name = plane_geom_name(plane.id)
        if cfg.support_hfield and scene is not None and scene.mesh and store_root is not None:
            if mesh_cache is None:
                from ..sim.model import load_scene_mesh

                mesh_cache = load_scene_mesh(Path(store_root) / scene.mesh)
            if _add_hfield(spec, plane, mesh_cache, cfg, name):
                info.planes[plane.id] = name
                info.hfields.append(plane.id)
                continue
        rect = rectangle_box(plane.polygon)
        g = _support_geom(wb, name, cfg.support_condim)
        if rect is not None:
            # A rectangle becomes a box: analytic box collisions are much cheaper than mesh (CCD) ones.
            (cx, cy), (hx, hy), yaw = rect
            g.type = mujoco.mjtGeom.mjGEOM_BOX
            g.size = [hx, hy, cfg.support_thickness / 2]
            g.pos = [cx, cy, plane.height - cfg.support_thickness / 2]
            g.quat = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        else:
            m = spec.add_mesh()
            m.name = f"{name}_mesh"
            m.uservert = prism_vertices(plane.polygon, plane.height, cfg.support_thickness).ravel().tolist()
            g.type = mujoco.mjtGeom.mjGEOM_MESH
            g.meshname = m.name
        info.planes[plane.id] = name
    return info


def _add_hfield(spec: mujoco.MjSpec, plane: ReceptaclePlane, mesh: tuple[np.ndarray, np.ndarray, np.ndarray],
                cfg: PlaceConfig, name: str) -> bool:
    """Add a heightfield of the scene surface over a plane when it is not flat; return whether one was added."""
    verts, faces, _ = mesh
    poly = np.asarray(plane.polygon, float)
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    res = cfg.hfield_resolution
    nx = max(int(np.ceil((hi[0] - lo[0]) / res)) + 1, 2)
    ny = max(int(np.ceil((hi[1] - lo[1]) / res)) + 1, 2)
    xs, ys = np.linspace(lo[0], hi[0], nx), np.linspace(lo[1], hi[1], ny)
    gx, gy = np.meshgrid(xs, ys)
    top = plane.height + 0.3
    # Only the triangles near the plane's slab matter: crop before building the ray tracer.
    c = verts[faces].mean(axis=1)
    keep = (c[:, 0] > lo[0] - res) & (c[:, 0] < hi[0] + res) & (c[:, 1] > lo[1] - res) & (c[:, 1] < hi[1] + res) \
        & (c[:, 2] < top) & (c[:, 2] > plane.height - 0.3)
    if not keep.any():
        return False
    origins = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, top)])
    tri, hz = first_hits(verts, faces[keep], origins, axis=2, sign=-1)
    idx = np.nonzero(tri >= 0)[0]
    z = np.full(len(origins), plane.height)
    z[idx] = hz[idx]
    z = np.clip(z, plane.height - 0.15, plane.height + 0.15)
    if float(np.ptp(z[idx])) < cfg.hfield_flatness if len(idx) else True:
        return False
    # MuJoCo normalises elevation data to [0, 1]: anchor the geom at the lowest sample, scale by the range.
    base = float(z.min())
    zrange = max(float(z.max()) - base, 1e-4)
    h = spec.add_hfield()
    h.name = f"{name}_hfield"
    h.nrow, h.ncol = ny, nx  # rows run along +Y, columns along +X
    h.size = [(hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, zrange, cfg.support_thickness]
    h.userdata = ((z - base) / zrange).tolist()
    g = _support_geom(spec.worldbody, name, cfg.support_condim)
    g.type = mujoco.mjtGeom.mjGEOM_HFIELD
    g.hfieldname = h.name
    g.pos = [(hi[0] + lo[0]) / 2, (hi[1] + lo[1]) / 2, base]
    return True
