"""Targeted views: cameras chosen to show the parts of given surfaces that no view has shown yet.

Coverage viewpoints (section 3.1) are sampled for area coverage, not for what they show of each surface:
a bookshelf's side panels hide its back corners from oblique viewpoints, a wall shelf above the agent is
seen edge-on. A ``ViewTarget`` names a horizontal surface to look at (an XY rectangle at a height, plus the
cells of it already seen); ``plan_target_views`` tries cameras on navigable cells around it at every
camera height of the observe config, each aimed at the rectangle's centre, renders their depth at low
resolution, and keeps greedily the few that add the most unseen surface cells. Geometry only (depth):
the choice does not depend on any detector. ``render_poses`` renders the chosen cameras as Observations.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Iterator

import numpy as np

from ..config import AgentConfig, ConfigError, ObserveConfig
from ..records import NavMap, Observation
from ..sim.camera import backproject, pose_cv
from ..sim.render import SceneRenderer, clip_depth, hiding, spheres_meet_box
from .render_views import observation_at, segment_lut

SEEN_TOL = 0.015  # m: a depth point within this of the target height lies on the target surface


@dataclasses.dataclass(frozen=True)
class ViewTarget:
    """A horizontal surface to be seen: XY rectangle [lo, hi] at `height` on `floor`, and the cells already seen."""

    lo: np.ndarray  # (2,) world XY
    hi: np.ndarray  # (2,)
    height: float
    floor: int
    seen_points: np.ndarray | None = None  # (N, 3) world points already observed on the surface


def _cells(target: ViewTarget, cell: float) -> tuple[int, int]:
    """Return the grid shape (nx, ny) of a target rectangle at `cell` size."""
    ext = np.maximum(np.asarray(target.hi, float) - np.asarray(target.lo, float), cell)
    return int(math.ceil(ext[0] / cell)), int(math.ceil(ext[1] / cell))


def surface_cells(target: ViewTarget, points: np.ndarray, cell: float) -> np.ndarray:
    """Return the flat indices of the target's grid cells that world points on its surface fall in."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    p = p[np.abs(p[:, 2] - target.height) < SEEN_TOL]
    nx, ny = _cells(target, cell)
    i = np.floor((p[:, 0] - target.lo[0]) / cell).astype(np.int64)
    j = np.floor((p[:, 1] - target.lo[1]) / cell).astype(np.int64)
    ok = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
    return np.unique(i[ok] * ny + j[ok])


def candidate_positions(navmap: NavMap, target: ViewTarget, cfg: ObserveConfig) -> np.ndarray:
    """Return navigable XY positions (N, 2) within the targeted distance range of the rectangle, evenly thinned."""
    rows, cols = np.nonzero(navmap.navigable)
    if len(rows) == 0:
        return np.zeros((0, 2))
    xy = navmap.frame.to_world(np.stack([rows, cols], axis=1))
    lo, hi = np.asarray(target.lo, float), np.asarray(target.hi, float)
    d = np.linalg.norm(np.maximum(np.maximum(lo - xy, xy - hi), 0.0), axis=1)
    if len(cfg.targeted_distance) != 2:
        raise ConfigError(f"observe.targeted_distance must be (min, max) in metres, got {cfg.targeted_distance!r}")
    dmin, dmax = (float(x) for x in cfg.targeted_distance)
    keep = (d >= dmin) & (d <= dmax)
    xy = xy[keep]
    if len(xy) == 0:
        return xy
    # thin to a lattice of targeted_spacing (first cell per lattice square, in row-major order)
    key = np.floor(xy / float(cfg.targeted_spacing)).astype(np.int64)
    _u, first = np.unique(key, axis=0, return_index=True)
    xy = xy[np.sort(first)]
    cap = int(cfg.targeted_candidates)
    if len(xy) > cap:
        xy = xy[np.linspace(0, len(xy) - 1, cap).round().astype(int)]
    return xy


def aim(position: np.ndarray, look_at: np.ndarray, max_down: float = 80.0) -> np.ndarray:
    """Return T_cam of a camera at `position` aimed at `look_at` (pitch clamped to [-max_down, 30] deg)."""
    d = np.asarray(look_at, float) - np.asarray(position, float)
    yaw = math.degrees(math.atan2(d[1], d[0]))
    pitch = math.degrees(math.atan2(d[2], max(math.hypot(d[0], d[1]), 1e-6)))
    return pose_cv(position, yaw, float(np.clip(pitch, -max_down, 30.0)))


def camera_heights(cfg: ObserveConfig, agent: AgentConfig = AgentConfig()) -> list[float]:
    """Return the camera heights above the floor the observe stage renders at (agent height first)."""
    return [float(agent.camera_height)] + [float(h) for h in cfg.camera_heights]


def plan_target_views(renderer: SceneRenderer, navmaps: list[NavMap], targets: list[ViewTarget],
                      cfg: ObserveConfig, agent: AgentConfig = AgentConfig()) -> list[np.ndarray]:
    """Return camera poses T_cam (world <- OpenCV) that show the most unseen cells of each target, in target order.

    Parameters
    ----------
    renderer : SceneRenderer
        Renderer of the scene (its intrinsics K).
    navmaps : list of NavMap
        Navigation maps, one per floor (candidate camera positions come from their navigable cells).
    targets : list of ViewTarget
        Receptacle targets with the points seen so far.
    cfg : ObserveConfig
        Targeted-view cell size and views per target.
    agent : AgentConfig
        The agent's body (radius, height) and camera (height, HFOV), metres and degrees.
    """
    by_floor = {nm.floor: nm for nm in navmaps}
    cell, per_target = float(cfg.targeted_cell), int(cfg.targeted_views)
    poses: list[np.ndarray] = []
    K = renderer.K
    centres = np.asarray(renderer.data.geom_xpos).copy()  # the geoms' bounding spheres (the scene does not move)
    radii = np.asarray(renderer.model.geom_rbound).copy()
    for t in targets:
        nm = by_floor.get(int(t.floor))
        if nm is None or per_target <= 0:
            continue
        nx, ny = _cells(t, cell)
        seen = np.zeros(nx * ny, dtype=bool)
        if t.seen_points is not None and len(t.seen_points):
            seen[surface_cells(t, t.seen_points, cell)] = True
        centre = np.array([(t.lo[0] + t.hi[0]) / 2.0, (t.lo[1] + t.hi[1]) / 2.0, t.height])
        # What `surface_cells` counts lies in this box (the grid's cells, SEEN_TOL about the height); a pixel
        # counts when its ray's first hit is there, and that ray runs inside the box of the camera and it. A geom
        # whose bounding sphere misses that box can be met only beyond, so hiding it leaves the cells as a render
        # of everything gives them (the nearest fragment's depth is the same), and the render is cheaper.
        cells_lo = np.array([t.lo[0], t.lo[1], t.height - SEEN_TOL]) - 1e-6
        cells_hi = np.array([t.lo[0] + nx * cell, t.lo[1] + ny * cell, t.height + SEEN_TOL]) + 1e-6
        cands: list[tuple[np.ndarray, np.ndarray]] = []
        for xy in candidate_positions(nm, t, cfg):
            for h in camera_heights(cfg, agent):
                pos = np.array([xy[0], xy[1], nm.height + h])
                if pos[2] <= t.height + 0.05:
                    continue  # a camera at or below a surface cannot see its top
                T = aim(pos, centre)
                near = spheres_meet_box(centres, radii, np.minimum(cells_lo, pos), np.maximum(cells_hi, pos))
                far = np.nonzero(~near)[0]
                with hiding(renderer.model, far):
                    fr = renderer.render(T, rgb=False, depth=True, segmentation=False)
                dep = clip_depth(fr.depth, cfg.depth_min, cfg.depth_max)
                cands.append((T, surface_cells(t, backproject(dep, K, T), cell)))
        for _k in range(per_target):
            gains = [int((~seen[c]).sum()) for _T, c in cands]
            if not gains:
                break
            best = int(np.argmax(gains))  # first maximum: deterministic
            if gains[best] < max(1, int(cfg.targeted_min_gain * nx * ny)):
                break
            T, c = cands.pop(best)
            seen[c] = True
            poses.append(T)
    return poses


def render_poses(renderer: SceneRenderer, poses: list[np.ndarray], cfg: ObserveConfig,
                 start_view_id: int = 0) -> Iterator[Observation]:
    """Yield one Observation per camera pose (RGB, clipped depth, instance segmentation), viewpoint -1."""
    lut = segment_lut(renderer.model)
    for k, T in enumerate(poses):
        fwd = T[:3, 2]
        yield observation_at(renderer, np.asarray(T, float), cfg, lut, int(start_view_id) + k, -1,
                             math.degrees(math.atan2(fwd[1], fwd[0])), math.degrees(math.asin(float(np.clip(fwd[2], -1.0, 1.0)))))
