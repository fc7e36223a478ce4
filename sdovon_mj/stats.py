"""Dataset statistics of a run folder: tables like the paper's tables 1-2 and category charts like its figures 4-7.

Reads only the run folder's records, where `sdovon_mj.runview.RunLayout` places them: each scene's SceneAsset,
NavMaps, perceived planes and region maps (optional), each variant's SceneVariant and episodes, a chain of days'
records (`day_statistics`), the object library and the run's config (optional).

Any of these may be missing (a partial run): missing parts count as zero. A file that exists but
cannot be read raises ``InputError`` naming it.

Writes the run's statistics folder (`RunLayout.STATS`): ``statistics.json`` (sorted keys, floats rounded), ``statistics.md``
(markdown tables) and four PNG bar charts; the same records give the same bytes.
"""

from __future__ import annotations

import io
import math
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from .errors import InputError
from .geometry import polygon_area
from .records import (
    Episode,
    NavMap,
    ObjectAsset,
    Placement,
    ReceptaclePlane,
    RecordError,
    RegionMap,
    Relevance,
    SceneAsset,
    SceneVariant,
    dumps,
    load_json,
)
from .runview import RunLayout
from .store import atomic_write_bytes, atomic_write_text

DIGITS = 4  # decimals kept for floats in statistics.json
UNKNOWN = "unknown"
CHARTS = {
    "placed_categories": ("category_frequency_placed.png", "Object category frequency of placed objects", "object category", "placed instances"),
    "goal_categories": ("category_frequency_goals.png", "Goal object category frequency of episodes", "goal category", "episodes"),
    "receptacle_categories": ("receptacle_frequency.png", "Receptacle category frequency of placed objects", "receptacle category", "placed instances"),
    "placement_regions": ("region_frequency.png", "Region frequency of placed objects", "region", "placed instances"),
}


# ----------------------------------------------------------------------------------------------
# Reading


def _read(path: Path, cls: type) -> Any:
    """Load a record file, or raise InputError naming it."""
    try:
        return load_json(path, cls)
    except RecordError as e:
        raise InputError(path, str(e)) from None
    except OSError as e:
        raise InputError(path, f"cannot read ({e.strerror or e})") from None


def _read_list(path: Path, cls: type) -> list[Any]:
    """Load a list-of-records file ([] if missing)."""
    if not path.is_file():
        return []
    data = _read(path, cls)
    return data if isinstance(data, list) else [data]


def _floor_of(path: Path) -> int:
    """Return the floor index in a name like navmap_<floor>.json (-1 if none)."""
    m = re.search(r"_(-?\d+)$", path.stem)
    return int(m.group(1)) if m else -1


def _objects(root: Path) -> list[ObjectAsset]:
    """Return the run's object library (deduplicated by name, sorted)."""
    found: dict[str, ObjectAsset] = {}
    for obj in _read_list(root / RunLayout.OBJECT_LIBRARY, ObjectAsset):
        found.setdefault(obj.name, obj)
    for p in sorted(root.glob(RunLayout.object_record("*"))):
        obj = _read(p, ObjectAsset)
        found.setdefault(obj.name, obj)
    return [found[k] for k in sorted(found)]


def _config_info(root: Path) -> dict[str, Any]:
    """Return the dataset name and k_e/k_v from the run's config.yaml (empty if absent)."""
    path = root / RunLayout.CONFIG
    if not path.is_file():
        return {}
    from .config import load_config  # local: config is only needed when the run has one

    try:
        cfg = load_config(path)
    except Exception as e:  # noqa: BLE001 - any config error becomes an InputError naming the file
        raise InputError(path, f"not a readable run config ({e})") from None
    return {"name": cfg.name, "k_e": int(cfg.episodes.k_e), "k_v": int(getattr(cfg.place, "k_v", 0) or 0)}


# ----------------------------------------------------------------------------------------------
# Helpers


def rejection_key(p: Placement) -> str:
    """Return a placement's rejection reason without numbers and object names ('' if it rests)."""
    if p.status == "resting":
        return ""
    text = (p.reason or "").strip()
    verdict = p.status
    m = re.match(r"^(\w+) \(", text)
    if m:  # "fell (rests on the floor) after 2 attempts": the verdict and what is inside its brackets
        verdict, depth, start = m.group(1), 0, m.end() - 1
        end = len(text)
        for i in range(start, len(text)):
            depth += {"(": 1, ")": -1}.get(text[i], 0)
            if depth == 0:
                end = i
                break
        text = text[start + 1:end]
    cause = re.split(r" \(|;|, touching| touching ", text)[0].strip()
    cause = re.sub(r"-?\d+(\.\d+)?", "#", cause)
    if p.status == "dropped" and verdict != "dropped":
        return f"{verdict}: {cause}" if cause else verdict
    return f"{p.status}: {cause}" if cause else p.status


def _quartiles(values: Iterable[float]) -> list[float]:
    """Return the [25 %, 50 %, 75 %] quartiles of values (linear interpolation; zeros if empty)."""
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    return [float(q) for q in np.percentile(v, [25, 50, 75])] if v.size else [0.0, 0.0, 0.0]


def _room_instances(scene: SceneAsset | None) -> list[int]:
    """Return the labelled instances of each room of a scene (ground truth: each instance's room), room by room."""
    if scene is None or not scene.rooms:
        return []
    per = Counter(int(i.room) for i in scene.instances)
    return [int(per.get(int(r.id), 0)) for r in scene.rooms]


def _summary(values: Iterable[float]) -> dict[str, float]:
    """Return mean/min/max of values (zeros if empty)."""
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return {"mean": 0.0, "min": 0.0, "max": 0.0}
    return {"mean": float(v.mean()), "min": float(v.min()), "max": float(v.max())}


def _sorted_counts(counter: Counter) -> dict[str, int]:
    """Return a Counter as a plain dict (keys sorted)."""
    return {str(k): int(counter[k]) for k in sorted(counter)}


def _round(data: Any) -> Any:
    """Round every float in nested data to DIGITS decimals (non-finite -> 0.0)."""
    if isinstance(data, float):
        return round(data, DIGITS) if math.isfinite(data) else 0.0
    if isinstance(data, dict):
        return {str(k): _round(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [_round(v) for v in data]
    return data


def _ratio(a: float, b: float) -> float:
    """Return a / b, 0 when b is 0."""
    return float(a) / float(b) if b else 0.0


# ----------------------------------------------------------------------------------------------
# Statistics of one scene


def _scene_names(root: Path) -> list[str]:
    """Return the names of the run's scene folders, sorted (none when it has no scenes folder)."""
    return sorted(p.name for p in root.glob(RunLayout.scene_dir("*")) if p.is_dir())


def _navmaps(root: Path, scene: str) -> list[NavMap]:
    """Return a scene's navigation maps by floor."""
    return [_read(p, NavMap) for p in sorted(root.glob(RunLayout.navmap(scene)), key=_floor_of)]


def _area_m2(mask: np.ndarray, resolution: float) -> float:
    """Return the area in m^2 of the true cells of a grid mask with `resolution` metres per cell."""
    return float(np.count_nonzero(mask)) * float(resolution) ** 2


def _scene_planes(root: Path, name: str, scene: SceneAsset | None,
                  inst_label: dict[int, str]) -> tuple[str, list[tuple[int, str, float]]]:
    """Return where a scene's receptacle planes come from and (id, label, area m^2) of each.

    Perceived planes when the perceive stage wrote them, else the scene's ground-truth support surfaces.
    """
    planes_path = root / RunLayout.planes(name, "perceive")
    if planes_path.is_file():
        return "perceive", [(p.id, p.label or inst_label.get(p.instance_id, UNKNOWN), float(abs(p.area)))
                            for p in _read_list(planes_path, ReceptaclePlane)]
    if scene is not None and scene.support_surfaces:
        planes = []
        for k, s in enumerate(scene.support_surfaces):
            planes.append((k, inst_label.get(s.instance_id, UNKNOWN), abs(polygon_area(s.polygon))))
        return "ground_truth", planes
    return "none", []


def _scene_regions(root: Path, scene: str) -> tuple[set[str], set[str]]:
    """Return the region labels present in a scene's region maps and the backends that labelled them."""
    labels: set[str] = set()
    backends: set[str] = set()
    for p in sorted(root.glob(RunLayout.regions(scene)), key=_floor_of):
        rm = _read(p, RegionMap)
        present = np.unique(np.asarray(rm.label_map))
        labels.update(rm.labels[int(i)] for i in present if 0 <= int(i) < len(rm.labels))
        if rm.backend:
            backends.add(rm.backend)
    return labels, backends


def _scene_variants(root: Path, scene: str, plane_label: dict[int, str],
                    inst_label: dict[int, str]) -> list[dict[str, Any]]:
    """Return a scene's variants: name, placements, each placement's receptacle label and episodes."""
    variants: list[dict[str, Any]] = []
    names = sorted({p.parent.name for p in root.glob(RunLayout.variant_record(scene))}
                   | {p.parent.name for p in root.glob(RunLayout.episodes(scene))})
    for vname in names:
        vpath, epath = root / RunLayout.variant_record(scene, vname), root / RunLayout.episodes(scene, vname)
        variant = _read(vpath, SceneVariant) if vpath.is_file() else None
        episodes: list[Episode] = _read_list(epath, Episode)
        placements = variant.placements if variant is not None else []
        variants.append({
            "name": variant.name if variant is not None else vname,
            "has_variant": variant is not None,
            "placements": placements,
            "receptacles": [plane_label.get(pl.plane_id) or inst_label.get(pl.receptacle_instance) or UNKNOWN for pl in placements],
            "episodes": episodes,
            "has_episodes": epath.is_file(),
        })
    return variants


def _scene_stats(root: Path, name: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """Return one scene's statistics and the raw data the run totals need (planes, variants, regions)."""
    spath = root / RunLayout.scene_record(name)
    scene: SceneAsset | None = _read(spath, SceneAsset) if spath.is_file() else None
    navmaps = _navmaps(root, name)
    inst_label = {i.id: i.label for i in scene.instances} if scene is not None else {}
    planes_src, planes = _scene_planes(root, name, scene, inst_label)
    region_labels, region_backends = _scene_regions(root, name)
    variants = _scene_variants(root, name, {pid: label for pid, label, _ in planes}, inst_label)
    per_room = _room_instances(scene)
    stats = {
        "name": scene.name if scene is not None else name,
        "floors": len(scene.floors) if scene is not None else len(navmaps),
        "navmaps": len(navmaps),
        "navigable_area_m2": sum(_area_m2(m.navigable, m.resolution) for m in navmaps),
        "free_area_m2": sum(_area_m2(m.free, m.resolution) for m in navmaps),
        "instances": len(scene.instances) if scene is not None else 0,
        "rooms": len(scene.rooms) if scene is not None else 0,
        "receptacle_planes": len(planes),
        "receptacle_planes_source": planes_src,
        "receptacle_plane_area_m2": sum(a for _, _, a in planes),
        "regions": len(region_labels),
        "region_labels": sorted(region_labels),
        "region_backends": sorted(region_backends),
        "variants": sum(1 for v in variants if v["has_variant"]),
        "placed_objects": sum(1 for v in variants for p in v["placements"] if p.status == "resting"),
        "episodes": sum(len(v["episodes"]) for v in variants),
        "instances_per_room": _ratio(sum(per_room), len(per_room)),
        "room_instances_median": float(np.median(per_room)) if per_room else 0.0,
        "geodesic_quartiles_m": _quartiles(float(e.geodesic_distance) for v in variants for e in v["episodes"]),
    }
    raw = {"planes": planes, "variants": variants, "regions": region_labels, "room_instances": per_room}
    return stats, raw


# ----------------------------------------------------------------------------------------------
# Run totals


@dataclass
class _Tally:
    """Counts and per-episode values gathered over every scene's variants (in scene, variant order)."""

    placed_cat: Counter = field(default_factory=Counter)  # category -> resting placements
    placed_var: Counter = field(default_factory=Counter)  # category -> variants with it resting
    goal_cat: Counter = field(default_factory=Counter)  # category -> episodes with it as goal
    rec_place: Counter = field(default_factory=Counter)  # receptacle label -> resting placements
    rec_planes: Counter = field(default_factory=Counter)  # receptacle label -> planes
    regions_place: Counter = field(default_factory=Counter)  # region -> resting placements
    by_status: Counter = field(default_factory=Counter)
    rejected: Counter = field(default_factory=Counter)  # rejection_key -> placements
    placed_assets: set[str] = field(default_factory=set)
    region_labels: set[str] = field(default_factory=set)
    geo: list[float] = field(default_factory=list)  # geodesic distance per episode, metres
    euc: list[float] = field(default_factory=list)  # euclidean distance per episode, metres
    ratio: list[float] = field(default_factory=list)  # euclidean / geodesic per episode
    goals_per_ep: list[int] = field(default_factory=list)
    vps_per_goal: list[int] = field(default_factory=list)
    eps_per_variant: list[int] = field(default_factory=list)
    cats_per_variant: list[int] = field(default_factory=list)
    objs_per_variant: list[int] = field(default_factory=list)
    n_variants: int = 0
    n_variants_with_eps: int = 0


def _count_placements(t: _Tally, v: dict[str, Any]) -> None:
    """Add one variant's placements (outcomes, categories, receptacles, regions) to the tally."""
    if v["has_variant"]:
        t.n_variants += 1
        resting = [p for p in v["placements"] if p.status == "resting"]
        t.objs_per_variant.append(len(resting))
        t.placed_var.update({p.category for p in resting})
    for p, rec in zip(v["placements"], v["receptacles"]):
        t.by_status[p.status] += 1
        if p.status == "resting":
            t.placed_cat[p.category] += 1
            t.placed_assets.add(p.asset)
            t.rec_place[rec] += 1
            t.regions_place[p.region or UNKNOWN] += 1
        else:
            t.rejected[rejection_key(p)] += 1


def _count_episodes(t: _Tally, v: dict[str, Any]) -> None:
    """Add one variant's episodes (goal categories, distances, goals and view points) to the tally."""
    if v["has_episodes"]:
        t.n_variants_with_eps += 1
        t.eps_per_variant.append(len(v["episodes"]))
        t.cats_per_variant.append(len({e.object_category for e in v["episodes"]}))
    for e in v["episodes"]:
        t.goal_cat[e.object_category] += 1
        t.geo.append(float(e.geodesic_distance))
        t.euc.append(float(e.euclidean_distance))
        if e.geodesic_distance > 0:
            t.ratio.append(float(e.euclidean_distance) / float(e.geodesic_distance))
        t.goals_per_ep.append(len(e.goals))
        t.vps_per_goal.extend(len(g.view_points) for g in e.goals)


def _tally(raws: list[dict[str, Any]]) -> _Tally:
    """Return the counts over every scene's planes, regions and variants."""
    t = _Tally()
    for raw in raws:
        t.rec_planes.update(label for _, label, _ in raw["planes"])
        t.region_labels |= raw["regions"]
        for v in raw["variants"]:
            _count_placements(t, v)
            _count_episodes(t, v)
    return t


def _totals(scenes: list[dict[str, Any]], t: _Tally, objects: list[ObjectAsset]) -> dict[str, Any]:
    """Return the run totals (paper tables 1-2 quantities)."""
    n_eps = len(t.geo)
    return {
        "scenes": len(scenes),
        "scenes_with_variants": sum(1 for s in scenes if s["variants"] > 0),
        "floors": sum(s["floors"] for s in scenes),
        "navigable_area_m2": sum(s["navigable_area_m2"] for s in scenes),
        "free_area_m2": sum(s["free_area_m2"] for s in scenes),
        "receptacle_planes": sum(t.rec_planes.values()),
        "receptacle_categories": len(t.rec_planes),
        "regions": sum(s["regions"] for s in scenes),
        "region_labels": len(t.region_labels),
        "variants": t.n_variants,
        "variants_with_episodes": t.n_variants_with_eps,
        "placements": sum(t.by_status.values()),
        "placed_objects": sum(t.placed_cat.values()),
        "placed_object_assets": len(t.placed_assets),
        "placed_categories": len(t.placed_cat),
        "objects_rejected": sum(t.rejected.values()),
        "object_assets": len(objects),
        "object_categories": len({o.category for o in objects}),
        "episodes": n_eps,
        "goal_categories": len(t.goal_cat),
        "mean_episodes_per_variant": _ratio(n_eps, t.n_variants_with_eps),
        "mean_placed_objects_per_variant": _ratio(sum(t.objs_per_variant), len(t.objs_per_variant)),
        "geodesic_quartiles_m": _quartiles(t.geo),
    }


def _tally_table(t: _Tally, fn: Callable[[Any], dict], fields: tuple[tuple[str, str], ...]) -> dict[str, dict]:
    """Return {key: fn(tally attribute)} for each (key, attribute name) of `fields`, in that order."""
    return {key: fn(getattr(t, attr)) for key, attr in fields}


_EPISODE_SUMMARIES = (("geodesic_distance_m", "geo"), ("euclidean_distance_m", "euc"),
                      ("euclidean_geodesic_ratio", "ratio"), ("goals_per_episode", "goals_per_ep"),
                      ("view_points_per_goal", "vps_per_goal"))
_FREQUENCIES = (("placed_categories", "placed_cat"), ("variants_with_category", "placed_var"),
                ("goal_categories", "goal_cat"), ("receptacle_categories", "rec_place"),
                ("receptacle_planes", "rec_planes"), ("placement_regions", "regions_place"))


def _episode_summaries(t: _Tally) -> dict[str, dict[str, float]]:
    """Return mean/min/max of the episodes' distances (metres), goals and view points."""
    return _tally_table(t, _summary, _EPISODE_SUMMARIES)


def _episode_formula(scenes: list[dict[str, Any]], t: _Tally, cfg: dict[str, Any]) -> dict[str, Any]:
    """Return the measured factors of N = k_s * k_v * n_c * k_e and the configured k_e, k_v.

    k_s: scenes with variants; k_v: variants per such scene; n_c: mean goal categories per variant;
    k_e: episodes per (variant, category). Their product is the episode count.
    """
    cat_slots = sum(t.cats_per_variant)
    k_s = sum(1 for s in scenes if s["variants"] > 0)
    k_v = _ratio(t.n_variants, k_s)
    n_c = _ratio(cat_slots, t.n_variants)
    k_e = _ratio(len(t.geo), cat_slots)
    return {"k_s": k_s, "k_v": k_v, "n_c": n_c, "k_e": k_e, "N": k_s * k_v * n_c * k_e,
            "k_e_config": cfg.get("k_e", 0), "k_v_config": cfg.get("k_v", 0)}


def _homes(scenes: list[dict[str, Any]], raws: list[dict[str, Any]]) -> dict[str, Any]:
    """Return the medians over the scenes of their size (rooms, storeys, navigable m^2), clutter (labelled instances
    per room: each scene's mean) and episode length (each scene's median start-to-goal geodesic), and the median
    room's labelled instances over every room of every scene."""
    def med(key: str) -> float:
        v = [float(x[key]) for x in scenes]
        return float(np.median(v)) if v else 0.0

    rooms = [n for r in raws for n in r["room_instances"]]
    geo = [float(x["geodesic_quartiles_m"][1]) for x in scenes if x["episodes"]]
    return {"scenes": len(scenes), "rooms_median": med("rooms"), "floors_median": med("floors"),
            "navigable_area_m2_median": med("navigable_area_m2"), "instances_per_room_median": med("instances_per_room"),
            "room_instances_median": float(np.median(rooms)) if rooms else 0.0,
            "geodesic_median_m": float(np.median(geo)) if geo else 0.0}


def homes_table(stats: dict) -> str:
    """Return a plain-text table of the scenes' size, clutter and episode lengths, and their medians (the homes of
    the default world's presets: docs/world.md)."""
    head = ("scene", "storeys", "rooms", "navigable m2", "inst/room", "median room", "episodes", "geodesic m q1 / q2 / q3")
    rows = [(s_["name"], str(s_["floors"]), str(s_["rooms"]), f"{s_['navigable_area_m2']:.1f}", f"{s_['instances_per_room']:.1f}",
             f"{s_['room_instances_median']:.1f}", str(s_["episodes"]),
             " / ".join(f"{q:.2f}" for q in s_["geodesic_quartiles_m"])) for s_ in stats["scenes"]]
    h = stats["homes"]
    q = stats["totals"]["geodesic_quartiles_m"]
    rows.append(("median of scenes", f"{h['floors_median']:g}", f"{h['rooms_median']:g}", f"{h['navigable_area_m2_median']:.1f}",
                 f"{h['instances_per_room_median']:.1f}", f"{h['room_instances_median']:.1f} (all rooms)",
                 str(stats["totals"]["episodes"]), f"{h['geodesic_median_m']:.2f} (scene medians)"))
    rows.append(("all episodes", "", "", "", "", "", str(stats["totals"]["episodes"]), " / ".join(f"{x:.2f}" for x in q)))
    widths = [max(len(r[k]) for r in rows + [head]) for k in range(len(head))]
    line = "  ".join("-" * w for w in widths)
    fmt = lambda r: "  ".join(c.ljust(w) if k == 0 else c.rjust(w) for k, (c, w) in enumerate(zip(r, widths)))  # noqa: E731
    return "\n".join([fmt(head), line] + [fmt(r) for r in rows[:-2]] + [line] + [fmt(r) for r in rows[-2:]])


def _library(objects: list[ObjectAsset]) -> dict[str, Any]:
    """Return the object library by source (instances, categories) and its category counts."""
    lib_sources: dict[str, dict[str, Any]] = {}
    for o in objects:
        src = o.source or UNKNOWN
        entry = lib_sources.setdefault(src, {"instances": 0, "categories": set()})
        entry["instances"] += 1
        entry["categories"].add(o.category)
    return {
        "by_source": {src: {"instances": e["instances"], "categories": len(e["categories"])} for src, e in sorted(lib_sources.items())},
        "library_categories": _sorted_counts(Counter(o.category for o in objects)),
    }


def _frequencies(t: _Tally) -> dict[str, dict[str, int]]:
    """Return the category, receptacle and region frequency tables (paper figures 4-7)."""
    return _tally_table(t, _sorted_counts, _FREQUENCIES)


def dataset_statistics(run_root: Path) -> dict:
    """Return the run folder's dataset statistics (counts, distances, frequencies, placement outcomes).

    Steps: per scene, read its records into statistics and raw data; read the object library and the
    config; tally the raw data over all scenes; derive totals, summaries and tables; round the floats.
    """
    root = Path(run_root)
    per_scene = [_scene_stats(root, n) for n in _scene_names(root)]
    scenes = [s for s, _ in per_scene]
    objects = _objects(root)
    cfg = _config_info(root)
    t = _tally([r for _, r in per_scene])
    days = day_statistics(root) if (root / RunLayout.SCENES).is_dir() else {}
    return _round({
        **({"days": days} if days else {}),  # runs with chains of days only: other runs keep their bytes
        "homes": _homes(scenes, [r for _, r in per_scene]),
        "dataset": cfg.get("name", "sdovon"),
        "totals": _totals(scenes, t, objects),
        "episodes": _episode_summaries(t),
        "episode_count_formula": _episode_formula(scenes, t, cfg),
        "placements": {"by_status": _sorted_counts(t.by_status), "rejected_by_reason": _sorted_counts(t.rejected)},
        "objects": _library(objects),
        "frequency": _frequencies(t),
        "scenes": scenes,
    })


# ----------------------------------------------------------------------------------------------
# Rendering


def _table(headers: list[str], rows: list[list[Any]]) -> str:
    """Return a markdown table."""
    out = ["| " + " | ".join(headers) + " |", "|" + "|".join(" --- " for _ in headers) + "|"]
    out += ["| " + " | ".join(_fmt(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def _fmt(v: Any) -> str:
    """Format a table cell."""
    if isinstance(v, float):
        return f"{v:.2f}"
    return str(v).replace("|", "\\|")


def _by_count(freq: dict[str, int]) -> list[tuple[str, int]]:
    """Return (key, count) pairs by decreasing count, then name."""
    return sorted(freq.items(), key=lambda kv: (-kv[1], kv[0]))


def statistics_markdown(stats: dict) -> str:
    """Return the statistics as markdown tables (like the paper's tables 1-2 plus details)."""
    t, ep, f, fr = stats["totals"], stats["episodes"], stats["episode_count_formula"], stats["frequency"]
    parts = [f"# Dataset statistics: {stats['dataset']}", ""]
    parts += ["## ObjectNav task dataset (paper table 2)", "",
              _table(["Dataset", "# of Categories", "Scenes", "Scene Variants", "# of Episodes"],
                     [[stats["dataset"], t["goal_categories"], t["scenes"], t["variants"], t["episodes"]]]), ""]
    src_rows = [[src, e["instances"], e["categories"]] for src, e in stats["objects"]["by_source"].items()]
    src_rows.append(["Library (all sources)", t["object_assets"], t["object_categories"]])
    src_rows.append(["Placed (resting)", t["placed_object_assets"], t["placed_categories"]])
    parts += ["## Objects (paper table 1)", "", _table(["Source", "# of Instances", "# of Categories"], src_rows), ""]
    parts += ["## Totals", "", _table(["Quantity", "Value"], [
        ["scenes", t["scenes"]], ["floors", t["floors"]], ["navigable area (m^2)", t["navigable_area_m2"]],
        ["receptacle planes", t["receptacle_planes"]], ["receptacle categories", t["receptacle_categories"]],
        ["regions (per scene, summed)", t["regions"]], ["region labels", t["region_labels"]],
        ["scene variants", t["variants"]], ["object placements", t["placements"]], ["placed objects (resting)", t["placed_objects"]],
        ["objects rejected", t["objects_rejected"]], ["mean placed objects per variant", t["mean_placed_objects_per_variant"]],
        ["episodes", t["episodes"]], ["mean episodes per variant", t["mean_episodes_per_variant"]]]), ""]
    parts += ["## Episodes", "", _table(["Quantity", "Mean", "Min", "Max"], [
        [name, ep[k]["mean"], ep[k]["min"], ep[k]["max"]] for name, k in [
            ("geodesic distance (m)", "geodesic_distance_m"), ("euclidean distance (m)", "euclidean_distance_m"),
            ("euclidean / geodesic", "euclidean_geodesic_ratio"), ("goals per episode", "goals_per_episode"),
            ("view points per goal", "view_points_per_goal")]]), ""]
    parts += ["## Episode count N = k_s x k_v x n_c x k_e (measured)", "",
              _table(["k_s", "k_v", "n_c", "k_e", "N", "k_e (config)"],
                     [[f["k_s"], f["k_v"], f["n_c"], f["k_e"], f["N"], f["k_e_config"]]]), ""]
    pl = stats["placements"]
    parts += ["## Placement outcomes", "", _table(["Status", "Objects"], [[k, v] for k, v in _by_count(pl["by_status"])] or [["(none)", 0]]), ""]
    parts += ["## Objects rejected by reason", "", _table(["Reason", "Objects"], [[k, v] for k, v in _by_count(pl["rejected_by_reason"])] or [["(none)", 0]]), ""]
    cats = sorted(set(fr["placed_categories"]) | set(fr["goal_categories"]), key=lambda c: (-fr["placed_categories"].get(c, 0), -fr["goal_categories"].get(c, 0), c))
    parts += ["## Object category frequency (paper figures 4-7)", "", _table(
        ["Category", "Placed instances", "Variants", "Episodes (goal)"],
        [[c, fr["placed_categories"].get(c, 0), fr["variants_with_category"].get(c, 0), fr["goal_categories"].get(c, 0)] for c in cats] or [["(none)", 0, 0, 0]]), ""]
    recs = sorted(set(fr["receptacle_planes"]) | set(fr["receptacle_categories"]), key=lambda c: (-fr["receptacle_categories"].get(c, 0), -fr["receptacle_planes"].get(c, 0), c))
    parts += ["## Receptacle category frequency", "", _table(
        ["Receptacle", "Planes", "Placed instances"],
        [[c, fr["receptacle_planes"].get(c, 0), fr["receptacle_categories"].get(c, 0)] for c in recs] or [["(none)", 0, 0]]), ""]
    parts += ["## Region frequency of placed objects", "", _table(
        ["Region", "Placed instances"], [[k, v] for k, v in _by_count(fr["placement_regions"])] or [["(none)", 0]]), ""]
    parts += ["## Scenes", "", _table(
        ["Scene", "Floors", "Navigable area (m^2)", "Receptacle planes", "Regions", "Variants", "Placed objects", "Episodes"],
        [[s["name"], s["floors"], s["navigable_area_m2"], f"{s['receptacle_planes']} ({s['receptacle_planes_source']})", s["regions"],
          s["variants"], s["placed_objects"], s["episodes"]] for s in stats["scenes"]] or [["(none)", 0, 0.0, 0, 0, 0, 0, 0]]), ""]
    parts += ["## Homes: size, clutter, episode length", "", "```", homes_table(stats), "```", ""]
    if stats.get("days"):
        parts += ["## Days: what changed overnight", "", "```", days_table(stats["days"]), "```", ""]
    return "\n".join(parts)


def summary_table(stats: dict) -> str:
    """Return a plain-text table for the terminal: scenes, variants, categories, episodes, rejections by reason."""
    t = stats["totals"]
    rows = [("scenes", t["scenes"]), ("variants", t["variants"]), ("object categories (placed)", t["placed_categories"]),
            ("goal categories", t["goal_categories"]), ("placed objects", t["placed_objects"]), ("episodes", t["episodes"]),
            ("objects rejected", t["objects_rejected"])]
    rows += [(f"  {k}", v) for k, v in _by_count(stats["placements"]["rejected_by_reason"])]
    if stats.get("days"):  # chains of days (place.days): their days and what the nights changed
        d = stats["days"]
        rows += [("days (chains of days)", len(d["days"]))]
        rows += [(f"  {k} overnight", v["observed"]) for k, v in d["rates"].items()]
    width = max(len(k) for k, _ in rows)
    vwidth = max(len(str(v)) for _, v in rows)
    line = "-" * (width + vwidth + 3)
    return "\n".join([line] + [f"{k:<{width}}   {v:>{vwidth}}" for k, v in rows] + [line])


def bar_chart_png(freq: dict[str, int], title: str, xlabel: str, ylabel: str) -> bytes:
    """Return a deterministic PNG bar chart of a frequency table (largest first)."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    items = _by_count(freq)
    with matplotlib.rc_context({"svg.hashsalt": "sdovon-mj", "font.family": "DejaVu Sans", "font.size": 9,
                                "path.simplify": True, "figure.dpi": 100}):
        fig = Figure(figsize=(max(6.0, 0.28 * len(items) + 1.5), 4.5))
        FigureCanvasAgg(fig)
        ax = fig.add_subplot(1, 1, 1)
        if items:
            x = np.arange(len(items))
            ax.bar(x, [c for _, c in items], color="#4c72b0")
            ax.set_xticks(x)
            ax.set_xticklabels([k for k, _ in items], rotation=70, ha="right")
            ax.set_xlim(-0.6, len(items) - 0.4)
        else:
            ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)
            ax.set_xticks([])
        ax.set_title(f"{title} (total {sum(freq.values())})")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.yaxis.get_major_locator().set_params(integer=True)
        fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()


def write_statistics(run_root: Path, out_rel: str = RunLayout.STATS) -> list[Path]:
    """Write statistics.json, statistics.md and the category charts into <run>/<out_rel>/ and return their paths."""
    root = Path(run_root)
    stats = dataset_statistics(root)
    out = root / out_rel
    written: list[Path] = []
    atomic_write_text(out / "statistics.json", dumps(stats))
    written.append(out / "statistics.json")
    atomic_write_text(out / "statistics.md", statistics_markdown(stats))
    written.append(out / "statistics.md")
    for key, (fname, title, xlabel, ylabel) in CHARTS.items():
        atomic_write_bytes(out / fname, bar_chart_png(stats["frequency"][key], title, xlabel, ylabel))
        written.append(out / fname)
    return written


def llm_fallbacks(run_root: Path) -> dict[str, int]:
    """Return counts of LLM replies that failed and fell back, summed over the run's scenes, per stage.

    Keys: ``perceive.receptacle_naming`` (perceive's ``llm.json``), ``semantics.region_proposals``
    (the region maps' ``fallbacks``) and ``semantics.relevance`` (``relevance.json``'s ``fallbacks``).
    A scene folder that lacks a file adds nothing.
    """
    import json

    out = {"perceive.receptacle_naming": 0, "semantics.region_proposals": 0, "semantics.relevance": 0}

    def _count(path: Path) -> int:
        try:
            return len(json.loads(path.read_text(encoding="utf-8")).get("fallbacks") or [])
        except (OSError, ValueError) as e:
            raise InputError(f"{path}: not a readable JSON record ({e})") from None

    root = Path(run_root)
    for sc in _scene_names(root):
        if (root / RunLayout.llm_record(sc)).is_file():
            out["perceive.receptacle_naming"] += _count(root / RunLayout.llm_record(sc))
        for rp in sorted(root.glob(RunLayout.regions(sc))):
            out["semantics.region_proposals"] += _count(rp)
        if (root / RunLayout.relevance(sc)).is_file():
            out["semantics.relevance"] += _count(root / RunLayout.relevance(sc))
    return out


PLACED_STATUSES = ("resting", "resting_elsewhere")


def placement_top_pairs(run_root: Path, k: int = 3) -> dict[str, Any]:
    """Return how often placed objects sit on one of their top-k (region, receptacle) pairs, and a random baseline.

    Per scene, the available pairs are the (region, receptacle label) of its annotated planes
    (``semantics/planes.json``); an object category's top-k pairs are the k available pairs where it
    takes the largest share of the placement direction (`Relevance.top_pairs`: ``Relevance.joint`` over the
    scene's pairs, what placement samples from and keeps each category to with ``place.top_pairs``). A placed object
    (status resting or resting_elsewhere) counts when its intended plane's pair is one of them. The
    random baseline places each of the same objects on one of the same planes uniformly: its expected
    share is the fraction of the scene's planes whose pair is in the category's top k (exact, no sampling).
    ``ceiling`` is the ratio of a placement that draws, for each counted object's plane, uniformly among
    the categories whose top-k holds the plane's pair (every draw a hit): with k = 3 and a scene of few
    pairs, top-3 pairs already cover much of the scene, and no placement rule gets far above this.
    Returns {"k", "placed", "on_top_k", "share", "random_share", "ratio", "ceiling"}; a ratio is inf when
    its random share is 0 and its share is not.
    """
    placed, hits, rand = 0, 0, 0.0
    ceil_hits, ceil_rand = 0.0, 0.0
    root = Path(run_root)
    for sc in _scene_names(root):
        planes_path, rel_path = root / RunLayout.planes(sc, "semantics"), root / RunLayout.relevance(sc)
        if not (planes_path.is_file() and rel_path.is_file()):
            continue
        planes = _read_list(planes_path, ReceptaclePlane)
        rel = _read(rel_path, Relevance)
        pair_of = {int(p.id): (str(p.region), str(p.label)) for p in planes}
        available = set(pair_of.values())
        top = rel.top_pairs(sorted(available), k)
        cover = {o: sum(1 for q in pair_of.values() if q in best) / len(pair_of) for o, best in top.items()}
        for v in _scene_variants(root, sc, {}, {}):
            for pl in v["placements"]:
                if pl.status not in PLACED_STATUSES or int(pl.plane_id) not in pair_of:
                    continue
                if pl.category not in top:
                    raise InputError(f"{rel_path}: no relevance row for placed category {pl.category!r}")
                q = pair_of[int(pl.plane_id)]
                placed += 1
                hits += int(q in top[pl.category])
                rand += cover[pl.category]
                good = [o for o in rel.objects if q in top[o]]  # the ceiling's draw on this plane
                ceil_hits += 1.0 if good else 0.0
                ceil_rand += float(np.mean([cover[o] for o in (good or rel.objects)]))
    share = hits / placed if placed else 0.0
    rshare = rand / placed if placed else 0.0
    ratio = share / rshare if rshare > 0 else (math.inf if share > 0 else 0.0)
    ceiling = ceil_hits / ceil_rand if ceil_rand > 0 else (math.inf if ceil_hits > 0 else 0.0)
    return {"k": int(k), "placed": placed, "on_top_k": hits, "share": share, "random_share": rshare, "ratio": ratio,
            "ceiling": ceiling}


# ----------------------------------------------------------------------------------------------
# Days: what the chains of days changed (place.days)

DAY_LEVEL = 0.999  # the two-sided level of the intervals the observed counts are compared with


def poisson_binomial_interval(rates: Iterable[float], level: float = DAY_LEVEL) -> tuple[int, int]:
    """Return the central `level` interval (lo, hi) of the number of successes of independent trials with these
    success probabilities (exact: the distribution by convolution; equal rates: the binomial interval). Counts below
    `lo` and above `hi` each have probability at most (1 - level) / 2."""
    pmf = np.ones(1)
    for p in rates:
        pmf = np.convolve(pmf, [1.0 - float(p), float(p)])
    cdf = np.cumsum(pmf)
    tail = (1.0 - level) / 2.0
    lo = int(np.searchsorted(cdf, tail, side="right"))  # P(X < lo) = cdf[lo - 1] <= tail
    hi = int(np.searchsorted(cdf, 1.0 - tail - 1e-12, side="left"))  # P(X > hi) = 1 - cdf[hi] <= tail
    return lo, min(hi, len(pmf) - 1)


def day_statistics(run_root: Path) -> dict[str, Any]:
    """Return what the run's chains of days changed ({} when the run has none).

    ``days``: per scene and day the objects present the day before and how many stayed, moved, left, arrived, were
    dropped (could not rest) or resettled (stayed, but settling moved them). ``rates``: per outcome (moved, left,
    arrived) over every object-day of the run, the count observed, the count the configured rates expect and its
    `DAY_LEVEL` interval (`poisson_binomial_interval` of each object-day's configured rate). ``transitions``: moves
    counted by (from receptacle, to receptacle) and by (from region, to region). ``prior``: the moves' mean relevance
    of the plane moved to (`Relevance.plane_relevance`) beside the same objects' mean relevance over every plane of
    their scene.
    """
    from .runview import RunView

    view = RunView(run_root)
    rows: list[dict[str, Any]] = []
    rates: dict[str, list[float]] = {"moved": [], "left": [], "arrived": []}
    seen = {"moved": 0, "left": 0, "arrived": 0}
    by_rec: Counter = Counter()
    by_region: Counter = Counter()
    to_rel: list[float] = []
    all_rel: list[float] = []
    for scene in view.scene_names():
        days = view.days(scene)
        if not days:
            continue
        planes = view.planes(scene)
        rel = view.relevance(scene)
        plane_index = {p.id: k for k, p in enumerate(planes)}
        for v in days:
            c = view.day_change(v)
            rows.append({"scene": scene, "day": c.day, "previous": c.previous, "present": len(v.resting),
                         "stayed": len(c.stayed), "moved": len(c.moved), "left": len(c.left), "arrived": len(c.arrived),
                         "dropped": len(c.dropped), "resettled": len(c.resettled)})
            if c.day == 0:
                continue
            for move, leave in c.rates.values():
                rates["moved"].append(move)
                rates["left"].append(leave)
            rates["arrived"] += [c.arrive_rate] * c.previous
            seen["moved"] += len(c.moved)
            seen["left"] += len(c.left)
            seen["arrived"] += len(c.arrived)
            for m in c.moved:
                if m.to_plane < 0:
                    continue
                by_rec[f"{m.from_receptacle} -> {m.to_receptacle}"] += 1
                by_region[f"{m.from_region} -> {m.to_region}"] += 1
                if rel is not None and m.to_plane in plane_index:
                    w = rel.plane_relevance(m.category, planes)
                    to_rel.append(float(w[plane_index[m.to_plane]]))
                    all_rel.append(float(w.mean()))
    if not rows:
        return {}
    out_rates = {}
    for k, rs in rates.items():
        lo, hi = poisson_binomial_interval(rs)
        out_rates[k] = {"observed": seen[k], "object_days": len(rs), "expected": float(sum(rs)),
                        "interval": [lo, hi], "level": DAY_LEVEL, "within": lo <= seen[k] <= hi}
    return _round({"days": rows, "rates": out_rates,
                   "transitions": {"receptacle": _sorted_counts(by_rec), "region": _sorted_counts(by_region)},
                   "prior": {"moves": len(to_rel), "mean_relevance_moved_to": float(np.mean(to_rel)) if to_rel else 0.0,
                             "mean_relevance_all_planes": float(np.mean(all_rel)) if all_rel else 0.0}})


def days_table(days: dict[str, Any]) -> str:
    """Return `day_statistics` as plain-text tables: per day, the rates against the config, the transitions."""
    if not days:
        return "no chains of days in this run (place.days: 0)"
    keys = ("previous", "present", "stayed", "moved", "left", "arrived", "dropped", "resettled")
    lines = ["Days: what changed overnight (per scene and day)",
             f"{'scene':<14}{'day':>4}" + "".join(f"{k:>10}" for k in keys)]
    lines += [f"{r['scene']:<14}{r['day']:>4}" + "".join(f"{r[k]:>10}" for k in keys) for r in days["days"]]
    lines += ["", f"Over every object-day: observed against the configured rates ({100 * DAY_LEVEL:g} % interval)",
              f"{'outcome':<10}{'observed':>10}{'expected':>10}{'interval':>14}{'object-days':>13}  within"]
    for k, r in days["rates"].items():
        lines.append(f"{k:<10}{r['observed']:>10}{r['expected']:>10.1f}{str(r['interval'][0]) + '-' + str(r['interval'][1]):>14}"
                     f"{r['object_days']:>13}  {'yes' if r['within'] else 'NO'}")
    for what in ("receptacle", "region"):
        lines += ["", f"Moves by {what} (from -> to)"]
        lines += [f"  {n:>5}  {k}" for k, n in _by_count(days["transitions"][what])] or ["  (none)"]
    p = days["prior"]
    lines += ["", f"Moves and the prior: mean relevance of the plane moved to {p['mean_relevance_moved_to']:.4f}, "
                  f"over every plane of the scene {p['mean_relevance_all_planes']:.4f} ({p['moves']} moves)"]
    return "\n".join(lines)
