"""`sdovon-mj observe SCENE --out DIR`: floors, navigable maps, coverage viewpoints, RGB-D shards."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..config import load_config
from ..errors import InputError
from ..records import RecordError, SceneAsset, load_json


def find_scene(path: str | Path) -> tuple[SceneAsset, Path]:
    """Return a SceneAsset and its store root from a scene.json or a folder holding one."""
    p = Path(path)
    if p.is_dir():
        cands = [p / "scene.json"] if (p / "scene.json").exists() else sorted(p.glob("*.json"))
        scenes = []
        for c in cands:
            try:
                scenes.append((load_json(c, SceneAsset), c))
            except (RecordError, ValueError):
                continue
        if not scenes:
            raise InputError(p, "no SceneAsset json (scene.json) in this folder")
        if len(scenes) > 1:
            raise InputError(p, "several scene records here: " + ", ".join(c.name for _s, c in scenes) + "; name one")
        scene, p = scenes[0]
    elif p.exists():
        try:
            scene = load_json(p, SceneAsset)
        except RecordError as e:
            raise InputError(p, f"not a SceneAsset record ({e})") from None
    else:
        raise InputError(p, "scene not found")
    # record paths are relative to the store root the scene was written into: the json's folder or above
    for root in [p.parent, *p.parent.parents][:4]:
        if (root / scene.mjcf).exists() and (not scene.mesh or (root / scene.mesh).exists()):
            return scene, root
    raise InputError(p, f"cannot find the scene's MJCF {scene.mjcf!r} / mesh {scene.mesh!r} relative to {p.parent} or its parents")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the observe subcommand's arguments."""
    parser.add_argument("scene", metavar="SCENE", help="a converted scene: scene.json (SceneAsset) or its folder")
    parser.add_argument("--out", required=True, help="output folder (navmaps, viewpoints, pictures, obs_*.npz shards)")
    parser.add_argument("--config", default=None, help="YAML config file")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override a config key, e.g. --set observe.yaw_steps=8 (repeatable)")
    parser.add_argument("--seed", type=int, default=None, help="sampling seed (default: the config's seed)")
    parser.add_argument("--no-render", action="store_true", help="maps and viewpoints only, no RGB-D shards")


def run(args: argparse.Namespace) -> int:
    """Observe one scene and print a one-line-per-floor report."""
    from .stage import observe_scene

    cfg = load_config(args.config, args.overrides)
    scene, root = find_scene(args.scene)
    out = Path(args.out).resolve()
    seed = cfg.seed if args.seed is None else args.seed
    s = observe_scene(scene, root, ".", cfg.observe, seed=seed, out_root=out, render=not args.no_render)
    for m in s["maps"]:
        c = m["coverage"]
        print(f"floor {m['floor']} z={m['height']:.2f} m: navigable {m['navigable_m2']:.1f} m^2, {m['viewpoints']} viewpoints, "
              f"coverage {c['coverage']:.3f}{'' if c['reached'] else ' (threshold not reached)'}")
    for k, why in s["skipped_floors"].items():
        print(f"floor {k}: skipped: {why}")
    print(f"{s['frames']} frames in {len(s['shards'])} shards -> {out} ({s['seconds']:.1f} s)")
    return 0
