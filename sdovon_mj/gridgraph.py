"""The one geodesic: the cell graph of a boolean grid and the distances measured on it.

The graph is 8-connected with sqrt(2) diagonals and no corner cutting. `GeodesicField` is the one
definition of the geodesic distance from a world point to a set of world targets: the episode
generator stores it as an episode's ``geodesic_distance``, the suite uses it for distance to goal and
the SPL denominator, and the agents' planners measure on the same graph (`graph_of`, `distance_field`).
So an episode's stored distance equals the suite's shortest-path length for the same start.
Distances come from scipy's Dijkstra on the graph or, where the compiled kernels load, from a search of the
mask itself (`grid_distances`): the same values, byte for byte.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import dijkstra

from . import native
from .grid import GridFrame, segment_free, true_box

# (drow, dcol, cost in cells); a diagonal needs both orthogonal neighbours free (no corner cutting).
STEPS = ((0, 1, 1.0), (1, 0, 1.0), (1, 1, math.sqrt(2.0)), (1, -1, math.sqrt(2.0)))


def cell_graph(mask: np.ndarray) -> tuple[csr_matrix, np.ndarray]:
    """Return the symmetric graph (costs in cells) of the True cells and the cell -> node index map (-1 off the mask)."""
    nav = np.asarray(mask, dtype=bool)
    h, w = nav.shape
    n = int(nav.sum())
    index = np.full((h, w), -1, dtype=np.int64)
    index[nav] = np.arange(n)
    rows, cols, costs = [], [], []
    for dr, dc, cost in STEPS:
        r0, r1 = max(0, -dr), h - max(0, dr)
        c0, c1 = max(0, -dc), w - max(0, dc)
        ok = nav[r0:r1, c0:c1] & nav[r0 + dr:r1 + dr, c0 + dc:c1 + dc]
        if dr and dc:
            ok &= nav[r0 + dr:r1 + dr, c0:c1] & nav[r0:r1, c0 + dc:c1 + dc]
        ia = index[r0:r1, c0:c1][ok]
        ib = index[r0 + dr:r1 + dr, c0 + dc:c1 + dc][ok]
        rows += [ia, ib]
        cols += [ib, ia]
        costs += [np.full(len(ia), cost), np.full(len(ia), cost)]
    g = coo_matrix((np.concatenate(costs), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()
    g.sort_indices()
    return g, index


_GRAPHS: dict[tuple[tuple[int, ...], bytes], tuple[csr_matrix, np.ndarray]] = {}
_GRAPHS_MAX = 16  # a variant's floors and an agent's recent planning masks


def graph_of(mask: np.ndarray) -> tuple[csr_matrix, np.ndarray]:
    """Return cell_graph(mask), memoised by the mask's contents (the index map is read-only)."""
    nav = np.ascontiguousarray(mask, dtype=bool)
    key = (nav.shape, nav.tobytes())
    hit = _GRAPHS.get(key)
    if hit is None:
        if len(_GRAPHS) >= _GRAPHS_MAX:
            _GRAPHS.pop(next(iter(_GRAPHS)))
        g, index = cell_graph(nav)
        index.setflags(write=False)
        hit = _GRAPHS[key] = (g, index)
    return hit


def distance_field(mask: np.ndarray, sources: np.ndarray, resolution: float) -> np.ndarray:
    """Return the (H, W) geodesic distance (metres) from the nearest source cell (row, col); inf where unreachable."""
    nav = np.asarray(mask, dtype=bool)
    out = np.full(nav.shape, np.inf)
    src = np.atleast_2d(np.asarray(sources, dtype=np.int64)).reshape(-1, 2)
    h, w = nav.shape
    inside = (src[:, 0] >= 0) & (src[:, 0] < h) & (src[:, 1] >= 0) & (src[:, 1] < w)
    src = src[inside]
    src = src[nav[src[:, 0], src[:, 1]]]  # sources off the mask are no nodes
    if len(src) == 0:
        return out
    r0, r1, c0, c1 = true_box(nav)  # not None: a source lies on the mask
    # the search on the window that holds every mask cell: the same graph (cells outside are no nodes), the same
    # distances, and no work on the empty rest of the grid
    cells = grid_distances(nav[r0:r1, c0:c1], (src[:, 0] - r0) * (c1 - c0) + (src[:, 1] - c0))
    if cells is not None:  # no graph to build: the kernel walks the mask
        out[r0:r1, c0:c1] = cells * float(resolution)
        return out
    g, index = graph_of(nav)
    nodes = np.unique(index[src[:, 0], src[:, 1]])
    # The graph holds both directions of every edge: a directed search gives the undirected distances
    # (byte-identical) without scipy transposing the graph on every call.
    d = dijkstra(g, directed=True, indices=nodes, min_only=True)
    out[nav] = d * float(resolution)
    return out


def grid_distances(mask: np.ndarray, sources: np.ndarray, limit: float = np.inf,
                   start: np.ndarray | None = None) -> np.ndarray | None:
    """Return the (H, W) distances in cells over `cell_graph(mask)` from the nearest of the flat source cells (those
    on the mask; `start`: each source's own starting distance in cells, default 0), inf where unreached or past
    `limit` cells; None where the compiled kernels are not available.

    The compiled search (native ``sdv_grid_dijkstra``) walks the grid itself. Its values are scipy's Dijkstra's on
    the graph, byte for byte: a cell's distance is the least of fl(d(u) + cost) over its neighbours u, and that
    least value does not depend on the order in which either queue settles equal keys (tests/test_native.py).
    """
    lib = native.library()
    if lib is None or (start is not None and not np.all((np.asarray(start) >= 0.0) & (np.asarray(start) < 1.0))):
        return None  # the compiled search queues its sources first: their starts must lie within one step
    nav = np.ascontiguousarray(mask, dtype=np.uint8)
    h, w = nav.shape
    src = np.asarray(sources, dtype=np.int64).reshape(-1)
    on = nav.reshape(-1)[src] != 0
    init = None
    if start is None:
        src = np.ascontiguousarray(np.unique(src[on]))
    else:
        src, init = np.ascontiguousarray(src[on]), np.ascontiguousarray(np.asarray(start, dtype=np.float64)[on])
    dist = np.full(h * w, np.inf)
    if lib.sdv_grid_dijkstra(nav.ctypes.data, h, w, src.ctypes.data, None if init is None else init.ctypes.data,
                             len(src), float(limit), dist.ctypes.data):
        raise MemoryError("grid Dijkstra: out of memory")
    return dist.reshape(h, w)


def node_distances(mask: np.ndarray, cell: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Return the distances in cells from `cell` (on the mask) to every node of `cell_graph(mask)`, and its index
    map: what ``dijkstra(g, indices=index[cell])`` gives with ``g, index = cell_graph(mask)``, byte for byte (the
    compiled search when available: no graph is built)."""
    nav = np.asarray(mask, dtype=bool)
    h, w = nav.shape
    cells = grid_distances(nav, np.array([int(cell[0]) * w + int(cell[1])]))
    if cells is None:
        g, index = cell_graph(nav)
        return dijkstra(g, indices=int(index[cell[0], cell[1]])), index
    index = np.full((h, w), -1, dtype=np.int64)
    index[nav] = np.arange(int(nav.sum()))
    return cells[nav], index




class GeodesicField:
    """Geodesic distance (m) on a grid to the nearest of a set of world XY targets: THE geodesic.

    Definition: the shortest path from a point ``p`` to a target ``t`` made of a straight first leg from
    ``p`` to the centre of one of its (up to 9) neighbouring cells, then edges of `cell_graph` between
    cell centres, then a straight last leg from a cell centre to ``t`` in that cell; or the straight
    segment ``p -> t`` itself when every sample of it lies on the mask (`grid.segment_free`). So distances
    are exact on open floor and grid-geodesic around obstacles. `field` holds, for every cell, the
    distance from its centre through the graph (without the straight shortcut); `distance` adds the
    first leg and the shortcut, so ``distance(p) <= field[cell of p]`` for a point on a cell centre.

    Parameters
    ----------
    mask : numpy.ndarray
        (H, W) bool, the cells one may stand on (a navmap's ``navigable``).
    frame : GridFrame
        The grid's placement in the world (origin in metres, resolution in m/cell).
    targets_xy : numpy.ndarray
        (N, 2) or (N, 3) world targets, metres (XY used); targets off the mask are ignored.
    graph : tuple, optional
        A ready ``cell_graph(mask)``; default ``graph_of(mask)`` (memoised by mask contents).
    """

    def __init__(self, mask: np.ndarray, frame: GridFrame, targets_xy: np.ndarray,
                 graph: tuple[csr_matrix, np.ndarray] | None = None) -> None:
        self.mask = np.asarray(mask, dtype=bool)
        self.frame = frame
        self.targets = np.atleast_2d(np.asarray(targets_xy, dtype=float))[:, :2] if len(targets_xy) else np.zeros((0, 2))
        g, index = graph if graph is not None else graph_of(self.mask)
        n = g.shape[0]
        self.field = np.full(self.mask.shape, np.inf)
        cells = frame.to_cell(self.targets) if len(self.targets) else np.zeros((0, 2), np.int64)
        ok = frame.inside(cells)
        nodes = np.full(len(cells), -1, dtype=np.int64)
        nodes[ok] = index[cells[ok, 0], cells[ok, 1]]
        keep = nodes >= 0
        if not keep.any() or n == 0:
            return
        # A virtual source node n linked to each target's cell with the exact offset to the cell centre
        # (cells); the graph holds both directions of every edge, so the directed search from n gives
        # the undirected distances. The source row is appended to the CSR arrays without a COO round trip.
        # Several targets in one cell: the nearest to its centre counts (one edge per cell).
        offs = np.linalg.norm(self.targets[keep] - frame.to_world(cells[keep]), axis=1) / frame.resolution
        kn = nodes[keep]
        order = np.lexsort((offs, kn))
        first = np.ones(len(order), dtype=bool)
        first[1:] = kn[order][1:] != kn[order][:-1]
        src_nodes, src_offs = kn[order][first], offs[order][first]
        cells_d = grid_distances(self.mask, np.flatnonzero(self.mask.reshape(-1))[src_nodes], start=src_offs + 1e-9)
        if cells_d is not None:  # the virtual source's search, compiled: each target cell starts at its edge's cost
            self.field[self.mask] = cells_d[self.mask] * frame.resolution
            return
        indptr = np.concatenate([g.indptr, [g.indptr[-1] + len(src_nodes)]])
        indices = np.concatenate([g.indices, src_nodes])
        data = np.concatenate([g.data, src_offs + 1e-9])
        big = csr_matrix((data, indices, indptr), shape=(n + 1, n + 1))
        d = dijkstra(big, directed=True, indices=n)
        self.field[self.mask] = d[:n] * frame.resolution

    def distance(self, xy: np.ndarray) -> float:
        """Return the geodesic distance (m) from a world XY point to the nearest target; inf if unreachable."""
        p = np.asarray(xy, dtype=float)[:2]
        if len(self.targets) == 0:
            return math.inf
        best = math.inf
        eu = np.linalg.norm(self.targets - p[None], axis=1)
        for k in np.argsort(eu, kind="stable")[:8]:
            if eu[k] >= best:
                break
            if segment_free(self.mask, self.frame, p, self.targets[k]):
                best = float(eu[k])
                break
        # the 9 cells around p (p's own cell 4), in Python floats: the same operations as GridFrame's to_cell and
        # to_world and numpy's norm of a 2-vector (sqrt of the unfused dx * dx + dy * dy), without nine small arrays
        fr = self.frame
        ox, oy, res = float(fr.origin[0]), float(fr.origin[1]), float(fr.resolution)
        px, py = float(p[0]), float(p[1])
        r0, c0 = math.floor((py - oy) / res), math.floor((px - ox) / res)
        h, w = int(fr.shape[0]), int(fr.shape[1])
        k = -1
        for r in (r0 - 1, r0, r0 + 1):
            for c in (c0 - 1, c0, c0 + 1):
                k += 1
                if not (0 <= r < h and 0 <= c < w and self.mask[r, c]):
                    continue
                cx, cy = ox + (c + 0.5) * res, oy + (r + 0.5) * res
                if k != 4 and not segment_free(self.mask, fr, p, (cx, cy)):
                    continue
                dx, dy = cx - px, cy - py
                best = min(best, float(self.field[r, c]) + math.sqrt(dx * dx + dy * dy))
        return best

    def distances(self, xy: np.ndarray) -> np.ndarray:
        """Return `distance` at each of (N, 2) world XY points, metres (N,)."""
        pts = np.atleast_2d(np.asarray(xy, dtype=float))
        return np.array([self.distance(p) for p in pts], dtype=float)
