"""Goal view points: navigable cells near a settled object from which the agent camera sees it.

Dense, as Habitat's ObjectNav datasets: a candidate is a navigable cell on a lattice of navmap cells
(``viewpoint_step``; by default the sparsest lattice that puts every cell within ``success_distance`` of
a lattice point: 0.15 m on a 0.05 m map for 0.1 m, `lattice_stride`) whose centre lies within
``viewpoint_radius`` of the object's XY bounding box, with no cap that thins them. Cheap test first: MuJoCo rays, cast in one vectorised call
per target point from a 3x3x3 grid of points inside the object's box towards every candidate camera; a
candidate whose every ray is blocked by scene geometry is dropped without rendering. The kept test is the
object's pixel fraction in a low-resolution segmentation image (``vis_width`` x ``vis_height``) of the
agent camera (at agent height, yaw facing the object), which must reach ``eta_gt`` at one of a few
pitches. Most candidates are confirmed without a render: rays through a subsample of the pixel centres
of the object's projection at the aimed pitch (`VisibilityChecker.ray_pixels`) that meet the object
first are object pixels of that image, so enough of them prove the fraction (stored as the subsample's
estimate); the rest are rendered (geoms that cannot cover the object culled). Then the edge of the covered area is refined at the navmap
resolution: the ring of navigable cells next to a cell within ``success_distance`` of a view point,
but not themselves within it, is tested too. So every cell that sees the object lies within the success
distance of a stored view point, up to the render resolution and the ray pre-test. View points are
sorted by visible fraction, largest first.
"""

from __future__ import annotations

import math
import time
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


def lattice_stride(resolution: float, step: float, success_distance: float) -> int:
    """Return the view-point lattice stride in cells: ``step`` in cells, or for ``step <= 0`` the largest
    stride whose lattice puts every grid cell within ``success_distance`` of a lattice point.

    A cell lies at most ``floor(s / 2)`` cells from the nearest lattice row and column of an ``s``-cell
    lattice, so the worst cell is ``sqrt(2) * floor(s / 2) * resolution`` away (metres).
    """
    if step > 0:
        return max(1, int(round(step / resolution)))
    s = 1
    while math.sqrt(2.0) * ((s + 1) // 2) * resolution < success_distance:
        s += 1
    return s


def candidate_cells(navmap: NavMap, box: ObjectBox, radius: float, stride: int) -> np.ndarray:
    """Return navigable (row, col) cells on a ``stride``-cell lattice within `radius` (m) of the box's XY footprint."""
    lo, hi = box.lo[:2] - radius, box.hi[:2] + radius
    stride = max(1, int(stride))
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
        # Where the time goes: candidates ray-tested, renders made, seconds in each.
        self.timing: dict[str, float] = {"rays": 0, "rays_s": 0.0, "renders": 0, "render_s": 0.0,
                                         "ray_confirmed": 0, "pixel_rays_s": 0.0}
        self._own_cache: dict[int, np.ndarray] = {}

    def close(self) -> None:
        """Free the renderer."""
        self.renderer.close()

    def rays_clear(self, cameras: np.ndarray, box: ObjectBox) -> np.ndarray:
        """Return, per camera (N, 3), whether a ray between it and a point inside the object is unblocked.

        The rays start at a 3x3x3 grid of points spanning 90 % of the object's box and run towards
        every camera at once (`mujoco.mj_multiRay`, the object's own body excluded); a camera is kept when
        one of them reaches it before any other geometry (or first meets a part of the object itself).
        """
        t0 = time.perf_counter()
        cams = np.atleast_2d(np.asarray(cameras, dtype=float))
        out = np.zeros(len(cams), dtype=bool)
        if len(cams) == 0:
            return out
        own_geom = self._own_geom(box)
        half = 0.45 * (box.hi - box.lo)
        grid = np.array([[x, y, z] for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)], dtype=float)
        geomid = np.zeros(len(cams), dtype=np.int32)
        dist = np.zeros(len(cams), dtype=np.float64)
        for g in grid:
            src = box.center + g * half
            vec = cams - src[None]
            length = np.linalg.norm(vec, axis=1)
            near = length < 1e-6
            unit = np.where(near[:, None], np.array([0.0, 0.0, 1.0]), vec / np.maximum(length, 1e-12)[:, None])
            mujoco.mj_multiRay(self.model, self.data, src, np.ascontiguousarray(unit.ravel()), self._scene_groups, 1,
                               box.body, geomid, dist, None, len(cams), float(length.max()) + 1.0)
            hit_own = (geomid >= 0) & own_geom[np.maximum(geomid, 0)]
            out |= near | (dist < 0) | (dist >= length - 1e-3) | hit_own
            if out.all():
                break
        self.timing["rays_s"] += time.perf_counter() - t0
        self.timing["rays"] += len(cams)
        return out

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

    def ray_pixels(self, camera: np.ndarray, box: ObjectBox, yaw: float, pitch: float, max_rays: int = 64) -> float | None:
        """Confirm visibility without a render: rays through pixel centres of the low-resolution image.

        Casts, from the camera at (yaw, pitch), the rays of a regular 1-in-``s``-by-``s`` subsample (at most
        ``max_rays``) of the pixels inside the object box's projection (`mujoco.mj_multiRay`, the groups the
        render shows). Every ray that meets the object first is a pixel of the object in the render, so
        when at least ``ceil(eta_gt * width * height)`` of them do, the render's fraction reaches ``eta_gt``:
        return the estimated fraction (hits * s^2 / pixels, at least eta_gt). Otherwise (or when the box
        reaches behind the camera) return None and the caller renders.

        Parameters
        ----------
        camera : numpy.ndarray
            (3,) camera position, world metres.
        box : ObjectBox
            The object's world box.
        yaw, pitch : float
            Camera yaw about +Z and pitch, degrees.
        max_rays : int
            Most rays cast (the pixel subsample's size).
        """
        t0 = time.perf_counter()
        try:
            T = pose_cv(camera, yaw, pitch)
            corners = np.array([[x, y, z] for x in (box.lo[0], box.hi[0]) for y in (box.lo[1], box.hi[1])
                                for z in (box.lo[2], box.hi[2])])
            pc = (corners - T[:3, 3]) @ T[:3, :3]
            if (pc[:, 2] <= 1e-3).any():
                return None
            K, w, h = self.renderer.K, self.renderer.width, self.renderer.height
            uv = (pc @ K.T)[:, :2] / pc[:, 2:3]
            u0, u1 = max(0, int(math.floor(uv[:, 0].min()))), min(w - 1, int(math.ceil(uv[:, 0].max())))
            v0, v1 = max(0, int(math.floor(uv[:, 1].min()))), min(h - 1, int(math.ceil(uv[:, 1].max())))
            if u0 > u1 or v0 > v1:
                return None
            npix = (u1 - u0 + 1) * (v1 - v0 + 1)
            step = max(1, int(math.ceil(math.sqrt(npix / float(max_rays)))))
            us = np.arange(u0 + step // 2, u1 + 1, step, dtype=float) + 0.5
            vs = np.arange(v0 + step // 2, v1 + 1, step, dtype=float) + 0.5
            uu, vv = np.meshgrid(us, vs)
            d_cam = np.stack([(uu.ravel() - K[0, 2]) / K[0, 0], (vv.ravel() - K[1, 2]) / K[1, 1], np.ones(uu.size)], 1)
            d = d_cam @ T[:3, :3].T
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            n = len(d)
            geomid = np.zeros(n, dtype=np.int32)
            dist = np.zeros(n, dtype=np.float64)
            mujoco.mj_multiRay(self.model, self.data, np.asarray(camera, dtype=float), np.ascontiguousarray(d.ravel()),
                               self._scene_groups, 1, -1, geomid, dist, None, n, 1e6)
            hits = int(np.count_nonzero((geomid >= 0) & self._own_geom(box)[np.maximum(geomid, 0)]))
            need = int(math.ceil(self.agent.eta_gt * w * h - 1e-9))
            if hits < max(need, 1):
                return None
            self.timing["ray_confirmed"] += 1
            return max(hits * step * step / float(w * h), self.agent.eta_gt)
        finally:
            self.timing["pixel_rays_s"] += time.perf_counter() - t0

    def _own_geom(self, box: ObjectBox) -> np.ndarray:
        """Return a mask over all geoms: those of the object's body or its descendants (memoised per body)."""
        hit = self._own_cache.get(box.body)
        if hit is None:
            own = {box.body} | {i for i in range(self.model.nbody) if _descends(self.model, i, box.body)}
            hit = self._own_cache[box.body] = np.isin(np.asarray(self.model.geom_bodyid), sorted(own))
        return hit

    def _in_frame(self, T_cam: np.ndarray, box: ObjectBox) -> bool:
        """Return whether all 8 corners of the box project inside the image of a camera at pose T_cam (world <- camera)."""
        corners = np.array([[x, y, z] for x in (box.lo[0], box.hi[0]) for y in (box.lo[1], box.hi[1])
                            for z in (box.lo[2], box.hi[2])])
        pc = (corners - T_cam[:3, 3]) @ T_cam[:3, :3]
        if (pc[:, 2] <= 1e-6).any():
            return False
        uv = (pc @ self.renderer.K.T)[:, :2] / pc[:, 2:3]
        return bool(((uv[:, 0] >= 0) & (uv[:, 0] <= self.renderer.width) & (uv[:, 1] >= 0)
                     & (uv[:, 1] <= self.renderer.height)).all())

    def visible_fraction(self, camera: np.ndarray, box: ObjectBox) -> tuple[float, float, float]:
        """Return (best pixel fraction, yaw, pitch) of the object seen from a camera position."""
        yaw, pitch0 = facing(camera, box.center)
        seg_id = object_segment_id(box.object_id)
        best = (0.0, yaw, pitch0)
        pitches = [float(np.clip(pitch0, -80.0, 80.0))] + [float(p) for p in self.cfg.pitches]
        # Geoms that cannot touch the object's pixels are neither drawn nor ray-tested (same counts, cheaper).
        hidden = self._drawn[~self.occluder_candidates(camera, box)]
        groups = self.model.geom_group
        saved = groups[hidden].copy()
        groups[hidden] = GROUP_AGENT  # a group neither the visibility renderer nor the rays see
        try:
            quick = self.ray_pixels(camera, box, yaw, pitches[0])
            if quick is not None:
                return quick, yaw, pitches[0]
            t0 = time.perf_counter()
            for k, pitch in enumerate(dict.fromkeys(round(p, 6) for p in pitches)):
                frame = self.renderer.render(pose_cv(camera, yaw, pitch), rgb=False, depth=False, segmentation=True)
                self.timing["renders"] += 1
                seg = segment_image(frame.segmentation, self.lut)
                frac = float(np.count_nonzero(seg == seg_id)) / seg.size
                if frac > best[0]:
                    best = (frac, yaw, pitch)
                if k == 0 and (frac >= self.agent.eta_gt or (frac == 0.0 and self._in_frame(pose_cv(camera, yaw, pitch), box))):
                    # The pitch aimed at the centre sees it; or it shows none of an object whose whole box is
                    # in frame, so the object is hidden from here and no other pitch of this camera shows it.
                    break
            self.timing["render_s"] += time.perf_counter() - t0
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
        View-point radius, lattice step, success distance and cap (metres; cap 0 = none).
    agent : AgentConfig
        The agent's body (radius, height) and camera (height, HFOV), metres and degrees.
    """
    seen: dict[tuple[int, int], tuple[float, float]] = {}  # cell -> (fraction, yaw) of the cells that see it
    tested: set[tuple[int, int]] = set()

    def test(cells: np.ndarray) -> None:
        """Ray-test then render the untested cells; record those that see the object."""
        cells = np.array([c for c in map(tuple, cells.tolist()) if c not in tested], dtype=np.int64).reshape(-1, 2)
        tested.update(map(tuple, cells.tolist()))
        if len(cells) == 0:
            return
        xy = navmap.frame.to_world(cells)
        cams = np.column_stack([xy, np.full(len(xy), navmap.height + agent.camera_height)])
        clear = checker.rays_clear(cams, box)
        for cell, cam in zip(cells[clear], cams[clear]):
            frac, yaw, _pitch = checker.visible_fraction(cam, box)
            if frac >= agent.eta_gt:
                seen[(int(cell[0]), int(cell[1]))] = (frac, yaw)

    stride = lattice_stride(navmap.resolution, cfg.viewpoint_step, cfg.success_distance)
    test(candidate_cells(navmap, box, cfg.viewpoint_radius, stride))
    if seen and stride > 1:
        # Refine the edge of the covered area at the grid resolution: the ring of cells not within the
        # success distance of a view point but next to (8-neighbours of) a cell that is.
        fine = candidate_cells(navmap, box, cfg.viewpoint_radius, 1)
        xy = navmap.frame.to_world(fine)
        covered = _nearest(xy, navmap.frame.to_world(np.array(sorted(seen)))) < cfg.success_distance - 1e-9
        ring = ~covered & (_nearest(xy, xy[covered]) <= navmap.resolution * (math.sqrt(2.0) + 1e-6))
        test(fine[ring])
    out = []
    for (r, c), (frac, yaw) in seen.items():
        xy = navmap.frame.to_world(np.array([[r, c]]))[0]
        out.append((frac, ViewPoint(position=np.array([xy[0], xy[1], navmap.height]), rotation=yaw_quat(yaw),
                                    visible_fraction=frac)))
    out.sort(key=lambda t: (-t[0], float(t[1].position[0]), float(t[1].position[1])))
    vps = [vp for _f, vp in out]
    return vps[: cfg.max_viewpoints] if cfg.max_viewpoints > 0 else vps


def _nearest(points: np.ndarray, refs: np.ndarray) -> np.ndarray:
    """Return the Euclidean distance (N,) from each point (N, 2) to its nearest reference point (M, 2)."""
    if len(refs) == 0:
        return np.full(len(points), np.inf)
    from scipy.spatial import cKDTree

    return cKDTree(refs).query(points)[0]


def floor_navmap(navmaps: list[NavMap], z: float) -> NavMap | None:
    """Return the navmap of the floor an object at height z stands over (highest floor below it)."""
    below = [m for m in navmaps if m.height <= z + 0.05]
    return max(below, key=lambda m: m.height) if below else None
