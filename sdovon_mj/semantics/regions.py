"""Region map (paper section 3.4): sliding-window region proposals over top-down instances.

Fused instances of one floor are projected top-down. A circular window of radius r slides over the
floor's NavMap grid with step d (centres at integer multiples of d in world XY). With
``window_walls`` (default) walls cut a window: it covers only the cells connected to its centre
through floor space (free/navigable cells plus the cells under instances), so a window never
mixes two rooms except through a doorway; without it, the window is the paper's plain disc. The
distinct labels of the instances with a point in the window go to the backend's region-proposal
question (identical label sets are asked once; structure labels such as wall/floor are left out).
The k-th proposal (0-based) of a window votes 1/(k+1)^2 for the window's cells, times
(1 - (dist/r)^2) so that a window speaks loudest about its centre. With ``region_votes = walking``
(default) ``dist`` is the walking distance from the centre over the floor space (`gridgraph`, the one
geodesic; 8-connected, no corner cutting) and the window is the cells within r walk: a room behind a
doorway is reached only by the path through it, so its cells get little or no vote and its furniture
stays out of the window's labels; with ``euclidean`` it is the straight-line distance (the window
still cut by walls when ``window_walls``). Without ``window_walls`` (the paper's plain disc) votes are
always euclidean. The per-cell sum is the
``scores`` volume; its argmax the label map. Cells no window reached are filled from the nearest
labelled cell when they are floor (free) or within r of it.
"""

from __future__ import annotations

import dataclasses
import io
import re
from functools import lru_cache
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ..config import SemanticsConfig
from ..records import Instance, NavMap, ReceptaclePlane, RegionMap, Room
from ..store import atomic_write_bytes
from .backends import Backend
from .priors import default_priors
from .validate import normalise

MAX_POINTS_PER_INSTANCE = 256
FLOOR_BAND = (-0.2, 2.6)  # instance z range (relative to the floor height) that belongs to a floor
DOORWAY_HALF = 0.55  # m: floor space eroded by this much parts at doorways (up to 1.1 m clear), joined elsewhere
MIN_ROOM_AREA = 0.5  # m^2 of eroded floor space that counts as a room (a room of about 1.8 m x 1.8 m or more)

# Words of node and part names that say nothing about which room a thing stands in. Artists and exporters name
# pieces by their primitive ("Cube.012", "Cylinder"), their part of a fixture ("Fridge_Body", "Island_Top",
# "cabinet_door_link", "hinge_joint"), where they sit ("Upper_Cabinet", "left"), what they are made of
# ("Countertop_Marble") and a number ("Shelf_03"). Such words go before the region question; a label of nothing
# else is no evidence at all (a "cube" would vote for the playroom a Rubik's cube belongs in).
PRIMITIVE_WORDS = frozenset({
    "box", "cube", "cuboid", "cylinder", "sphere", "capsule", "plane", "mesh", "geom", "geometry", "ellipsoid", "cone",
    "torus", "prism", "primitive", "shape", "quad", "collision", "visual", "col", "vis", "obj", "object", "model",
    "node", "group", "instance", "inst", "part", "piece", "default", "untitled", "empty", "proxy", "lod", "polysurface",
    "polygon", "poly", "solid", "brep", "component", "assembly", "asm"})
PART_WORDS = frozenset({
    "body", "door", "doors", "handle", "handles", "knob", "knobs", "base", "top", "lid", "leg", "legs", "frame",
    "panel", "panels", "link", "joint", "hinge", "slide", "rail", "rails", "seat", "back", "arm", "arms", "surface",
    "board", "boards", "trim", "cover", "bracket", "mount", "plinth", "kick", "toe", "shell", "carcass", "case", "front"})
POSITION_WORDS = frozenset({
    "left", "right", "upper", "lower", "bottom", "middle", "center", "centre", "inner", "outer", "side", "l", "r",
    "lt", "rt", "up", "down", "main", "mid", "small", "large", "big", "tall", "short", "wide", "long", "new", "old"})
MATERIAL_WORDS = frozenset({
    "marble", "wood", "wooden", "metal", "metallic", "steel", "stainless", "glass", "plastic", "granite", "stone",
    "oak", "walnut", "pine", "chrome", "ceramic", "fabric", "leather", "concrete", "brass", "white", "black", "grey",
    "gray", "dark", "beige", "mat", "matte", "glossy", "material", "mtl", "tex", "texture"})
NOISE_WORDS = PRIMITIVE_WORDS | PART_WORDS | POSITION_WORDS | MATERIAL_WORDS


def rank_weight(k: int) -> float:
    """Return the vote of the k-th (0-based) region proposal of a window."""
    return 1.0 / (k + 1.0) ** 2


@lru_cache(maxsize=1)
def _vocabulary() -> frozenset[str]:
    """Return the words of the priors' labels and synonyms and the noise words (for splitting run-together words)."""
    pri = default_priors()
    words = {w for name in list(pri.labels) + list(pri.synonyms) for w in normalise(name).split(" ") if len(w) > 1}
    return frozenset(words | NOISE_WORDS)


def _segment(token: str, vocab: frozenset[str]) -> list[str]:
    """Split a run-together token into the fewest vocabulary words ('hingecabinet' -> hinge cabinet); [token] when
    it is a word itself, short, or cannot be split wholly into words of two letters or more."""
    if token in vocab or len(token) < 6:
        return [token]
    best: list[list[str] | None] = [[]] + [None] * len(token)
    for end in range(2, len(token) + 1):
        for start in range(max(0, end - 16), end - 1):
            prev, piece = best[start], token[start:end]
            if prev is not None and piece in vocab and (best[end] is None or len(prev) + 1 < len(best[end])):
                best[end] = prev + [piece]
    return best[-1] or [token]


@lru_cache(maxsize=8192)
def room_label(label: str) -> str:
    """Return what an instance label says about the room it stands in: the label itself when the priors know it as
    written, else its words with naming noise taken out ('' when nothing is left, e.g. 'Cube.012').

    Noise, whatever model the names come from: camel case and separators (``HingeCabinet``, ``fridge_body``),
    numbering (``Shelf_03``, ``stool2``), words run together (``slidecabinet`` -> slide cabinet, split on the
    priors' vocabulary), and words that name a primitive, a part, a joint or link, a position or a material
    (`NOISE_WORDS`); a building word (wall, floor, door, ...) next to another word only places that thing (``shelf
    wall`` -> shelf, ``floor lamp`` -> lamp). What is left and still unknown goes to the backend as it is: the
    offline backend falls back on sentence embeddings (its k nearest known labels) for unknown words.
    """
    spaced = re.sub(r"(?<=[a-z])(?=[A-Z])|(?<=[A-Z])(?=[A-Z][a-z])", " ", str(label))
    n = normalise(spaced)
    pri = default_priors()
    if not n or pri._lookup(n) is not None:
        return n
    vocab = _vocabulary()
    words = [p for w in re.sub(r"[\d/]+", " ", n).split() for p in _segment(w, vocab)]
    structure = {w for w in words if _is_structure(w)}
    content = [w for w in words if w not in NOISE_WORDS and w not in structure]
    if content:
        return " ".join(content)
    kept = [w for w in words if w in structure]
    return " ".join(dict.fromkeys(kept))  # only building words (a structure label) or nothing at all


def floor_space(instances: Sequence[Instance], navmap: NavMap) -> np.ndarray:
    """Return the floor's space (H, W): free or navigable cells, the cells under the instances standing on it, and
    what they enclose (a table's footprint between the points seen of it: furniture stands in a room, not a wall)."""
    h, w = navmap.navigable.shape
    space = np.asarray(navmap.free, dtype=bool) | np.asarray(navmap.navigable, dtype=bool)
    pts, _idx = _points_xy(instances)
    if len(pts):
        pc = navmap.frame.to_cell(pts)
        ok = (pc[:, 0] >= 0) & (pc[:, 0] < h) & (pc[:, 1] >= 0) & (pc[:, 1] < w)
        space[pc[ok, 0], pc[ok, 1]] = True
    return ndimage.binary_fill_holes(space)


def room_count(space: np.ndarray, resolution: float) -> int:
    """Return how many rooms a floor's space holds: its parts once eroded by `DOORWAY_HALF` (doorways close, rooms
    stay), counting those of at least `MIN_ROOM_AREA` (corridor ends and closets do not count)."""
    r = int(np.ceil(DOORWAY_HALF / resolution))
    if r <= 0 or not space.any():
        return int(space.any())
    inner = ndimage.distance_transform_edt(np.pad(space, 1)) [1:-1, 1:-1] > r
    comp, n = ndimage.label(inner)
    if n == 0:
        return 1  # nothing survives the erosion: a room smaller than a doorway is one room
    areas = np.bincount(comp.ravel())[1:] * resolution * resolution
    return max(1, int(np.sum(areas >= MIN_ROOM_AREA)))


def floor_instances(instances: Sequence[Instance], navmap: NavMap) -> list[Instance]:
    """Return the instances that stand on the NavMap's floor."""
    out = []
    for inst in instances:
        b = inst.bounds
        if b[1, 2] > navmap.height + FLOOR_BAND[0] and b[0, 2] < navmap.height + FLOOR_BAND[1]:
            out.append(inst)
    return out


def _points_xy(instances: Sequence[Instance]) -> tuple[np.ndarray, np.ndarray]:
    """Return top-down points (M, 2) and their instance index (M,), at most a few hundred per instance."""
    pts, idx = [], []
    for k, inst in enumerate(instances):
        p = inst.world_points[:, :2]
        if len(p) == 0:
            continue
        if len(p) > MAX_POINTS_PER_INSTANCE:
            p = p[np.linspace(0, len(p) - 1, MAX_POINTS_PER_INSTANCE).astype(int)]
        pts.append(p)
        idx.append(np.full(len(p), k))
    if not pts:
        return np.zeros((0, 2)), np.zeros(0, dtype=int)
    return np.concatenate(pts), np.concatenate(idx)


def window_centres(navmap: NavMap, step: float) -> np.ndarray:
    """Return window centres (N, 2): multiples of `step` in world XY covering the map."""
    h, w = navmap.navigable.shape
    x0, y0 = float(navmap.origin[0]), float(navmap.origin[1])
    x1, y1 = x0 + w * navmap.resolution, y0 + h * navmap.resolution
    xs = np.arange(np.ceil(x0 / step), np.floor(x1 / step) + 1) * step
    ys = np.arange(np.ceil(y0 / step), np.floor(y1 / step) + 1) * step
    gx, gy = np.meshgrid(xs, ys)
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def window_labels(instances: Sequence[Instance], centres: np.ndarray, radius: float) -> list[tuple[str, ...]]:
    """Return, per window (plain disc), the sorted distinct labels of instances with a point inside it."""
    pts, idx = _points_xy(instances)
    if len(pts) == 0:
        return [() for _ in range(len(centres))]
    tree = cKDTree(pts)
    labels = [normalise(inst.label) for inst in instances]
    out = []
    for hits in tree.query_ball_point(centres, r=radius):
        out.append(tuple(sorted({labels[i] for i in idx[hits]} - {""})))
    return out


def _is_structure(label: str) -> bool:
    """Return whether a label names building structure (wall, floor, ceiling, window, door)."""
    pri = default_priors()
    key = pri.resolve(label, embed=False)
    if key is None:
        key = pri.resolve(normalise(label).split(" ")[-1], embed=False)
    return key is not None and pri.labels[key].get("kind") == "structure"


def _windows(insts: Sequence[Instance], navmap: NavMap, r: float, d: float, walls: bool, walking: bool = False
             ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, tuple[str, ...]]]:
    """Return per window: covered rows, cols, centre weights (1 - (dist/r)^2) and its distinct labels.

    ``walking``: dist is the walking distance over the floor space (the window: cells within r walk).
    """
    h, w = navmap.navigable.shape
    res = float(navmap.resolution)
    pts, idx = _points_xy(insts)
    pc = navmap.frame.to_cell(pts) if len(pts) else np.zeros((0, 2), dtype=int)
    ok = (pc[:, 0] >= 0) & (pc[:, 0] < h) & (pc[:, 1] >= 0) & (pc[:, 1] < w)
    pc, idx = pc[ok], idx[ok]
    pflat = pc[:, 0] * w + pc[:, 1]
    labels = np.array([normalise(i.label) for i in insts] + [""], dtype=object)
    space = np.asarray(navmap.free, dtype=bool) | np.asarray(navmap.navigable, dtype=bool)
    space[pc[:, 0], pc[:, 1]] = True  # furniture stands in the room: its cells join the room's space
    rc = int(np.ceil(r / res))
    oy, ox = np.mgrid[-rc : rc + 1, -rc : rc + 1]
    out = []
    centres = window_centres(navmap, d)
    if walking:
        return _walking_windows(navmap, space, centres, r, pflat, idx, labels)
    for (ci, cj), c_xy in zip(navmap.frame.to_cell(centres), centres):
        rows, cols = ci + oy, cj + ox
        cell_xy = navmap.frame.to_world(np.stack([rows.ravel(), cols.ravel()], axis=1))
        dist2 = (np.sum((cell_xy - c_xy) ** 2, axis=1) / (r * r)).reshape(rows.shape)
        inside = (dist2 <= 1.0) & (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        if walls:
            if not (0 <= ci < h and 0 <= cj < w) or not space[ci, cj]:
                continue  # centred on a wall or outside: no window
            m = inside.copy()
            m[inside] = space[rows[inside], cols[inside]]
            comp, _n = ndimage.label(m)
            inside = comp == comp[rc, rc]
        rr, cc = rows[inside], cols[inside]
        if len(rr) == 0:
            continue
        hit = np.isin(pflat, rr * w + cc)
        labs = tuple(sorted(set(labels[idx[hit]]) - {""}))
        out.append((rr, cc, 1.0 - dist2[inside], labs))
    return out


WALK_BATCH = 16  # window centres per Dijkstra call (16 distance rows of the floor's cells at a time)


def _walking_windows(navmap: NavMap, space: np.ndarray, centres: np.ndarray, r: float, pflat: np.ndarray,
                     idx: np.ndarray, labels: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, tuple[str, ...]]]:
    """Return the windows of `_windows` with walking distance: cells within r walk of the centre, weight 1 - (walk/r)^2.

    Parameters
    ----------
    navmap : NavMap
        The floor's map (grid frame, resolution in m per cell).
    space : ndarray of bool, shape (H, W)
        Floor space: free or navigable cells and the cells under instances.
    centres : ndarray, shape (N, 2)
        Window centres, world XY (m).
    r : float
        Window radius (m of walk).
    pflat, idx : ndarray, shape (M,)
        Flat cell index of each instance point and the index of its instance.
    labels : ndarray of str, shape (n_instances + 1,)
        Normalised instance labels ('' last).
    """
    h, w = space.shape
    res = float(navmap.resolution)
    # the instances standing on each cell, once: (cell, instance) pairs instead of every point per window
    pairs = np.unique(pflat.astype(np.int64) * (len(labels) + 1) + idx)
    pair_cell, pair_inst = pairs // (len(labels) + 1), pairs % (len(labels) + 1)
    cells = np.array([ci * w + cj for ci, cj in navmap.frame.to_cell(centres)
                      if 0 <= ci < h and 0 <= cj < w and space[ci, cj]], dtype=np.int64)  # a wall or outside: none
    out = []
    in_window = np.zeros(h * w, dtype=bool)
    for flat, dist in _walk_reach(space, cells, r / res + 1e-9):
        dist = dist * res
        keep = dist <= r
        flat, dist = flat[keep], dist[keep]
        rr, cc = flat // w, flat % w
        in_window[flat] = True
        labs = tuple(sorted(set(labels[pair_inst[in_window[pair_cell]]]) - {""}))
        in_window[flat] = False
        out.append((rr, cc, 1.0 - (dist / r) ** 2, labs))
    return out


def _walk_reach(space: np.ndarray, cells: np.ndarray, limit: float) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Yield, per start cell (flat index on `space`), the cells its walk reaches within `limit` cells (flat indices,
    ascending: the cell graph's node order) and their distances in cells: scipy's Dijkstra with ``limit`` on the
    floor's cell graph. Compiled where available (native ``sdv_grid_reach``: the same values, see
    `gridgraph.grid_distances`, and only the cells reached are touched), else scipy, WALK_BATCH starts per call (it
    checks and converts the graph once per call, then runs each start on its own)."""
    from .. import native

    lib = native.library()
    if lib is not None:
        mask = np.ascontiguousarray(space, dtype=np.uint8)
        h, w = mask.shape
        scratch = np.full(h * w, np.inf)
        n = int(mask.sum())
        reached, dist = np.empty(n, dtype=np.int64), np.empty(n)
        for start in cells.tolist():
            k = lib.sdv_grid_reach(mask.ctypes.data, h, w, start, float(limit), scratch.ctypes.data,
                                   reached.ctypes.data, dist.ctypes.data)
            if k < 0:
                raise MemoryError("walking windows: out of memory")
            order = np.argsort(reached[:k], kind="stable")
            yield reached[:k][order], dist[:k][order]
        return
    from scipy.sparse.csgraph import dijkstra

    from ..gridgraph import graph_of

    g, index = graph_of(space)
    nodes = np.flatnonzero(np.asarray(space).reshape(-1))  # node k's flat cell
    flat_index = index.reshape(-1)
    for b in range(0, len(cells), WALK_BATCH):
        rows = dijkstra(g, directed=True, indices=flat_index[cells[b : b + WALK_BATCH]], limit=limit)
        for d in rows.reshape(-1, g.shape[0]):
            ok = np.isfinite(d)
            yield nodes[ok], d[ok]


class _Vocab:
    """Region label vocabulary: the configured names first, new open-vocabulary names appended."""

    def __init__(self, names: Sequence[str]) -> None:
        self.names: list[str] = []
        self.index: dict[str, int] = {}
        for n in names:
            self._add(normalise(n))
        self._canon = {}
        pri = default_priors()
        for n in list(self.names):
            c = pri.resolve_region(n)
            if c is not None and c not in self._canon:
                self._canon[c] = self.index[n]

    def _add(self, n: str) -> int:
        if n not in self.index:
            self.index[n] = len(self.names)
            self.names.append(n)
        return self.index[n]

    def lookup(self, proposal: str) -> int | None:
        """Return the vocabulary index of a proposal (adding an unknown region name)."""
        n = normalise(proposal)
        if not n:
            return None
        if n in self.index:
            return self.index[n]
        c = default_priors().resolve_region(n)
        if c is not None:
            if c in self._canon:
                return self._canon[c]
            i = self._add(c)
            self._canon[c] = i
            return i
        return self._add(n)


def region_map(instances: Sequence[Instance], navmap: NavMap, backend: Backend,
               cfg: SemanticsConfig | None = None) -> RegionMap:
    """Return the dense region map of the NavMap's floor from the instances standing on it."""
    cfg = cfg or SemanticsConfig()
    r, d = float(cfg.window_radius), float(cfg.window_step)
    if r <= 0 or d <= 0:
        raise ValueError(f"window radius and step must be positive (got r={r}, d={d})")
    on_floor = floor_instances(instances, navmap)
    insts = [i if room_label(i.label) == normalise(i.label) else dataclasses.replace(i, label=room_label(i.label))
             for i in on_floor]
    insts = [i for i in insts if i.label and not _is_structure(i.label)]  # naming noise alone is no evidence
    windows = _windows(insts, navmap, r, d, bool(cfg.window_walls), walking=cfg.region_votes == "walking" and bool(cfg.window_walls))
    vocab = _Vocab(cfg.region_labels)
    n_fb = len(backend.fallbacks)
    answers: dict[tuple[str, ...], list[int]] = {}
    for s in sorted({win[3] for win in windows}):
        if not s:
            continue
        props = backend.propose_regions(list(s), list(cfg.region_labels))
        idx: list[int] = []
        for p in props:
            i = vocab.lookup(p)
            if i is not None and i not in idx:
                idx.append(i)
        answers[s] = idx

    h, w = navmap.navigable.shape
    res = float(navmap.resolution)
    n_lab = len(vocab.names)
    scores = np.zeros((h, w, max(n_lab, 1)), dtype=np.float64)
    for rr, cc, wgt, s in windows:
        for k, lab in enumerate(answers.get(s) or []):
            scores[rr, cc, lab] += wgt * rank_weight(k)

    total = scores.sum(axis=2)
    label_map = np.where(total > 0, np.argmax(scores, axis=2), -1).astype(np.int16)
    if total.any() and room_count(floor_space(insts, navmap), res) == 1:
        # one room (a kitchen with no wall between its parts): one region, the label with the most votes over it
        label_map[total > 0] = int(np.argmax(scores.reshape(-1, scores.shape[2]).sum(axis=0)))
    known = label_map >= 0
    if known.any():
        free = np.asarray(navmap.free, dtype=bool) | np.asarray(navmap.navigable, dtype=bool)
        near_free = ndimage.distance_transform_edt(~free) * res <= r
        todo = ~known & near_free
        if todo.any():
            _dist, (ii, jj) = ndimage.distance_transform_edt(~known, return_indices=True)
            label_map[todo] = label_map[ii[todo], jj[todo]]
    return RegionMap(
        floor=int(navmap.floor), origin=np.asarray(navmap.origin, dtype=np.float64).copy(), resolution=res,
        labels=list(vocab.names), label_map=label_map, scores=scores[:, :, :n_lab].astype(np.float32),
        backend=backend.label, fallbacks=list(backend.fallbacks[n_fb:]),
    )


def input_region_map(rooms: Sequence[Room], navmap: NavMap) -> RegionMap:
    """Return the region map of the NavMap's floor from the input's region annotations (``semantics.regions=input``).

    Each cell takes the type of the room (`SceneAsset.rooms`: HM3D/MP3D regions, Habitat ``region_annotations``,
    the default world's rooms) whose polygon holds its centre; cells in no room are -1 (unknown). Scores are one-hot.
    Raises ValueError when no room lies on this floor.
    """
    from ..geometry import points_in_polygon

    mine = [r for r in rooms if int(r.floor) == int(navmap.floor)]
    if not mine:
        raise ValueError(f"semantics.regions=input, but the scene has no region annotations on floor {navmap.floor} "
                         f"({len(rooms)} on other floors); use semantics.regions=window")
    labels = sorted({str(r.type) for r in mine})
    frame = navmap.frame
    h, w = frame.shape
    ii, jj = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    xy = frame.to_world(np.stack([ii.ravel(), jj.ravel()], axis=1))
    label_map = np.full(h * w, -1, dtype=np.int16)
    for r in mine:
        label_map[(label_map < 0) & points_in_polygon(np.asarray(r.polygon, dtype=float), xy)] = labels.index(str(r.type))
    label_map = label_map.reshape(h, w)
    scores = np.zeros((h, w, len(labels)), dtype=np.float32)
    known = label_map >= 0
    scores[known, label_map[known]] = 1.0
    return RegionMap(floor=int(navmap.floor), origin=np.asarray(navmap.origin, dtype=np.float64).copy(),
                     resolution=float(navmap.resolution), labels=labels, label_map=label_map, scores=scores,
                     backend="input")


PALETTE = np.array([
    [230, 159, 0], [86, 180, 233], [0, 158, 115], [240, 228, 66], [0, 114, 178], [213, 94, 0], [204, 121, 167],
    [120, 120, 200], [160, 200, 120], [200, 120, 120], [120, 200, 200], [200, 200, 120],
], dtype=np.uint8)


def region_picture(rmap: RegionMap, path: str | Path, navmap: NavMap | None = None, scale: int = 4) -> Path:
    """Write a PNG of the region map (colour per label, legend; navigable cells bright) and return its path."""
    from PIL import Image, ImageDraw

    lm = np.asarray(rmap.label_map)
    h, w = lm.shape
    img = np.full((h, w, 3), 40, dtype=np.uint8)
    for k in range(len(rmap.labels)):
        img[lm == k] = PALETTE[k % len(PALETTE)]
    if navmap is not None and navmap.navigable.shape == lm.shape:
        dim = ~np.asarray(navmap.navigable, dtype=bool) & (lm >= 0)
        img[dim] = (img[dim].astype(np.float32) * 0.55).astype(np.uint8)
    img = img[::-1]  # row 0 is the south edge: draw north up
    pic = Image.fromarray(img).resize((w * scale, h * scale), Image.NEAREST)
    legend_h = 14 * (len(rmap.labels) + 1)
    canvas = Image.new("RGB", (max(pic.width, 180), pic.height + legend_h), (255, 255, 255))
    canvas.paste(pic, (0, 0))
    draw = ImageDraw.Draw(canvas)
    for k, name in enumerate(rmap.labels):
        y = pic.height + 4 + 14 * k
        draw.rectangle([4, y, 14, y + 10], fill=tuple(int(v) for v in PALETTE[k % len(PALETTE)]))
        draw.text((20, y - 1), name, fill=(0, 0, 0))
    buf = io.BytesIO()
    canvas.save(buf, format="PNG")
    atomic_write_bytes(Path(path), buf.getvalue())
    return Path(path)


def annotate_planes(planes: list[ReceptaclePlane], maps: dict[int, tuple[NavMap, RegionMap]]) -> list[ReceptaclePlane]:
    """Return the planes with their floor (the nearest floor below) and region (the region map at their centre).

    ``maps`` holds floor -> (NavMap, RegionMap). A plane whose centre falls on an unlabelled cell takes the
    region of the nearest labelled cell; a plane below every floor keeps its floor and region.
    """
    from ..observe.floors import floor_below

    navmaps = [nm for nm, _rm in maps.values()]
    out = []
    for plane in planes:
        below = floor_below(plane.height, navmaps)
        floor = below.floor if below is not None else plane.floor
        region = plane.region
        if floor in maps:
            rm = maps[floor][1]
            region = rm.region_at(np.asarray(plane.polygon, float).mean(axis=0)) or _nearest_region(rm, plane) or region
        out.append(dataclasses.replace(plane, floor=floor, region=region))
    return out


def _nearest_region(rm: RegionMap, plane: ReceptaclePlane) -> str:
    """Return the region label of the labelled cell nearest to a plane's centre ('' if none)."""
    rows, cols = np.nonzero(rm.label_map >= 0)
    if len(rows) == 0:
        return ""
    c = np.asarray(plane.polygon, float).mean(axis=0)
    xy = rm.frame.to_world(np.stack([rows, cols], 1))
    k = int(np.argmin(((xy - c) ** 2).sum(1)))
    return rm.labels[int(rm.label_map[rows[k], cols[k]])]
