"""Grid geodesics on a NavMap: multi-source Dijkstra, 8-connected, sqrt(2) diagonals, no corner cutting."""

from __future__ import annotations

import numpy as np

from ..gridgraph import distance_field
from ..records import NavMap

__all__ = ["GeodesicField", "distance_field", "geodesic_distance"]


class GeodesicField:
    """Geodesic distances on one NavMap from a fixed set of world XY sources (e.g. a category's view points)."""

    def __init__(self, navmap: NavMap, sources_xy: np.ndarray) -> None:
        self.navmap = navmap
        cells = navmap.frame.to_cell(np.asarray(sources_xy, dtype=float).reshape(-1, 2)) if len(sources_xy) else np.zeros((0, 2), int)
        self.field = distance_field(navmap.navigable, cells, navmap.resolution)

    def at(self, xy: np.ndarray) -> np.ndarray:
        """Return geodesic distances (N,) at world XY points; inf off the grid or unreachable."""
        rc = self.navmap.frame.to_cell(np.asarray(xy, dtype=float).reshape(-1, 2))
        h, w = self.field.shape
        ok = (rc[:, 0] >= 0) & (rc[:, 0] < h) & (rc[:, 1] >= 0) & (rc[:, 1] < w)
        out = np.full(len(rc), np.inf)
        out[ok] = self.field[rc[ok, 0], rc[ok, 1]]
        return out


def geodesic_distance(navmap: NavMap, start_xy: np.ndarray, goals_xy: np.ndarray) -> float:
    """Return the grid geodesic distance (m) from a world XY point to the nearest of goals_xy."""
    return float(GeodesicField(navmap, goals_xy).at(np.asarray(start_xy, dtype=float).reshape(1, 2))[0])
