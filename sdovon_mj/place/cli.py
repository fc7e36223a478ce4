"""`sdovon-mj place SCENE --out DIR`: semantic placement + physical settling -> scene variants."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ..config import load_config
from ..errors import InputError
from ..records import ObjectAsset, ReceptaclePlane, RecordError, Relevance, SceneAsset, load_json


def find_scene(path: str | Path) -> tuple[SceneAsset, Path]:
    """Return a SceneAsset and the store root its paths are relative to, from scene.json or its folder."""
    p = Path(path)
    if p.is_dir():
        p = p / "scene.json"
    if not p.exists():
        raise InputError(p, "scene record not found")
    try:
        scene = load_json(p, SceneAsset)
    except RecordError as e:
        raise InputError(p, f"not a SceneAsset record ({e})") from None
    for root in [p.parent, *p.parent.parents][:4]:
        if (root / scene.mjcf).exists():
            return scene, root
    raise InputError(p, f"cannot find the scene's MJCF {scene.mjcf!r} relative to {p.parent} or its parents")


def load_objects(paths: list[str], root: Path) -> list[ObjectAsset]:
    """Return ObjectAssets from record files, objects.json lists or folders holding them (default: root/objects)."""
    files: list[Path] = []
    for raw in paths or [str(root / "objects")]:
        p = Path(raw)
        if p.is_dir():
            files += sorted(set(p.rglob("object.json")) | set(p.rglob("asset.json")) | set(p.glob("objects.json")))
        elif p.exists():
            files.append(p)
        else:
            raise InputError(p, "object record or folder not found")
    out: dict[str, ObjectAsset] = {}
    for f in files:
        try:
            recs = load_json(f, ObjectAsset)
        except RecordError as e:
            raise InputError(f, f"not an ObjectAsset record ({e})") from None
        for r in recs if isinstance(recs, list) else [recs]:
            out.setdefault(r.name, r)
    if not out:
        raise InputError(paths[0] if paths else root / "objects", "no ObjectAsset records (object.json / asset.json) found")
    return [out[k] for k in sorted(out)]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the place subcommand's arguments."""
    parser.add_argument("scene", metavar="SCENE", help="a converted scene: scene.json (SceneAsset) or its folder")
    parser.add_argument("--out", required=True, help="run folder: variants go to scenes/<scene>/variants/<variant>/")
    parser.add_argument("--objects", nargs="*", default=[], help="ObjectAsset records or folders (default: <store>/objects)")
    parser.add_argument("--planes", default=None, help="receptacle planes json (default: perceive/planes.json, else the scene's ground truth)")
    parser.add_argument("--relevance", default=None, help="Relevance json (default: semantics/relevance.json, else uniform)")
    parser.add_argument("--variants", type=int, default=None, help="variants to make (default: place.k_v)")
    parser.add_argument("--seed", type=int, default=None, help="scene seed the variant seeds derive from (default: config seed)")
    parser.add_argument("--config", default=None, help="YAML config file")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override a config key, e.g. --set place.spawn_mode=stable (repeatable)")
    parser.add_argument("--pictures", action="store_true", help="also write top-down and perspective pictures per variant")
    parser.add_argument("--check", action="store_true", help="run the independent resting check and print figures per category")


def run(args: argparse.Namespace) -> int:
    """Place and settle variants of one scene; print a line per variant and what went wrong."""
    from dataclasses import replace

    from .check import check_variant, format_report
    from .pictures import top_down_picture, view_picture
    from .variants import run_variant, variant_paths, variant_seed, planes_from_scene

    cfg = load_config(args.config, args.overrides)
    pcfg = cfg.place if args.variants is None else replace(cfg.place, k_v=int(args.variants))
    scene, root = find_scene(args.scene)
    out = Path(args.out).resolve()
    scene_dir = Path(args.scene) if Path(args.scene).is_dir() else Path(args.scene).parent
    planes_file = Path(args.planes) if args.planes else scene_dir / "perceive" / "planes.json"
    if planes_file.exists():
        try:
            planes = load_json(planes_file, ReceptaclePlane)
        except RecordError as e:
            raise InputError(planes_file, f"not a list of ReceptaclePlane records ({e})") from None
        planes = planes if isinstance(planes, list) else [planes]
    elif args.planes:
        raise InputError(planes_file, "planes file not found")
    else:
        planes = planes_from_scene(scene)
        print(f"place: no perceive/planes.json for {scene.name}: using its {len(planes)} ground-truth support surfaces", file=sys.stderr)
    objects = load_objects(args.objects, root)
    rel_file = Path(args.relevance) if args.relevance else scene_dir / "semantics" / "relevance.json"
    if rel_file.exists():
        try:
            relevance = load_json(rel_file, Relevance)
        except RecordError as e:
            raise InputError(rel_file, f"not a Relevance record ({e})") from None
    elif args.relevance:
        raise InputError(rel_file, "relevance file not found")
    else:
        cats = sorted({o.category for o in objects})
        regions = sorted({p.region for p in planes}) or [""]
        recs = sorted({p.label for p in planes}) or [""]
        relevance = Relevance(objects=cats, regions=regions, receptacles=recs, backend="uniform",
                              p_obj_region=np.full((len(cats), len(regions)), 1.0 / max(len(cats), 1)),
                              p_obj_receptacle=np.full((len(cats), len(recs)), 1.0 / max(len(cats), 1)))
        print(f"place: no relevance table for {scene.name}: placing categories uniformly (no semantics)", file=sys.stderr)
    seed = cfg.seed if args.seed is None else int(args.seed)
    total, checks = 0, []
    for k in range(pcfg.k_v):
        v, st = run_variant(scene, planes, relevance, objects, root, pcfg, variant_seed(seed, k), k, out_root=out)
        total += len(v.resting)
        print(f"{v.name}: {len(v.resting)}/{len(v.placements)} objects resting  "
              f"(sample+settle {st.place_s:.2f} s, {st.sim_time:.2f} s simulated, {st.rounds} round(s))")
        for n in v.notes:
            print(f"  note: {n}")
        if args.pictures:
            d = out / Path(variant_paths(scene.name, k)[1]).parent
            top_down_picture(v, planes, out, d / "top_down.png")
            view_picture(v, planes, out, d / "view.png")
        if args.check:
            checks.append(check_variant(v, planes, out))
    if checks:
        print(format_report(checks))
    if total == 0:
        print(f"sdovon-mj place: no object came to rest in any variant of {scene.name} (see the notes above)", file=sys.stderr)
        return 1
    return 0
