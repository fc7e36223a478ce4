"""Turning A* paths into discrete actions: pure pursuit with replanning, and an exact lattice approach.

Controllers are generators: they yield an action, receive the next dm_env TimeStep (observations
`position`, `heading`) and return True when they reached the target (StopIteration value).
"""

from __future__ import annotations

import heapq
import math
from typing import Callable, Generator

import numpy as np

from .astar import plan
from .grid import GridFrame, segment_free

MOVE_FORWARD, TURN_LEFT, TURN_RIGHT = 1, 2, 3


def _pose(ts) -> tuple[np.ndarray, float]:
    o = ts.observation
    return np.asarray(o["position"], dtype=float)[:2], math.degrees(float(o["heading"][0]))


def _wrap(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


class Navigator:
    """Follows A* paths on a planning mask with MOVE_FORWARD / TURN_LEFT / TURN_RIGHT."""

    def __init__(self, nav, mask_fn: Callable[[], np.ndarray], frame: GridFrame, max_replans: int = 4) -> None:
        self.nav = nav
        self.mask_fn = mask_fn
        self.frame = frame
        self.max_replans = max_replans

    def goto(self, target: np.ndarray, tolerance: float, ts) -> Generator[int, object, bool]:
        """Yield actions until within `tolerance` (m) of target; return whether it got there."""
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


def lattice_approach(pos: np.ndarray, yaw: float, target: np.ndarray, can_stand: Callable[[np.ndarray, np.ndarray], bool],
                     nav, radius: float = 0.05, max_nodes: int = 60000) -> list[int] | None:
    """Return the shortest action list (forward/turn lattice) that ends within `radius` of target, or None."""
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


def segment_checker(mask: np.ndarray, frame: GridFrame) -> Callable[[np.ndarray, np.ndarray], bool]:
    """Return can_stand(a, b): whether the straight move a -> b stays on the mask."""
    return lambda a, b: segment_free(mask, frame, a, b)
