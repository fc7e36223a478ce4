"""Ground-truth inputs and scoring for the region map, from a generated apartment (duck-typed).

Until perception output is at hand, a default-world apartment gives what the region map needs: one
``records.Instance`` per non-structure instance (its mesh triangles' vertices and centroids), a
NavMap per floor rasterised from the room polygons (minus walls and furniture footprints, eroded
by the agent radius), and per-cell true room types to score a RegionMap against. The apartment is
any object with ``floors`` (index, height), ``rooms`` (id, type, floor, polygon), ``instances``
(id, label, floor, kind) and ``mesh`` (vertices, faces, face_instance), as
``sdovon_mj.world.generate_apartment`` returns.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import ndimage

from sdovon_mj.geometry import points_in_polygon
from sdovon_mj.grid import GridFrame
from sdovon_mj.records import Instance, NavMap, RegionMap

STRUCTURE_KINDS = ("structure",)
WALL_HALF = 0.06  # cells this close to a room edge are wall
BLOCK_BELOW = 0.9  # furniture with points lower than this above the floor blocks walking


def apartment_instances(apt: Any) -> list[Instance]:
    """Return one Instance (label, world points of its triangles) per non-structure instance."""
    mesh = apt.mesh
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces)
    fi = np.asarray(mesh.face_instance)
    out = []
    for inst in apt.instances:
        if inst.kind in STRUCTURE_KINDS:
            continue
        faces = f[fi == inst.id]
        if len(faces) == 0:
            continue
        pts = np.concatenate([v[np.unique(faces)], v[faces].mean(axis=1)])
        centre = pts.mean(axis=0)
        out.append(Instance(id=int(inst.id), label=str(inst.label), points=(pts - centre).astype(np.float32),
                            center=centre, gt_id=int(inst.id)))
    return out


def _grid(apt: Any, floor: int, res: float) -> tuple[np.ndarray, int, int]:
    polys = [np.asarray(r.polygon, dtype=float) for r in apt.rooms if r.floor == floor]
    allp = np.concatenate(polys)
    lo = np.floor(allp.min(axis=0) / res) * res - 2 * res
    hi = np.ceil(allp.max(axis=0) / res) * res + 2 * res
    w, h = int(round((hi[0] - lo[0]) / res)), int(round((hi[1] - lo[1]) / res))
    return lo, h, w


def room_type_grid(apt: Any, floor: int, origin: np.ndarray, shape: tuple[int, int], res: float) -> tuple[np.ndarray, list[str]]:
    """Return (per-cell index into the type list, -1 outside rooms; the type list) for a floor."""
    h, w = shape
    jj, ii = np.meshgrid(np.arange(w), np.arange(h))
    xy = GridFrame(np.asarray(origin, dtype=float), float(res), shape).to_world(np.stack([ii.ravel(), jj.ravel()], 1))
    types = sorted({r.type for r in apt.rooms if r.floor == floor})
    out = np.full(h * w, -1, dtype=np.int16)
    for r in apt.rooms:
        if r.floor != floor:
            continue
        inside = points_in_polygon(r.polygon, xy)
        out[inside] = types.index(r.type)
    return out.reshape(h, w), types


def apartment_navmap(apt: Any, floor: int = 0, res: float = 0.05, agent_radius: float = 0.18) -> NavMap:
    """Return a NavMap of one floor: room interiors minus walls and low furniture, eroded."""
    height = float(next(f.height for f in apt.floors if f.index == floor))
    origin, h, w = _grid(apt, floor, res)
    rooms, _types = room_type_grid(apt, floor, origin, (h, w), res)
    inside = rooms >= 0
    # walls: cells within WALL_HALF of a room boundary (type change or outside)
    edge = np.zeros_like(inside)
    for ax in (0, 1):
        for sh in (1, -1):
            edge |= np.roll(rooms, sh, axis=ax) != rooms
    wall = ndimage.binary_dilation(edge, iterations=max(1, int(round(WALL_HALF / res))))
    free = inside & ~wall
    mesh = apt.mesh
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces)
    fi = np.asarray(mesh.face_instance)
    for inst in apt.instances:
        if inst.kind in STRUCTURE_KINDS or inst.floor != floor:
            continue
        tri = v[f[fi == inst.id]]
        if len(tri) == 0:
            continue
        low = tri[tri[:, :, 2].min(axis=1) < height + BLOCK_BELOW]
        if len(low) == 0:
            continue
        lo_xy, hi_xy = low.reshape(-1, 3)[:, :2].min(axis=0), low.reshape(-1, 3)[:, :2].max(axis=0)
        c0 = np.floor((lo_xy - origin) / res).astype(int)
        c1 = np.ceil((hi_xy - origin) / res).astype(int)
        free[max(c0[1], 0):max(c1[1], 0), max(c0[0], 0):max(c1[0], 0)] = False
    rad = int(np.ceil(agent_radius / res))
    yy, xx = np.mgrid[-rad:rad + 1, -rad:rad + 1]
    disk = (xx * xx + yy * yy) <= rad * rad
    navigable = ndimage.binary_erosion(free, structure=disk, border_value=0)
    return NavMap(floor=floor, height=height, origin=origin, resolution=res, navigable=navigable, free=free)


def region_accuracy(rmap: RegionMap, apt: Any, navmap: NavMap) -> dict[str, tuple[int, int]]:
    """Return {true room type: (navigable cells labelled with it, navigable cells of it)}."""
    truth, types = room_type_grid(apt, navmap.floor, np.asarray(navmap.origin), navmap.navigable.shape,
                                  navmap.resolution)
    lm = np.asarray(rmap.label_map)
    nav = np.asarray(navmap.navigable, dtype=bool)
    out: dict[str, tuple[int, int]] = {}
    for k, t in enumerate(types):
        cells = nav & (truth == k)
        pred_idx = rmap.labels.index(t) if t in rmap.labels else -2
        out[t] = (int(np.sum(cells & (lm == pred_idx))), int(np.sum(cells)))
    return out
