"""The A* baselines' memory of a scene: frames -> instances -> receptacle planes -> navigation points.

Light-weight built-in stages (ground-truth detector semantics): depth + segmentation frames are
back-projected and grouped by segmentation id; a receptacle's plane is the top slab of its points
(convex hull in XY). Every stage can be replaced: pass `planes` (e.g. from the EM plane detector),
`region_of` (e.g. `RegionMap.region_at`) and a `Relevance` table to `build_memory`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull, QhullError

from ..geometry import points_in_polygon
from ..records import Instance, Observation, ReceptaclePlane, Relevance
from ..sim.camera import backproject
from ..grid import GridFrame


@dataclass
class MemoryEntry:
    """One receptacle plane with its region and the navigation points around it."""

    plane: ReceptaclePlane
    region: str
    nav_points: np.ndarray  # (K, 2) world XY

    @property
    def centre(self) -> np.ndarray:
        """Return the plane polygon's centroid (world XY)."""
        return np.asarray(self.plane.polygon, float).mean(axis=0)


RANKINGS = ("placement", "search")  # the orders `SceneMemory.ranked` knows (Semantic A*'s ``ranking``)


@dataclass
class SceneMemory:
    """What an A* baseline remembers of a scene after exploring it."""

    scene: str
    frame: GridFrame
    traversable: np.ndarray  # (H, W) bool planning mask
    entries: list[MemoryEntry] = field(default_factory=list)
    instances: list[Instance] = field(default_factory=list)

    def scores(self, category: str, relevance: Relevance | None, direction: str = "placement") -> np.ndarray | None:
        """Return each entry's relevance score for the goal (None without a relevance that knows the category).

        ``direction="placement"`` (the paper's algorithm 4, eq. 5): the goal's share of `Relevance.joint` at
        the pair among the pairs this memory holds: which categories a home keeps at that pair rather than
        elsewhere (with a learned pair model, Bayes' rule over these pairs and the relevance's objects).
        ``"search"``: `Relevance.pair_score`, how likely people would put the goal there, comparable across
        pairs of one object (a receptacle that suits everything, such as a shelf, ranks high for every goal).
        """
        if direction not in RANKINGS:
            raise ValueError(f"unknown ranking direction {direction!r} ({' or '.join(RANKINGS)})")
        if relevance is None or category not in relevance.objects:
            return None
        if direction == "placement":
            pairs = sorted({(e.region, e.plane.label) for e in self.entries})
            i = relevance.objects.index(category)
            share = {q: float(relevance.joint(q[0], q[1], pairs)[i]) for q in pairs}
            return np.array([share[(e.region, e.plane.label)] for e in self.entries])
        return np.array([relevance.pair_score(category, e.region, e.plane.label) for e in self.entries])

    def ranked(self, category: str, relevance: Relevance | None, rng: np.random.Generator,
               direction: str = "placement") -> list[MemoryEntry]:
        """Return entries by decreasing relevance of their (region, receptacle) for the goal (ties random; `scores`)."""
        if direction not in RANKINGS:
            raise ValueError(f"unknown ranking direction {direction!r} ({' or '.join(RANKINGS)})")
        tiebreak = rng.permutation(len(self.entries))
        scores = self.scores(category, relevance, direction)
        if scores is None:
            return [self.entries[i] for i in tiebreak]
        order = sorted(range(len(self.entries)), key=lambda i: (-scores[i], tiebreak[i]))
        return [self.entries[i] for i in order]


def instances_from_frames(frames: Sequence[Observation], labels: dict[int, str], depth_max: float = 5.0,
                          min_points: int = 30, voxel: float = 0.03) -> list[Instance]:
    """Return one Instance per segmentation id seen in the frames (gt detector semantics).

    Parameters
    ----------
    frames : sequence of Observation
        Frames with depth, intrinsics, pose and segmentation (frames without segmentation are passed over).
    labels : dict of int to str
        Segmentation id -> label (ids not in it are left out).
    depth_max : float
        The sensor's range in metres (pixels at it are left out).
    min_points : int
        Fewest points an instance keeps.
    voxel : float
        Voxel size in metres of the points' downsampling.
    """
    pts: dict[int, list[np.ndarray]] = {}
    views: dict[int, list[int]] = {}
    for f in frames:
        if f.segmentation is None:
            continue
        seg = np.asarray(f.segmentation)
        for sid in np.unique(seg):
            sid = int(sid)
            if sid < 0 or sid not in labels:
                continue
            p = backproject(f.depth, f.K, f.T_cam, mask=seg == sid, depth_max=depth_max - 1e-3)
            if len(p):
                pts.setdefault(sid, []).append(p)
                views.setdefault(sid, []).append(int(f.view_id))
    out = []
    for sid in sorted(pts):
        p = np.concatenate(pts[sid])
        q = np.unique(np.floor(p / voxel).astype(np.int64), axis=0, return_index=True)[1]
        p = p[np.sort(q)]
        if len(p) < min_points:
            continue
        c = np.median(p, axis=0)
        out.append(Instance(id=sid, label=labels[sid], points=(p - c).astype(np.float32), center=c,
                            confidences=[1.0], source_views=sorted(set(views[sid])), gt_id=sid))
    return out


def top_plane(inst: Instance, plane_id: int, slab: float = 0.04, min_points: int = 10) -> ReceptaclePlane | None:
    """Return the top horizontal plane of an instance's points (convex hull of the top slab), or None."""
    p = inst.world_points
    top = np.quantile(p[:, 2], 0.98)
    sel = p[np.abs(p[:, 2] - top) <= slab]
    if len(sel) < min_points:
        return None
    try:
        hull = ConvexHull(sel[:, :2])
    except (QhullError, ValueError):
        return None
    poly = sel[hull.vertices, :2]  # scipy returns 2D hull vertices counter-clockwise
    return ReceptaclePlane(id=plane_id, instance_id=inst.id, label=inst.label, height=float(np.median(sel[:, 2])),
                           polygon=poly, normal=np.array([0.0, 0.0, 1.0]), inliers=int(len(sel)))


def planes_from_instances(instances: Sequence[Instance], receptacle_labels: Sequence[str]) -> list[ReceptaclePlane]:
    """Return the top plane of every instance whose label is a receptacle label."""
    rec = {l.lower() for l in receptacle_labels}
    out = []
    for inst in instances:
        if inst.label.lower() in rec:
            pl = top_plane(inst, len(out))
            if pl is not None:
                out.append(pl)
    return out


def container_planes(instances: Sequence[Instance], planes: Sequence[ReceptaclePlane], labels: Sequence[str],
                     navmap: Any, regions: Any) -> list[ReceptaclePlane]:
    """Return a footprint plane for each instance of an openable label that has no plane yet (a closed fridge).

    Exploration with doors and drawers as they are finds no plane inside a closed piece and often none on it; an
    agent that opens furniture still has to remember where the piece stands. Its plane is the top slab of the
    points seen (`top_plane`), annotated with its region on the agent's own region map (`semantics.annotate_planes`);
    ids follow the given planes'. Empty `labels`: none.

    Parameters
    ----------
    instances : sequence of Instance
        The instances the agent saw.
    planes : sequence of ReceptaclePlane
        The planes it found (an instance with one gets none here).
    labels : sequence of str
        The openable labels (fridge, cabinet, ...).
    navmap : NavMap
        The agent's map (the planes' floor).
    regions : RegionMap or None
        The agent's region map (None: no region).
    """
    from ..semantics import annotate_planes

    want = {str(l).lower() for l in labels}
    have = {int(p.instance_id) for p in planes}
    next_id = max((int(p.id) for p in planes), default=-1) + 1
    out = []
    for inst in instances:
        if inst.label.lower() not in want or int(inst.id) in have:
            continue
        pl = top_plane(inst, next_id + len(out))
        if pl is not None:
            out.append(pl)
    return annotate_planes(out, {0: (navmap, regions)}) if out else []


def sample_nav_points(plane: ReceptaclePlane, traversable: np.ndarray, frame: GridFrame, near: float = 0.25,
                      far: float = 1.0, spacing: float = 0.5) -> np.ndarray:
    """Return navigation points (K, 2): traversable cells `near`..`far` m from the plane, `spacing` apart.

    Parameters
    ----------
    plane : ReceptaclePlane
        The plane (its polygon, world XY).
    traversable : ndarray (H, W) bool
        Where the agent may stand.
    frame : GridFrame
        The mask's frame.
    near, far : float
        Metres from the plane's polygon.
    spacing : float
        Least metres between two points.
    """
    h, w = traversable.shape
    # The work is done in a window: the polygon's cells and every cell within far + 1 m of them (+ 2 cells). A cell
    # outside it is farther than any candidate, and the Euclidean distance transform is exact, so a window cell's
    # distance to the nearest polygon cell is the one the whole map gives; the candidates and their (row-major,
    # stably sorted) order are the same. Without a polygon cell in the window (a plane off the map), the whole map.
    poly = np.asarray(plane.polygon, float)
    margin = int(math.ceil((far + 1.0) / frame.resolution)) + 2
    lo, hi = frame.to_cell(poly.min(axis=0)[None])[0], frame.to_cell(poly.max(axis=0)[None])[0]
    windows = [(max(0, int(lo[0]) - margin), min(h, int(hi[0]) + margin + 1),
                max(0, int(lo[1]) - margin), min(w, int(hi[1]) + margin + 1)), (0, h, 0, w)]
    for r0, r1, c0, c1 in windows:
        if r1 <= r0 or c1 <= c0:
            continue
        rows, cols = np.mgrid[r0:r1, c0:c1]
        centres = frame.to_world(np.stack([rows.ravel(), cols.ravel()], 1))
        inside = points_in_polygon(plane.polygon, centres).reshape(r1 - r0, c1 - c0)
        if not inside.any():
            c = frame.to_cell(poly.mean(axis=0)[None])[0]
            if frame.inside(c[None])[0] and r0 <= c[0] < r1 and c0 <= c[1] < c1:
                inside[c[0] - r0, c[1] - c0] = True
        if inside.any() or (r0, r1, c0, c1) == (0, h, 0, w):
            break
    trav = traversable[r0:r1, c0:c1]
    dist = ndimage.distance_transform_edt(~inside) * frame.resolution
    cand = np.argwhere(trav & (dist >= near) & (dist <= far))
    if len(cand) == 0:
        cand = np.argwhere(trav & (dist <= far + 1.0))
    if len(cand) == 0:
        return np.zeros((0, 2))
    order = np.argsort(dist[cand[:, 0], cand[:, 1]], kind="stable")
    xy = frame.to_world(cand[order] + np.array([r0, c0]))
    # greedy: a point is kept when it lies at least `spacing` from every point kept before it (np.linalg.norm). The
    # squared distance in plain floats decides all but the points within a relative 1e-9 of spacing^2 (the norm's
    # own rounding is some 1e-16 of it); those few ask np.linalg.norm, so the same points are kept.
    keep: list[np.ndarray] = []
    kept: list[tuple[float, float]] = []
    s2 = spacing * spacing
    lo2, hi2 = s2 * (1.0 - 1e-9), s2 * (1.0 + 1e-9)
    for p, (px, py) in zip(xy, xy.tolist()):
        for k, (qx, qy) in enumerate(kept):
            dx, dy = px - qx, py - qy
            d2 = dx * dx + dy * dy
            if d2 < lo2 or (d2 <= hi2 and np.linalg.norm(p - keep[k]) < spacing):
                break
        else:
            keep.append(p)
            kept.append((px, py))
    return np.array(keep)


def build_memory(scene: str, frames: Sequence[Observation], labels: dict[int, str], traversable: np.ndarray,
                 frame: GridFrame, receptacle_labels: Sequence[str], planes: Sequence[ReceptaclePlane] | None = None,
                 region_of: Callable[[np.ndarray], str] | None = None, depth_max: float = 5.0) -> SceneMemory:
    """Return the memory of a scene from exploration frames (or injected planes) and a planning mask.

    Parameters
    ----------
    scene : str
        The scene's name.
    frames : sequence of Observation
        Exploration frames (instances come from their segmentation).
    labels : dict of int to str
        Segmentation id -> label.
    traversable : ndarray (H, W) bool
        Where the agent may stand.
    frame : GridFrame
        The mask's frame.
    receptacle_labels : sequence of str
        Labels whose instances give planes.
    planes : sequence of ReceptaclePlane, optional
        Planes given instead of those found in the frames.
    region_of : callable, optional
        World XY -> region label, for planes without one.
    depth_max : float
        The sensor's range in metres.
    """
    instances = instances_from_frames(frames, labels, depth_max) if planes is None or frames else []
    pl = list(planes) if planes is not None else planes_from_instances(instances, receptacle_labels)
    entries = []
    for p in pl:
        pts = sample_nav_points(p, traversable, frame)
        if len(pts) == 0:
            continue
        centre = np.asarray(p.polygon, float).mean(axis=0)
        region = p.region or (region_of(centre) if region_of else "")
        entries.append(MemoryEntry(p, region, pts))
    return SceneMemory(scene, frame, traversable, entries, instances)


def extract_planes(frames: Sequence[Observation], detector: Any, receptacle_labels: Sequence[str], occupancy: Any,
                   backend: Any, perceive_cfg: Any = None, receptacle_cfg: Any = None,
                   semantics_cfg: Any = None) -> tuple[list[Instance], list[ReceptaclePlane], Any, Any]:
    """The paper's ExtractPlanes (appendix D) on an agent's own exploration frames, with the pipeline's stages.

    Perceive (detect, back-project, fuse, correct: `perceive.perceive_scene`) -> receptacle planes (EM:
    `receptacles.find_receptacle_planes`) -> region map over the explored free space (sliding window and the
    semantics backend: `semantics.region_map`) -> planes annotated with their region (`semantics.annotate_planes`).

    Parameters
    ----------
    frames : sequence of Observation
        The exploration frames (RGB-D, segmentation for the gt detector, K, T_cam in the agent's frame).
    detector : Detector
        The agent's detector (the suite's ground-truth detector, or a model).
    receptacle_labels : sequence of str
        Labels that count as receptacles.
    occupancy : OccupancyMap
        The agent's occupancy map after exploring (its free space becomes the region map's floor).
    backend : Backend
        The semantics backend naming regions (`semantics.get_backend`).
    perceive_cfg, receptacle_cfg, semantics_cfg : optional
        Stage configs (defaults: `PerceiveConfig()`, `ReceptacleConfig()`, `SemanticsConfig()`).

    Returns
    -------
    instances, planes, region_map, navmap
        The fused instances, the annotated receptacle planes, the RegionMap and the NavMap of the explored floor.
    """
    from ..config import PerceiveConfig, ReceptacleConfig, SemanticsConfig
    from ..perceive import perceive_scene
    from ..receptacles import find_receptacle_planes
    from ..records import NavMap
    from ..semantics import annotate_planes, region_map
    from .frontier import FREE

    instances = perceive_scene(frames, None, perceive_cfg or PerceiveConfig(), detector=detector)
    planes = find_receptacle_planes(instances, receptacle_cfg or ReceptacleConfig(), tuple(receptacle_labels))
    fr = occupancy.frame
    navmap = NavMap(floor=0, height=float(occupancy.floor_z), origin=np.asarray(fr.origin, float),
                    resolution=float(fr.resolution), navigable=occupancy.traversable(), free=occupancy.state == FREE)
    rm = region_map(instances, navmap, backend, semantics_cfg or SemanticsConfig())
    return instances, annotate_planes(planes, {0: (navmap, rm)}), rm, navmap
