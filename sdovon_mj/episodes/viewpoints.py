"""Goal view points: navigable cells near a settled object from which the agent camera sees it.

Dense, as Habitat's ObjectNav datasets: a candidate is a navigable cell on a lattice of navmap cells
(``viewpoint_step``; by default the sparsest lattice that puts every cell within ``success_distance`` of
a lattice point: 0.15 m on a 0.05 m map for 0.1 m, `lattice_stride`; navigable cells farther than that from
every navigable lattice cell, in strips between its rows, are candidates too: `covering_cells`) whose centre lies within
``viewpoint_radius`` of the object's XY bounding box, with no cap that thins them. Cheap test first: MuJoCo rays, cast in one vectorised call
per target point from a 3x3x3 grid of points inside the object's box towards every candidate camera; a
candidate whose every ray is blocked by scene geometry is dropped without rendering (a heuristic: an object that
shows only a sliver past an enclosure can be seen with every such ray blocked, so objects inside articulated
pieces skip it and test every cell, ``object_view_points(..., exhaustive=True)``). The kept test is the
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

Short cuts that change no answer (each argued where it is made, checked in tests/test_episodes_speed.py):
the ray pre-test hides geoms whose bounding sphere misses the box of the object and the cameras, and
re-casts only cameras with no clear ray yet; the pixel rays are cast against the object alone first and
only those that meet it against everything; the occluder masks of all cameras of an object come from
one vectorised call; a pitch after the aimed one is not rendered when the object's projected box holds
fewer than ``eta_gt`` pixels there (`VisibilityChecker._pixel_bound`). A bound on the object's angular
size alone culls nothing at the defaults (``eta_gt`` x 160 x 120 = 2 pixels), so there is none.
"""

from __future__ import annotations

import functools
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
from ..sim import GROUP_CEILING, GROUP_OBJECT_VISUAL, GROUP_SCENE
from ..sim.camera import pose_cv
from ..sim.model import geom_segment_ids, object_segment_id, pose_settled, segment_image
from ..sim.render import SceneRenderer, hiding, spheres_meet_box, spheres_off_cone


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

    @functools.cached_property
    def corners(self) -> np.ndarray:
        """Return the 8 corners (8, 3), x slowest and z fastest (lo before hi on each axis); computed once."""
        return np.stack([self.lo, self.hi]).astype(float)[_CORNER_SIDE, _CORNER_AXIS]


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


_CORNER_SIDE = np.array([[sx, sy, sz] for sx in (0, 1) for sy in (0, 1) for sz in (0, 1)])  # 0 = lo, 1 = hi
_CORNER_AXIS = np.tile(np.arange(3), (8, 1))


def _corners(box: ObjectBox) -> np.ndarray:
    """Return the 8 corners (8, 3) of a box, x slowest and z fastest (lo before hi on each axis)."""
    return box.corners


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


def covering_cells(navmap: NavMap, box: ObjectBox, radius: float, stride: int, success_distance: float,
                   fine: np.ndarray | None = None) -> np.ndarray:
    """Return the first-pass view point candidates: the ``stride`` lattice, plus every navigable cell within `radius`
    of the box that lies `success_distance` (m) or farther from each navigable lattice cell.

    The lattice alone misses navigable areas that fall between its rows and columns (a strip one or two cells wide
    beside a counter, a doorway): no lattice cell there is navigable, so none is tested, and an agent standing there
    that sees the object would be off every view point. Those cells are tested themselves.

    Parameters
    ----------
    navmap : NavMap
        Navigation map of the object's floor.
    box : ObjectBox
        The object's world bounding box, metres.
    radius : float
        View radius around the box's XY footprint, metres.
    stride : int
        Lattice stride in cells (`lattice_stride`); 1 returns every navigable cell in the radius.
    success_distance : float
        A cell at least this far (metres) from every navigable lattice cell is a candidate itself.
    fine : (M, 2) int array, optional
        ``candidate_cells(navmap, box, radius, 1)`` when the caller has it already.

    Returns
    -------
    (K, 2) int array of (row, col) cells: the lattice cells first, then the added ones.
    """
    lattice = candidate_cells(navmap, box, radius, stride)
    if stride <= 1:
        return lattice
    fine = candidate_cells(navmap, box, radius, 1) if fine is None else fine
    far = _nearest(navmap.frame.to_world(fine), navmap.frame.to_world(lattice)) >= success_distance - 1e-9
    return np.concatenate([lattice, fine[far]]) if far.any() else lattice


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
        self._always = self._rbound <= 0.0  # planes (infinite extent) are always kept
        self._drawn_body = np.asarray(model.geom_bodyid)[self._drawn].copy()
        # The settled pose does not change while the checker lives: the drawn geoms' centres are read once.
        self._drawn_xpos = np.asarray(data.geom_xpos)[self._drawn].copy()
        # Where the time goes: candidates ray-tested, renders made, seconds in each.
        self.timing: dict[str, float] = {"rays": 0, "rays_s": 0.0, "renders": 0, "render_s": 0.0, "renders_skipped": 0,
                                         "ray_confirmed": 0, "pixel_rays_s": 0.0}
        self._own_cache: dict[int, np.ndarray] = {}
        self._seg_corners: dict[int, np.ndarray | None] = {}
        self._others_cache: dict[int, np.ndarray] = {}  # body -> the drawn geoms not of its object
        # Object pixels a view needs to be seen: ceil(eta_gt * width * height), at least 1.
        self._need = max(int(math.ceil(agent.eta_gt * cfg.vis_width * cfg.vis_height - 1e-9)), 1)

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
        # Every ray runs between a point inside the box and a camera, so it lies in the AABB of the box and
        # the cameras: a geom whose bounding sphere misses that AABB can only be met beyond the camera,
        # where a hit counts as clear anyway. Hiding those geoms leaves every answer as it was (cheaper).
        hidden = self._drawn[~self._near_aabb(np.minimum(cams.min(axis=0), box.lo), np.maximum(cams.max(axis=0), box.hi),
                                              box)]
        with hiding(self.model, hidden):
            todo = np.arange(len(cams))  # cameras with no clear ray yet: only these are cast again
            for g in grid:
                src = box.center + g * half
                c = cams[todo]
                vec = c - src[None]
                length = np.linalg.norm(vec, axis=1)
                near = length < 1e-6
                unit = np.where(near[:, None], np.array([0.0, 0.0, 1.0]), vec / np.maximum(length, 1e-12)[:, None])
                geomid = np.zeros(len(c), dtype=np.int32)
                dist = np.zeros(len(c), dtype=np.float64)
                mujoco.mj_multiRay(self.model, self.data, src, np.ascontiguousarray(unit.ravel()), self._scene_groups, 1,
                                   box.body, geomid, dist, None, len(c), float(length.max()) + 1.0)
                hit_own = (geomid >= 0) & own_geom[np.maximum(geomid, 0)]
                ok = near | (dist < 0) | (dist >= length - 1e-3) | hit_own
                out[todo[ok]] = True
                todo = todo[~ok]
                if len(todo) == 0:
                    break
        self.timing["rays_s"] += time.perf_counter() - t0
        self.timing["rays"] += len(cams)
        return out

    def _near_aabb(self, lo: np.ndarray, hi: np.ndarray, box: ObjectBox) -> np.ndarray:
        """Return a mask over the drawn geoms: those whose bounding sphere meets the box [lo, hi] (planes and the object's own always)."""
        return spheres_meet_box(self._drawn_xpos, self._rbound, lo, hi) | (self._drawn_body == box.body)

    def occluder_candidates(self, camera: np.ndarray, box: ObjectBox) -> np.ndarray:
        """Return a mask over the drawn geoms: those that may cover a pixel of the object seen from `camera`.

        A geom can only put its id on (or hide) a pixel of the object if it meets the cone from the
        camera around the object box's bounding sphere, between the camera and the far side of the box.
        The test uses each geom's bounding sphere (conservative), so hiding the others leaves the
        object's pixel count exactly as a render of everything gives.
        """
        return self.occluder_masks(np.asarray(camera, dtype=float)[None], box)[0]

    def occluder_masks(self, cameras: np.ndarray, box: ObjectBox) -> np.ndarray:
        """Return `occluder_candidates` for many cameras (N, 3) at once: a (N, drawn geoms) bool mask."""
        cams = np.atleast_2d(np.asarray(cameras, dtype=float))
        c = box.center
        R = 0.5 * float(np.linalg.norm(box.hi - box.lo))
        V = c[None] - cams
        D = np.sqrt(np.einsum("ij,ij->i", V, V))
        inside = D <= R + 1e-6  # the camera is inside the object's bounding sphere: draw everything
        Ds = np.where(inside, 1.0, D)
        u = V / Ds[:, None]
        sin_a = np.where(inside, 0.0, R / Ds)
        cos_a = np.sqrt(np.maximum(1.0 - sin_a * sin_a, 0.0))
        p = self._drawn_xpos[None] - cams[:, None]  # (N, G, 3)
        r = (self._rbound + 1e-3)[None]
        off, t = spheres_off_cone(p, r, u[:, None], sin_a[:, None], cos_a[:, None])
        keep = ~off & (t - r <= (D + R)[:, None])
        keep[inside] = True
        keep |= (self._always | (self._drawn_body == box.body))[None]
        return keep

    def ray_pixels(self, camera: np.ndarray, box: ObjectBox, yaw: float, pitch: float, max_rays: int = 64) -> float | None:
        """Confirm visibility without a render: rays through pixel centres of the low-resolution image.

        Casts, from the camera at (yaw, pitch), the rays of a regular 1-in-``s``-by-``s`` subsample (at most
        ``max_rays``) of the pixels inside the object box's projection (`mujoco.mj_multiRay`, the groups the
        render shows). Every ray that meets the object first is a pixel of the object in the render, so
        when at least ``ceil(eta_gt * width * height)`` of them do, the render's fraction reaches ``eta_gt``:
        return the estimated fraction (hits * s^2 / pixels, at least eta_gt). Otherwise (or when the box
        reaches behind the camera) return None and the caller renders. The rays are cast first with only
        the object shown, then only those that meet it with everything shown (the same hits, fewer rays).

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
            pc = (_corners(box) - T[:3, 3]) @ T[:3, :3]
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
            # Pixel rays row by row (rows = vs, columns = us), camera frame, z = 1.
            d_cam = np.empty((len(us) * len(vs), 3))
            d_cam[:, 0].reshape(len(vs), len(us))[:] = ((us - K[0, 2]) / K[0, 0])[None, :]
            d_cam[:, 1].reshape(len(vs), len(us))[:] = ((vs - K[1, 2]) / K[1, 1])[:, None]
            d_cam[:, 2] = 1.0
            d = d_cam @ T[:3, :3].T
            d /= np.sqrt(np.add.reduce(d * d, axis=1, keepdims=True))  # np.linalg.norm's own sum (same bits)
            own = self._own_geom(box)
            cam = np.asarray(camera, dtype=float)
            # Two casts count the same hits as one cast against everything shown: MuJoCo tests every geom on
            # its own and keeps the nearest, so a ray whose first hit is the object also meets the object when
            # only the object is shown. The rays that do are cast again with everything shown (exactly the
            # one-cast answer for them); the others cannot be object pixels, and too few end it early.
            others = self._others_cache.get(box.body)
            if others is None:
                others = self._others_cache[box.body] = self._drawn[~own[self._drawn]]
            with hiding(self.model, others):
                gid = self._cast(cam, d)
            meets = (gid >= 0) & own[np.maximum(gid, 0)]
            if int(np.count_nonzero(meets)) < self._need:
                return None
            gid = self._cast(cam, d[meets])
            hits = int(np.count_nonzero((gid >= 0) & own[np.maximum(gid, 0)]))
            if hits < self._need:
                return None
            self.timing["ray_confirmed"] += 1
            return max(hits * step * step / float(w * h), self.agent.eta_gt)
        finally:
            self.timing["pixel_rays_s"] += time.perf_counter() - t0

    def _cast(self, origin: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        """Return the first geom id (-1: none) of rays (N, 3 unit) from one origin, among the shown scene groups."""
        n = len(dirs)
        geomid = np.zeros(n, dtype=np.int32)
        dist = np.zeros(n, dtype=np.float64)
        if n:
            mujoco.mj_multiRay(self.model, self.data, origin, np.ascontiguousarray(dirs.ravel()), self._scene_groups, 1, -1,
                               geomid, dist, None, n, 1e6)
        return geomid

    def _own_geom(self, box: ObjectBox) -> np.ndarray:
        """Return a mask over all geoms: those of the object's body or its descendants (memoised per body)."""
        hit = self._own_cache.get(box.body)
        if hit is None:
            own = {box.body} | {i for i in range(self.model.nbody) if _descends(self.model, i, box.body)}
            hit = self._own_cache[box.body] = np.isin(np.asarray(self.model.geom_bodyid), sorted(own))
        return hit

    def _in_frame(self, T_cam: np.ndarray, box: ObjectBox) -> bool:
        """Return whether all 8 corners of the box project inside the image of a camera at pose T_cam (world <- camera)."""
        pc = (_corners(box) - T_cam[:3, 3]) @ T_cam[:3, :3]
        if (pc[:, 2] <= 1e-6).any():
            return False
        uv = (pc @ self.renderer.K.T)[:, :2] / pc[:, 2:3]
        return bool(((uv[:, 0] >= 0) & (uv[:, 0] <= self.renderer.width) & (uv[:, 1] >= 0)
                     & (uv[:, 1] <= self.renderer.height)).all())

    def _pixel_bound(self, T_cam: np.ndarray, box: ObjectBox) -> float:
        """Return an upper bound on the object's pixels in the render from pose T_cam (inf: none known).

        Every drawn geom with the object's segmentation id lies in the box of their corners
        (`_segment_corners`); with all 8 corners in front of the camera the object's projection lies in
        the convex hull of their projections, so only pixels whose centre falls in its bounding rectangle,
        widened by 1 pixel on each side (rasterisation snapping), clipped to the image, can show it.
        """
        corners = self._segment_corners(box)
        if corners is None:
            return 0.0
        pc = (corners - T_cam[:3, 3]) @ T_cam[:3, :3]
        if (pc[:, 2] <= 1e-6).any():
            return math.inf
        uv = (pc @ self.renderer.K.T)[:, :2] / pc[:, 2:3]
        w, h = self.renderer.width, self.renderer.height
        u0, u1 = max(0, int(math.floor(uv[:, 0].min())) - 1), min(w - 1, int(math.ceil(uv[:, 0].max())) + 1)
        v0, v1 = max(0, int(math.floor(uv[:, 1].min())) - 1), min(h - 1, int(math.ceil(uv[:, 1].max())) + 1)
        if u0 > u1 or v0 > v1:
            return 0.0
        return float((u1 - u0 + 1) * (v1 - v0 + 1))

    def _segment_corners(self, box: ObjectBox) -> np.ndarray | None:
        """Return the 8 corners of the world box of every drawn geom carrying the object's segmentation id (None: none)."""
        seg_id = object_segment_id(box.object_id)
        if seg_id not in self._seg_corners:
            geoms = self._drawn[self.lut[self._drawn] == seg_id]
            pts = []
            for g in geoms:
                c, half = self.model.geom_aabb[g, :3], self.model.geom_aabb[g, 3:]
                local = c[None, :] + (2 * _CORNER_SIDE - 1) * half[None, :]
                pts.append(local @ self.data.geom_xmat[g].reshape(3, 3).T + self.data.geom_xpos[g])
            if pts:
                allp = np.concatenate(pts)
                self._seg_corners[seg_id] = ObjectBox(box.object_id, box.body, allp.min(axis=0), allp.max(axis=0)).corners
            else:
                self._seg_corners[seg_id] = None
        return self._seg_corners[seg_id]

    def visible_fraction(self, camera: np.ndarray, box: ObjectBox, keep: np.ndarray | None = None,
                         aimed_only: bool = False) -> tuple[float, float, float]:
        """Return (best pixel fraction, yaw, pitch) of the object seen from a camera position.

        ``keep`` is `occluder_candidates` (camera, box), when already computed. The fraction is exact when
        it reaches ``eta_gt``; below it, it is the best of the pitches rendered (a pitch after the first is
        not rendered when `_pixel_bound` proves the object covers fewer pixels than ``eta_gt`` there).
        ``aimed_only``: only the pitch aimed at the box centre, always rendered (no pixel-ray confirmation,
        whose ray casts and the rasteriser can disagree on the pixel or two an object shows through a gap):
        exactly the render the suite's "goal seen" check makes.
        """
        yaw, pitch0 = facing(camera, box.center)
        seg_id = object_segment_id(box.object_id)
        best = (0.0, yaw, pitch0)
        pitches = [float(np.clip(pitch0, -80.0, 80.0))] + ([] if aimed_only else [float(p) for p in self.cfg.pitches])
        # Geoms that cannot touch the object's pixels are neither drawn nor ray-tested (same counts, cheaper).
        hidden = self._drawn[~(self.occluder_candidates(camera, box) if keep is None else keep)]
        with hiding(self.model, hidden):  # neither the visibility renderer nor the rays see them
            quick = None if aimed_only else self.ray_pixels(camera, box, yaw, pitches[0])
            if quick is not None:
                return quick, yaw, pitches[0]
            t0 = time.perf_counter()
            for k, pitch in enumerate(dict.fromkeys(round(p, 6) for p in pitches)):
                T = pose_cv(camera, yaw, pitch)
                if k > 0 and self._pixel_bound(T, box) < self._need:
                    # Below eta_gt here for sure: this pitch can neither make the camera see the object nor
                    # be the best pitch of a camera that does (that one's fraction is >= eta_gt).
                    self.timing["renders_skipped"] += 1
                    continue
                frame = self.renderer.render(T, rgb=False, depth=False, segmentation=True)
                self.timing["renders"] += 1
                seg = segment_image(frame.segmentation, self.lut)
                frac = float(np.count_nonzero(seg == seg_id)) / seg.size
                if frac > best[0]:
                    best = (frac, yaw, pitch)
                if k == 0 and (frac >= self.agent.eta_gt or (frac == 0.0 and self._in_frame(T, box))):
                    # The pitch aimed at the centre sees it; or it shows none of an object whose whole box is
                    # in frame, so the object is hidden from here and no other pitch of this camera shows it.
                    break
            self.timing["render_s"] += time.perf_counter() - t0
        return best


def object_view_points(checker: VisibilityChecker, navmap: NavMap, box: ObjectBox, cfg: EpisodeConfig,
                       agent: AgentConfig = AgentConfig(), exhaustive: bool = False) -> list[ViewPoint]:
    """Return the valid view points of one object on one floor, best visible fraction first.

    Two short cuts can miss an object that shows only a sliver past an enclosure (a shoe in an ajar drawer, seen
    from above, from a few cells right in front of the piece): the ray pre-test (`VisibilityChecker.rays_clear`)
    samples 27 points of the object's box, and the first pass tests only the lattice (the edge ring is refined
    only around cells that saw it); and a pixel or two past a door's gap can be counted by the pixel rays and
    not by the rasteriser. ``exhaustive=True`` (objects inside articulated pieces) renders every navigable cell
    within the radius at the pitch aimed at the object (`VisibilityChecker.visible_fraction` ``aimed_only``),
    the render the suite's "goal seen" check makes.

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
    exhaustive : bool
        Test every navigable cell within the radius (stride 1) and render each at the aimed pitch (no ray
        pre-test, no pixel rays); default: the lattice, the ray pre-test and the edge ring.
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
        clear = np.ones(len(cams), dtype=bool) if exhaustive else checker.rays_clear(cams, box)
        keep = checker.occluder_masks(cams[clear], box)
        for cell, cam, kp in zip(cells[clear], cams[clear], keep):
            frac, yaw, _pitch = checker.visible_fraction(cam, box, kp, aimed_only=exhaustive)
            if frac >= agent.eta_gt:
                seen[(int(cell[0]), int(cell[1]))] = (frac, yaw)

    stride = 1 if exhaustive else lattice_stride(navmap.resolution, cfg.viewpoint_step, cfg.success_distance)
    fine = candidate_cells(navmap, box, cfg.viewpoint_radius, 1) if stride > 1 else None
    test(covering_cells(navmap, box, cfg.viewpoint_radius, stride, cfg.success_distance, fine))
    if seen and stride > 1:
        # Refine the edge of the covered area at the grid resolution: the ring of cells not within the
        # success distance of a view point but next to (8-neighbours of) a cell that is.
        xy = navmap.frame.to_world(fine)
        covered = _nearest(xy, navmap.frame.to_world(np.array(sorted(seen)))) < cfg.success_distance - 1e-9
        ring = ~covered & (_nearest(xy, xy[covered]) <= navmap.resolution * (math.sqrt(2.0) + 1e-6))
        test(fine[ring])
    out = []
    # to_world is elementwise: one call for every seen cell gives each cell's centre as one call per cell did.
    seen_xy = navmap.frame.to_world(np.array(list(seen), dtype=np.int64).reshape(-1, 2))
    for xy, (frac, yaw) in zip(seen_xy, seen.values()):
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
