"""Grid geodesics on a NavMap: multi-source Dijkstra, 8-connected, sqrt(2) diagonals, no corner cutting."""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import dijkstra

from ..gridgraph import cell_graph
from ..records import NavMap

_GRAPHS: dict[tuple[tuple[int, ...], bytes], tuple] = {}
_GRAPHS_MAX = 4  # a variant's floors; every field of a variant shares its floor's graph


def _graph(navigable: np.ndarray):
    """Return the sparse cell graph of the navigable cells and the cell -> node index map (memoised per grid)."""
    nav = np.ascontiguousarray(navigable, dtype=bool)
    key = (nav.shape, nav.tobytes())
    hit = _GRAPHS.get(key)
    if hit is None:
        if len(_GRAPHS) >= _GRAPHS_MAX:
            _GRAPHS.pop(next(iter(_GRAPHS)))
        hit = _GRAPHS[key] = _build_graph(nav)
    return hit


def _build_graph(nav: np.ndarray):
    """Build the sparse cell graph of a boolean grid and its (read-only) cell -> node index map."""
    g, index = cell_graph(nav)
    index.setflags(write=False)
    return g, index


def distance_field(navigable: np.ndarray, sources: np.ndarray, resolution: float) -> np.ndarray:
    """Return the (H, W) geodesic distance (metres) from the nearest source cell; inf where unreachable."""
    nav = np.asarray(navigable, dtype=bool)
    out = np.full(nav.shape, np.inf)
    src = np.atleast_2d(np.asarray(sources, dtype=np.int64)).reshape(-1, 2)
    g, index = _graph(nav)
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


class GeodesicField:
    """Geodesic distances on one NavMap from a fixed set of world XY sources (e.g. a category's view points)."""

    def __init__(self, navmap: NavMap, sources_xy: np.ndarray) -> None:
        self.navmap = navmap
        cells = navmap.world_to_cell(np.asarray(sources_xy, dtype=float).reshape(-1, 2)) if len(sources_xy) else np.zeros((0, 2), int)
        self.field = distance_field(navmap.navigable, cells, navmap.resolution)

    def at(self, xy: np.ndarray) -> np.ndarray:
        """Return geodesic distances (N,) at world XY points; inf off the grid or unreachable."""
        rc = self.navmap.world_to_cell(np.asarray(xy, dtype=float).reshape(-1, 2))
        h, w = self.field.shape
        ok = (rc[:, 0] >= 0) & (rc[:, 0] < h) & (rc[:, 1] >= 0) & (rc[:, 1] < w)
        out = np.full(len(rc), np.inf)
        out[ok] = self.field[rc[ok, 0], rc[ok, 1]]
        return out


def geodesic_distance(navmap: NavMap, start_xy: np.ndarray, goals_xy: np.ndarray) -> float:
    """Return the grid geodesic distance (m) from a world XY point to the nearest of goals_xy."""
    return float(GeodesicField(navmap, goals_xy).at(np.asarray(start_xy, dtype=float).reshape(1, 2))[0])
