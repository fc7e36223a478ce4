"""Multi-view instance fusion, ConceptGraphs style (paper section 3.2).

The overall similarity of a new instance i and a fused instance j is

    phi(i, j) = k_sem * phi_label(i, j) + k_geo * phi_overlap(i, j)

where, following the weights' names (see docs/choices.md: the paper's text pairs the
names the other way round),

- ``k_sem`` multiplies the **label** term: the cosine similarity of the all-MiniLM-L6-v2 sentence
  embeddings of the two labels, clipped to [0, 1] (``label_similarity = "exact"``: 1 when the
  labels are equal, else 0);
- ``k_geo`` multiplies the **geometric** term: the fraction of i's points that lie within
  ``overlap_radius`` of one of j's points (KD-tree nearest neighbour, ConceptGraphs' "overlap").

i joins the j with the highest phi if phi >= phi_min, else it starts a new fused instance. Merged
clouds are voxel-downsampled. Presets (``config.with_fusion_preset``): paper 0.4 / 1.6 / 0.8,
conceptgraphs 1 / 1 / 1.1, or custom.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import native
from ..config import PerceiveConfig, with_fusion_preset
from ..embeddings import embed_labels
from ..geometry import axis_bounds, boxes_apart
from ..records import Instance
from .backproject import make_instance, voxel_stats

MAX_OVERLAP_QUERY = 500  # points of a new instance tested for overlap (evenly strided subset: the fraction to ~2%)


def box_margin(radius: float) -> float:
    """Return how far past a box a point may lie and still be within `radius` of a point in it (with room for
    rounding): the overlap test's box filters keep every such point."""
    return radius * (1.0 + 1e-6) + 1e-9


def query_points(points: np.ndarray) -> np.ndarray:
    """Return the points of an instance that the overlap test queries (all, or an evenly strided MAX_OVERLAP_QUERY)."""
    if len(points) > MAX_OVERLAP_QUERY:
        return points[np.linspace(0, len(points) - 1, MAX_OVERLAP_QUERY).astype(np.int64)]
    return points


class _Chunk:
    """Points a fused instance's overlap test searches, with their box; the search structures (a cell index for the
    compiled test, a KD-tree for scipy's) are built on the first query that reaches the box (many chunks are never
    searched: a query point outside the box has no neighbour there)."""

    __slots__ = ("data", "mins", "maxes", "box", "_tree", "_cells")

    def __init__(self, points: np.ndarray, bounds: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self.data = np.asarray(points, dtype=np.float64)
        if bounds is None:
            self.mins, self.maxes = axis_bounds(self.data)
        else:  # the points' own min and max, known: converting to float64 keeps the order, so they are the same
            self.mins, self.maxes = (np.asarray(b, dtype=np.float64) for b in bounds)
        self.box = (*self.mins.tolist(), *self.maxes.tolist())  # as floats: the per-query box test in plain Python
        self._tree = None
        self._cells = None

    @property
    def tree(self):  # noqa: ANN201 - scipy's cKDTree
        """Return the chunk's KD-tree (built once, on the points in their own order)."""
        if self._tree is None:
            from scipy.spatial import cKDTree

            # sliding-midpoint build: half the time of the balanced one, and the queries are as exact
            self._tree = cKDTree(self.data, balanced_tree=False, compact_nodes=False)
        return self._tree

    def cells(self, radius: float) -> tuple:
        """Return the cell index of `native.sdv_near_any` for `radius` as its arguments after the query's: (the
        points sorted by cell key (N, 3), their keys (N,), N, the grid's origin x, y, z, cell size h, cell counts
        nx, ny, nz), the arrays as addresses (kept alive here). Cells of h = 1.01 * radius, so that a point within
        the radius of a query lies in the query's cell or a neighbour whatever the rounding of the division."""
        if self._cells is None or self._cells[0] != radius:
            h = radius * 1.01
            data = np.ascontiguousarray(self.data)
            pts, keys, n = np.empty_like(data), np.empty(len(data), dtype=np.int64), np.zeros(3, dtype=np.int64)
            if native.library().sdv_cells(data.ctypes.data, len(data), *self.mins.tolist(), h, pts.ctypes.data,
                                          keys.ctypes.data, n.ctypes.data):
                raise MemoryError("fusion: out of memory building a chunk's cell index")
            args = (pts.ctypes.data, keys.ctypes.data, len(keys), *self.mins.tolist(), h, *n.tolist())
            self._cells = (radius, args, pts, keys)
        return self._cells[1]


def label_similarity(a: str, b: str, mode: str = "minilm") -> float:
    """Return the label term of fusion in [0, 1] (embedding cosine, or exact equality)."""
    if mode == "exact":
        return 1.0 if a == b else 0.0
    if mode != "minilm":
        raise ValueError(f"unknown label_similarity mode {mode!r} (minilm or exact)")
    if a == b:
        return 1.0
    e = embed_labels([a, b])
    return float(np.clip(e[0] @ e[1], 0.0, 1.0))


@dataclass
class _Fused:
    """A fused instance being built: a voxel map of its points plus what its detections brought.

    Points are kept as per-voxel sums and counts (merging is a sorted-key union, no re-sorting of
    points); the overlap test queries KD-trees of the chunks added since the last consolidation (each
    built on its first query), so a big instance (the floor) is not re-indexed on every view.
    """

    voxel: float
    keys: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    sums: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    counts: np.ndarray = field(default_factory=lambda: np.zeros(0))
    heights: np.ndarray = field(default_factory=lambda: np.zeros(0))  # per voxel: highest camera above it, m (NaN: unknown)
    confidences: list[float] = field(default_factory=list)
    views: list[int] = field(default_factory=list)
    label_votes: dict[str, float] = field(default_factory=dict)
    gt_votes: dict[int, int] = field(default_factory=dict)
    chunks: list[_Chunk] = field(default_factory=list)
    lo: np.ndarray = field(default_factory=lambda: np.full(3, np.inf))
    hi: np.ndarray = field(default_factory=lambda: np.full(3, -np.inf))
    _label: str | None = field(default=None, repr=False, compare=False)  # `label`, until the votes change
    _points: np.ndarray | None = field(default=None, repr=False, compare=False)  # `points`, until the voxels change
    _probe_world: tuple | None = field(default=None, repr=False, compare=False)  # `probe`'s world, likewise

    MAX_CHUNKS = 8

    @property
    def points(self) -> np.ndarray:
        """Return the voxel-mean points (world; read-only: kept until the voxel map changes)."""
        if self._points is None:  # read for every probe and merge of consolidation, and by a merge's chunk
            self._points = self.sums / self.counts[:, None]
            self._points.setflags(write=False)
        return self._points

    def probe(self) -> tuple[Instance, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Return this instance as consolidation tests it: an Instance of its points (as float32, centred at 0)
        and, for `InstanceFuser.best_match`, its (query points, world min, world max), kept until the voxel map
        changes. best_match reads an instance's world points only through `query_points`, which returns at most
        MAX_OVERLAP_QUERY points and leaves such a set as it is: keeping those few gives its answer, not a copy
        of every point."""
        inst = Instance(id=-1, label=self.label, points=self.points.astype(np.float32), center=np.zeros(3))
        if self._probe_world is None:
            p, lo, hi = _world(inst)
            self._probe_world = (np.ascontiguousarray(query_points(p)), lo, hi)
        return inst, self._probe_world

    @property
    def view_height(self) -> np.ndarray | None:
        """Return the per-voxel view heights (float32), or None when no constituent recorded any."""
        return None if np.isnan(self.heights).all() else self.heights.astype(np.float32)

    @property
    def label(self) -> str:
        """Return the label with the highest summed confidence (ties: alphabetical)."""
        if self._label is None:  # read for every candidate of every match; the votes change only in absorb/merge
            self._label = min(self.label_votes.items(), key=lambda kv: (-kv[1], kv[0]))[0]
        return self._label

    @property
    def gt_id(self) -> int:
        """Return the most frequent ground-truth id of the constituents."""
        return min(self.gt_votes.items(), key=lambda kv: (-kv[1], kv[0]))[0] if self.gt_votes else -1

    def overlap(self, points: np.ndarray, radius: float) -> float:
        """Return the fraction of `points` (`query_points` of them) within `radius` of this instance's points."""
        if len(points) == 0:
            return 0.0
        points = query_points(points)  # an evenly strided subset estimates the fraction
        lib = native.library()
        if lib is not None:
            return self._overlap_cells(lib, points, radius)
        todo = np.ones(len(points), dtype=bool)
        # A point farther than the radius from a chunk's box (on one axis) has no neighbour in that chunk:
        # it is not queried there (the margin keeps every point that could be within the radius). The boxes of
        # all chunks are tested at once; which chunk finds a point's neighbour first does not change the count.
        margin = box_margin(radius)
        mins = np.array([c.mins for c in self.chunks]).reshape(-1, 3)
        maxes = np.array([c.maxes for c in self.chunks]).reshape(-1, 3)
        inside = ((points[None] >= mins[:, None] - margin) & (points[None] <= maxes[:, None] + margin)).all(axis=2)
        for c in range(len(self.chunks) - 1, -1, -1):
            idx = np.flatnonzero(inside[c] & todo)
            if len(idx) == 0:
                continue
            d, _ = self.chunks[c].tree.query(points[idx], k=1, distance_upper_bound=radius)
            todo[idx[np.isfinite(d)]] = False
        return float(1.0 - np.count_nonzero(todo) / len(points))

    def _overlap_cells(self, lib, points: np.ndarray, radius: float) -> float:  # noqa: ANN001 - the ctypes library
        """`overlap` by the compiled cell search, the same count: a point the kernel finds well inside the radius
        cKDTree finds too (its leaf test is d < r*r on the same squared distance, and the roundings by which its
        pruning could pass over a leaf are some 1e-15 of r*r), one well outside it cannot find; the few within a
        relative 1e-9 of the radius are asked of the chunk's KD-tree, as before."""
        q = np.ascontiguousarray(points, dtype=np.float64)
        n = len(q)
        todo = np.ones(n, dtype=np.uint8)
        state = np.zeros(n, dtype=np.int8)
        r2 = radius * radius
        lo, hi = r2 * (1.0 - 1e-9), r2 * (1.0 + 1e-9)
        margin = box_margin(radius)
        q_lo, q_hi = axis_bounds(q)
        x0, y0, z0 = (q_lo - margin).tolist()
        x1, y1, z1 = (q_hi + margin).tolist()
        head = (q.ctypes.data, n, todo.ctypes.data, state.ctypes.data)
        near_any = lib.sdv_near_any
        unsure = []
        for chunk in reversed(self.chunks):
            bx0, by0, bz0, bx1, by1, bz1 = chunk.box
            if bx0 > x1 or by0 > y1 or bz0 > z1 or bx1 < x0 or by1 < y0 or bz1 < z0:
                continue  # no query point within the radius of the chunk's box
            if near_any(*head, *chunk.cells(radius), lo, hi):  # points without todo keep their state: see below
                unsure.append((chunk, np.flatnonzero(state == 2)))
        for chunk, idx in unsure:
            idx = idx[todo[idx] != 0]
            if len(idx):
                d, _ = chunk.tree.query(q[idx], k=1, distance_upper_bound=radius)
                todo[idx[np.isfinite(d)]] = 0
        return float(1.0 - np.count_nonzero(todo) / n)

    def merge(self, other: "_Fused") -> None:
        """Absorb another fused instance (points, votes, confidences)."""
        self._union(other.keys, other.sums, other.counts, other.heights)
        self.lo, self.hi = np.minimum(self.lo, other.lo), np.maximum(self.hi, other.hi)
        self.chunks = [_Chunk(self.points)]
        self.confidences.extend(other.confidences)
        self.views.extend(other.views)
        for k, v in other.label_votes.items():
            self.label_votes[k] = self.label_votes.get(k, 0.0) + v
        self._label = None
        for k, v in other.gt_votes.items():
            self.gt_votes[k] = self.gt_votes.get(k, 0) + v

    def _union(self, k: np.ndarray, s: np.ndarray, c: np.ndarray, h: np.ndarray | None = None) -> None:
        """Add voxel sums/counts and view heights `h` (sorted unique keys `k`; h None: unknown) to the map.

        Both key arrays are sorted and unique, so the union is a merge (no re-sort of the map): the new
        voxels are inserted in place, then the new sums added. A voxel's sum is old + new, as the
        bincount over the concatenation that this replaces gave (0 + old is old: a sum is never -0).
        """
        self._points = self._probe_world = None
        lib = native.library()
        if lib is not None and self.sums.dtype == np.float64 and self.counts.dtype == np.float64:
            self._union_compiled(lib, k, s, c, h)
            return
        old = self.keys
        pos = np.searchsorted(old, k)
        hit = pos < len(old)
        hit[hit] = old[pos[hit]] == k[hit]
        fresh = np.nonzero(~hit)[0]
        at = pos[fresh]  # each fresh key goes before old[at]; fresh keys ascend, so do their slots
        # a fresh key lands after its `at` old keys and the fresh keys before it; an old key moves right
        # by the number of fresh keys inserted at or before its index
        new_at = np.empty(len(k), dtype=np.int64)
        new_at[fresh] = at + np.arange(len(fresh))
        ph = pos[hit]
        new_at[hit] = ph + np.searchsorted(at, ph, side="right")
        if len(fresh):  # np.insert's result for the four arrays, the slots computed once
            n = len(old) + len(fresh)
            moved = np.arange(len(old))
            moved += np.searchsorted(at, moved, side="right")
            keys = np.empty(n, dtype=old.dtype)
            keys[moved] = old
            keys[new_at[fresh]] = k[fresh]
            sums = np.zeros((n,) + self.sums.shape[1:], dtype=self.sums.dtype)
            sums[moved] = self.sums
            counts = np.zeros(n, dtype=self.counts.dtype)
            counts[moved] = self.counts
            heights = np.full(n, np.nan, dtype=self.heights.dtype)
            heights[moved] = self.heights
            self.keys, self.sums, self.counts, self.heights = keys, sums, counts, heights
        self.sums[new_at] += s
        self.counts[new_at] += c
        if h is not None:  # a voxel was seen from as high as its highest observation (fmax: NaN is unknown)
            self.heights[new_at] = np.fmax(self.heights[new_at], h)

    def _union_compiled(self, lib, k: np.ndarray, s: np.ndarray, c: np.ndarray,  # noqa: ANN001 - ctypes library
                        h: np.ndarray | None) -> None:
        """`_union` in one compiled merge pass (`native.sdv_union`): the same arrays, the same additions."""
        ok = np.ascontiguousarray(self.keys, dtype=np.int64)
        os_, oc, oh = (np.ascontiguousarray(a, dtype=np.float64) for a in (self.sums, self.counts, self.heights))
        nk = np.ascontiguousarray(k, dtype=np.int64)
        ns = np.ascontiguousarray(s, dtype=np.float64).reshape(-1, 3)
        nc = np.ascontiguousarray(c, dtype=np.float64)
        cap = len(ok) + len(nk)
        uk, us = np.empty(cap, dtype=np.int64), np.empty((cap, 3))
        uc, uh, new_at = np.empty(cap), np.empty(cap), np.empty(len(nk), dtype=np.int64)
        n = lib.sdv_union(ok.ctypes.data, os_.ctypes.data, oc.ctypes.data, oh.ctypes.data, len(ok), nk.ctypes.data,
                          ns.ctypes.data, nc.ctypes.data, len(nk), uk.ctypes.data, us.ctypes.data, uc.ctypes.data,
                          uh.ctypes.data, new_at.ctypes.data)
        self.keys, self.sums, self.counts, self.heights = uk[:n], us[:n], uc[:n], uh[:n]
        if h is not None:  # as in `_union`
            self.heights[new_at] = np.fmax(self.heights[new_at], h)

    def absorb(self, inst: Instance, world: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> None:
        """Merge a new instance's points (voxel union) and bookkeeping.

        ``world``, when given, is the instance's (world points, their min, their max) already computed.
        """
        p, plo, phi = world if world is not None else _world(inst)
        vh = inst.view_height
        if vh is not None and len(vh) != len(p):
            raise ValueError(f"instance {inst.id} ({inst.label}): {len(vh)} view heights for {len(p)} points")
        k, s, c, h = voxel_stats(p, self.voxel, vh)
        self._union(k, s, c, h)
        self.lo = np.minimum(self.lo, plo)
        self.hi = np.maximum(self.hi, phi)
        if len(self.chunks) >= self.MAX_CHUNKS:
            self.chunks = [_Chunk(self.points)]
        self.chunks.append(_Chunk(p, (plo, phi)))
        self.confidences.extend(float(x) for x in inst.confidences)
        self.views.extend(int(v) for v in inst.source_views)
        w = float(sum(inst.confidences)) if inst.confidences else 1.0
        self.label_votes[inst.label] = self.label_votes.get(inst.label, 0.0) + w
        self._label = None
        self.gt_votes[int(inst.gt_id)] = self.gt_votes.get(int(inst.gt_id), 0) + 1


def _world(inst: Instance) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return an instance's world points (N, 3) and their per-axis min and max (3,)."""
    p = inst.world_points
    return (p, *axis_bounds(p))


class InstanceFuser:
    """Incremental fusion: feed instances view by view, read the fused instances at the end."""

    def __init__(self, cfg: PerceiveConfig) -> None:
        self.cfg = with_fusion_preset(cfg)
        self.fused: list[_Fused] = []
        self._sem: dict[tuple[str, str], float] = {}

    def _label_sim(self, a: str, b: str) -> float:
        key = (a, b) if a <= b else (b, a)
        if key not in self._sem:
            self._sem[key] = label_similarity(a, b, self.cfg.label_similarity)
        return self._sem[key]

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the fused instances' box corners (F, 3) each (read once per view or consolidation)."""
        if not self.fused:
            return np.zeros((0, 3)), np.zeros((0, 3))
        # one concatenation of the (3,) corners: the values of np.array over the list, without its per-item discovery
        return (np.concatenate([f.lo for f in self.fused]).reshape(-1, 3),
                np.concatenate([f.hi for f in self.fused]).reshape(-1, 3))

    def _near(self, inst: Instance, world: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
              bounds: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
        """Return the instance's world points and the mask of the fused instances whose boxes come within the
        overlap radius of its box (the others have phi -inf)."""
        p, p_lo, p_hi = world if world is not None else _world(inst)
        lo, hi = p_lo - self.cfg.overlap_radius, p_hi + self.cfg.overlap_radius
        flo, fhi = bounds if bounds is not None else self._bounds()
        return p, ~boxes_apart(flo, fhi, lo, hi)

    def similarity(self, inst: Instance, world: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                   bounds: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """Return phi(inst, j) for every fused j (-inf where the boxes are too far apart to overlap).

        ``world``, when given, is the instance's (world points, their min, their max) already computed;
        ``bounds`` the fused boxes (`_bounds`) of the map as it is.
        """
        cfg = self.cfg
        phi = np.full(len(self.fused), -np.inf)
        if not self.fused:
            return phi
        p, near = self._near(inst, world, bounds)
        for j in np.nonzero(near)[0]:
            f = self.fused[j]
            geo = f.overlap(p, cfg.overlap_radius)
            sem = self._label_sim(inst.label, f.label)
            phi[j] = cfg.k_sem * sem + cfg.k_geo * geo
        return phi

    def best_match(self, inst: Instance, world: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                   bounds: tuple[np.ndarray, np.ndarray] | None = None, allowed: np.ndarray | None = None) -> int:
        """Return the fused j with the highest phi(inst, j) (the first of equals) if it reaches phi_min, else -1.

        The same answer as thresholding the argmax of `similarity` (over the ``allowed`` mask, when given), with
        fewer overlap tests: phi(inst, j) <= k_sem * label + k_geo * `_overlap_bounds`, so the candidates are
        tested in order of that bound and the search stops at the first whose bound is below phi_min or below the
        best phi found (floating-point sums and products are monotone: the bound holds exactly).
        """
        cfg = self.cfg
        if not self.fused:
            return -1
        if bounds is None:
            bounds = self._bounds()
        p, near = self._near(inst, world, bounds)
        if allowed is not None:
            near &= allowed
        cands = np.nonzero(near)[0]
        if len(cands) == 0:
            return -1
        q = query_points(p)
        sems = [self._label_sim(inst.label, self.fused[j].label) for j in cands]
        bound = np.array([cfg.k_sem * sem + cfg.k_geo * b
                          for sem, b in zip(sems, self._overlap_bounds(q, cands, bounds))])
        best_j, best = -1, -np.inf
        for k in np.lexsort((cands, -bound)):  # highest bound first, then lowest index
            if bound[k] < max(best, cfg.phi_min):
                break
            j = int(cands[k])
            phi = cfg.k_sem * sems[k] + cfg.k_geo * self.fused[j].overlap(q, cfg.overlap_radius)
            if phi > best or (phi == best and j < best_j):
                best_j, best = j, phi
        return best_j if best >= cfg.phi_min else -1

    def _overlap_bounds(self, q: np.ndarray, cands: np.ndarray, bounds: tuple[np.ndarray, np.ndarray]) -> list[float]:
        """Return, per candidate fused instance, an upper bound on its `_Fused.overlap` of the query points `q`: the
        fraction of them within its box (from `bounds`, the map's `_bounds`) widened by the overlap test's margin (a
        point outside it is outside every chunk's box), all candidates tested at once."""
        if len(q) == 0:
            return [0.0] * len(cands)
        margin = box_margin(self.cfg.overlap_radius)
        lo = bounds[0][cands] - margin
        hi = bounds[1][cands] + margin
        inside = (q[:, 0] >= lo[:, 0, None]) & (q[:, 0] <= hi[:, 0, None])  # (candidates, points), axis by axis
        for d in (1, 2):
            inside &= (q[:, d] >= lo[:, d, None]) & (q[:, d] <= hi[:, d, None])
        return [float(1.0 - int(len(q) - n) / len(q)) for n in np.count_nonzero(inside, axis=1)]

    def add_view(self, instances: list[Instance]) -> list[int]:
        """Associate one view's instances with the map as it was before the view; return the fused index of each."""
        if self.cfg.label_similarity == "minilm":
            embed_labels(sorted({i.label for i in instances} | {f.label for f in self.fused}))
        worlds = [_world(inst) for inst in instances]
        bounds = self._bounds() if self.fused else None  # the map before the view
        matches = [self.best_match(inst, w, bounds) for inst, w in zip(instances, worlds)]
        out = []
        for inst, j, w in zip(instances, matches, worlds):
            if j < 0:
                self.fused.append(_Fused(voxel=self.cfg.voxel_size))
                j = len(self.fused) - 1
            self.fused[j].absorb(inst, w)
            out.append(j)
        return out

    def consolidate(self) -> int:
        """Merge fused instances into one another with the same test (fragments whose link was seen later); return merges.

        Pass after pass, the smallest instance that has a bigger one to merge into merges, and the pass starts
        again. An instance found with none keeps that finding until a merge grows an instance near it: nothing
        else its test reads changes (its own points and label, the other instances' points, labels and boxes, the
        order of sizes and indices among them), so every other candidate still scores below phi_min and the re-test
        asks the grown instances alone, which gives the answer of a full test. The grown instance itself is tested
        anew in full. A house fuses a thousand instances.
        """
        merges = 0
        changed = True
        settled: dict[int, _Fused] = {}  # id -> instances with nothing to merge into, in the map as it is
        recheck: dict[int, list[_Fused]] = {}  # id of a settled one -> instances grown near it since (held: live ids)
        r = self.cfg.overlap_radius
        # the instances' sizes and boxes, kept in step with the list: a merge changes the target's, drops the merged
        sizes = np.array([len(f.keys) for f in self.fused], dtype=np.int64)
        bounds = self._bounds()
        while changed and len(self.fused) > 1:
            changed = False
            index = np.arange(len(self.fused))
            order = np.lexsort((index, sizes)).tolist()  # smallest first, then lowest index
            where = {id(f): k for k, f in enumerate(self.fused)}
            for i in order:
                small = self.fused[i]
                key = id(small)
                only = None
                if key in settled:
                    grown = sorted({where[id(g)] for g in recheck.get(key, ()) if id(g) in where})
                    if not grown:
                        continue
                    only = np.zeros(len(self.fused), dtype=bool)
                    only[grown] = True
                probe, world = small.probe()
                # Only merge into a bigger instance (never itself), so every pass strictly shrinks the list.
                allowed = (sizes > sizes[i]) | ((sizes == sizes[i]) & (index > i))
                if only is not None:
                    allowed &= only
                j = self.best_match(probe, world, bounds=bounds, allowed=allowed)
                if j >= 0:
                    target = self.fused[j]
                    target.merge(small)
                    del self.fused[i]
                    sizes[j] = len(target.keys)
                    bounds[0][j], bounds[1][j] = target.lo, target.hi
                    sizes = np.delete(sizes, i)
                    bounds = (np.delete(bounds[0], i, axis=0), np.delete(bounds[1], i, axis=0))
                    merges += 1
                    changed = True
                    settled.pop(key, None)
                    recheck.pop(key, None)
                    settled.pop(id(target), None)  # the grown instance: a full test
                    recheck.pop(id(target), None)
                    lo, hi = target.lo - 2 * r, target.hi + 2 * r  # whose test may now find the grown instance
                    if settled:
                        keys = list(settled)
                        slo = np.concatenate([settled[k].lo for k in keys]).reshape(-1, 3)
                        shi = np.concatenate([settled[k].hi for k in keys]).reshape(-1, 3)
                        for n in np.flatnonzero(~boxes_apart(slo, shi, lo, hi)):
                            recheck.setdefault(keys[n], []).append(target)
                    break
                settled[key] = small
                recheck.pop(key, None)
        return merges

    def instances(self) -> list[Instance]:
        """Return the fused instances with at least min_points points, ids 0..n-1 in creation order."""
        self.consolidate()
        out = []
        for f in self.fused:
            if len(f.keys) < self.cfg.min_points:
                continue
            out.append(make_instance(f.points, f.label, f.confidences, f.views, f.gt_id, len(out), view_height=f.view_height))
        return out


def fuse_instances(instances: list[Instance], cfg: PerceiveConfig) -> list[Instance]:
    """Fuse per-view instances into scene instances (views associated in order of first appearance)."""
    fuser = InstanceFuser(cfg)
    order: list[int] = []
    by_view: dict[int, list[Instance]] = {}
    for inst in instances:
        v = int(inst.source_views[0]) if inst.source_views else -1
        if v not in by_view:
            by_view[v] = []
            order.append(v)
        by_view[v].append(inst)
    for v in order:
        fuser.add_view(by_view[v])
    return fuser.instances()
