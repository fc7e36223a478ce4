"""The cell graph of a boolean grid: 8-connected, sqrt(2) diagonals, no corner cutting.

Shared by the episode generator's geodesics and the navigation agents' planners, so the distances an
episode is scored with and the paths an agent plans come from one graph.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import dijkstra

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
    g, index = graph_of(nav)
    h, w = nav.shape
    inside = (src[:, 0] >= 0) & (src[:, 0] < h) & (src[:, 1] >= 0) & (src[:, 1] < w)
    src = src[inside]
    nodes = np.unique(index[src[:, 0], src[:, 1]]) if len(src) else np.zeros(0, dtype=np.int64)
    nodes = nodes[nodes >= 0]
    if len(nodes) == 0:
        return out
    # The graph holds both directions of every edge: a directed search gives the undirected distances
    # (byte-identical) without scipy transposing the graph on every call.
    d = dijkstra(g, directed=True, indices=nodes, min_only=True)
    out[nav] = d * float(resolution)
    return out
