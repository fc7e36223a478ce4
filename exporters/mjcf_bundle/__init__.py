"""MJCF bundle exporter: one self-contained folder per variant (layout in README.md next to this file)."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from sdovon_mj.errors import InputError
from sdovon_mj.records import NavMap, SceneVariant, dumps
from sdovon_mj.sim.model import object_segment_id, pose_settled
from sdovon_mj.store import atomic_copy, atomic_write_text
from sdovon_mj.export import ExportOptions, ExportReport, Exporter, RunView, exportable_variants, finish_export

import mujoco  # after sdovon_mj, whose package entry sets MUJOCO_GL

BUNDLE_VERSION = 2  # 2: generator artefacts (navmaps, labels, relevance, region maps) under oracle/


def _resolve(spec_dir: Path, subdir: str, file: str) -> Path:
    """Return the absolute path MuJoCo would open for an asset file of a spec."""
    p = Path(file)
    if p.is_absolute():
        return p
    return (spec_dir / subdir / p).resolve()


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


def bundle_variant_xml(run: RunView, variant: SceneVariant, bundle_dir: Path) -> tuple[str, list[Path]]:
    """Return the variant's self-contained MJCF text (objects posed settled) and the asset files copied."""
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
    copied: list[Path] = []

    def take(file: str, subdir: str) -> str:
        if not file:
            return file
        src = _resolve(spec_dir, subdir, file)
        if not src.exists():
            raise InputError(src, f"asset referenced by {path} not found")
        name = _bundle_name(src, used, run.root)
        dst = bundle_dir / "assets" / name
        if dst not in copied:
            atomic_copy(src, dst)
            copied.append(dst)
        return name

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
    spec.meshdir = "assets"
    spec.texturedir = "assets"
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
    return spec.to_xml(), copied


def write_oracle(run: RunView, variant: SceneVariant, bdir: Path, navmaps: list[NavMap]) -> list[Path]:
    """Write the generator's artefacts of a variant into ``<bundle>/oracle/`` (out of honest agents' reach).

    ``navmap_<floor>.json`` (the environment's collision map and the metrics' geodesics),
    ``instance_labels.json`` (scene instance id -> label) and ``object_labels.json`` (segmentation id -> category
    of every placed object that came to rest): the ground-truth detector's label table; and, when the run has
    them, ``relevance.json`` (the table that drove placement) and ``region_map_<floor>.json``. The suite reads
    them for the environment and the gt detector; agents only through a declared oracle
    (`sdovon_mj.suite.boundary`).
    """
    odir = bdir / "oracle"
    out: list[Path] = []
    for nm in navmaps:
        atomic_write_text(odir / f"navmap_{nm.floor}.json", nm.to_json())
        out.append(odir / f"navmap_{nm.floor}.json")
    labels = {str(i.id): i.label for i in sorted(run.scene(variant.scene).instances, key=lambda i: i.id)}
    atomic_write_text(odir / "instance_labels.json", json.dumps(labels, indent=1, sort_keys=True) + "\n")
    objects = {str(object_segment_id(p.object_id)): p.category for p in variant.placements
               if p.status in ("resting", "resting_elsewhere")}
    atomic_write_text(odir / "object_labels.json", json.dumps(objects, indent=1, sort_keys=True) + "\n")
    out += [odir / "instance_labels.json", odir / "object_labels.json"]
    rel = run.relevance(variant.scene)
    if rel is not None:
        atomic_write_text(odir / "relevance.json", rel.to_json())
        out.append(odir / "relevance.json")
    for rm in run.region_maps(variant.scene):
        atomic_write_text(odir / f"region_map_{rm.floor}.json", rm.to_json())
        out.append(odir / f"region_map_{rm.floor}.json")
    return out


class MjcfBundleExporter(Exporter):
    """Writes <out>/<name>/<variant>/{scene.xml, assets/, episodes.json, bundle.json, oracle/}."""

    name = "mjcf"

    def export(self, run: RunView, out_dir: Path, options: ExportOptions) -> ExportReport:
        """Write one self-contained MJCF bundle per variant with episodes."""
        root = Path(out_dir) / options.name
        report = ExportReport(format=self.name, out_dir=str(out_dir), name=options.name)
        written: list[Path] = []
        index = []
        for variant, eps in exportable_variants(run, report):
            bdir = root / variant.name
            xml, copied = bundle_variant_xml(run, variant, bdir)
            atomic_write_text(bdir / "scene.xml", xml)
            written += copied + [bdir / "scene.xml"]
            navmaps = run.navmaps(variant.scene)
            atomic_write_text(bdir / "episodes.json", dumps([e.to_dict() for e in eps]))
            written.append(bdir / "episodes.json")
            written += write_oracle(run, variant, bdir, navmaps)
            meta = {"bundle_version": BUNDLE_VERSION, "dataset": options.name, "split": options.split,
                    "scene": variant.scene, "variant": variant.name, "model": "scene.xml", "episodes": "episodes.json",
                    "navmaps": {str(nm.floor): f"oracle/navmap_{nm.floor}.json" for nm in navmaps}, "oracle": "oracle/",
                    "keyframe": "settled" if variant.qpos is not None else "",
                    "categories": sorted({e.object_category for e in eps}), "n_episodes": len(eps),
                    "frame": "mujoco: metres, Z up, quaternions wxyz; positions are the agent base on the floor"}
            atomic_write_text(bdir / "bundle.json", json.dumps(meta, indent=1, sort_keys=True) + "\n")
            written.append(bdir / "bundle.json")
            index.append({"variant": variant.name, "path": variant.name, "n_episodes": len(eps)})
            report.variants.append(variant.name)
            report.episodes += len(eps)
        return finish_export(report, root, options, index, written, index_key="bundles")
