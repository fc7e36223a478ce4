"""The cell graph of a boolean grid: 8-connected, sqrt(2) diagonals, no corner cutting.

Shared by the episode generator's geodesics and the navigation agents' planners, so the distances an
episode is scored with and the paths an agent plans come from one graph.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix, csr_matrix

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
