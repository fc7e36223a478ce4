"""Days in a home: a scene's chain of days, each derived from the day before by a habit model.

Day 0 is placed as a variant (`run_variant`). Overnight (`next_day`) each object present the day before stays, moves
to another receptacle plane or leaves, with its category's probabilities (``place.day_rates``, else
``place.day_move`` / ``place.day_leave``), and new objects arrive (each present object brings one with probability
``place.day_arrive``). A move's plane is drawn in the placement direction (`Relevance.joint` at each plane's
(region, receptacle) pair, kept to the category's ``place.top_pairs`` pairs of the scene as placement keeps it); an
arrival's plane uniformly, its category as `sample_placements` draws one for that plane. The day is composed and
settled with the variants' own settle loop (`variants._spawned`, `_settle_rounds`: the same judge, the same
resampling) and written as a `SceneVariant` with its `day`; a `DayChange` says what stayed, moved, left and arrived.
Objects keep their ids (``obj_<n>``, never reused) across days; one that stays keeps its pose unless settling moved it
by more than `STAY_TOL` (recorded in `DayChange.resettled`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..config import PlaceConfig, day_rates
from ..runview import RunLayout
from ..records import (DayChange, DayMove, ObjectAsset, Placement, ReceptaclePlane, Relevance, SceneAsset, SceneVariant,
                       save_json)
from .sample import _inset, _place_one, category_distribution, object_radius, plane_headrooms
from .settle import RESTING
from .variants import _keep_settled_poses, _settle_rounds, _spawned, _variant_record, run_variant, write_variant_model

STAY_TOL = 0.001  # m: a staying object that settling moved less than this keeps the day before's pose exactly
STAY_ANGLE_TOL = 0.01  # rad: ... and turned less than this
PLANE_TRIES = 5  # planes drawn for a moving or arriving object before it is given up (recorded as dropped)


def first_day(scene: SceneAsset, planes: list[ReceptaclePlane], relevance: Relevance, objects: list[ObjectAsset],
              store_root: str | Path, cfg: PlaceConfig, seed: int, open_parts: float = 1.0
              ) -> tuple[SceneVariant, DayChange]:
    """Place day 0 of a scene's chain as a variant; write it in its day's folder (`RunLayout.day_dir`) and return it.

    Parameters
    ----------
    scene : SceneAsset
        The converted scene (world metres, Z up).
    planes : list of ReceptaclePlane
        The scene's receptacle planes (with floor and region).
    relevance : Relevance
        Object-category relevance (the moves' and arrivals' draws).
    objects : list of ObjectAsset
        The object library.
    store_root : str or Path
        The run folder the scene's and objects' files are relative to (written into).
    cfg : PlaceConfig
        Placement, settling and the habit model's rates (``place.day_*``).
    seed : int
        The day's seed (`sdovon_mj.seeds.day_seed`).
    open_parts : float
        As in `run_variant`.
    """
    variant, _stats = run_variant(scene, planes, relevance, objects, store_root, cfg, seed, 0, write=False,
                                  open_parts=open_parts)
    variant.day = 0
    change = DayChange(scene=scene.name, day=0, arrived=[p.object_id for p in variant.placements],
                       dropped={p.object_id: p.reason for p in variant.placements if p.status != RESTING},
                       next_object=_next_object(variant.placements, 0))
    _write_day(variant, change, scene, planes, objects, store_root, cfg)
    return variant, change


def next_day(previous: SceneVariant, before: DayChange, scene: SceneAsset, planes: list[ReceptaclePlane],
             relevance: Relevance, objects: list[ObjectAsset], store_root: str | Path, cfg: PlaceConfig, seed: int
             ) -> tuple[SceneVariant, DayChange]:
    """Derive the next day of a chain from `previous` by the habit model, settle it, write it and return it.

    Parameters
    ----------
    previous : SceneVariant
        The day before (its resting objects are the ones present overnight).
    before : DayChange
        The day before's change record (the next free object number).
    scene, planes, relevance, objects, store_root, cfg : as in `first_day`
    seed : int
        This day's seed (`sdovon_mj.seeds.day_seed`).
    """
    if scene.articulated:
        from ..errors import StageError

        raise StageError(f"scene {scene.name}: chains of days (place.days) need a scene without articulated pieces "
                         "(its doors and drawers would need their states carried from day to day)")
    day = int(previous.day or 0) + 1
    rng = np.random.default_rng(seed)
    rates = day_rates(cfg)
    assets = {a.name: a for a in objects}
    by_cat: dict[str, list[ObjectAsset]] = {}
    for a in sorted(objects, key=lambda a: (a.category, a.name)):
        by_cat.setdefault(a.category, []).append(a)
    plane_of = {p.id: p for p in planes}
    headroom = plane_headrooms(planes, cfg.support_thickness)
    pairs = sorted({(p.region, p.label) for p in planes})
    tops = relevance.top_pairs(pairs, cfg.top_pairs) if cfg.top_pairs > 0 else {}
    present = sorted(previous.resting, key=lambda p: p.object_id)
    change = DayChange(scene=scene.name, day=day, arrive_rate=float(cfg.day_arrive), previous=len(present))
    # The draws first, in object order, so what happens to one object never shifts another's draw.
    fates = {}
    for p in present:
        move, leave = rates.get(p.category, (cfg.day_move, cfg.day_leave))
        change.rates[p.object_id] = [float(move), float(leave)]
        u = float(rng.random())
        fates[p.object_id] = "left" if u < leave else "moved" if u < leave + move else "stayed"
    n_new = int((rng.random(len(present)) < cfg.day_arrive).sum())
    taken: dict[int, list[tuple[np.ndarray, float]]] = {}
    placements: list[Placement] = []
    for p in present:
        if fates[p.object_id] == "stayed":
            change.stayed.append(p.object_id)
            q = _carry(p)
            placements.append(q)
            taken.setdefault(p.plane_id, []).append((np.asarray(p.settled_pos, float)[:2],
                                                      object_radius(assets[p.asset], cfg.spawn_mode)))
        elif fates[p.object_id] == "left":
            change.left.append(p.object_id)
    for p in present:
        if fates[p.object_id] != "moved":
            continue
        target = _move_target(p, assets[p.asset], planes, relevance, pairs, tops, taken, cfg, rng, headroom)
        src = plane_of[p.plane_id]
        if target is None:
            change.moved.append(DayMove(p.object_id, p.category, src.id, -1, src.label, "", src.region, ""))
            change.dropped[p.object_id] = "no room on any receptacle plane drawn for its move"
            continue
        plane, (pos, quat) = target
        change.moved.append(DayMove(p.object_id, p.category, src.id, plane.id, src.label, plane.label, src.region,
                                    plane.region))
        placements.append(Placement(object_id=p.object_id, asset=p.asset, category=p.category, plane_id=plane.id,
                                    receptacle_instance=plane.instance_id, region=plane.region, spawn_pos=pos,
                                    spawn_quat=quat))
    number = max(before.next_object, _next_object(previous.placements, 0))
    categories = sorted(c for c in by_cat if c in relevance.objects)
    for _ in range(n_new):
        oid = f"obj_{number:03d}"
        number += 1
        change.arrived.append(oid)
        new = _arrival(oid, planes, relevance, categories, by_cat, pairs, tops, taken, cfg, rng, headroom)
        if new is None:
            change.dropped[oid] = "no room for it on any receptacle plane drawn"
        else:
            placements.append(new)
    change.next_object = number
    placements.sort(key=lambda p: p.object_id)
    notes: list[str] = []
    if placements:
        settler = _spawned(scene, planes, assets, placements, store_root, cfg)
        _settle_rounds(settler, placements, assets, planes, cfg, rng)
        _keep_settled_poses(settler, placements)
    before_pose = {p.object_id: p for p in present}
    for q in placements:
        if q.status != RESTING:
            change.dropped[q.object_id] = f"{q.status}: {q.reason}" if q.reason else q.status
            q.status = "dropped"
        elif q.object_id in change.stayed:
            _keep_or_record(q, before_pose[q.object_id], change)
    variant = _variant_record(scene.name, day, seed, placements, notes)
    variant.day = day
    _write_day(variant, change, scene, planes, objects, store_root, cfg)
    return variant, change


def _carry(p: Placement) -> Placement:
    """Return a staying object's placement for the next day: spawned where it rested."""
    return Placement(object_id=p.object_id, asset=p.asset, category=p.category, plane_id=p.plane_id,
                     receptacle_instance=p.receptacle_instance, region=p.region,
                     spawn_pos=np.asarray(p.settled_pos, float).copy(), spawn_quat=np.asarray(p.settled_quat, float).copy())


def _keep_or_record(q: Placement, old: Placement, change: DayChange) -> None:
    """Give a staying object its old pose when settling barely moved it; else record how far it moved."""
    d = float(np.linalg.norm(np.asarray(q.settled_pos) - np.asarray(old.settled_pos)))
    dot = abs(float(np.dot(np.asarray(q.settled_quat, float), np.asarray(old.settled_quat, float))))
    angle = 2.0 * float(np.arccos(min(dot, 1.0)))
    if d < STAY_TOL and angle < STAY_ANGLE_TOL:
        q.settled_pos = np.asarray(old.settled_pos, float).copy()
        q.settled_quat = np.asarray(old.settled_quat, float).copy()
    else:
        change.resettled[q.object_id] = round(d, 6)


def _draw_plane(weights: np.ndarray, rng: np.random.Generator) -> int:
    """Return an index drawn in proportion to `weights` (uniform when they sum to nothing)."""
    w = np.where(np.isfinite(weights), np.maximum(weights, 0.0), 0.0)
    if w.sum() <= 0:
        w = np.ones(len(w))
    return int(rng.choice(len(w), p=w / w.sum()))


def _move_target(p: Placement, asset: ObjectAsset, planes: list[ReceptaclePlane], relevance: Relevance,
                 pairs: list[tuple[str, str]], tops: dict[str, set[tuple[str, str]]],
                 taken: dict[int, list[tuple[np.ndarray, float]]], cfg: PlaceConfig, rng: np.random.Generator,
                 headroom: dict[int, float]) -> tuple[ReceptaclePlane, tuple[np.ndarray, np.ndarray]] | None:
    """Draw another plane for a moving object (placement direction) and a free spawn pose on it; None: no room."""
    r = object_radius(asset, cfg.spawn_mode)
    cand = [q for q in sorted(planes, key=lambda q: q.id) if q.id != p.plane_id and len(_inset(q.polygon, r)) >= 3]
    best = tops.get(p.category, set())
    if any((q.region, q.label) in best for q in cand):  # kept to the category's top pairs, as placement keeps it
        cand = [q for q in cand if (q.region, q.label) in best]
    if not cand:
        return None
    weights = relevance.plane_relevance(p.category, cand, pairs)
    for _ in range(PLANE_TRIES):
        plane = cand[_draw_plane(weights, rng)]
        pose = _place_one(asset, plane, taken.setdefault(plane.id, []), cfg, rng, headroom[plane.id])
        if pose is not None:
            return plane, pose
    return None


def _arrival(oid: str, planes: list[ReceptaclePlane], relevance: Relevance, categories: list[str],
             by_cat: dict[str, list[ObjectAsset]], pairs: list[tuple[str, str]], tops: dict[str, set[tuple[str, str]]],
             taken: dict[int, list[tuple[np.ndarray, float]]], cfg: PlaceConfig, rng: np.random.Generator,
             headroom: dict[int, float]) -> Placement | None:
    """Draw a new object (plane uniform, category as placement draws it there, an instance) and its spawn pose."""
    if not planes or not categories:
        return None
    allowed: dict[tuple[str, str], set[str]] = {}
    for cat, best in tops.items():
        for q in best:
            allowed.setdefault(q, set()).add(cat)
    order = sorted(planes, key=lambda q: q.id)
    for _ in range(PLANE_TRIES):
        plane = order[int(rng.integers(len(order)))]
        cats, p = category_distribution(relevance, plane.region, plane.label, categories, cfg.temperature, cfg.top_k,
                                        pairs, allowed.get((plane.region, plane.label)) if tops else None)
        if not cats:
            continue
        cat = cats[int(rng.choice(len(cats), p=p))]
        asset = by_cat[cat][int(rng.integers(len(by_cat[cat])))]
        pose = _place_one(asset, plane, taken.setdefault(plane.id, []), cfg, rng, headroom[plane.id])
        if pose is not None:
            return Placement(object_id=oid, asset=asset.name, category=cat, plane_id=plane.id,
                             receptacle_instance=plane.instance_id, region=plane.region, spawn_pos=pose[0],
                             spawn_quat=pose[1])
    return None


def _next_object(placements: list[Placement], floor: int) -> int:
    """Return the object number after every ``obj_<n>`` among `placements` (at least `floor`)."""
    nums = [int(p.object_id.rsplit("_", 1)[1]) for p in placements if p.object_id.rsplit("_", 1)[-1].isdigit()]
    return max([floor] + [n + 1 for n in nums])


def _write_day(variant: SceneVariant, change: DayChange, scene: SceneAsset, planes: list[ReceptaclePlane],
               objects: list[ObjectAsset], store_root: str | Path, cfg: PlaceConfig) -> None:
    """Write a day's composed model, its record and its change record in its day's folder (`RunLayout`)."""
    write_variant_model(variant, scene, planes, objects, store_root, cfg,
                        rel=RunLayout.day_mjcf(variant.scene, variant.name))
    save_json(variant, Path(store_root) / RunLayout.day_record(variant.scene, variant.name))
    save_json(change, Path(store_root) / RunLayout.day_change(variant.scene, variant.name))


__all__ = ["STAY_TOL", "first_day", "next_day"]
