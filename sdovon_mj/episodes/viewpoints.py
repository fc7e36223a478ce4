"""Goal view points: navigable cells near a settled object from which the agent camera sees it.

A candidate is a navigable cell (on a ``viewpoint_step`` lattice) whose centre lies within
``viewpoint_radius`` of the object's XY bounding box. Cheap test first: MuJoCo rays from the camera
to the object's centre and box corners; a candidate whose every ray is blocked by scene geometry
is dropped without rendering. The kept test is the segmentation render: the object's pixel
fraction must reach ``eta_gt`` at one of a few pitches (camera at agent height, yaw facing the
object). View points are sorted by visible fraction, largest first, and capped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import mujoco

from ..config import AgentConfig, EpisodeConfig
from ..errors import InputError
from ..geometry import yaw_quat
from ..records import NavMap, SceneVariant, ViewPoint
from ..sim import GROUP_AGENT, GROUP_CEILING, GROUP_OBJECT_VISUAL, GROUP_SCENE
from ..sim.camera import pose_cv
from ..sim.model import geom_segment_ids, object_segment_id, pose_settled, segment_image
from ..sim.render import SceneRenderer


@dataclass
class ObjectBox:
    """World axis-aligned box and centre of a placed object body."""

    object_id: str
    body: int
    lo: np.ndarray
    hi: np.ndarray

    @property
    def center(self) -> np.ndarray:
        """Return the box centre (3,)."""
        return (self.lo + self.hi) / 2.0


def load_variant_model(variant: SceneVariant, store_root: str | Path) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Compile a variant's composed MJCF and set its settled qpos."""
    path = Path(store_root) / variant.mjcf
    if not variant.mjcf or not path.exists():
        raise InputError(path, f"variant {variant.name}: composed MJCF not found")
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as e:
        raise InputError(path, f"MJCF does not compile: {e}") from None
    data = mujoco.MjData(model)
    pose_settled(model, data, variant.qpos, f"{path} (variant {variant.name})")
    return model, data


def object_box(model: mujoco.MjModel, data: mujoco.MjData, object_id: str,
               groups: tuple[int, ...] = (GROUP_OBJECT_VISUAL,)) -> ObjectBox | None:
    """Return the world AABB of a body's visual geoms (None when the body is absent)."""
    b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, object_id)
    if b < 0:
        return None
    bodies = {b} | {i for i in range(model.nbody) if _descends(model, i, b)}
    corners = []
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    for g in range(model.ngeom):
        if int(model.geom_bodyid[g]) not in bodies:
            continue
        if groups and int(model.geom_group[g]) not in groups:
            continue
        c, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        local = c[None, :] + signs * half[None, :]
        R = data.geom_xmat[g].reshape(3, 3)
        corners.append(local @ R.T + data.geom_xpos[g])
    if not corners:
        return None
    pts = np.concatenate(corners)
    return ObjectBox(object_id, b, pts.min(axis=0), pts.max(axis=0))


def _descends(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    """Return whether `body` is a strict descendant of `ancestor`."""
    while body > 0:
        body = int(model.body_parentid[body])
        if body == ancestor:
            return True
    return False


def candidate_cells(navmap: NavMap, box: ObjectBox, radius: float, step: float) -> np.ndarray:
    """Return navigable (row, col) cells on a `step` lattice within `radius` of the box's XY footprint."""
    lo, hi = box.lo[:2] - radius, box.hi[:2] + radius
    stride = max(1, int(round(step / navmap.resolution)))
    h, w = navmap.navigable.shape
    rc_lo = navmap.frame.to_cell(lo[None])[0]
    rc_hi = navmap.frame.to_cell(hi[None])[0]
    # Anchor the lattice to the grid (not to the box), so nearby objects share cells.
    r0 = max(0, int(math.ceil(rc_lo[0] / stride)) * stride)
    c0 = max(0, int(math.ceil(rc_lo[1] / stride)) * stride)
    rows = np.arange(r0, min(h - 1, rc_hi[0]) + 1, stride)
    cols = np.arange(c0, min(w - 1, rc_hi[1]) + 1, stride)
    if len(rows) == 0 or len(cols) == 0:
        return np.zeros((0, 2), dtype=int)
    rr, cc = np.meshgrid(rows, cols, indexing="ij")
    cells = np.stack([rr.ravel(), cc.ravel()], axis=1)
    cells = cells[navmap.navigable[cells[:, 0], cells[:, 1]]]
    xy = navmap.frame.to_world(cells)
    dx = np.maximum(np.maximum(box.lo[0] - xy[:, 0], 0.0), xy[:, 0] - box.hi[0])
    dy = np.maximum(np.maximum(box.lo[1] - xy[:, 1], 0.0), xy[:, 1] - box.hi[1])
    return cells[np.hypot(dx, dy) <= radius]


def facing(camera: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """Return (yaw, pitch) in degrees pointing a camera at a target."""
    d = np.asarray(target, float) - np.asarray(camera, float)
    yaw = math.degrees(math.atan2(d[1], d[0]))
    pitch = math.degrees(math.atan2(d[2], math.hypot(d[0], d[1])))
    return yaw, pitch


class VisibilityChecker:
    """Renders segmentation from agent camera poses and measures an object's pixel fraction."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, cfg: EpisodeConfig, agent: AgentConfig = AgentConfig()) -> None:
        self.model, self.data, self.cfg, self.agent = model, data, cfg, agent
        self.renderer = SceneRenderer(model, data, width=cfg.vis_width, height=cfg.vis_height, hfov=agent.hfov,
                                      groups=(GROUP_SCENE, GROUP_CEILING, GROUP_OBJECT_VISUAL))
        self.lut = geom_segment_ids(model)
        self._scene_groups = np.zeros(6, dtype=np.uint8)
        for g in (GROUP_SCENE, GROUP_CEILING, GROUP_OBJECT_VISUAL):
            self._scene_groups[g] = 1
        # Geoms the segmentation render draws (candidates for culling) and their bounding radii.
        self._drawn = np.nonzero(np.isin(model.geom_group, (GROUP_SCENE, GROUP_CEILING, GROUP_OBJECT_VISUAL)))[0]
        self._rbound = np.asarray(model.geom_rbound)[self._drawn].copy()

    def close(self) -> None:
        """Free the renderer."""
        self.renderer.close()

    def rays_clear(self, camera: np.ndarray, box: ObjectBox) -> bool:
        """Return whether any ray from the camera to the box centre or corners reaches the object first."""
        lo, hi = box.lo, box.hi
        targets = [box.center] + [np.array([x, y, z]) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        geomid = np.zeros(1, dtype=np.int32)
        for t in targets:
            t = box.center + 0.9 * (np.asarray(t) - box.center)  # just inside the box
            vec = t - camera
            dist = float(np.linalg.norm(vec))
            if dist < 1e-6:
                return True
            d = mujoco.mj_ray(self.model, self.data, camera, vec / dist, self._scene_groups, 1, -1, geomid)
            if d < 0 or d >= dist - 1e-3:
                return True
            hit_body = int(self.model.geom_bodyid[geomid[0]])
            if hit_body == box.body or _descends(self.model, hit_body, box.body):
                return True
        return False

    def occluder_candidates(self, camera: np.ndarray, box: ObjectBox) -> np.ndarray:
        """Return a mask over the drawn geoms: those that may cover a pixel of the object seen from `camera`.

        A geom can only put its id on (or hide) a pixel of the object if it meets the cone from the
        camera around the object box's bounding sphere, between the camera and the far side of the box.
        The test uses each geom's bounding sphere (conservative), so hiding the others leaves the
        object's pixel count exactly as a render of everything gives.
        """
        c = box.center
        R = 0.5 * float(np.linalg.norm(box.hi - box.lo))
        D = float(np.linalg.norm(c - camera))
        keep = np.ones(len(self._drawn), dtype=bool)
        if D <= R + 1e-6:
            return keep  # the camera is inside the object's bounding sphere: draw everything
        u = (c - camera) / D
        sin_a = R / D
        cos_a = math.sqrt(max(1.0 - sin_a * sin_a, 0.0))
        p = self.data.geom_xpos[self._drawn] - camera
        t = p @ u
        q = np.sqrt(np.maximum(np.einsum("ij,ij->i", p, p) - t * t, 0.0))
        r = self._rbound + 1e-3
        keep = (t + r >= 0.0) & (t - r <= D + R) & (q * cos_a - t * sin_a <= r)
        keep |= self._rbound <= 0.0  # planes (infinite extent)
        own = np.asarray(self.model.geom_bodyid)[self._drawn]
        keep |= own == box.body
        return keep

    def visible_fraction(self, camera: np.ndarray, box: ObjectBox) -> tuple[float, float, float]:
        """Return (best pixel fraction, yaw, pitch) of the object seen from a camera position."""
        yaw, pitch0 = facing(camera, box.center)
        seg_id = object_segment_id(box.object_id)
        best = (0.0, yaw, pitch0)
        pitches = [float(np.clip(pitch0, -80.0, 80.0))] + [float(p) for p in self.cfg.pitches]
        # Geoms that cannot touch the object's pixels are not drawn (same counts, cheaper renders).
        hidden = self._drawn[~self.occluder_candidates(camera, box)]
        groups = self.model.geom_group
        saved = groups[hidden].copy()
        groups[hidden] = GROUP_AGENT  # a group the visibility renderer does not show
        try:
            for k, pitch in enumerate(dict.fromkeys(round(p, 6) for p in pitches)):
                frame = self.renderer.render(pose_cv(camera, yaw, pitch), rgb=False, depth=False, segmentation=True)
                seg = segment_image(frame.segmentation, self.lut)
                frac = float(np.count_nonzero(seg == seg_id)) / seg.size
                if frac > best[0]:
                    best = (frac, yaw, pitch)
                if frac >= self.agent.eta_gt and k == 0:
                    break  # the pitch aimed at the centre already sees it
        finally:
            groups[hidden] = saved
        return best


def object_view_points(checker: VisibilityChecker, navmap: NavMap, box: ObjectBox, cfg: EpisodeConfig,
                       agent: AgentConfig = AgentConfig()) -> list[ViewPoint]:
    """Return the valid view points of one object on one floor, best visible fraction first.

    Parameters
    ----------
    checker : VisibilityChecker
        Ray and render checks on the variant's model.
    navmap : NavMap
        Navigation map of the object's floor.
    box : ObjectBox
        The object's world bounding box, metres.
    cfg : EpisodeConfig
        View-point radius, lattice step and cap (metres).
    agent : AgentConfig
        The agent's body (radius, height) and camera (height, HFOV), metres and degrees.
    """
    cells = candidate_cells(navmap, box, cfg.viewpoint_radius, cfg.viewpoint_step)
    out: list[tuple[float, ViewPoint]] = []
    for xy in navmap.frame.to_world(cells):
        cam = np.array([xy[0], xy[1], navmap.height + agent.camera_height])
        if not checker.rays_clear(cam, box):
            continue
        frac, yaw, _pitch = checker.visible_fraction(cam, box)
        if frac >= agent.eta_gt:
            vp = ViewPoint(position=np.array([xy[0], xy[1], navmap.height]), rotation=yaw_quat(yaw), visible_fraction=frac)
            out.append((frac, vp))
    out.sort(key=lambda t: (-t[0], float(t[1].position[0]), float(t[1].position[1])))
    return [vp for _f, vp in out[: cfg.max_viewpoints]]


def floor_navmap(navmaps: list[NavMap], z: float) -> NavMap | None:
    """Return the navmap of the floor an object at height z stands over (highest floor below it)."""
    below = [m for m in navmaps if m.height <= z + 0.05]
    return max(below, key=lambda m: m.height) if below else None
