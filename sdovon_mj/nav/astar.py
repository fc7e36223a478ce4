"""A* on an occupancy grid: 8-connected, octile heuristic, no corner cutting, goal tolerance eps_nav."""

from __future__ import annotations

import heapq
import math

import numpy as np

from .grid import GridFrame, nearest_true, segment_free

_SQ2 = math.sqrt(2.0)
_MOVES = ((-1, 0, 1.0), (1, 0, 1.0), (0, -1, 1.0), (0, 1, 1.0),
          (-1, -1, _SQ2), (-1, 1, _SQ2), (1, -1, _SQ2), (1, 1, _SQ2))


def astar(mask: np.ndarray, start: tuple[int, int], goal: tuple[int, int], tolerance_cells: float = 0.0,
          max_expansions: int = 2_000_000) -> list[tuple[int, int]] | None:
    """Return the cell path from start to the first free cell within `tolerance_cells` of goal, or None."""
    m = np.asarray(mask, dtype=bool)
    h, w = m.shape
    s, g = (int(start[0]), int(start[1])), (int(goal[0]), int(goal[1]))
    if not (0 <= s[0] < h and 0 <= s[1] < w) or not m[s]:
        return None
    tol2 = float(tolerance_cells) ** 2

    def heur(r: int, c: int) -> float:
        dr, dc = abs(r - g[0]), abs(c - g[1])
        octile = (dr + dc) + (_SQ2 - 2.0) * min(dr, dc)
        return max(0.0, octile - tolerance_cells)

    def at_goal(r: int, c: int) -> bool:
        return (r - g[0]) ** 2 + (c - g[1]) ** 2 <= tol2 + 1e-9

    gscore = np.full((h, w), np.inf)
    parent = np.full((h, w), -1, dtype=np.int64)
    closed = np.zeros((h, w), dtype=bool)
    gscore[s] = 0.0
    heap = [(heur(*s), 0.0, s[0], s[1])]
    expansions = 0
    while heap:
        _f, gs, r, c = heapq.heappop(heap)
        if closed[r, c]:
            continue
        closed[r, c] = True
        if at_goal(r, c):
            path = [(r, c)]
            k = parent[r, c]
            while k >= 0:
                rr, cc = divmod(int(k), w)
                path.append((rr, cc))
                k = parent[rr, cc]
            return path[::-1]
        expansions += 1
        if expansions > max_expansions:
            return None
        for dr, dc, cost in _MOVES:
            nr, nc = r + dr, c + dc
            if not (0 <= nr < h and 0 <= nc < w) or not m[nr, nc] or closed[nr, nc]:
                continue
            if dr and dc and not (m[r + dr, c] and m[r, c + dc]):
                continue
            ng = gs + cost
            if ng < gscore[nr, nc]:
                gscore[nr, nc] = ng
                parent[nr, nc] = r * w + c
                heapq.heappush(heap, (ng + heur(nr, nc), ng, nr, nc))
    return None


def smooth_path(mask: np.ndarray, frame: GridFrame, points: np.ndarray) -> np.ndarray:
    """Return world waypoints with redundant points removed where the straight line stays free."""
    pts = np.asarray(points, dtype=float)
    if len(pts) <= 2:
        return pts
    out = [pts[0]]
    i = 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not segment_free(mask, frame, pts[i], pts[j]):
            j -= 1
        out.append(pts[j])
        i = j
    return np.array(out)


def plan(mask: np.ndarray, frame: GridFrame, start_xy: np.ndarray, goal_xy: np.ndarray,
         tolerance: float = 0.0) -> np.ndarray | None:
    """Return smoothed world waypoints (K, 2) from start to within `tolerance` (m) of goal, or None."""
    s = frame.to_cell(np.asarray(start_xy, dtype=float)[None, :2])[0]
    if not frame.inside(s[None])[0] or not mask[s[0], s[1]]:
        ns = nearest_true(mask, s)
        if ns is None:
            return None
        s = ns
    g = frame.to_cell(np.asarray(goal_xy, dtype=float)[None, :2])[0]
    cells = astar(mask, (int(s[0]), int(s[1])), (int(g[0]), int(g[1])), tolerance / frame.resolution)
    if cells is None:
        return None
    world = frame.to_world(np.array(cells))
    world[0] = np.asarray(start_xy, dtype=float)[:2] if mask[s[0], s[1]] else world[0]
    return smooth_path(mask, frame, world)
