"""Frontier-based exploration: an occupancy map built from depth, frontiers, a scan at each frontier.

The map is the agent's own (`agent_frame`: a square around where it starts) and holds only what it
saw: depth pixels back-projected to the world; hits between `obstacle_min` above the floor and
the agent height (+ margin) mark occupied cells; rays carve free cells from the camera to each hit
in 2D. Planning uses free cells away from occupied ones by the agent radius; unknown is not
traversable. Exploration (`Explorer`) is a policy over dm_env-style time steps whose observations include
`position`, `heading`, `pitch`, `depth` (and `category` to keep the category image with the frames).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Generator

import numpy as np
from scipy import ndimage

from .. import native
from ..actions import TURN_LEFT
from ..config import AgentConfig
from ..records import Observation
from ..sim.camera import backproject, pose_cv
from ..grid import GridFrame, dilate, nearest_true, true_box
from ..gridgraph import node_distances

UNKNOWN, FREE, OCCUPIED = 0, 1, 2


@dataclass
class OccupancyMap:
    """Occupancy grid from depth: UNKNOWN / FREE / OCCUPIED per cell."""

    frame: GridFrame
    floor_z: float = 0.0
    agent: AgentConfig = AgentConfig()  # body: obstacles up to its height (+ margin), planning margin its radius
    obstacle_min: float = 0.1
    state: np.ndarray = field(default=None)  # type: ignore[assignment]
    blocked: np.ndarray | None = None
    stop_reason: str = ""  # why exploration ended (set by `explore`)
    targets: list = field(default_factory=list)  # frontier targets driven to, in order (set by `explore`)

    def __post_init__(self) -> None:
        if self.state is None:
            self.state = np.zeros(self.frame.shape, dtype=np.int8)

    def integrate(self, depth: np.ndarray, K: np.ndarray, T_cam: np.ndarray, depth_max: float, stride: int = 2) -> None:
        """Add one depth frame seen from T_cam.

        Parameters
        ----------
        depth : ndarray (H, W) or (H, W, 1)
            Depth in metres.
        K : ndarray (3, 3)
            The camera intrinsics.
        T_cam : ndarray (4, 4)
            World <- OpenCV camera.
        depth_max : float
            The sensor's range (metres): pixels at it saw nothing, the ray up to it is free.
        stride : int
            Every `stride`-th pixel of each row and column is used.
        """
        d = np.asarray(depth, dtype=np.float32)
        if d.ndim == 3:
            d = d[..., 0]
        d = d[::stride, ::stride]
        Ks = K.copy()
        Ks[0, 0] /= stride
        Ks[1, 1] /= stride
        Ks[0, 2] /= stride
        Ks[1, 2] /= stride
        far = d >= depth_max - 1e-3
        pts = backproject(np.where(far, depth_max, d), Ks, T_cam, depth_min=0.01, depth_max=depth_max + 1.0)
        farv = far[np.nonzero((np.where(far, depth_max, d) > 0.01))]
        cam = T_cam[:3, 3]
        z = pts[:, 2] - self.floor_z
        hit_obstacle = (~farv) & (z > self.obstacle_min) & (z < self.agent.height + 0.1)
        # carve free space along each ray (2D), stopping short of the hit cell
        res = self.frame.resolution
        vec = pts[:, :2] - cam[None, :2]
        length = np.linalg.norm(vec, axis=1)
        n = int(np.ceil(length.max() / res)) if len(length) else 0
        if n > 0:
            t = np.arange(n) * res
            unit = vec / np.maximum(length[:, None], 1e-9)
            # Only the valid samples are computed (ray i, step j: t[j] < length[i] - res, the first `count[i]` steps
            # since t ascends), each as cam + unit * t like the full (rays, n, 2) array did: the same float
            # operations, so the same cells, at a fraction of the memory traffic.
            count = np.searchsorted(t, length - res, side="left")
            ox, oy = self.frame.origin[0], self.frame.origin[1]  # the cells as `GridFrame.to_cell` computes them
            lib = native.library()
            if lib is not None and self.state.flags.c_contiguous and self.state.dtype == np.int8:
                # the same samples, cells and marks compiled (native/kernels.c `sdv_carve`), without the arrays
                ux, uy = (np.ascontiguousarray(unit[:, a], dtype=np.float64) for a in (0, 1))
                count, t = np.ascontiguousarray(count, dtype=np.int64), np.ascontiguousarray(t, dtype=np.float64)
                h, w = self.frame.shape
                lib.sdv_carve(self.state.ctypes.data, h, w, ux.ctypes.data, uy.ctypes.data, count.ctypes.data,
                              len(count), t.ctypes.data, float(cam[0]), float(cam[1]), float(ox), float(oy), float(res))
            else:
                i = np.repeat(np.arange(len(count)), count)
                j = np.arange(len(i)) - np.repeat(np.cumsum(count) - count, count)
                tj = t[j]
                ux, uy = np.ascontiguousarray(unit[:, 0])[i], np.ascontiguousarray(unit[:, 1])[i]
                self._mark_free(np.floor((cam[1] + uy * tj - oy) / res).astype(np.int64),
                                np.floor((cam[0] + ux * tj - ox) / res).astype(np.int64))
        floor_hits = (~farv) & (np.abs(z) <= self.obstacle_min)
        fc = self.frame.to_cell(pts[floor_hits, :2])
        self._mark_free(fc[:, 0], fc[:, 1])
        oc = self.frame.to_cell(pts[hit_obstacle, :2])
        oc = oc[self.frame.inside(oc)]
        self.state[oc[:, 0], oc[:, 1]] = OCCUPIED

    def _mark_free(self, rows: np.ndarray, cols: np.ndarray) -> None:
        """Mark cells (rows, cols: (N,) each) FREE unless OCCUPIED; cells off the grid are skipped, repeats allowed.

        Every cell's state is read before any is written, as the whole-grid form
        (``state[mask & (state != OCCUPIED)] = FREE``) did; the result is the same.
        """
        h, w = self.frame.shape
        ok = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        seen = np.zeros(h * w, dtype=bool)
        seen[rows[ok] * w + cols[ok]] = True  # each cell once (a ray's samples repeat cells)
        rows, cols = np.divmod(np.flatnonzero(seen), w)
        keep = self.state[rows, cols] != OCCUPIED
        self.state[rows[keep], cols[keep]] = FREE

    def mark_free_disc(self, xy: np.ndarray, radius: float) -> None:
        """Mark the agent's own footprint free (it stands there)."""
        rc = self.frame.to_cell(np.asarray(xy, float)[None, :2])[0]
        r = int(math.ceil(radius / self.frame.resolution))
        rr, cc = np.mgrid[-r:r + 1, -r:r + 1]
        inside = rr ** 2 + cc ** 2 <= r * r
        rows, cols = rc[0] + rr[inside], rc[1] + cc[inside]
        ok = (rows >= 0) & (rows < self.frame.shape[0]) & (cols >= 0) & (cols < self.frame.shape[1])
        sel = self.state[rows[ok], cols[ok]] != OCCUPIED
        self.state[rows[ok][sel], cols[ok][sel]] = FREE

    def mark_blocked(self, cells: np.ndarray) -> None:
        """Record cells where the world refused the agent's base (a forward move that did not move)."""
        if self.blocked is None:
            self.blocked = np.zeros(self.frame.shape, dtype=bool)
        c = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
        self.blocked[c[:, 0], c[:, 1]] = True

    def traversable(self) -> np.ndarray:
        """Return cells the agent's base may plan through: free, at least a radius from obstacles, not refused."""
        # Computed in a window: the free cells' bounding box widened by the radius (+ 2 cells). An occupied cell
        # within the radius of a free cell lies in it, and a window cell's distance to the window's nearest occupied
        # cell is never below the whole map's, so each free cell's verdict is the whole-map one (cells that are not
        # free are never traversable); the distance transform no longer runs over the whole 40 m map per call.
        free = self.state == FREE
        trav = np.zeros(self.frame.shape, dtype=bool)
        box = true_box(free)
        if box is not None:
            m = int(math.ceil(self.agent.radius / self.frame.resolution)) + 2
            r0, r1 = max(0, box[0] - m), box[1] + m
            c0, c1 = max(0, box[2] - m), box[3] + m
            occ = self.state[r0:r1, c0:c1] == OCCUPIED
            trav[r0:r1, c0:c1] = free[r0:r1, c0:c1] & ~dilate(occ, self.agent.radius, self.frame.resolution)
        return trav if self.blocked is None else trav & ~self.blocked

    def frontiers(self, min_cells: int = 4) -> list[np.ndarray]:
        """Return clusters (each (N, 2) cells) of traversable cells next to unknown cells."""
        trav = self.traversable()
        box = true_box(trav)
        if box is None:
            return []
        # Computed in the traversable cells' bounding box (frontier cells are traversable), the unknown cells one
        # cell around it (all a 3x3 dilation reads; the map's edge counts as known, as before): a component's cells
        # and the raster order that numbers the components are the whole map's, so are the clusters and their order.
        h, w = self.state.shape
        r0, r1, c0, c1 = box
        R0, R1, C0, C1 = max(0, r0 - 1), min(h, r1 + 1), max(0, c0 - 1), min(w, c1 + 1)
        near_unknown = ndimage.binary_dilation(self.state[R0:R1, C0:C1] == UNKNOWN, structure=np.ones((3, 3), bool))
        fr = trav[r0:r1, c0:c1] & near_unknown[r0 - R0:r1 - R0, c0 - C0:c1 - C0]
        lab, n = ndimage.label(fr, structure=np.ones((3, 3), bool))
        cells = np.argwhere(lab > 0)  # raster order; a stable sort by label keeps it within each cluster
        labels = lab[cells[:, 0], cells[:, 1]]
        order = np.argsort(labels, kind="stable")
        cells, labels = cells[order] + np.array([r0, c0]), labels[order]
        return [c for c in np.split(cells, np.flatnonzero(np.diff(labels)) + 1) if len(c) >= min_cells]


def scan_actions(turn_angle: float) -> int:
    """Return how many turns make a full 360-degree scan."""
    return max(1, int(round(360.0 / turn_angle)))


def agent_frame(position: np.ndarray, size: float, resolution: float) -> GridFrame:
    """Return the agent's own map frame: a square of `size` metres centred on a position, `resolution` m/cell."""
    n = int(math.ceil(size / resolution))
    origin = np.asarray(position, float)[:2] - 0.5 * n * resolution
    return GridFrame(origin, float(resolution), (n, n))


class Explorer:
    """Frontier exploration as a policy (the first visit of the A* agents, paper algorithms 3-4 "Explore").

    `run` is a generator: it yields ``(action, render)`` (``render``: whether the next observation needs images)
    and receives each next time step, whose observation holds the pose the agent is granted (``position``,
    ``heading``, ``pitch``), ``depth`` and, with the ground-truth detector, ``category``. It scans (a full turn,
    each view rendered), drives to the nearest frontier not tried yet, scans again, until no frontier is left or
    ``max_steps`` is used. What it builds stays readable at any time, also when the evaluator ends the phase
    first: `occ` (the agent's own occupancy map: ``nav.map_size`` metres square around the start at
    ``nav.map_resolution``, the floor at the start's height) and `frames` (the rendered views, every
    ``keep_every``-th, each image subsampled by ``downsample`` with the intrinsics scaled to match).

    Parameters
    ----------
    nav : NavConfig
        Moves, depth range and map settings.
    agent : AgentConfig
        The body (obstacle heights, planning margin) and camera height.
    K : ndarray
        (3, 3) intrinsics of the full-size images.
    max_steps : int
        Step budget of the exploration.
    keep_every : int
        Keep every n-th rendered view as a frame.
    downsample : int
        Keep every n-th pixel of each row and column of the frames (and of the depth the map integrates).
    """

    def __init__(self, nav, agent: AgentConfig, K: np.ndarray, max_steps: int = 3000, keep_every: int = 1,
                 downsample: int = 1) -> None:
        self.nav, self.agent = nav, agent
        self.s = max(1, int(downsample))
        self.K = np.asarray(K, float).copy()  # pixel j of the subsampled image is pixel s * j of the full one
        self.K[0, 0] /= self.s
        self.K[1, 1] /= self.s
        self.K[:2, 2] = (self.K[:2, 2] - 0.5) / self.s + 0.5  # pixel centres at + 0.5 (`sim.camera.backproject`)
        self.max_steps, self.keep_every = int(max_steps), max(1, int(keep_every))
        self.occ: OccupancyMap | None = None
        self.frames: list[Observation] = []
        self.steps = 0
        self.views = 0
        self.ts = None

    def _record(self, ts) -> None:
        o = ts.observation
        s = self.s
        pos = np.asarray(o["position"], float)
        T = pose_cv(pos + np.array([0.0, 0.0, self.agent.camera_height]), math.degrees(float(o["heading"][0])),
                    math.degrees(float(o["pitch"][0])))
        depth = np.ascontiguousarray(np.asarray(o["depth"])[::s, ::s, 0])
        self.occ.integrate(depth, self.K, T, self.nav.depth_max)
        self.views += 1
        if self.views % self.keep_every == 0:
            cat = o.get("category")
            self.frames.append(Observation(rgb=np.ascontiguousarray(np.asarray(o["rgb"])[::s, ::s]), depth=depth,
                                           K=self.K.copy(), T_cam=T, view_id=len(self.frames),
                                           segmentation=None if cat is None else np.ascontiguousarray(np.asarray(cat)[::s, ::s])))

    def _step(self, action: int, render: bool) -> Generator[tuple[int, bool], object, object]:
        self.ts = yield (int(action), bool(render))
        self.steps += 1
        return self.ts

    def _scan(self) -> Generator[tuple[int, bool], object, None]:
        for _ in range(scan_actions(self.nav.turn_angle)):
            if self.steps >= self.max_steps:
                return
            self._record((yield from self._step(TURN_LEFT, True)))

    def run(self, ts) -> Generator[tuple[int, bool], object, None]:
        """Explore from the current (rendered) time step; yields (action, render) pairs, receives time steps."""
        from .control import Navigator, blocked_cells

        nav, agent = self.nav, self.agent
        self.ts = ts
        start = np.asarray(ts.observation["position"], float)
        frame = agent_frame(start, nav.map_size, nav.map_resolution)
        occ = self.occ = OccupancyMap(frame, floor_z=float(start[2]), agent=agent)
        occ.mark_free_disc(start, agent.radius + 0.05)
        self._record(ts)
        yield from self._scan()
        tried: list[np.ndarray] = occ.targets
        while self.steps < self.max_steps:
            pos = np.asarray(self.ts.observation["position"], float)[:2]
            occ.mark_free_disc(pos, agent.radius + 0.05)
            trav = occ.traversable()
            clusters = occ.frontiers()
            if not clusters:
                occ.stop_reason = "no frontiers"
                return
            rc = frame.to_cell(pos[None])[0]
            if not (frame.inside(rc[None])[0] and trav[rc[0], rc[1]]):
                rc = nearest_true(trav, rc)  # standing at the rim of the planning map
                if rc is None or np.linalg.norm(frame.to_world(rc[None])[0] - pos) > 0.5:
                    occ.stop_reason = "off the planning map"
                    return
            dist, index = node_distances(trav, rc)
            best, best_d = None, math.inf
            for cells in clusters:
                xy = frame.to_world(cells)
                dd = dist[index[cells[:, 0], cells[:, 1]]].copy()
                for t in tried:  # cells near a target already driven to are not offered again
                    dd[np.linalg.norm(xy - t[None], axis=1) < 0.5] = np.inf
                k = int(np.argmin(dd))
                if math.isfinite(dd[k]) and dd[k] < best_d:
                    best, best_d = xy[k], dd[k]
            if best is None:
                occ.stop_reason = "no reachable untried frontier"
                return
            tried.append(best)
            nv = Navigator(nav, occ.traversable, frame,
                           on_blocked=lambda p, yaw: occ.mark_blocked(blocked_cells(frame, p, yaw, nav.forward_step)))
            gen = nv.goto(best, tolerance=0.25, ts=self.ts)
            try:
                action = next(gen)
                while self.steps < self.max_steps:
                    action = gen.send((yield from self._step(action, False)))
            except StopIteration:
                pass
            yield from self._scan()
        occ.stop_reason = "step budget"
