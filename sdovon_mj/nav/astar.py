"""Shortest paths on an occupancy grid: 8-connected, no corner cutting, goal tolerance eps_nav.

`astar` is the textbook A* (octile heuristic); `plan` gives the same optimal paths with scipy's
Dijkstra on a cached cell graph (fast in Python) and smooths them into straight segments.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from scipy.sparse.csgraph import dijkstra

from ..gridgraph import graph_of
from ..grid import GridFrame, nearest_true, segment_free, true_box

_SQ2 = math.sqrt(2.0)
_MOVES = ((-1, 0, 1.0), (1, 0, 1.0), (0, -1, 1.0), (0, 1, 1.0),
          (-1, -1, _SQ2), (-1, 1, _SQ2), (1, -1, _SQ2), (1, 1, _SQ2))


def astar(mask: np.ndarray, start: tuple[int, int], goal: tuple[int, int], tolerance_cells: float = 0.0,
          max_expansions: int = 2_000_000) -> list[tuple[int, int]] | None:
    """Return the cell path from start to the first free cell within `tolerance_cells` of goal, or None.

    Parameters
    ----------
    mask : ndarray (H, W) bool
        Free cells.
    start, goal : tuple of int
        (row, col) cells.
    tolerance_cells : float
        Cells from goal that count as arrived.
    max_expansions : int
        Expanded cells after which the search gives up (None).
    """
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


def smooth_path(mask: np.ndarray, frame: GridFrame, points: np.ndarray, stride: int = 3) -> np.ndarray:
    """Return world waypoints with redundant points removed where the straight line stays free.

    Greedy string pulling: from the current waypoint, extend to later path points (every `stride`-th
    and the last) while the straight segment stays on the mask; keep the last one that did.
    """
    pts = np.asarray(points, dtype=float)
    if len(pts) <= 2:
        return pts
    out = [pts[0]]
    i, n = 0, len(pts)
    while i < n - 1:
        best = i + 1
        j = min(i + stride, n - 1)
        while True:
            if not segment_free(mask, frame, pts[i], pts[j]):
                break
            best = j
            if j == n - 1:
                break
            j = min(j + stride, n - 1)
        out.append(pts[best])
        i = best
    return np.array(out)


def plan_cells(mask: np.ndarray, start: tuple[int, int], goal: tuple[int, int],
               tolerance_cells: float = 0.0) -> list[tuple[int, int]] | None:
    """Return a shortest 8-connected cell path from start to the nearest-by-path cell within tolerance of goal.

    Same result as `astar` (optimal path, no corner cutting), computed with scipy's Dijkstra on the
    cached cell graph of the mask, which is much faster in Python than a heap-based A*.
    """
    m = np.asarray(mask, dtype=bool)
    h, w = m.shape
    if not (0 <= start[0] < h and 0 <= start[1] < w) or not m[start[0], start[1]]:
        return None
    # the graph of the window holding every mask cell: the same nodes in the same order (row-major), the same
    # canonical (sorted) graph, so scipy's search gives the same distances and predecessors on a smaller grid
    a, b, c, d = true_box(m)  # not None: the start lies on the mask
    g, index = graph_of(m[a:b, c:d])
    s = int(index[start[0] - a, start[1] - c])
    r = int(math.ceil(tolerance_cells))
    r0, r1 = max(0, goal[0] - r), min(h, goal[0] + r + 1)
    c0, c1 = max(0, goal[1] - r), min(w, goal[1] + r + 1)
    if r0 >= r1 or c0 >= c1:
        return None
    rr, cc = np.mgrid[r0:r1, c0:c1]
    near = ((rr - goal[0]) ** 2 + (cc - goal[1]) ** 2 <= tolerance_cells ** 2 + 1e-9) & m[r0:r1, c0:c1]
    if not near.any():
        return None
    cand = np.stack([rr[near], cc[near]], axis=1)
    # The graph holds both directions of every edge: the directed search settles and relaxes exactly as the
    # undirected one (which also scans the transpose, relaxing nothing more), distances and predecessors alike,
    # without scipy transposing the graph on every call.
    dist, pred = dijkstra(g, directed=True, indices=s, return_predecessors=True)
    dc = dist[index[cand[:, 0] - a, cand[:, 1] - c]]
    if not np.isfinite(dc).any():
        return None
    off = (cand[:, 0] - goal[0]) ** 2 + (cand[:, 1] - goal[1]) ** 2
    k = int(np.lexsort((off, dc))[0])
    node = int(index[cand[k, 0] - a, cand[k, 1] - c])
    nodes = [node]
    while node != s:
        node = int(pred[node])
        if node < 0:
            return None
        nodes.append(node)
    cells = np.argwhere(m[a:b, c:d])  # node n is the n-th True cell in row-major order (cell_graph's numbering)
    return [(int(cells[n][0]) + a, int(cells[n][1]) + c) for n in nodes[::-1]]


def plan(mask: np.ndarray, frame: GridFrame, start_xy: np.ndarray, goal_xy: np.ndarray,
         tolerance: float = 0.0) -> np.ndarray | None:
    """Return smoothed world waypoints (K, 2) from start to within `tolerance` (m) of goal, or None.

    Parameters
    ----------
    mask : ndarray (H, W) bool
        Free cells.
    frame : GridFrame
        The mask's frame.
    start_xy, goal_xy : ndarray
        World XY (metres); a start off the mask starts from its nearest free cell.
    tolerance : float
        Metres from goal that count as arrived.
    """
    s = frame.to_cell(np.asarray(start_xy, dtype=float)[None, :2])[0]
    if not frame.inside(s[None])[0] or not mask[s[0], s[1]]:
        ns = nearest_true(mask, s)
        if ns is None:
            return None
        s = ns
    g = frame.to_cell(np.asarray(goal_xy, dtype=float)[None, :2])[0]
    cells = plan_cells(mask, (int(s[0]), int(s[1])), (int(g[0]), int(g[1])), tolerance / frame.resolution)
    if cells is None:
        return None
    world = frame.to_world(np.array(cells))
    world[0] = np.asarray(start_xy, dtype=float)[:2] if mask[s[0], s[1]] else world[0]
    return smooth_path(mask, frame, world)
