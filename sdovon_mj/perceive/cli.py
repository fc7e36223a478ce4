"""`sdovon-mj perceive OBS_DIR --scene SCENE --out DIR`: instances and receptacle planes from an observe output."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Iterator

from ..config import load_config
from ..errors import InputError
from ..records import Observation, RecordError, SceneAsset, load_json, load_npz, save_json, save_npz


def _scene(path: str | Path) -> SceneAsset:
    """Load a SceneAsset from scene.json or a folder holding one (InputError naming the file)."""
    p = Path(path)
    if p.is_dir():
        p = p / "scene.json"
    if not p.is_file():
        raise InputError(p, "scene record not found")
    try:
        return load_json(p, SceneAsset)
    except RecordError as e:
        raise InputError(p, f"not a SceneAsset record ({e})") from None


def _observations(shards: list[Path]) -> Iterator[Observation]:
    """Yield the observations of the shards in order (InputError naming a bad shard)."""
    for s in shards:
        try:
            recs = load_npz(s)
        except RecordError as e:
            raise InputError(s, f"not an observation shard ({e})") from None
        for r in recs:
            if not isinstance(r, Observation):
                raise InputError(s, f"holds a {type(r).__name__} record, not Observation")
            yield r


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the perceive subcommand's arguments."""
    parser.add_argument("observations", metavar="OBS_DIR", help="an observe output folder (obs_*.npz shards)")
    parser.add_argument("--scene", default=None, help="the scene record (scene.json or its folder); needed by the gt detector")
    parser.add_argument("--out", required=True, help="output folder: instances.npz, planes.json")
    parser.add_argument("--config", default=None, help="YAML config file")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override a config key, e.g. --set perceive.fusion_preset=conceptgraphs (repeatable)")
    parser.add_argument("--seed", type=int, default=None, help="seed for noise models (default: the config's seed)")


def run(args: argparse.Namespace) -> int:
    """Detect, fuse and correct instances, find receptacle planes, write them, print a summary."""
    from . import perceive_scene
    from ..receptacles import find_receptacle_planes

    cfg = load_config(args.config, args.overrides)
    obs_dir = Path(args.observations)
    if not obs_dir.is_dir():
        raise InputError(obs_dir, "observation folder not found")
    shards = sorted(obs_dir.glob("obs_*.npz")) or sorted(obs_dir.glob("*.npz"))
    if not shards:
        raise InputError(obs_dir, "no observation shards (obs_*.npz) in this folder")
    scene = _scene(args.scene) if args.scene else None
    if scene is None and cfg.perceive.detector == "gt":
        raise InputError(obs_dir, "the gt detector needs the scene's labels: pass --scene")
    seed = cfg.seed if args.seed is None else args.seed
    t0 = time.perf_counter()
    instances = perceive_scene(_observations(shards), scene, cfg.perceive, seed=seed)
    t1 = time.perf_counter()
    planes = find_receptacle_planes(instances, cfg.receptacles)
    t2 = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    save_npz(instances, out / "instances.npz")
    save_json(planes, out / "planes.json")
    recs = sorted({p.instance_id for p in planes})
    print(f"{len(instances)} instances ({t1 - t0:.1f} s), {len(planes)} planes on {len(recs)} receptacles ({t2 - t1:.1f} s) -> {out}")
    return 0
