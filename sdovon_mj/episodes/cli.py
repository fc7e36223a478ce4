"""`sdovon-mj episodes RUN_DIR`: ObjectNav episodes for the variants of a run folder.

Reads ``scenes/<scene>/variants/<variant>/variant.json`` and ``scenes/<scene>/observe/navmap_<floor>.json``
and writes ``episodes.json`` next to each variant (layout: exporters/base.py).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..config import load_config
from ..errors import InputError
from ..records import NavMap, RecordError, SceneVariant, load_json, save_json
from .generate import episode_report, generate_episodes_with_report


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the episodes subcommand's arguments."""
    parser.add_argument("run_dir", metavar="RUN_DIR", help="run folder (scenes/<scene>/variants/<variant>/variant.json)")
    parser.add_argument("--scene", action="append", default=[], help="only these scenes (repeatable)")
    parser.add_argument("--config", default=None, help="YAML config file")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="config override, e.g. episodes.k_e=5")


def _load(path: Path, cls: type):
    try:
        return load_json(path, cls)
    except (RecordError, FileNotFoundError) as e:
        raise InputError(path, str(e)) from None


def run(args: argparse.Namespace) -> int:
    """Generate and write episodes for every variant of the run; print the N report."""
    cfg = load_config(args.config, args.set)
    root = Path(args.run_dir).resolve()
    scenes = sorted(p.parent.name for p in (root / "scenes").glob("*/scene.json"))
    if args.scene:
        scenes = [s for s in scenes if s in set(args.scene)]
    if not scenes:
        raise InputError(root, "no scenes/<scene>/scene.json in this run folder")
    by_variant = {}
    for scene in scenes:
        navmaps = [_load(p, NavMap) for p in sorted((root / "scenes" / scene / "observe").glob("navmap_*.json"))]
        if not navmaps:
            raise InputError(root / "scenes" / scene / "observe", "no navmap_<floor>.json")
        for vp in sorted((root / "scenes" / scene / "variants").glob("*/variant.json")):
            variant = _load(vp, SceneVariant)
            eps, rep = generate_episodes_with_report(variant, navmaps, root, cfg.episodes, cfg.seed * 100003 + variant.seed)
            save_json(eps, vp.parent / "episodes.json")
            by_variant[variant.name] = eps
            dropped = ", ".join(f"{k} ({v})" for k, v in sorted(rep.dropped.items()))
            print(f"{variant.name}: {len(eps)} episodes, {len(rep.kept)} goals" + (f"; dropped {dropped}" if dropped else ""))
    r = episode_report(by_variant, cfg.episodes.k_e)
    print(f"N = k_s*k_v*n_c*k_e = {r['k_s']}*{r['k_v']:.2f}*{r['n_c']:.2f}*{r['k_e']} = {r['N_formula']:.1f}; written {r['N_actual']}")
    return 0
