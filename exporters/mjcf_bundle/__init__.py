"""MJCF bundle exporter: one folder per variant sharing the dataset's asset folder (layout: docs/formats/mjcf-bundle.md).

Default layout: ``<name>/assets/<run-relative path>`` holds every scene's and object's asset files once
(``assets/scenes/<scene>/...``, ``assets/objects/<object>/...``), each bundle's ``scene.xml`` refers to them
with relative paths (compiler ``meshdir="../assets"``). ``ExportOptions.extra["standalone"]`` writes
self-contained bundles (each its own ``assets/``); `make_standalone` turns an exported bundle into one.
Bundle v4: a scene's oracle files (navmaps, region maps, instance labels, relevance) once per scene under
``<name>/oracle/<scene>/`` (npz for the grids), each variant's goals once in ``goals.npz``
(`sdovon_mj.suite.goals`), named by relative paths in ``bundle.json``.
Units: one per scene (the pipeline exports scenes in parallel, as soon as a scene's variants are done).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sdovon_mj.errors import InputError
from sdovon_mj.records import NavMap, SceneVariant, save_npz
from sdovon_mj.suite.goals import pack_episodes
from sdovon_mj.sim.model import object_segment_id, pose_settled
from sdovon_mj.store import atomic_copy, atomic_write_bytes, atomic_write_text, file_hash
from sdovon_mj.export import (ExportOptions, ExportReport, ExportUnit, Exporter, RunView, UnitResult, finish_export,
                              merge_unit_results)

import mujoco  # after sdovon_mj, whose package entry sets MUJOCO_GL

BUNDLE_VERSION = 5  # 2: generator artefacts under oracle/; 3: assets shared per dataset (../assets), "assets" key;
# 4: goals once per bundle (goals.npz + EpisodeRef rows), scene oracle files once per scene (../oracle/<scene>/);
# 5: the dataset's vocabulary in index.json (a new version so that runs exported before re-export)
SHARED_ASSETS = "assets"  # under the dataset root; a bundle refers to it as ../assets
SHARED_ORACLE = "oracle"  # under the dataset root: oracle/<scene>/, a bundle refers to it as ../oracle/<scene>/


@dataclass
class AssetMemo:
    """What an export finds once and keeps across the variants of a scene (the files do not change while it runs)."""

    folders: dict[tuple[Path, str], Path] = field(default_factory=dict)  # (spec folder, asset subdir) -> resolved
    files: dict[tuple[Path, tuple[str, ...]], Path] = field(default_factory=dict)  # (folder, rest of path) -> file
    shared: dict[Path, tuple[str, Path]] = field(default_factory=dict)  # source file -> (shared name, its copy)


def _resolve(spec_dir: Path, subdir: str, file: str, memo: AssetMemo | None = None) -> Path:
    """Return the absolute path MuJoCo would open for an asset file of a spec.

    ``memo`` (kept by the caller across the variants of a scene) saves resolving again: the spec's asset folder is
    resolved once, the file's leading ``..`` are taken off it as its parents (the parent of a resolved folder is
    what ``..`` resolves to), and the rest is resolved once per (folder, rest), which the variants of a scene share.
    """
    p = Path(file)
    if p.is_absolute():
        return p
    if memo is None:
        return (spec_dir / subdir / p).resolve()
    base = memo.folders.get((spec_dir, subdir))
    if base is None:
        base = memo.folders[(spec_dir, subdir)] = (spec_dir / subdir).resolve()
    parts = p.parts
    k = 0
    while k < len(parts) and parts[k] == "..":
        base, k = base.parent, k + 1
    hit = memo.files.get((base, parts[k:]))
    if hit is None:
        hit = memo.files[(base, parts[k:])] = base.joinpath(*parts[k:]).resolve()
    return hit


def retarget_assets(spec: "mujoco.MjSpec", take: Any) -> None:
    """Replace every asset file name of a spec (meshes, height fields, skins, textures) by ``take(file, its dir)``."""
    for m in spec.meshes:
        m.file = take(m.file, spec.meshdir)
    for h in spec.hfields:
        h.file = take(h.file, spec.meshdir)
    for s in spec.skins:
        s.file = take(s.file, spec.meshdir)
    for t in spec.textures:
        t.file = take(t.file, spec.texturedir)
        if any(t.cubefiles):
            t.cubefiles = [take(f, spec.texturedir) for f in t.cubefiles]


def _bundle_name(src: Path, used: dict[str, Path], root: Path | None = None) -> str:
    """Return a unique file name in assets/ for a source file (same file -> same name)."""
    name = src.name
    if name in used and used[name] != src:
        # Hash the run-relative path (not the absolute one) so a run exports the same bytes wherever it lives.
        key = str(src)
        if root is not None:
            try:
                key = src.resolve().relative_to(Path(root).resolve()).as_posix()
            except ValueError:
                pass
        name = f"{hashlib.sha256(key.encode()).hexdigest()[:8]}_{src.name}"
    used[name] = src
    return name


def _shared_name(run: RunView, src: Path) -> str:
    """Return an asset's path inside the dataset's shared asset folder: its run-relative path.

    A file outside the run folder goes to ``external/<content digest>/<name>`` (same bytes wherever it lives).
    """
    try:
        return src.resolve().relative_to(run.root.resolve()).as_posix()
    except ValueError:
        h = hashlib.sha256(src.read_bytes()).hexdigest()[:12]
        return f"external/{h}/{src.name}"


def bundle_variant_xml(run: RunView, variant: SceneVariant, bundle_dir: Path, shared: Path | None = None,
                       seen: set[Path] | None = None, memo: AssetMemo | None = None) -> tuple[str, list[Path]]:
    """Return the variant's MJCF text (objects posed settled) and the asset files it uses (copied where needed).

    Parameters
    ----------
    run : RunView
        The run folder.
    variant : SceneVariant
        The variant to bundle.
    bundle_dir : Path
        The bundle folder (``<out>/<name>/<variant>``); the MJCF text is meant for ``bundle_dir/scene.xml``.
    shared : Path, optional
        The dataset's shared asset folder (``bundle_dir/../assets``): assets are copied there once under their
        run-relative paths and the MJCF refers to them as ``../assets/...``. None: into the bundle's own
        ``assets/`` (self-contained).
    seen : set of Path, optional
        Shared asset files already written by this caller (skipped, and added to as files are written).
    memo : AssetMemo, optional
        Kept by the caller across the variants it bundles: resolved asset paths and, with ``shared``, each source
        file's shared name (found once; the files do not change while an export runs).
    """
    path = run.path(variant.mjcf)
    if not path.exists():
        raise InputError(path, "composed MJCF not found")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        model = spec.compile()
    except ValueError as e:
        raise InputError(path, f"MJCF does not load: {e}") from None
    data = mujoco.MjData(model)
    pose_settled(model, data, variant.qpos, path)
    spec_dir = path.parent
    used: dict[str, Path] = {}
    copied: dict[Path, None] = {}  # files this variant uses, in first-use order
    taken: dict[tuple[str, str], str] = {}  # (file, subdir) -> name: a mesh used by many geoms is resolved once

    def take(file: str, subdir: str) -> str:
        if not file:
            return file
        if (file, subdir) in taken:
            return taken[(file, subdir)]
        src = _resolve(spec_dir, subdir, file, memo)
        if shared is not None and memo is not None and src in memo.shared:
            name, dst = memo.shared[src]
        elif not src.exists():
            raise InputError(src, f"asset referenced by {path} not found")
        elif shared is not None:
            name = _shared_name(run, src)
            dst = shared / name
            if memo is not None:
                memo.shared[src] = (name, dst)
        else:
            name = _bundle_name(src, used, run.root)
            dst = bundle_dir / "assets" / name
        if dst not in copied:
            if seen is None or dst not in seen:
                if not (shared is not None and dst.is_file() and dst.stat().st_size == src.stat().st_size
                        and file_hash(dst) == file_hash(src)):  # shared: another unit wrote it already
                    atomic_copy(src, dst)
                if seen is not None:
                    seen.add(dst)
            copied[dst] = None
        taken[(file, subdir)] = name
        return name

    retarget_assets(spec, take)
    rel_assets = "assets" if shared is None else os.path.relpath(shared, bundle_dir).replace(os.sep, "/")
    spec.meshdir = rel_assets
    spec.texturedir = rel_assets
    spec.strippath = False
    # Settled poses become the bodies' initial poses (qpos0) and a keyframe.
    for j in range(model.njnt):
        if int(model.jnt_type[j]) != int(mujoco.mjtJoint.mjJNT_FREE):
            continue
        b = int(model.jnt_bodyid[j])
        if int(model.body_parentid[b]) != 0:
            continue
        body = spec.body(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b))
        body.pos = data.xpos[b].copy()
        body.quat = data.xquat[b].copy()
    if variant.qpos is not None and not any(k.name == "settled" for k in spec.keys):
        spec.add_key(name="settled", qpos=np.asarray(data.qpos, dtype=float).copy())
    spec.modelfiledir = str(bundle_dir.resolve()) + os.sep  # to_xml recompiles: resolve assets in the bundle
    return spec.to_xml(), list(copied)


def write_scene_oracle(run: RunView, scene: str, odir: Path, navmaps: list[NavMap]) -> dict[str, object]:
    """Write a scene's generator artefacts (the same for all its variants) into `odir`; return their file names.

    ``navmap_<floor>.npz`` (records.NavMap, `records.save_npz`: the environment's collision map and the metrics'
    geodesics), ``instance_labels.json`` (scene instance id -> label: the ground-truth detector's scene table)
    and, when the run has them, ``relevance.json`` (the table that drove placement) and
    ``region_map_<floor>.npz`` (records.RegionMap). Returns {"navmaps": {floor: name}, "region_maps": {floor:
    name}, "instance_labels": name, "relevance": name or ""} (names relative to `odir`).
    """
    names: dict[str, object] = {"navmaps": {}, "region_maps": {}, "relevance": ""}
    for nm in navmaps:
        save_npz([nm], odir / f"navmap_{nm.floor}.npz")
        names["navmaps"][str(nm.floor)] = f"navmap_{nm.floor}.npz"  # type: ignore[index]
    labels = {str(i.id): i.label for i in sorted(run.scene(scene).instances, key=lambda i: i.id)}
    atomic_write_text(odir / "instance_labels.json", json.dumps(labels, indent=1, sort_keys=True) + "\n")
    names["instance_labels"] = "instance_labels.json"
    rel = run.relevance(scene)
    if rel is not None:
        atomic_write_text(odir / "relevance.json", rel.to_json())
        names["relevance"] = "relevance.json"
    for rm in run.region_maps(scene):
        save_npz([rm], odir / f"region_map_{rm.floor}.npz")
        names["region_maps"][str(rm.floor)] = f"region_map_{rm.floor}.npz"  # type: ignore[index]
    return names


def _oracle_files(names: dict[str, object], odir: Path) -> list[Path]:
    """Return the files `write_scene_oracle` wrote (its returned names under `odir`)."""
    out = [odir / str(n) for k in ("navmaps", "region_maps") for n in names[k].values()]  # type: ignore[union-attr]
    return out + [odir / str(names[k]) for k in ("instance_labels", "relevance") if names[k]]


def _oracle_meta(names: dict[str, object], odir: Path, bdir: Path) -> dict[str, object]:
    """Return bundle.json's entries for the scene oracle files (`write_scene_oracle` names), relative to `bdir`."""
    def rel(name: object) -> str:
        return _rel(odir / str(name), bdir) if name else ""

    return {"scene_oracle": _rel(odir, bdir) + "/",
            "navmaps": {f: rel(n) for f, n in names["navmaps"].items()},  # type: ignore[union-attr]
            "region_maps": {f: rel(n) for f, n in names["region_maps"].items()},  # type: ignore[union-attr]
            "instance_labels": rel(names["instance_labels"]), "relevance": rel(names["relevance"])}


def write_object_labels(variant: SceneVariant, bdir: Path) -> Path:
    """Write ``<bundle>/oracle/object_labels.json``: segmentation id -> category of every placed object at rest."""
    objects = {str(object_segment_id(p.object_id)): p.category for p in variant.placements
               if p.status in ("resting", "resting_elsewhere")}
    path = bdir / "oracle" / "object_labels.json"
    atomic_write_text(path, json.dumps(objects, indent=1, sort_keys=True) + "\n")
    return path


def dataset_vocabulary(run: RunView, root: Path, results: list[UnitResult]) -> dict[str, list[str]]:
    """Return the dataset's vocabulary (``index.json``'s ``vocabulary``): the goal categories of every exported bundle
    (their bundle.json ``categories``), every label the suite's category image can show (scene instance labels,
    categories of the objects at rest, goal categories) and the object categories (of the objects at rest and the
    goals); one list each for every variant, as the evaluation uses them (`sdovon_mj.suite.observation.Vocabulary`)."""
    goals: set[str] = set()
    labels: set[str] = set()
    objects: set[str] = set()
    for r in results:
        names = set(r.variants)
        if not names:
            continue
        for scene in sorted({str(json.loads((root / v / "bundle.json").read_text(encoding="utf-8"))["scene"])
                             for v in names}):
            labels |= {i.label for i in run.scene(scene).instances if i.label}
            for variant in run.dataset_variants(scene):
                if variant.name in names:
                    objects |= {p.category for p in variant.placements if p.status in ("resting", "resting_elsewhere")}
        for v in names:
            goals |= set(json.loads((root / v / "bundle.json").read_text(encoding="utf-8")).get("categories", []))
    return {"goal_categories": sorted(goals), "labels": sorted(labels | objects | goals),
            "object_categories": sorted(objects | goals)}


def _day_meta(variant: SceneVariant, days: list[str]) -> dict[str, Any]:
    """Return a bundle's day keys ({} outside a chain of days): its day, and the sequence (the scene's days in order,
    each a bundle folder beside this one; the one before and after, '' at the ends)."""
    if variant.day is None:
        return {}
    i = days.index(variant.name)
    return {"day": int(variant.day), "sequence": {"days": list(days), "previous": days[i - 1] if i > 0 else "",
                                                  "next": days[i + 1] if i + 1 < len(days) else ""}}


def _rel(path: Path, bdir: Path) -> str:
    """Return a path relative to a bundle folder, with forward slashes."""
    return os.path.relpath(path, bdir).replace(os.sep, "/")


def _standalone(options: ExportOptions) -> bool:
    """Return whether the options ask for self-contained bundles."""
    return bool(options.extra.get("standalone", False))


def _standalone_oracle(bdir: Path, meta: dict) -> list[Path]:
    """Copy the scene oracle files a v4 bundle.json names outside the bundle into its ``oracle/``; edit `meta`.

    Returns the files copied (none for older bundles, whose oracle files all live in the bundle).
    """
    copied: list[Path] = []

    def take(rel: str, key: str) -> str:
        if not rel:
            return rel
        src = (bdir / rel).resolve()
        if src.is_relative_to(bdir):
            return rel
        if not src.is_file():
            raise InputError(src, f"scene oracle file named by {bdir / 'bundle.json'} ('{key}') not found")
        dst = bdir / "oracle" / src.name
        atomic_copy(src, dst)
        copied.append(dst)
        return f"oracle/{src.name}"

    if int(meta.get("bundle_version", 0) or 0) < 4:
        return copied
    for key in ("navmaps", "region_maps"):
        meta[key] = {f: take(str(r), f"{key}.{f}") for f, r in (meta.get(key) or {}).items()}
    for key in ("instance_labels", "relevance"):
        meta[key] = take(str(meta.get(key) or ""), key)
    if copied:
        meta["scene_oracle"] = "oracle/"
    return copied


def make_standalone(bundle_dir: str | Path) -> list[Path]:
    """Make an exported bundle self-contained: copy the assets its scene.xml uses into its own ``assets/`` and
    the scene oracle files it shares with its scene's other variants (bundle v4) into its own ``oracle/``.

    The bundle keeps working when copied alone afterwards. Returns the files copied (none when the
    bundle is already self-contained). Raises InputError naming the file when the bundle or an asset is missing.
    """
    bdir = Path(bundle_dir).resolve()
    xml, meta_path = bdir / "scene.xml", bdir / "bundle.json"
    if not xml.is_file() or not meta_path.is_file():
        raise InputError(bdir, "not an MJCF bundle folder (needs scene.xml and bundle.json)")
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise InputError(meta_path, f"not valid JSON ({e})") from None
    try:
        spec = mujoco.MjSpec.from_file(str(xml))
    except ValueError as e:
        raise InputError(xml, f"MJCF does not load: {e}") from None
    copied = _standalone_oracle(bdir, meta)
    if spec.meshdir == "assets" and spec.texturedir == "assets":
        if copied:
            atomic_write_text(meta_path, json.dumps(meta, indent=1, sort_keys=True) + "\n")
        return copied
    shared_root = (bdir / spec.meshdir).resolve()
    used: dict[str, Path] = {}

    def take(file: str, subdir: str) -> str:
        if not file:
            return file
        src = _resolve(bdir, subdir, file)
        if not src.exists():
            raise InputError(src, f"asset referenced by {xml} not found")
        name = _bundle_name(src, used, shared_root)
        dst = bdir / "assets" / name
        if dst not in copied:
            atomic_copy(src, dst)
            copied.append(dst)
        return name

    retarget_assets(spec, take)
    spec.meshdir = "assets"
    spec.texturedir = "assets"
    spec.modelfiledir = str(bdir) + os.sep
    atomic_write_text(xml, spec.to_xml())
    meta["assets"] = "assets/"
    atomic_write_text(meta_path, json.dumps(meta, indent=1, sort_keys=True) + "\n")
    return copied


class MjcfBundleExporter(Exporter):
    """Writes <out>/<name>/{index.json, assets/, oracle/<scene>/,
    <variant>/{scene.xml, episodes.json, goals.npz, bundle.json, oracle/object_labels.json}}."""

    name = "mjcf"
    version = f"bundle-{BUNDLE_VERSION}"

    def units(self, run: RunView, options: ExportOptions) -> list[ExportUnit]:
        """Return one unit per scene (it reads that scene's records and the object library)."""
        return [ExportUnit(s, (s,)) for s in run.scene_names()]

    def export_unit(self, run: RunView, out_dir: Path, options: ExportOptions, unit: ExportUnit) -> UnitResult:
        """Write the bundles of one scene's variants with episodes (and the shared assets they use)."""
        root = Path(out_dir) / options.name
        shared = None if _standalone(options) else root / SHARED_ASSETS
        res = UnitResult(unit.key)
        scratch = ExportReport(format=self.name, out_dir=str(out_dir), name=options.name)
        written: list[Path] = []
        seen: set[Path] = set()
        memo = AssetMemo()  # asset paths resolved and named once for the scene's variants
        cfg = run.config()
        # The episodes' visibility definition: the suite's "goal seen" check renders the same way.
        visibility = {"width": cfg.episodes.vis_width, "height": cfg.episodes.vis_height, "eta_gt": cfg.agent.eta_gt}
        for scene in unit.scenes or ():
            navmaps = None
            scene_oracle: dict[str, object] | None = None
            sdir = root / SHARED_ORACLE / scene
            days = [d.name for d in run.days(scene)]  # the scene's chain of days, in order
            for variant in run.dataset_variants(scene):
                eps = run.episodes(variant)
                if not eps:
                    scratch.skipped[variant.name] = "no valid goals (zero episodes)"
                    continue
                bdir = root / variant.name
                xml, copied = bundle_variant_xml(run, variant, bdir, shared, seen, memo)
                atomic_write_text(bdir / "scene.xml", xml)
                written += copied + [bdir / "scene.xml"]
                if navmaps is None:
                    navmaps = run.navmaps(variant.scene)
                odir = sdir if shared is not None else bdir / "oracle"
                if shared is None or scene_oracle is None:  # shared: once per scene
                    scene_oracle = write_scene_oracle(run, scene, odir, navmaps)
                    written += _oracle_files(scene_oracle, odir)
                eps_text, goals_bytes, goals_name = pack_episodes(eps)
                atomic_write_text(bdir / "episodes.json", eps_text)
                atomic_write_bytes(bdir / goals_name, goals_bytes)
                written += [bdir / "episodes.json", bdir / goals_name, write_object_labels(variant, bdir)]
                meta = {"bundle_version": BUNDLE_VERSION, "dataset": options.name, "split": options.split,
                        "scene": variant.scene, "variant": variant.name, "model": "scene.xml",
                        "episodes": "episodes.json", "goals": goals_name,
                        "assets": "assets/" if shared is None else f"../{SHARED_ASSETS}/",
                        "oracle": "oracle/", "object_labels": "oracle/object_labels.json",
                        **_oracle_meta(scene_oracle, odir, bdir),
                        "keyframe": "settled" if variant.qpos is not None else "",
                        "visibility": visibility,
                        "categories": sorted({e.object_category for e in eps}), "n_episodes": len(eps),
                        **_day_meta(variant, days),
                        "frame": "mujoco: metres, Z up, quaternions wxyz; positions are the agent base on the floor"}
                atomic_write_text(bdir / "bundle.json", json.dumps(meta, indent=1, sort_keys=True) + "\n")
                written.append(bdir / "bundle.json")
                res.index.append({"variant": variant.name, "path": variant.name, "n_episodes": len(eps),
                                  **({"day": variant.day} if variant.day is not None else {})})
                res.variants.append(variant.name)
                res.episodes += len(eps)
        res.skipped = scratch.skipped
        res.files = sorted({p.relative_to(Path(out_dir)).as_posix() for p in written})
        return res

    def make_standalone(self, bundle_dir: str | Path) -> list[Path]:
        """Make an exported bundle self-contained (`make_standalone`); return the asset files copied."""
        return make_standalone(bundle_dir)

    def finish(self, run: RunView, out_dir: Path, options: ExportOptions, results: list[UnitResult]) -> ExportReport:
        """Write the dataset's index.json from the units' results, with the dataset's vocabulary."""
        report, written = merge_unit_results(self.name, Path(out_dir), options.name, results)
        index = [row for r in results for row in r.index]
        return finish_export(report, Path(out_dir) / options.name, options, index, written, index_key="bundles",
                             extra={"vocabulary": dataset_vocabulary(run, Path(out_dir) / options.name, results)})
