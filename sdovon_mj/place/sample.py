"""Semantic sampling of what goes where (paper section 3.4): per receptacle plane in its region, m
repeatable categories by the joint relevance P(obj|rgn) * P(obj|rec), an instance per category, a
uniform position in the plane polygon shrunk by the object's footprint, a minimum gap between
objects, and the spawn pose (the paper's random X/Y/Z rotation from h_spawn, or a stable drop)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..config import PlaceConfig
from ..geometry import axis_quat, quat_mul, quat_to_mat, sample_in_polygon, shrink_polygon
from ..records import ObjectAsset, Placement, ReceptaclePlane, Relevance

POSITION_TRIES = 40  # candidate positions per object before giving up on a plane
_INSET_CACHE: dict[tuple[bytes, float], np.ndarray] = {}


def _inset(polygon: np.ndarray, r: float) -> np.ndarray:
    """Return the polygon shrunk by r (memoised: the same planes and objects come back every variant)."""
    key = (np.asarray(polygon, dtype=float).tobytes(), round(float(r), 6))
    hit = _INSET_CACHE.get(key)
    if hit is None:
        if len(_INSET_CACHE) > 100_000:
            _INSET_CACHE.clear()
        hit = _INSET_CACHE[key] = shrink_polygon(polygon, r)
    return hit


@dataclass
class SampleResult:
    """Sampled placements (status 'pending') and what could not be placed, in words."""

    placements: list[Placement] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def object_radius(asset: ObjectAsset, mode: str) -> float:
    """Return the footprint radius about the bbox centre: XY for stable drops, 3D for tumbling spawns."""
    lo, hi = np.asarray(asset.bbox[0], float), np.asarray(asset.bbox[1], float)
    half = (hi - lo) / 2.0
    return float(np.linalg.norm(half if mode == "paper" else half[:2]))


def category_distribution(relevance: Relevance, region: str, receptacle: str, categories: list[str],
                          temperature: float, top_k: int,
                          pairs: list[tuple[str, str]] | None = None,
                          allowed: set[str] | None = None) -> tuple[list[str], np.ndarray]:
    """Return the categories to draw from and their probabilities (placement direction, top-k, temperature).

    The weights are `Relevance.joint`: with a pair model (the learned offline backend), which
    categories belong at this (region, receptacle) more than elsewhere in the scene (Bayes' rule over
    the scene's `pairs`: P(obj | pair) proportional to P(pair | obj)); without one (the table,
    server backends), the paper's eq. 5, P(obj|rgn) * P(obj|rec). Only the `allowed` categories are
    drawn when any of them is known (those that belong here most in this scene, ``place.top_pairs``);
    the k largest are kept and sharpened by the temperature (softmax of the log weight / temperature;
    1: proportional).

    Parameters
    ----------
    relevance : Relevance
        Object-category relevance tables.
    region : str
        Region label of the plane.
    receptacle : str
        Receptacle label of the plane.
    categories : list of str
        Categories of the object library.
    temperature : float
        Softmax temperature on the log relevance (small: sharper).
    top_k : int
        Keep the k most relevant categories (0: all).
    pairs : list of (str, str), optional
        The (region, receptacle) pairs of the scene's planes (`Relevance.joint`); default: all of the record's.
    allowed : set of str, optional
        Categories this pair may take (`Relevance.top_pairs` holds it); None, or none of them known: every one.
    """
    known = [c for c in categories if c in relevance.objects]
    if allowed is not None and any(c in allowed for c in known):
        known = [c for c in known if c in allowed]
    if not known:
        return [], np.zeros(0)
    joint = relevance.joint(region, receptacle, pairs)
    scores = np.array([max(float(joint[relevance.objects.index(c)]), 0.0) for c in known])
    if not np.isfinite(scores).all() or scores.sum() <= 0:
        scores = np.ones(len(known))
    order = np.lexsort((np.array(known), -scores))  # descending score, ties by name
    if top_k > 0:
        order = order[:top_k]
    cats = [known[i] for i in order]
    s = scores[order]
    s = s / s.max()
    t = max(float(temperature), 1e-6)
    with np.errstate(divide="ignore"):
        logits = np.where(s > 0, np.log(np.maximum(s, 1e-300)) / t, -np.inf)
    p = np.exp(logits - logits[np.isfinite(logits)].max())
    p = np.where(np.isfinite(p), p, 0.0)
    return cats, p / p.sum()


def random_rotation_xyz(rng: np.random.Generator) -> np.ndarray:
    """Return a wxyz quaternion of random rotations about X, Y and Z (the paper's spawn)."""
    ax, ay, az = rng.uniform(0.0, 2.0 * math.pi, 3)
    return quat_mul(axis_quat(2, az), quat_mul(axis_quat(1, ay), axis_quat(0, ax)))


HEADROOM_MARGIN = 0.02  # m kept free between a spawned object's top and the surface above its plane


def spawn_pose(asset: ObjectAsset, plane: ReceptaclePlane, xy: np.ndarray, cfg: PlaceConfig,
               rng: np.random.Generator, headroom: float = math.inf) -> tuple[np.ndarray, np.ndarray] | None:
    """Return the body position and wxyz quaternion that put the object's bbox centre over `xy`.

    `headroom` is the free height above the plane (a shelf board above, say): the spawn is lowered
    so the object's top stays under it; None when the object cannot fit at all.

    Parameters
    ----------
    asset : ObjectAsset
        The object (bounding box in its body frame, metres).
    plane : ReceptaclePlane
        The plane it is placed on.
    xy : (2,) float
        World XY of the bounding-box centre, metres.
    cfg : PlaceConfig
        Spawn mode and spawn height.
    rng : numpy.random.Generator
        Random draws of the orientation.
    headroom : float
        Free height above the plane, metres.
    """
    lo, hi = np.asarray(asset.bbox[0], float), np.asarray(asset.bbox[1], float)
    centre = (lo + hi) / 2.0
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]) - centre
    top_limit = plane.height + headroom - HEADROOM_MARGIN
    if cfg.spawn_mode == "paper":
        for _ in range(8):
            q = random_rotation_xyz(rng)
            R = quat_to_mat(q)
            rz = corners @ R.T
            zc = plane.height + cfg.h_spawn - rz[:, 2].min()  # lowest point h_spawn above the plane
            zc = min(zc, top_limit - rz[:, 2].max())  # ... unless that would hit the surface above
            if zc + rz[:, 2].min() >= plane.height + 0.005:
                break
        else:
            return None
    elif cfg.spawn_mode == "stable":
        yaw = rng.uniform(0.0, 2.0 * math.pi)
        q = axis_quat(2, yaw)
        R = quat_to_mat(q)
        zc = plane.height + cfg.stable_drop + (centre[2] - lo[2])
        if zc + (hi[2] - centre[2]) > top_limit:
            return None
    else:
        raise ValueError(f"unknown place.spawn_mode {cfg.spawn_mode!r} (paper or stable)")
    world_centre = np.array([xy[0], xy[1], zc])
    pos = world_centre - R @ centre
    return pos, q


def plane_headroom(plane: ReceptaclePlane, planes: list[ReceptaclePlane], thickness: float) -> float:
    """Return the free height above a plane up to the lowest other plane's support overlapping it (inf if none)."""
    from shapely.geometry import Polygon

    mine = None
    best = math.inf
    for q in planes:
        if q.id == plane.id or q.floor != plane.floor or q.height <= plane.height + 1e-3:
            continue
        gap = q.height - thickness - plane.height
        if gap >= best:
            continue
        if mine is None:
            mine = Polygon(np.asarray(plane.polygon, float)).buffer(0)
        other = Polygon(np.asarray(q.polygon, float)).buffer(0)
        if mine.intersection(other).area > 1e-4:
            best = gap
    return best


_HEADROOMS: dict[tuple, dict[int, float]] = {}


def plane_headrooms(planes: list[ReceptaclePlane], thickness: float) -> dict[int, float]:
    """Return plane id -> plane_headroom for a scene's planes (memoised: every variant of a scene asks again)."""
    key = (float(thickness), tuple((p.id, p.floor, float(p.height), np.asarray(p.polygon, dtype=float).tobytes())
                                   for p in planes))
    hit = _HEADROOMS.get(key)
    if hit is None:
        if len(_HEADROOMS) > 64:
            _HEADROOMS.clear()
        hit = _HEADROOMS[key] = {p.id: plane_headroom(p, planes, thickness) for p in planes}
    return dict(hit)


def _fits(xy: np.ndarray, r: float, taken: list[tuple[np.ndarray, float]], gap: float) -> bool:
    """Return whether a footprint circle keeps `gap` from every taken one."""
    return all(float(np.hypot(*(xy - c))) >= r + rc + gap for c, rc in taken)


def sample_placements(planes: list[ReceptaclePlane], relevance: Relevance, objects: list[ObjectAsset],
                      cfg: PlaceConfig, rng: np.random.Generator) -> SampleResult:
    """Sample categories, instances and spawn poses for every plane; say in notes what was skipped.

    Parameters
    ----------
    planes : list of ReceptaclePlane
        The scene's receptacle planes.
    relevance : Relevance
        Object-category relevance (weights of the category draw).
    objects : list of ObjectAsset
        The object library.
    cfg : PlaceConfig
        Objects per plane, caps, temperature, spawn mode.
    rng : numpy.random.Generator
        Random draws of categories, instances and poses.
    """
    res = SampleResult()
    if not planes:
        res.notes.append("no receptacle planes in this scene: nothing to place")
        return res
    if not objects:
        res.notes.append("the object library is empty: nothing to place")
        return res
    by_cat: dict[str, list[ObjectAsset]] = {}
    for a in sorted(objects, key=lambda a: (a.category, a.name)):
        by_cat.setdefault(a.category, []).append(a)
    categories = sorted(c for c in by_cat if c in relevance.objects)
    if not categories:
        res.notes.append("no object category of the library is known to the relevance table "
                         f"(library: {', '.join(sorted(by_cat))}; relevance: {', '.join(relevance.objects)}): nothing to place")
        return res
    unknown = sorted(set(by_cat) - set(categories))
    if unknown:
        res.notes.append(f"categories unknown to the relevance table are never placed: {', '.join(unknown)}")
    min_r = min(object_radius(a, cfg.spawn_mode) for c in categories for a in by_cat[c])
    taken: dict[int, list[tuple[np.ndarray, float]]] = {}
    headroom = plane_headrooms(planes, cfg.support_thickness)
    order = sorted(planes, key=lambda p: p.id)
    order = [order[i] for i in rng.permutation(len(order))]
    scene_pairs = sorted({(p.region, p.label) for p in planes})
    allowed: dict[tuple[str, str], set[str]] = {}
    if cfg.top_pairs > 0:  # each category only on the pairs of this scene where it belongs most
        for cat, best in relevance.top_pairs(scene_pairs, cfg.top_pairs).items():
            for q in best:
                allowed.setdefault(q, set()).add(cat)
        open_to_all = [q for q in scene_pairs if not allowed.get(q, set()) & set(categories)]
        if open_to_all:
            res.notes.append(f"no category counts {len(open_to_all)} pair(s) among its top {cfg.top_pairs} "
                             f"(place.top_pairs): every category may go there: "
                             + ", ".join(f"{r}/{c}" for r, c in open_to_all))
    n = 0
    for plane in order:
        if n >= cfg.max_objects:
            res.notes.append(f"max_objects={cfg.max_objects} reached: later planes got nothing")
            break
        if len(_inset(plane.polygon, min_r)) < 3:
            res.notes.append(f"plane {plane.id} ({plane.label}, {abs(plane.area):.3f} m^2) is smaller than every object footprint: nothing placed on it")
            continue
        cats, p = category_distribution(relevance, plane.region, plane.label, categories, cfg.temperature, cfg.top_k,
                                        scene_pairs, allowed.get((plane.region, plane.label)))
        for _ in range(cfg.m):
            if n >= cfg.max_objects:
                break
            cat = cats[int(rng.choice(len(cats), p=p))]
            assets = by_cat[cat]
            asset = assets[int(rng.integers(len(assets)))]
            placed = _place_one(asset, plane, taken.setdefault(plane.id, []), cfg, rng, headroom[plane.id])
            if placed is None:
                fitting = [a for a in assets if len(_inset(plane.polygon, object_radius(a, cfg.spawn_mode))) >= 3]
                if fitting and asset not in fitting:
                    asset = fitting[int(rng.integers(len(fitting)))]
                    placed = _place_one(asset, plane, taken[plane.id], cfg, rng, headroom[plane.id])
            if placed is None:
                ext = np.asarray(asset.bbox[1], float) - np.asarray(asset.bbox[0], float)
                tight = math.isfinite(headroom[plane.id]) and float(ext.max()) + 2 * HEADROOM_MARGIN > headroom[plane.id]
                room = f" under {headroom[plane.id]:.2f} m headroom" if tight else ""
                res.notes.append(f"plane {plane.id} ({plane.label}): no room for a {cat} ({asset.name}){room}")
                continue
            pos, q = placed
            res.placements.append(Placement(object_id=f"obj_{n:03d}", asset=asset.name, category=cat, plane_id=plane.id,
                                            receptacle_instance=plane.instance_id, region=plane.region,
                                            spawn_pos=pos, spawn_quat=q))
            n += 1
    if not res.placements:
        res.notes.append("no object could be placed on any receptacle plane")
    return res


def _place_one(asset: ObjectAsset, plane: ReceptaclePlane, taken: list[tuple[np.ndarray, float]], cfg: PlaceConfig,
               rng: np.random.Generator, headroom: float = math.inf) -> tuple[np.ndarray, np.ndarray] | None:
    """Draw a free position for one object on a plane and its spawn pose, or None."""
    r = object_radius(asset, cfg.spawn_mode)
    region = _inset(plane.polygon, r)
    if len(region) < 3:
        return None
    for xy in sample_in_polygon(region, POSITION_TRIES, rng):
        if _fits(xy, r, taken, cfg.min_distance):
            pose = spawn_pose(asset, plane, xy, cfg, rng, headroom)
            if pose is None:
                return None
            taken.append((xy, r))
            return pose
    return None


def resample_pose(asset: ObjectAsset, plane: ReceptaclePlane, others: list[tuple[np.ndarray, float]], cfg: PlaceConfig,
                  rng: np.random.Generator, headroom: float = math.inf) -> tuple[np.ndarray, np.ndarray] | None:
    """Draw a new spawn pose for an object on its plane away from `others` (xy, radius), or None.

    Parameters
    ----------
    asset : ObjectAsset
        The object.
    plane : ReceptaclePlane
        Its plane.
    others : list of ((2,) float, float)
        World XY and radius (metres) of the objects already on the plane.
    cfg : PlaceConfig
        Spawn mode, spawn height and spacing.
    rng : numpy.random.Generator
        Random draws of position and orientation.
    headroom : float
        Free height above the plane, metres.
    """
    return _place_one(asset, plane, list(others), cfg, rng, headroom)


def top_pair_share(placements: list[Placement], relevance: Relevance, planes: list[ReceptaclePlane],
                   k: int = 3) -> dict[str, tuple[float, int]]:
    """Return per category the share of its placements on its k most relevant (region, receptacle) pairs present."""
    plane_pair = {p.id: (p.region, p.label) for p in planes}
    tops = relevance.top_pairs(sorted(set(plane_pair.values())), k)
    out: dict[str, tuple[float, int]] = {}
    for cat in sorted({p.category for p in placements}):
        if cat not in relevance.objects:
            continue
        top = tops[cat]
        mine = [p for p in placements if p.category == cat]
        hits = sum(1 for p in mine if plane_pair.get(p.plane_id) in top)
        out[cat] = (hits / len(mine), len(mine))
    return out
