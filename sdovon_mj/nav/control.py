"""Turning A* paths into discrete actions: pure pursuit with replanning, and an exact lattice approach.

Controllers are generators: they yield an action, receive the next dm_env TimeStep (observations
`position`, `heading`) and return True when they reached the target (StopIteration value).
"""

from __future__ import annotations

import heapq
import math
from typing import Callable, Generator

import numpy as np

from .. import native
from ..actions import MOVE_FORWARD, TURN_LEFT, TURN_RIGHT
from ..gridgraph import distance_field
from .astar import plan
from ..grid import GridFrame, segment_free, true_box


def _pose(ts) -> tuple[np.ndarray, float]:
    o = ts.observation
    return np.asarray(o["position"], dtype=float)[:2], math.degrees(float(o["heading"][0]))


def _wrap(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


class Navigator:
    """Follows A* paths on a planning mask with MOVE_FORWARD / TURN_LEFT / TURN_RIGHT.

    Parameters
    ----------
    nav : NavConfig
        Forward step and turn angle.
    mask_fn : callable
        Returns the current planning mask (H, W) bool (it may change between replans).
    frame : GridFrame
        The mask's frame.
    max_replans : int
        Plans after a refused move before giving up.
    on_blocked : callable, optional
        Called with (position, yaw in degrees) when a forward move did not move.
    """

    def __init__(self, nav, mask_fn: Callable[[], np.ndarray], frame: GridFrame, max_replans: int = 4,
                 on_blocked: Callable[[np.ndarray, float], None] | None = None) -> None:
        self.nav = nav
        self.mask_fn = mask_fn
        self.frame = frame
        self.max_replans = max_replans
        self.on_blocked = on_blocked  # called with (position, yaw deg) when a forward move did not move

    def goto(self, target: np.ndarray, tolerance: float, ts) -> Generator[int, object, bool]:
        """Yield actions until within `tolerance` (m) of target; return whether it got there.

        Plans exact action sequences with `lattice_plan` (A* over the agent's reachable poses, guided
        by the grid's geodesic distance), replanning when the world refuses a move; falls back to
        pure pursuit of a grid path when the lattice search gives up.
        """
        target = np.asarray(target, dtype=float)[:2]
        tol = max(tolerance, 1e-3)
        for _ in range(self.max_replans + 1):
            pos, yaw = _pose(ts)
            if np.linalg.norm(pos - target) <= tol:
                return True
            mask = self.mask_fn()
            acts = lattice_plan(pos, yaw, target, tol, mask, self.frame, self.nav)
            if acts is None:
                break
            blocked = False
            for a in acts:
                before = _pose(ts)[0]
                ts = yield a
                if a == MOVE_FORWARD and np.linalg.norm(_pose(ts)[0] - before) < 1e-4:
                    if self.on_blocked is not None:
                        self.on_blocked(before, _pose(ts)[1])
                    blocked = True
                    break
            if not blocked:
                return bool(np.linalg.norm(_pose(ts)[0] - target) <= tol + 1e-6)
        return (yield from self._pursue(target, tolerance, ts))

    def _pursue(self, target: np.ndarray, tolerance: float, ts) -> Generator[int, object, bool]:
        """Pure pursuit of a smoothed grid path with replanning (fallback of `goto`)."""
        target = np.asarray(target, dtype=float)[:2]
        stop_r = max(tolerance, self.nav.forward_step / 2.0)
        replans = 0
        pos, yaw = _pose(ts)
        mask = self.mask_fn()
        path = plan(mask, self.frame, pos, target, tolerance)
        if path is None:
            return False
        goal = path[-1]
        wi = 1
        last_pos = pos.copy()
        while True:
            pos, yaw = _pose(ts)
            if np.linalg.norm(pos - target) <= stop_r or np.linalg.norm(pos - goal) <= self.nav.forward_step / 2.0:
                return True
            while wi < len(path) - 1 and np.linalg.norm(path[wi] - pos) < self.nav.forward_step * 0.75:
                wi += 1
            if wi >= len(path):
                return np.linalg.norm(pos - target) <= stop_r + self.nav.forward_step
            wp = path[wi]
            bearing = math.degrees(math.atan2(wp[1] - pos[1], wp[0] - pos[0]))
            diff = _wrap(bearing - yaw)
            if abs(diff) > self.nav.turn_angle / 2.0 + 1e-6:
                ts = yield (TURN_LEFT if diff > 0 else TURN_RIGHT)
                continue
            if wi == len(path) - 1 and np.linalg.norm(wp - pos) < self.nav.forward_step / 2.0:
                return True
            ts = yield MOVE_FORWARD
            new_pos, _ = _pose(ts)
            if np.linalg.norm(new_pos - last_pos) < 1e-4:  # blocked: replan from here
                replans += 1
                if self.on_blocked is not None:
                    self.on_blocked(new_pos, yaw)
                if replans > self.max_replans:
                    return False
                path = plan(self.mask_fn(), self.frame, new_pos, target, tolerance)
                if path is None:
                    return False
                goal, wi = path[-1], 1
                # nudge: turn once so the next forward differs from the blocked one
                ts = yield (TURN_LEFT if replans % 2 else TURN_RIGHT)
            last_pos = _pose(ts)[0].copy()

    def face(self, point: np.ndarray, ts) -> Generator[int, object, None]:
        """Yield turns until the heading points at `point` within half a turn step."""
        for _ in range(int(360 / self.nav.turn_angle)):
            pos, yaw = _pose(ts)
            diff = _wrap(math.degrees(math.atan2(point[1] - pos[1], point[0] - pos[0])) - yaw)
            if abs(diff) <= self.nav.turn_angle / 2.0 + 1e-6:
                return
            ts = yield (TURN_LEFT if diff > 0 else TURN_RIGHT)


def goal_field(mask: np.ndarray, frame: GridFrame, target: np.ndarray, tolerance: float) -> np.ndarray:
    """Return the grid geodesic distance (m) of every cell to the mask cells within `tolerance` of target."""
    c = frame.to_cell(np.asarray(target, float)[None, :2])[0]
    r = int(math.ceil(tolerance / frame.resolution)) + 1
    h, w = mask.shape
    (ra, rb), (ca, cb) = (max(0, c[0] - r), min(h, c[0] + r + 1)), (max(0, c[1] - r), min(w, c[1] + r + 1))
    if ra >= rb or ca >= cb:  # the goal region lies off the grid: no cell reaches it
        return np.full(mask.shape, np.inf)
    rr, cc = np.mgrid[ra:rb, ca:cb]
    xy = frame.to_world(np.stack([rr.ravel(), cc.ravel()], 1))
    near = (np.linalg.norm(xy - np.asarray(target, float)[None, :2], axis=1) <= tolerance) & mask[rr.ravel(), cc.ravel()]
    return distance_field(mask, np.stack([rr.ravel()[near], cc.ravel()[near]], 1), frame.resolution)


def lattice_plan(pos: np.ndarray, yaw: float, target: np.ndarray, tolerance: float, mask: np.ndarray,
                 frame: GridFrame, nav, max_nodes: int = 20000, weight: float = 1.2) -> list[int] | None:
    """Return an action list (forward/turn) ending within `tolerance` of target with every move on the mask, or None.

    A* over the poses the agent can reach (0.25 m steps, 30-degree headings, positions keyed at 1 cm);
    the heuristic is the grid geodesic distance to the goal region in steps (weighted by `weight`,
    ties to the deeper node), so the search hugs the shortest grid path and threads doorways the
    agent's heading lattice can pass.

    Parameters
    ----------
    pos : ndarray
        The agent's position (world XY, metres).
    yaw : float
        Its heading in degrees.
    target : ndarray
        The goal (world XY, metres).
    tolerance : float
        Metres from target that count as arrived.
    mask : ndarray (H, W) bool
        Where the agent may stand.
    frame : GridFrame
        The mask's frame.
    nav : NavConfig
        Forward step and turn angle.
    max_nodes : int
        Expanded poses after which the search gives up (None).
    weight : float
        Weight of the heuristic (above 1: fewer poses expanded, plans possibly longer than the shortest).
    """
    step, turn = nav.forward_step, nav.turn_angle
    n_head = int(round(360.0 / turn))
    tx, ty = float(target[0]), float(target[1])
    field = goal_field(mask, frame, np.array([tx, ty]), tolerance)
    ox, oy, res = float(frame.origin[0]), float(frame.origin[1]), float(frame.resolution)
    # The field and mask cut to the mask's bounding box (the Python search reads them as lists): off the mask the field
    # is inf (`distance_field`) and `free` is False, exactly what a cell outside the box gives, so the plan is the
    # same while a 40 m map's 800 x 800 cells are no longer listed on every call.
    mb = np.asarray(mask, dtype=bool)
    r0, r1, c0, c1 = true_box(mb) or (0, 0, 0, 0)
    fw = np.ascontiguousarray(field[r0:r1, c0:c1] / step)
    mw = np.ascontiguousarray(mb[r0:r1, c0:c1])
    tol2 = tolerance * tolerance
    floor = math.floor

    def heur(x: float, y: float) -> float:
        if (tx - x) ** 2 + (ty - y) ** 2 <= tol2:
            return 0.0
        col, row = floor((x - ox) / res), floor((y - oy) / res)
        if not (r0 <= row < r1 and c0 <= col < c1):
            return math.inf
        return fl[row - r0][col - c0]

    n_s = max(1, int(math.ceil(step / (res / 2.0))))
    dirs, samples = [], []
    for k in range(n_head):
        c, s_ = math.cos(math.radians(yaw + k * turn)), math.sin(math.radians(yaw + k * turn))
        dirs.append((step * c, step * s_))
        samples.append([(step * c * i / n_s, step * s_ * i / n_s) for i in range(n_s + 1)])
    x0, y0 = float(pos[0]), float(pos[1])
    if (tx - x0) ** 2 + (ty - y0) ** 2 <= tol2:
        return []
    lib = native.library()
    if lib is not None:  # the same search compiled (native/kernels.c `sdv_lattice`): the same actions
        out = np.zeros(max_nodes + 1, dtype=np.int32)
        dirs_a, samples_a = np.ascontiguousarray(dirs, dtype=float), np.ascontiguousarray(samples, dtype=float)
        n = lib.sdv_lattice(fw.ctypes.data, mw.view(np.uint8).ctypes.data, r0, c0, r1 - r0, c1 - c0, ox, oy, res,
                            tx, ty, tol2, x0, y0, n_head, dirs_a.ctypes.data, samples_a.ctypes.data, n_s + 1,
                            float(weight), int(max_nodes), TURN_LEFT, TURN_RIGHT, MOVE_FORWARD, out.ctypes.data)
        if n == -2:
            raise MemoryError("lattice_plan: the compiled search ran out of memory")
        return None if n < 0 else [int(a) for a in out[:n]]
    fl, ml = fw.tolist(), mw.tolist()

    def free(x: float, y: float, k: int) -> bool:
        for dx, dy in samples[k]:
            col, row = floor((x + dx - ox) / res), floor((y + dy - oy) / res)
            if not (r0 <= row < r1 and c0 <= col < c1) or not ml[row - r0][col - c0]:
                return False
        return True

    h0 = heur(x0, y0)
    if not math.isfinite(h0):
        return None
    start = (round(x0 * 100.0), round(y0 * 100.0), 0)
    pose = {start: (x0, y0)}
    parent: dict[tuple, tuple] = {start: (None, -1)}
    gbest = {start: 0}
    heap = [(weight * h0, 0, 0, start)]
    counter = 0
    nodes = 0
    while heap and nodes < max_nodes:
        _f, ng, _c, kk = heapq.heappop(heap)
        g = -ng
        if gbest.get(kk, math.inf) < g:
            continue
        nodes += 1
        x, y = pose[kk]
        k = kk[2]
        if (tx - x) ** 2 + (ty - y) ** 2 <= tol2:
            acts = []
            while parent[kk][0] is not None:
                kk, a = parent[kk]
                acts.append(a)
            return acts[::-1]
        succ = [(x, y, (k + 1) % n_head, TURN_LEFT), (x, y, (k - 1) % n_head, TURN_RIGHT)]
        if free(x, y, k):
            succ.append((x + dirs[k][0], y + dirs[k][1], k, MOVE_FORWARD))
        for sx, sy, sk_, act in succ:
            hs = heur(sx, sy)
            if hs == math.inf:
                continue
            sk = (round(sx * 100.0), round(sy * 100.0), sk_)
            if g + 1 < gbest.get(sk, math.inf):
                gbest[sk] = g + 1
                parent[sk] = (kk, act)
                pose[sk] = (sx, sy)
                counter += 1
                heapq.heappush(heap, (g + 1 + weight * hs, -(g + 1), counter, sk))
    return None


def lattice_approach(pos: np.ndarray, yaw: float, target: np.ndarray, can_stand: Callable[[np.ndarray, np.ndarray], bool],
                     nav, radius: float = 0.05, max_nodes: int = 60000) -> list[int] | None:
    """Return the shortest action list (forward/turn lattice) that ends within `radius` of target, or None.

    Parameters
    ----------
    pos, yaw, target : as in `lattice_plan`
    can_stand : callable
        can_stand(a, b): whether the straight move a -> b is allowed.
    nav, max_nodes : as in `lattice_plan`
    radius : float
        Metres from target that count as arrived.
    """
    step, turn = nav.forward_step, nav.turn_angle
    n_head = int(round(360.0 / turn))
    target = np.asarray(target, float)[:2]
    start = (float(pos[0]), float(pos[1]), 0)
    key = lambda x, y, h: (round(x / 0.01), round(y / 0.01), h)  # noqa: E731

    def heur(x: float, y: float) -> float:
        return max(0.0, math.hypot(target[0] - x, target[1] - y) - radius) / step

    heap = [(heur(start[0], start[1]), 0, start, ())]
    seen = {key(*start)}
    nodes = 0
    while heap and nodes < max_nodes:
        _f, g, (x, y, h), acts = heapq.heappop(heap)
        nodes += 1
        if math.hypot(target[0] - x, target[1] - y) < radius:
            return list(acts)
        a = math.radians(yaw + h * turn)
        nx, ny = x + step * math.cos(a), y + step * math.sin(a)
        succ = []
        if can_stand(np.array([x, y]), np.array([nx, ny])):
            succ.append(((nx, ny, h), MOVE_FORWARD))
        succ.append(((x, y, (h + 1) % n_head), TURN_LEFT))
        succ.append(((x, y, (h - 1) % n_head), TURN_RIGHT))
        for s, act in succ:
            k = key(*s)
            if k in seen:
                continue
            seen.add(k)
            heapq.heappush(heap, (g + 1 + heur(s[0], s[1]), g + 1, s, acts + (act,)))
    return None


def blocked_cells(frame: GridFrame, pos: np.ndarray, yaw: float, step: float, radius: float = 0.05) -> np.ndarray:
    """Return the cells (N, 2) near the end of a forward move from pos along yaw that the world refused.

    Parameters
    ----------
    frame : GridFrame
        The grid's frame (cells outside it are left out).
    pos : ndarray
        Where the move started (world XY, metres).
    yaw : float
        Its heading in degrees.
    step : float
        The forward step in metres.
    radius : float
        Metres around the move's end that are marked.
    """
    a = math.radians(yaw)
    end = np.asarray(pos, float)[:2] + step * np.array([math.cos(a), math.sin(a)])
    c = frame.to_cell(end[None])[0]
    r = max(0, int(math.ceil(radius / frame.resolution)))
    rr, cc = np.mgrid[-r:r + 1, -r:r + 1]
    keep = rr ** 2 + cc ** 2 <= r * r
    cells = np.stack([c[0] + rr[keep], c[1] + cc[keep]], axis=1)
    return cells[frame.inside(cells)]


def segment_checker(mask: np.ndarray, frame: GridFrame) -> Callable[[np.ndarray, np.ndarray], bool]:
    """Return can_stand(a, b): whether the straight move a -> b stays on the mask."""
    return lambda a, b: segment_free(mask, frame, a, b)
