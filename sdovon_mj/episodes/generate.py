"""ObjectNav episodes for one scene variant (paper section 3.5).

Goals: every placed object body present in the composed model with at least one valid view point
(objects nobody can see are dropped). For each category with goals: ``k_e`` episodes, each with a
randomly chosen goal instance; the start is a navigable cell on that instance's floor, reachable from
the chosen instance's view points, drawn with Habitat's start filters (habitat-lab's
``is_compatible_episode``): its geodesic distance to the category's nearest view point lies in
[``min_start_distance``, ``max_start_distance``], and a start whose geodesic / Euclidean ratio (to the
nearest view point) is below ``start_ratio_threshold`` is kept only with probability
20 * (ratio - 0.98)^2 (straight-line episodes are mostly rejected); a uniformly random yaw. The
geodesic is `gridgraph.GeodesicField.distance`, the one the suite's SPL uses. An episode's goals are
all goal instances of its category (Habitat's ``goals_by_category``); it records the geodesic distance
to the nearest view point, the Euclidean distance to that goal's centre, that goal and the filters.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..config import AgentConfig, EpisodeConfig
from ..geometry import yaw_quat
from ..records import Episode, Goal, NavMap, SceneVariant
from ..gridgraph import GeodesicField
from .viewpoints import VisibilityChecker, floor_navmap, load_variant_model, object_box, object_view_points


@dataclass
class GoalReport:
    """What happened to each placed object when building goals."""

    kept: list[str]
    dropped: dict[str, str]  # object_id -> reason
    timing: dict[str, float] = field(default_factory=dict)  # where the time went: seconds and counts


def build_goals(variant: SceneVariant, navmaps: list[NavMap], store_root: str | Path,
                cfg: EpisodeConfig, agent: AgentConfig = AgentConfig()) -> tuple[list[Goal], dict[str, int], GoalReport]:
    """Return the variant's valid goals, each goal's floor index, and a kept/dropped report.

    Parameters
    ----------
    variant : SceneVariant
        The placed variant whose resting objects are the candidate goals.
    navmaps : list of NavMap
        Navigation maps of the scene, one per floor.
    store_root : str or Path
        Store root the variant's model is relative to.
    cfg : EpisodeConfig
        View-point radius, step and cap; visibility-render size.
    agent : AgentConfig
        The agent's body (radius, height) and camera (height, HFOV), metres and degrees.
    """
    t0 = time.perf_counter()
    model, data = load_variant_model(variant, store_root)
    t_load = time.perf_counter() - t0
    goals: list[Goal] = []
    floors: dict[str, int] = {}
    dropped: dict[str, str] = {}
    checker = VisibilityChecker(model, data, cfg, agent)
    try:
        for p in sorted(variant.placements, key=lambda p: p.object_id):
            box = object_box(model, data, p.object_id)
            if box is None:
                dropped[p.object_id] = "not in the composed model"
                continue
            nm = floor_navmap(navmaps, float(box.lo[2]))
            if nm is None:
                dropped[p.object_id] = "below every floor"
                continue
            # inside an articulated piece every navigable cell is rendered (short cuts miss slivers past a part)
            vps = object_view_points(checker, nm, box, cfg, agent, exhaustive=bool(p.part))
            open_part = None
            if not vps and p.part and variant.articulation:  # hidden in a closed door or drawer: seen once it opens
                from .inside import view_points_with_part_open

                vps = view_points_with_part_open(model, data, p.part, p.object_id, nm, cfg, agent)[0]
                open_part = p.part if vps else None
            if not vps:
                dropped[p.object_id] = "no view point sees it"
                continue
            goals.append(Goal(object_id=p.object_id, category=p.category, position=box.center.copy(),
                              view_points=vps, bounds=np.stack([box.lo, box.hi]), open_part=open_part))
            floors[p.object_id] = nm.floor
    finally:
        checker.close()
    timing = {"load_s": t_load, **checker.timing, "goals_s": time.perf_counter() - t0,
              "view_points": float(sum(len(g.view_points) for g in goals))}
    return goals, floors, GoalReport([g.object_id for g in goals], dropped, timing)


def generate_episodes(variant: SceneVariant, navmaps: list[NavMap], store_root: str | Path,
                      cfg: EpisodeConfig, seed: int, agent: AgentConfig = AgentConfig()) -> list[Episode]:
    """Return k_e ObjectNav episodes per valid goal category of a variant (empty: no valid goals).

    Parameters
    ----------
    variant
        The settled scene variant (its MJCF is loaded for visibility renders).
    navmaps
        The scene's navigable maps, one per floor.
    store_root
        Run folder the variant's paths are relative to.
    cfg
        Episode settings (k_e, view point lattice, start distances).
    seed
        Variant seed of start poses and goal choices.
    agent
        The agent camera (height above the floor, hfov) and ``eta_gt`` that define view points.
    """
    episodes, _report = generate_episodes_with_report(variant, navmaps, store_root, cfg, seed, agent)
    return episodes


def generate_episodes_with_report(variant: SceneVariant, navmaps: list[NavMap], store_root: str | Path,
                                  cfg: EpisodeConfig, seed: int, agent: AgentConfig = AgentConfig()) -> tuple[list[Episode], GoalReport]:
    """Return the episodes of a variant and the goal report (which objects were dropped and why).

    Parameters
    ----------
    variant : SceneVariant
        The placed variant whose resting objects are the goals.
    navmaps : list of NavMap
        Navigation maps of the scene, one per floor.
    store_root : str or Path
        Store root the variant's model is relative to.
    cfg : EpisodeConfig
        Episode settings (k_e, view-point radius and step, start distances).
    seed : int
        Seed of the episode draws.
    agent : AgentConfig
        The agent's body (radius, height) and camera (height, HFOV), metres and degrees.
    """
    rng = np.random.default_rng(seed)
    goals, floors, report = build_goals(variant, navmaps, store_root, cfg, agent)
    t0 = time.perf_counter()
    by_floor = {m.floor: m for m in navmaps}
    by_cat: dict[str, list[Goal]] = {}
    for g in goals:
        by_cat.setdefault(g.category, []).append(g)
    episodes: list[Episode] = []
    goal_fields: dict[str, GeodesicField] = {}  # one field per goal, shared by start sampling and closest goal

    def goal_field(g: Goal) -> GeodesicField:
        """Return (and memoise) the geodesic field of one goal's view points."""
        if g.object_id not in goal_fields:
            nm = by_floor[floors[g.object_id]]
            goal_fields[g.object_id] = GeodesicField(nm.navigable, nm.frame, _vp_xy(g))
        return goal_fields[g.object_id]

    for cat in sorted(by_cat):
        cat_goals = by_cat[cat]
        fields: dict[int, GeodesicField] = {}
        for k in range(cfg.k_e):
            chosen = cat_goals[int(rng.integers(len(cat_goals)))]
            floor = floors[chosen.object_id]
            nm = by_floor[floor]
            same_floor = [g for g in cat_goals if floors[g.object_id] == floor]
            if floor not in fields:
                fields[floor] = GeodesicField(nm.navigable, nm.frame, np.concatenate([_vp_xy(g) for g in same_floor]))
            start = _sample_start(rng, nm, fields[floor], goal_field(chosen), cfg)
            if start is None:
                continue
            xy, geo, ratio = start
            start_pos = np.array([xy[0], xy[1], nm.height])
            closest = _closest_goal(xy, same_floor, goal_field)
            yaw = float(rng.uniform(0.0, 360.0))
            episodes.append(Episode(
                episode_id=f"{variant.name}_{len(episodes):04d}", scene=variant.scene, variant=variant.name,
                object_category=cat, start_position=start_pos, start_rotation=yaw_quat(yaw), goals=cat_goals,
                geodesic_distance=float(geo), euclidean_distance=float(np.linalg.norm(closest.position - start_pos)),
                closest_goal_object_id=closest.object_id, floor=floor,
                start_filters={"min_geodesic_m": float(cfg.min_start_distance),
                               "max_geodesic_m": float(cfg.max_start_distance),
                               "geodesic_to_euclid_min_ratio": float(cfg.start_ratio_threshold),
                               "geodesic_to_euclid_ratio": float(ratio)}))
    report.timing["starts_s"] = time.perf_counter() - t0
    return episodes, report


def farthest_starts(variant: SceneVariant, navmaps: list[NavMap], store_root: str | Path, cfg: EpisodeConfig,
                    agent: AgentConfig = AgentConfig()) -> dict[str, float]:
    """Return, per goal category of a variant, the farthest start an episode could draw: the largest geodesic
    distance (m) from a navigable cell of a goal's floor to the category's nearest view point there (an empty dict
    when no placed object is a goal). Below ``min_start_distance`` for every category, the variant has no episode.

    Parameters
    ----------
    variant, navmaps, store_root, cfg, agent : as in `generate_episodes_with_report`
    """
    goals, floors, _report = build_goals(variant, navmaps, store_root, cfg, agent)
    by_floor = {m.floor: m for m in navmaps}
    groups: dict[tuple[str, int], list[Goal]] = {}
    for g in goals:
        groups.setdefault((g.category, floors[g.object_id]), []).append(g)
    out: dict[str, float] = {}
    for (cat, fl), gs in sorted(groups.items()):
        nm = by_floor[fl]
        dist = GeodesicField(nm.navigable, nm.frame, np.concatenate([_vp_xy(g) for g in gs])).field
        reach = dist[np.isfinite(dist)]
        if reach.size:
            out[cat] = max(out.get(cat, 0.0), float(reach.max()))
    return out


def _vp_xy(goal: Goal) -> np.ndarray:
    """Return the world XY of a goal's view points (N, 2)."""
    return np.array([vp.position[:2] for vp in goal.view_points], dtype=float)


def ratio_keep_probability(ratio: float, threshold: float) -> float:
    """Return the probability of keeping a start of this geodesic / Euclidean ratio (habitat-lab's rule).

    At or above ``threshold`` a start is always kept; below, with probability 20 * (ratio - 0.98)^2
    (habitat-lab's ``_ratio_sample_rate``: 0.008 at ratio 1, 0.098 at 1.05), capped at 1.
    """
    if ratio >= threshold:
        return 1.0
    return float(min(1.0, 20.0 * (ratio - 0.98) ** 2))


def _sample_start(rng: np.random.Generator, nm: NavMap, cat_field: GeodesicField, goal_field: GeodesicField,
                  cfg: EpisodeConfig) -> tuple[np.ndarray, float, float] | None:
    """Draw a start passing the Habitat filters; return (world XY, geodesic m, geodesic/Euclidean ratio) or None.

    The cell field (distance through the graph from the cell centre) bounds the point geodesic from
    above, so cells below ``min_start_distance`` there are excluded before drawing; each draw is then
    checked with the exact geodesic (`GeodesicField.distance`, the suite's SPL denominator).
    """
    ok = (np.isfinite(cat_field.field) & (cat_field.field >= cfg.min_start_distance) & np.isfinite(goal_field.field)
          & nm.navigable)
    cells = np.argwhere(ok)
    if len(cells) == 0:
        return None
    targets = cat_field.targets
    for _ in range(max(1, cfg.max_start_tries)):
        rc = cells[int(rng.integers(len(cells)))]
        xy = nm.frame.to_world(rc[None])[0]
        geo = cat_field.distance(xy)
        if not (math.isfinite(geo) and cfg.min_start_distance <= geo <= cfg.max_start_distance):
            continue
        euclid = float(np.min(np.linalg.norm(targets - xy[None], axis=1)))
        ratio = geo / max(euclid, 1e-9)
        if ratio < cfg.start_ratio_threshold and rng.random() > ratio_keep_probability(ratio, cfg.start_ratio_threshold):
            continue
        return xy, geo, ratio
    return None


def _closest_goal(xy: np.ndarray, goals: list[Goal], field: Callable[[Goal], GeodesicField]) -> Goal:
    """Return the goal whose nearest view point is geodesically closest to a start point."""
    best, best_d = goals[0], math.inf
    for g in goals:
        d = field(g).distance(xy)
        if d < best_d:
            best, best_d = g, d
    return best


def n_episodes_formula(k_s: int, k_v: int, n_c: float, k_e: int) -> float:
    """Return the paper's dataset size N = k_s * k_v * n_c * k_e."""
    return float(k_s) * float(k_v) * float(n_c) * float(k_e)


def episode_report(episodes_by_variant: dict[str, list[Episode]], k_e: int) -> dict[str, float]:
    """Return N = k_s*k_v*n_c*k_e (n_c = mean valid categories per variant) next to the actual count."""
    variants = sorted(episodes_by_variant)
    scenes = sorted({ep.scene for eps in episodes_by_variant.values() for ep in eps} |
                    {v.rsplit("_v", 1)[0] for v in variants})
    k_s = len(scenes)
    k_v = len(variants) / k_s if k_s else 0.0
    n_c = float(np.mean([len({e.object_category for e in episodes_by_variant[v]}) for v in variants])) if variants else 0.0
    actual = sum(len(v) for v in episodes_by_variant.values())
    return {"k_s": k_s, "k_v": k_v, "n_c": n_c, "k_e": k_e,
            "N_formula": n_episodes_formula(k_s, k_v, n_c, k_e), "N_actual": actual}
