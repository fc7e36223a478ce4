"""The wiring of the stages into tasks (used by `pipeline`): each stage's public API, run once per fingerprint.

This module is the one place that knows every stage; stages themselves only know records, config,
store and sim. Every stage writes into the run folder layout documented in `pipeline`.
"""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
from pathlib import Path
from typing import Any

from .config import RunConfig, config_hash, to_dict
from .errors import InputError, StageError
from .records import (Instance, NavMap, ObjectAsset, ReceptaclePlane, Relevance, SceneAsset, SceneVariant, load_json,
                      load_npz, save_json, save_npz)
from .store import Store, file_hash


def _scene_seed(cfg: RunConfig, scene: str) -> int:
    """Return the derived seed of a scene."""
    from .pipeline import derive_seed

    return derive_seed(cfg.seed, "scene", scene)


def _safe_name(stem: str) -> str:
    """Return a file-system-safe scene/object name."""
    s = re.sub(r"[^A-Za-z0-9_.-]+", "_", stem).strip("_.")
    return s or "scene"


def scene_inputs(store: Store, cfg: RunConfig) -> dict[str, str]:
    """Return scene name -> input file ('' for a default-world apartment)."""
    inputs = store.read_json("inputs.json")
    if not inputs["scenes"]:
        return {f"apt_{seed:04d}": "" for seed in cfg.world.scene_seeds}
    out: dict[str, str] = {}
    for path in inputs["scenes"]:
        name = _safe_name(Path(path).stem.replace("_vh_clean", ""))
        base, k = name, 1
        while name in out:
            k += 1
            name = f"{base}_{k}"
        out[name] = path
    return out


def scene_names(store: Store, cfg: RunConfig) -> list[str]:
    """Return the run's scene names in a fixed order."""
    return list(scene_inputs(store, cfg))


# ----------------------------------------------------------------------------------------------
# Objects


def _object_inputs(store: Store, cfg: RunConfig, runner: Any) -> list[tuple[Path, str | None]]:
    """Return (object file, category or None) for every input object, writing the default library if needed."""
    inputs = store.read_json("inputs.json")
    if inputs["objects"]:
        files: list[tuple[Path, str | None]] = []
        for p in map(Path, inputs["objects"]):
            if p.is_dir():
                found = sorted(q for q in p.rglob("*") if q.suffix.lower() in (".obj", ".glb", ".gltf", ".ply", ".stl"))
                if not found:
                    raise InputError(p, "folder holds no OBJ/GLB/glTF/PLY/STL object files")
                files += [(q, _meta_category(q)) for q in found]
            elif p.exists():
                files.append((p, _meta_category(p)))
            else:
                raise InputError(p, "object file not found")
        return files
    from .world import write_object_library

    w = cfg.world
    rel = "inputs/objects"

    def make() -> list[str]:
        paths = write_object_library(w.object_seed, store.path(rel), variants=w.object_variants,
                                     categories=list(w.object_categories) or None)
        return [store.rel(p) for p in paths]

    runner.run(rel, ["object-library", w.object_seed, w.object_variants, list(w.object_categories)], make)
    mark = store.mark(rel)
    assert mark is not None
    return [(store.path(o), _meta_category(store.path(o))) for o in mark.outputs if o.endswith((".obj", ".glb", ".ply"))]


def _converter_version() -> str:
    """Return the converter's output version (a new converter invalidates converted scenes and objects)."""
    from assets_convert.cache import CONVERTER_VERSION

    return CONVERTER_VERSION


def _input_name(store: Store, path: Path) -> str:
    """Return an input file's name for fingerprints: store-relative inside the run folder, else absolute."""
    try:
        return store.rel(path)
    except ValueError:
        return str(Path(path).resolve())


def _meta_category(path: Path) -> str | None:
    """Return the category named by a meta.json beside an object file, if any."""
    meta = path.parent / "meta.json"
    if meta.exists():
        try:
            return str(json.loads(meta.read_text(encoding="utf-8"))["category"])
        except (json.JSONDecodeError, KeyError):
            return None
    return None


def objects_task(store: Store, cfg: RunConfig, runner: Any) -> None:
    """Convert the object library into `objects/<name>/` (+ object.json) and `objects/objects.json`."""
    items = _object_inputs(store, cfg, runner)
    # Inputs inside the run folder are named relative to it, so the fingerprint (and the manifest) does
    # not depend on where the run folder lives.
    fp = ["objects", _converter_version(), to_dict(cfg.convert), [(_input_name(store, p), c, file_hash(p)) for p, c in items]]

    def make() -> list[str]:
        import tempfile

        from assets_convert.cache import link_tree
        from assets_convert.load import display_path
        from assets_convert.object import load_converted
        from assets_convert.tree import convert_tree

        assets: list[ObjectAsset] = []
        failures: dict[str, str] = {}
        # CoACD runs in convert_tree's process pool (convert.jobs workers, convert.timeout_s per object: a stuck
        # decomposition is killed and reported; one bad object is reported and the library goes on) into a
        # scratch folder, so its batch report and a killed worker's temp folder stay out of the run folder;
        # each converted object is then hard-linked into the run folder
        with tempfile.TemporaryDirectory(prefix="sdovon-objects-") as scratch:
            report = convert_tree([p for p, _c in items], scratch, jobs=cfg.convert.jobs, timeout=cfg.convert.timeout_s,
                                  progress=False, config=cfg.convert, categories={str(p): c for p, c in items if c})
            rows = {r["file"]: r for r in report["items"]}
            for path, _category in items:
                row = rows[display_path(path)]
                if row["status"] != "ok":
                    failures[str(path)] = str(row["error"])
                    continue
                asset = load_converted(scratch, row["name"])
                link_tree(Path(scratch) / "objects" / asset.name, store.path(f"objects/{asset.name}"))
                save_json(asset, store.path(f"objects/{asset.name}/object.json"))
                assets.append(asset)
        if not assets:
            raise StageError("no object converted: " + "; ".join(f"{k}: {v}" for k, v in failures.items()))
        assets.sort(key=lambda a: a.name)
        save_json(assets, store.path("objects/objects.json"))
        store.write_json("objects/failures.json", failures)
        return ["objects/objects.json", "objects/failures.json"] + [f"objects/{a.name}/object.json" for a in assets]

    runner.run("objects", fp, make)


def load_objects(store: Store) -> list[ObjectAsset]:
    """Return the run's converted objects."""
    return load_json(store.path("objects/objects.json"), ObjectAsset)


# ----------------------------------------------------------------------------------------------
# Scenes


def scene_task(store: Store, cfg: RunConfig, runner: Any, scene: str) -> None:
    """Convert, observe, perceive and annotate one scene (each step skipped when already done)."""
    src = scene_inputs(store, cfg)[scene]
    sdir = f"scenes/{scene}"
    seed = _scene_seed(cfg, scene)
    if not src:
        src = _write_world_scene(store, cfg, runner, scene)
    src_path = Path(src)
    if not src_path.exists():
        raise InputError(src_path, "scene file not found")

    def convert() -> list[str]:
        from assets_convert.scene import convert_scene

        asset = convert_scene(src_path, store.root, name=scene, units=cfg.convert.units, up=cfg.convert.up,
                              texture_max_size=cfg.convert.texture_max_size)
        save_json(asset, store.path(f"{sdir}/scene.json"))
        return [f"{sdir}/scene.json", asset.mjcf, asset.mesh]

    runner.run(f"{sdir}/convert", ["convert-scene", _converter_version(), file_hash(src_path), to_dict(cfg.convert)],
               convert)
    asset = load_json(store.path(f"{sdir}/scene.json"), SceneAsset)

    def observe() -> list[str]:
        from .observe import observe_scene

        summary = observe_scene(asset, store.root, f"{sdir}/observe", cfg.observe, seed=seed)
        return list(summary["outputs"])

    runner.run(f"{sdir}/observe", ["observe", _fp_of(store, f"{sdir}/convert"), to_dict(cfg.observe), seed], observe)

    def perceive() -> list[str]:
        from .observe import load_shards

        shards = sorted(store.path(f"{sdir}/observe").glob("*.npz"))
        # with no prespecified receptacle labels the LLM backend names them (prompt C.1), cached like semantics
        backend = None if cfg.receptacles.labels else _llm_backend(store, cfg)
        instances, planes, views = perceive_and_find_planes(load_shards(shards), asset, store.root,
                                                            load_navmaps(store, scene), cfg, seed, backend)
        save_npz(instances, store.path(f"{sdir}/perceive/instances.npz"))
        save_json(planes, store.path(f"{sdir}/perceive/planes.json"))
        save_targeted_views(views, store.path(f"{sdir}/perceive/targeted_views.json"))
        return [f"{sdir}/perceive/instances.npz", f"{sdir}/perceive/planes.json",
                f"{sdir}/perceive/targeted_views.json"]

    runner.run(f"{sdir}/perceive", ["perceive", _fp_of(store, f"{sdir}/observe"), to_dict(cfg.perceive),
                                    to_dict(cfg.receptacles), seed,
                                    None if cfg.receptacles.labels else to_dict(cfg.semantics)], perceive)

    def semantics() -> list[str]:
        from .semantics import region_map, region_picture, relevance

        instances: list[Instance] = load_npz(store.path(f"{sdir}/perceive/instances.npz"))  # type: ignore[assignment]
        planes: list[ReceptaclePlane] = load_json(store.path(f"{sdir}/perceive/planes.json"), ReceptaclePlane)
        navmaps = load_navmaps(store, scene)
        backend = _llm_backend(store, cfg)
        outs: list[str] = []
        maps = {}
        for nm in navmaps:
            rm = region_map(instances, nm, backend, cfg.semantics)
            maps[nm.floor] = (nm, rm)
            rel = f"{sdir}/semantics/regions_{nm.floor}.json"
            save_json(rm, store.path(rel))
            region_picture(rm, store.path(f"{sdir}/semantics/regions_{nm.floor}.png"), navmap=nm)
            outs += [rel, f"{sdir}/semantics/regions_{nm.floor}.png"]
        annotated = [_annotate_plane(p, maps) for p in planes]
        save_json(annotated, store.path(f"{sdir}/semantics/planes.json"))
        categories = sorted({o.category for o in load_objects(store)})
        regions = sorted({p.region for p in annotated if p.region} | set(cfg.semantics.region_labels))
        receptacles = sorted({p.label for p in annotated})
        rel = relevance(categories, regions, receptacles, backend)
        save_json(rel, store.path(f"{sdir}/semantics/relevance.json"))
        return outs + [f"{sdir}/semantics/planes.json", f"{sdir}/semantics/relevance.json"]

    runner.run(f"{sdir}/semantics", ["semantics", _fp_of(store, f"{sdir}/perceive"), _fp_of(store, "objects"),
                                     to_dict(cfg.semantics)], semantics)


def _llm_backend(store: Store, cfg: RunConfig) -> Any:
    """Return the run's LLM backend (replies cached under cache/llm of the run folder when enabled)."""
    from .semantics import get_backend

    return get_backend(cfg.semantics, cache_dir=store.path("cache/llm") if cfg.semantics.cache else None)


def _write_world_scene(store: Store, cfg: RunConfig, runner: Any, scene: str) -> str:
    """Write a default-world apartment as an input file; return its path."""
    from .world import generate_apartment, write_apartment

    seed = int(scene.split("_")[-1])
    rel_dir = f"inputs/scenes/{scene}"
    w = cfg.world

    def make() -> list[str]:
        apt = generate_apartment(seed, floors=w.floors or None)
        mesh = write_apartment(apt, store.path(rel_dir), mode=w.scene_mode, name=scene)
        return sorted(store.rel(p) for p in store.path(rel_dir).iterdir() if p.is_file() and not p.name.startswith(".")) or [store.rel(mesh)]

    runner.run(rel_dir, ["world-apartment", seed, w.floors, w.scene_mode], make)
    mark = store.mark(rel_dir)
    assert mark is not None
    mesh = [o for o in mark.outputs if o.endswith((".glb", ".ply")) and not o.endswith(".segs.json")]
    if not mesh:
        raise StageError(f"default-world apartment {scene} wrote no mesh")
    return str(store.path(mesh[0]))


def _plane_floor(height: float, navmaps: list[NavMap]) -> NavMap | None:
    """Return the navmap of the highest floor at or below a height (None when below every floor)."""
    below = [nm for nm in navmaps if nm.height <= height + 0.05]
    return max(below, key=lambda nm: nm.height) if below else None


def view_targets(instances: list[Instance], planes: list[ReceptaclePlane], navmaps: list[NavMap],
                 labels: tuple[str, ...]) -> list[Any]:
    """Return a ViewTarget per receptacle plane, and per receptacle instance without planes (its top)."""
    from .observe.targeted import ViewTarget
    from .receptacles import receptacle_instances

    by_id = {i.id: i for i in instances}
    out = []
    surfaces = [(by_id[p.instance_id], float(p.height)) for p in planes if p.instance_id in by_id]
    with_planes = {p.instance_id for p in planes}
    for inst in receptacle_instances(instances, labels):
        if inst.id not in with_planes and len(inst.points):
            surfaces.append((inst, float(inst.world_points[:, 2].max())))
    for inst, h in surfaces:
        nm = _plane_floor(h, navmaps)
        if nm is None:
            continue
        wp = inst.world_points
        lo, hi = wp[:, :2].min(axis=0), wp[:, :2].max(axis=0)
        out.append(ViewTarget(lo=lo, hi=hi, height=h, floor=nm.floor, seen_points=wp))
    return out


def receptacle_labels(instances: list[Instance], cfg: RunConfig, backend: Any = None) -> tuple[str, ...]:
    """Return the receptacle labels: the configured ones, or those the LLM backend picks among the instances' (C.1)."""
    if cfg.receptacles.labels:
        return tuple(cfg.receptacles.labels)
    from .semantics import get_backend, identify_receptacles

    return tuple(identify_receptacles(sorted({i.label for i in instances}), backend or get_backend(cfg.semantics)))


def perceive_and_find_planes(observations: Any, scene: SceneAsset, store_root: str | Path, navmaps: list[NavMap],
                             cfg: RunConfig, seed: int, backend: Any = None
                             ) -> tuple[list[Instance], list[ReceptaclePlane], list[Any]]:
    """Perceive a scene's observations, look again at its receptacle surfaces (targeted views), find their planes.

    Returns the fused instances, the receptacle planes and the targeted camera poses (T_cam, world <- OpenCV).
    With observe.targeted_views = 0 this is perceive + planes on the coverage views alone (the paper's). With
    receptacles.labels empty the LLM `backend` (default: the semantics config's) names the receptacles.
    """
    from .observe import load_model, make_renderer
    from .observe.targeted import plan_target_views, render_poses
    from .perceive import perceive_scene
    from .receptacles import find_receptacle_planes

    ocfg = cfg.observe
    poses: list[Any] = []

    def look_again(first: list[Instance], next_view: int) -> Any:
        labels = receptacle_labels(first, cfg, backend)
        targets = view_targets(first, find_receptacle_planes(first, cfg.receptacles, labels), navmaps, labels)
        if not targets:
            return
        model = load_model(scene, store_root)
        small = dataclasses.replace(ocfg, width=int(ocfg.targeted_width),
                                    height=max(1, round(ocfg.targeted_width * ocfg.height / ocfg.width)))
        r = make_renderer(model, small)
        try:
            poses.extend(plan_target_views(r, navmaps, targets, ocfg))
        finally:
            r.close()
        if not poses:
            return
        r = make_renderer(model, ocfg)
        try:
            yield from render_poses(r, poses, ocfg, start_view_id=next_view)
        finally:
            r.close()

    instances = perceive_scene(observations, scene, cfg.perceive, seed=seed,
                               look_again=look_again if ocfg.targeted_views > 0 else None)
    return instances, find_receptacle_planes(instances, cfg.receptacles, receptacle_labels(instances, cfg, backend)), poses


def save_targeted_views(poses: list[Any], path: Path) -> None:
    """Write targeted camera poses (T_cam rows, each value rounded to 6 decimals) as JSON."""
    import numpy as np

    from .store import atomic_write_text

    rows = [[[round(float(x), 6) for x in row] for row in np.asarray(T, float)] for T in poses]
    atomic_write_text(path, json.dumps({"T_cam": rows}, indent=None) + "\n")


def _fp_of(store: Store, stage: str) -> str:
    """Return the fingerprint a finished stage recorded ('' when not finished)."""
    m = store.mark(stage)
    return m.fingerprint if m else ""


def _annotate_plane(plane: ReceptaclePlane, maps: dict[int, tuple[NavMap, Any]]) -> ReceptaclePlane:
    """Return the plane with its floor (nearest floor below it) and region (region map at its centre)."""
    below = _plane_floor(plane.height, [nm for nm, _rm in maps.values()])
    floor = below.floor if below is not None else plane.floor
    region = plane.region
    if floor in maps:
        import numpy as np

        rm = maps[floor][1]
        region = rm.region_at(np.asarray(plane.polygon, float).mean(axis=0)) or _nearest_region(rm, plane) or region
    return dataclasses.replace(plane, floor=floor, region=region)


def _nearest_region(rm: Any, plane: ReceptaclePlane) -> str:
    """Return the region label of the labelled cell nearest to a plane's centre ('' if none)."""
    import numpy as np

    rows, cols = np.nonzero(rm.label_map >= 0)
    if len(rows) == 0:
        return ""
    c = np.asarray(plane.polygon, float).mean(axis=0)
    xy = np.stack([rm.origin[0] + (cols + 0.5) * rm.resolution, rm.origin[1] + (rows + 0.5) * rm.resolution], 1)
    k = int(np.argmin(((xy - c) ** 2).sum(1)))
    return rm.labels[int(rm.label_map[rows[k], cols[k]])]


def load_navmaps(store: Store, scene: str) -> list[NavMap]:
    """Return a scene's NavMaps sorted by floor."""
    maps = [load_json(p, NavMap) for p in sorted(store.path(f"scenes/{scene}/observe").glob("navmap_*.json"))]
    return sorted(maps, key=lambda m: m.floor)


# ----------------------------------------------------------------------------------------------
# Variants


def variant_task(store: Store, cfg: RunConfig, runner: Any, scene: str, index: int) -> None:
    """Place, settle and derive episodes for one variant of a scene."""
    from .place import variant_seed

    sdir = f"scenes/{scene}"
    name = f"{scene}_v{index:03d}"
    vdir = f"{sdir}/variants/{name}"
    seed = variant_seed(_scene_seed(cfg, scene), index)

    def place() -> list[str]:
        from .place import place_variant

        asset = load_json(store.path(f"{sdir}/scene.json"), SceneAsset)
        planes = load_json(store.path(f"{sdir}/semantics/planes.json"), ReceptaclePlane)
        rel = load_json(store.path(f"{sdir}/semantics/relevance.json"), Relevance)
        variant = place_variant(asset, planes, rel, load_objects(store), store.root, cfg.place, seed, index)
        return [f"{vdir}/variant.json", variant.mjcf]

    runner.run(f"{vdir}/place", ["place", _fp_of(store, f"{sdir}/semantics"), _fp_of(store, "objects"),
                                 to_dict(cfg.place), seed], place)

    def episodes() -> list[str]:
        from .episodes import generate_episodes

        variant = load_json(store.path(f"{vdir}/variant.json"), SceneVariant)
        eps = generate_episodes(variant, load_navmaps(store, scene), store.root, cfg.episodes, seed)
        save_json(eps, store.path(f"{vdir}/episodes.json"))
        return [f"{vdir}/episodes.json"]

    runner.run(f"{vdir}/episodes", ["episodes", _fp_of(store, f"{vdir}/place"), to_dict(cfg.episodes), seed], episodes)


# ----------------------------------------------------------------------------------------------
# Export and statistics


def export_task(store: Store, cfg: RunConfig, runner: Any, fmt: str) -> None:
    """Run one exporter plugin into `export/<fmt>/` (redone whenever the run's records change)."""
    from exporters.base import ExportOptions, RunView, run_export

    from . import plugins

    view = RunView(store.root)
    out = store.path(f"export/{fmt}")

    def make() -> list[str]:
        if out.exists():
            shutil.rmtree(out)  # our own folder: an older export of this run is replaced whole
        exporter = plugins.load("exporter", fmt)()
        report = run_export(exporter, view, out, ExportOptions(name=cfg.name, split=cfg.split))
        store.write_json(f"export/{fmt}.report.json", {"format": report.format, "variants": report.variants,
                                                       "skipped": report.skipped, "episodes": report.episodes})
        return [f"export/{fmt}.report.json"] + [f"export/{fmt}/{f}" for f in report.files]

    runner.run(f"export/{fmt}.stage", ["export", fmt, view.run_id(), cfg.name, cfg.split, config_hash(cfg.episodes)], make)


def write_statistics(store: Store, cfg: RunConfig, summary: Any) -> None:
    """Write dataset statistics, tables and charts into `stats/`."""
    from . import stats

    stats.write_statistics(store.root)


def summary_table(summary: Any) -> str:
    """Return the end-of-run summary (scenes, variants, categories, episodes, rejections, seconds per stage)."""
    from . import stats

    st = stats.dataset_statistics(Path(summary.run_root))
    lines = [stats.summary_table(st), "", "seconds per stage (this run; 0 = skipped, already done):"]
    for k, v in sorted(summary.seconds.items(), key=lambda kv: -kv[1]):
        lines.append(f"  {k:<12} {v:8.2f}")
    if summary.failures:
        lines.append("")
        lines.append("failed tasks:")
        for r in summary.failures:
            lines.append(f"  {r.spec.label}: {r.error}")
    return "\n".join(lines)
