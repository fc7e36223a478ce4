"""Receptacle planes inside articulated pieces: which part (joint) closes over each plane.

Perception looks at a scene with its articulated parts open (``observe.open_parts``), so EM finds the shelves
inside a cabinet or fridge and the bottoms of pulled-out drawers. A plane of an articulated piece's instance is
matched, geometrically, to one of the piece's interior surfaces (`SceneAsset.articulated[*].interiors`, given with
every part closed) moved to the perception state: the surface moves with its body (a drawer bottom slides out with
its drawer). A plane at the surface's height whose centre lies in the moved surface polygon gets that surface's
closing joint as `ReceptaclePlane.part`; planes that match none (a dresser's top) keep None.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from ..geometry import points_in_polygon
from ..records import Instance, ReceptaclePlane, SceneAsset

HEIGHT_TOL = 0.04  # m: an EM plane lies this close to the interior surface it is
GROW = 0.05  # m: the moved interior polygon is grown this much for the centre test (EM hulls are inexact)


def interior_polygons(scene: SceneAsset, store_root: str | Path, open_fraction: float) -> list[tuple[int, float, np.ndarray, str | None]]:
    """Return (instance id, height m, world XY polygon, closing joint) of every interior surface at the open state."""
    import mujoco

    from ..sim.articulation import set_parts

    if not scene.articulated:
        return []
    model = mujoco.MjModel.from_xml_path(str(Path(store_root) / scene.mjcf))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    closed = {b: (data.xpos[b].copy(), data.xmat[b].reshape(3, 3).copy()) for b in range(model.nbody)}
    set_parts(model, data, open_fraction)
    out = []
    for fx in scene.articulated:
        for s in fx.interiors:
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, s.body)
            pts = np.column_stack([s.polygon, np.full(len(s.polygon), s.height)])
            if b >= 0:
                p0, R0 = closed[b]
                p1, R1 = data.xpos[b], data.xmat[b].reshape(3, 3)
                pts = (pts - p0) @ R0 @ R1.T + p1  # closed world -> body -> open world
            out.append((fx.instance_id, float(pts[:, 2].mean()), pts[:, :2], s.joint))
    return out


def _grown(poly: np.ndarray, d: float) -> np.ndarray:
    """Return a convex polygon pushed out from its centroid by `d` (m)."""
    c = poly.mean(axis=0)
    v = poly - c
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return c + v * (1.0 + d / np.maximum(n, 1e-9))


def assign_parts(planes: list[ReceptaclePlane], scene: SceneAsset, store_root: str | Path,
                 open_fraction: float, instances: list[Instance] | None = None) -> list[ReceptaclePlane]:
    """Return the planes with `part` set for those inside an articulated piece (a copy; others unchanged).

    Parameters
    ----------
    planes : list of ReceptaclePlane
        Detected planes (world frame), found with the parts `open_fraction` open.
    scene : SceneAsset
        The converted scene (its `articulated` pieces and MJCF).
    store_root : str or Path
        Folder the scene's paths are relative to.
    open_fraction : float
        Fraction of every part's range it was open at during perception.
    instances : list of Instance, optional
        The fused instances the planes' `instance_id` refer to: where one knows its ground-truth scene instance
        (`gt_id`, the ground-truth detector), a plane matches only the interiors of that piece; else geometry alone.
    """
    interiors = interior_polygons(scene, store_root, open_fraction)
    if not interiors:
        return planes
    gt = {int(i.id): int(i.gt_id) for i in (instances or [])}
    out = []
    for pl in planes:
        best, part = None, None
        centre = np.asarray(pl.polygon, float).mean(axis=0)
        known = gt.get(int(pl.instance_id), -1)
        for iid, h, poly, joint in interiors:
            if (known >= 0 and iid != known) or abs(pl.height - h) > HEIGHT_TOL:
                continue
            if points_in_polygon(_grown(poly, GROW), centre[None])[0]:
                dh = abs(pl.height - h)
                if best is None or dh < best:
                    best, part = dh, joint
        out.append(replace(pl, part=part) if part is not None else pl)
    return out


__all__ = ["assign_parts", "interior_polygons"]
