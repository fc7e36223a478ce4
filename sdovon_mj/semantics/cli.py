"""`sdovon-mj semantics SCENE_DIR --out DIR`: region maps and object-region-receptacle relevance.

Inputs (a scene folder of a run, ``scenes/<scene>``): ``observe/navmap_<floor>.json`` (NavMap) and
``perceive/instances.npz`` (fused Instances; ``instances.json`` also read). ``--world SEED`` uses a
default-world apartment's ground truth instead (no observe/perceive needed). Outputs in ``--out``:
``regions_<floor>.json`` (RegionMap) + ``regions_<floor>.png``, ``relevance.json`` (Relevance),
``receptacles.json`` (the receptacle labels used) and ``summary.json``. LLM replies are cached in
``--cache`` (default ``<out>/llm_cache``).
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import Any

from ..errors import InputError

DEFAULT_OBJECTS = (
    "mug", "cup", "bowl", "plate", "book", "bottle", "can", "cereal box", "laptop", "remote control", "pillow",
    "stuffed toy", "vase", "potted plant", "lamp", "shoe", "toothbrush", "soap dispenser", "towel", "spoon",
    "knife", "apple", "banana", "keyboard", "cell phone", "alarm clock", "candle", "wine glass", "teapot",
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the semantics subcommand's arguments."""
    parser.add_argument("scene", metavar="SCENE_DIR", nargs="?", default=None,
                        help="scene folder with observe/navmap_<floor>.json and perceive/instances.npz")
    parser.add_argument("--world", type=int, default=None, metavar="SEED",
                        help="use a default-world apartment's ground-truth instances and rooms instead")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--config", default=None, help="YAML config file")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override a config key, e.g. --set semantics.backend=ollama (repeatable)")
    parser.add_argument("--backend", default=None, help="LLM backend (offline, ollama, openai, or a plugin)")
    parser.add_argument("--model", default=None, help="model name for server backends")
    parser.add_argument("--url", default=None, help="server base URL")
    parser.add_argument("--objects", default=None, help="comma-separated object categories for relevance")
    parser.add_argument("--receptacles", default=None,
                        help="comma-separated receptacle labels (default: the config's, else asked from the instance labels)")
    parser.add_argument("--cache", default=None, help="LLM reply cache folder (default <out>/llm_cache)")


def _split(text: str | None) -> list[str]:
    return [t.strip() for t in (text or "").split(",") if t.strip()]


def _generate_apartment() -> Any:
    """Return the default world's `generate_apartment` (input generator, used only with --world)."""
    try:
        from ..world import generate_apartment  # type: ignore[attr-defined]
    except ImportError:
        from ..world.apartment import generate_apartment
    return generate_apartment


def load_inputs(scene: Path) -> tuple[list[Any], list[Any]]:
    """Return (navmaps, instances) read from a scene folder; raise InputError naming what is missing."""
    from ..records import Instance, NavMap, RecordError, load_json, load_npz

    if not scene.is_dir():
        raise InputError(scene, "scene folder not found")
    nav_files = sorted(scene.glob("observe/navmap_*.json")) or sorted(scene.glob("navmap_*.json"))
    if not nav_files:
        raise InputError(scene, "no observe/navmap_<floor>.json: run `sdovon-mj observe` first")
    navmaps = []
    for p in nav_files:
        try:
            navmaps.append(load_json(p, NavMap))
        except RecordError as e:
            raise InputError(p, f"not a NavMap record ({e})") from None
    cands = [scene / "perceive" / "instances.npz", scene / "instances.npz", scene / "perceive" / "instances.json",
             scene / "instances.json"]
    inst_file = next((c for c in cands if c.exists()), None)
    if inst_file is None:
        raise InputError(scene, "no perceive/instances.npz: run `sdovon-mj perceive` first")
    try:
        recs = load_npz(inst_file) if inst_file.suffix == ".npz" else load_json(inst_file, Instance)
    except (RecordError, OSError, ValueError, KeyError) as e:
        raise InputError(inst_file, f"cannot read instances ({e})") from None
    instances = [r for r in (recs if isinstance(recs, list) else [recs]) if isinstance(r, Instance)]
    return navmaps, instances


def run(args: argparse.Namespace) -> int:
    """Build region maps and relevance for one scene; print a short report."""
    from ..config import load_config
    from ..records import dumps, save_json
    from ..store import atomic_write_text
    from . import get_backend, identify_receptacles, region_map, region_picture, relevance

    cfg = load_config(args.config, args.overrides)
    scfg = cfg.semantics
    for key in ("backend", "model", "url"):
        if getattr(args, key):
            scfg = dataclasses.replace(scfg, **{key: getattr(args, key)})
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    apt = None
    if args.world is not None:
        from .groundtruth import apartment_instances, apartment_navmap

        apt = _generate_apartment()(int(args.world))
        instances = apartment_instances(apt)
        navmaps = [apartment_navmap(apt, f.index, res=cfg.observe.map_resolution,
                                    agent_radius=cfg.observe.agent_radius) for f in apt.floors]
    elif args.scene:
        navmaps, instances = load_inputs(Path(args.scene))
    else:
        raise InputError("SCENE_DIR", "give a scene folder or --world SEED")
    backend = get_backend(scfg, Path(args.cache) if args.cache else out / "llm_cache")
    labels = sorted({i.label for i in instances})
    recs = _split(args.receptacles) or list(cfg.receptacles.labels) or identify_receptacles(labels, backend)
    objects = _split(args.objects) or list(DEFAULT_OBJECTS)
    regions: list[str] = []
    summary: dict[str, Any] = {"backend": backend.label, "floors": {}}
    for nm in navmaps:
        rm = region_map(instances, nm, backend, scfg)
        save_json(rm, out / f"regions_{nm.floor}.json")
        region_picture(rm, out / f"regions_{nm.floor}.png", nm)
        used = sorted({rm.labels[k] for k in set(rm.label_map[nm.navigable].ravel().tolist()) if k >= 0})
        line: dict[str, Any] = {"regions": used}
        if apt is not None:
            from .groundtruth import region_accuracy

            acc = region_accuracy(rm, apt, nm)
            hit, tot = sum(a for a, _ in acc.values()), sum(n for _, n in acc.values())
            line["agreement"] = round(hit / max(tot, 1), 4)
        summary["floors"][str(nm.floor)] = line
        regions += [r for r in used if r not in regions]
        print(f"floor {nm.floor}: regions {', '.join(used) or '-'}"
              + (f"; agreement with true room types {line['agreement']:.3f}" if "agreement" in line else ""))
    regions = regions or list(scfg.region_labels)
    rel = relevance(objects, regions, recs, backend)
    save_json(rel, out / "relevance.json")
    atomic_write_text(out / "receptacles.json", dumps(recs))
    summary.update({"objects": len(rel.objects), "regions": rel.regions, "receptacles": rel.receptacles,
                    "fallbacks": len(backend.fallbacks), "llm_requests": backend.requests})
    atomic_write_text(out / "summary.json", dumps(summary))
    print(f"relevance: {len(rel.objects)} objects x {len(rel.regions)} regions x {len(rel.receptacles)} receptacles "
          f"({backend.label}; {backend.requests} LLM requests, {len(backend.fallbacks)} fallbacks) -> {out}")
    return 0
