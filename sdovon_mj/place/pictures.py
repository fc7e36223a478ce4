"""Pictures of a variant: a top-down view with status markers and a perspective rendered view."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np

from ..errors import InputError
from ..records import ReceptaclePlane, SceneVariant
from ..sim import GROUP_OBJECT_VISUAL, GROUP_SCENE
from ..sim.camera import pose_cv, project
from ..sim.render import SceneRenderer
from ..store import atomic_write_bytes

_COLORS = {"resting": (40, 200, 40), "dropped": (230, 40, 40)}


def _load(variant: SceneVariant, store_root: str | Path) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Load a variant's composed model with its settled qpos."""
    path = Path(store_root) / variant.mjcf
    if not variant.mjcf or not path.exists():
        raise InputError(path, f"variant {variant.name} has no composed model on disk")
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    if variant.qpos is not None and len(variant.qpos) == model.nq:
        data.qpos[:] = variant.qpos
    mujoco.mj_forward(model, data)
    return model, data


def _write_png(path: str | Path, rgb: np.ndarray) -> Path:
    """Write an RGB image as PNG atomically."""
    import cv2

    ok, buf = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise RuntimeError(f"could not encode {path}")
    atomic_write_bytes(Path(path), buf.tobytes())
    return Path(path)


def _focus(variant: SceneVariant, planes: list[ReceptaclePlane]) -> tuple[np.ndarray, float, int]:
    """Return the XY centre, XY extent and floor of what the picture should show."""
    pts = [p.settled_pos if p.settled_pos is not None else p.spawn_pos for p in variant.placements]
    floor_of = {q.id: q.floor for q in planes}
    floors = [floor_of.get(p.plane_id, 0) for p in variant.placements]
    floor = max(set(floors), key=floors.count) if floors else 0
    polys = [np.asarray(q.polygon, float) for q in planes if q.floor == floor]
    xy = np.vstack([np.asarray(pts, float)[:, :2]] + polys) if pts else (np.vstack(polys) if polys else np.zeros((1, 2)))
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    return (lo + hi) / 2.0, float(max(hi - lo)) + 1.0, floor


def top_down_picture(variant: SceneVariant, planes: list[ReceptaclePlane], store_root: str | Path, out_path: str | Path,
                     size: int = 800, ceiling_z: float | None = None) -> Path:
    """Render the variant from straight above (scene + objects, no ceilings) with a marker per object.

    Parameters
    ----------
    variant : SceneVariant
        The variant (its composed model is rendered).
    planes : list of ReceptaclePlane
        The scene's receptacle planes (choose the floor and the framing).
    store_root : str or Path
        Store root the variant's model is relative to.
    out_path : str or Path
        PNG file to write.
    size : int
        Image side, pixels.
    ceiling_z : float, optional
        The camera stays 5 cm under this height, world metres.
    """
    import cv2

    model, data = _load(variant, store_root)
    centre, extent, floor = _focus(variant, planes)
    heights = [q.height for q in planes if q.floor == floor] or [0.0]
    hfov = 70.0
    z = max(heights) + (extent / 2.0) / math.tan(math.radians(hfov / 2.0)) + 0.2
    if ceiling_z is not None:
        z = min(z, ceiling_z - 0.05)
    T = pose_cv(np.array([centre[0], centre[1], z]), 90.0, -90.0)
    with SceneRenderer(model, data, width=size, height=size, hfov=hfov, groups=(GROUP_SCENE, GROUP_OBJECT_VISUAL)) as r:
        rgb = r.render(T, rgb=True, depth=False).rgb.copy()
        K = r.K
    for p in variant.placements:
        pos = p.settled_pos if p.settled_pos is not None else p.spawn_pos
        uv, d = project(np.asarray(pos, float)[None], K, T)
        if d[0] <= 0:
            continue
        u, v = int(round(uv[0, 0])), int(round(uv[0, 1]))
        col = _COLORS.get(p.status, (240, 160, 20))
        if p.status == "resting":
            cv2.circle(rgb, (u, v), 6, col, 2)
        else:
            cv2.drawMarker(rgb, (u, v), col, cv2.MARKER_TILTED_CROSS, 12, 2)
        cv2.putText(rgb, p.category, (u + 7, v - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.38, col, 1, cv2.LINE_AA)
    n_ok = len(variant.resting)
    cv2.putText(rgb, f"{variant.name}: {n_ok}/{len(variant.placements)} resting", (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55,
                (255, 255, 255), 1, cv2.LINE_AA)
    return _write_png(out_path, rgb)


def view_picture(variant: SceneVariant, planes: list[ReceptaclePlane], store_root: str | Path, out_path: str | Path,
                 width: int = 800, height: int = 600) -> Path:
    """Render a perspective view looking at the receptacle plane with the most resting objects.

    Parameters
    ----------
    variant : SceneVariant
        The variant (its composed model is rendered).
    planes : list of ReceptaclePlane
        The scene's receptacle planes.
    store_root : str or Path
        Store root the variant's model is relative to.
    out_path : str or Path
        PNG file to write.
    width, height : int
        Image size, pixels.
    """
    model, data = _load(variant, store_root)
    counts: dict[int, int] = {}
    for p in variant.resting:
        counts[p.plane_id] = counts.get(p.plane_id, 0) + 1
    by_id = {q.id: q for q in planes}
    pid = max(sorted(counts), key=lambda k: counts[k]) if counts else (planes[0].id if planes else None)
    if pid is None or pid not in by_id:
        target = np.array([0.0, 0.0, 0.5])
    else:
        q = by_id[pid]
        c = np.asarray(q.polygon, float).mean(axis=0)
        target = np.array([c[0], c[1], q.height])
    # Look from 1.3 m away and 0.8 m above the plane, from the side the room centre is on.
    away = np.array([1.0, -1.0]) / math.sqrt(2.0)
    cam = np.array([target[0] + 1.3 * away[0], target[1] + 1.3 * away[1], target[2] + 0.8])
    d = target - cam
    yaw = math.degrees(math.atan2(d[1], d[0]))
    pitch = math.degrees(math.atan2(d[2], math.hypot(d[0], d[1])))
    with SceneRenderer(model, data, width=width, height=height, hfov=70.0, groups=(GROUP_SCENE, GROUP_OBJECT_VISUAL)) as r:
        rgb = r.render(pose_cv(cam, yaw, pitch), rgb=True, depth=False).rgb
    return _write_png(out_path, rgb)
