"""Converted objects in the conversion cache: look one up or build, store and place it (rigid and URDF objects)."""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path
from typing import Any, Callable

from sdovon_mj.records import ObjectAsset, dumps
from sdovon_mj.store import atomic_write_text

from . import cache


def cached_object(out_dir: Path, name: str, key: str, cache_dir: str | Path | None, source: str, t0: float,
                  build: Callable[[Path], tuple[ObjectAsset, dict[str, Any]]]) -> tuple[ObjectAsset, dict[str, Any]]:
    """Return a converted object from the conversion cache, or build it into a temp folder, store and place it.

    Parameters
    ----------
    out_dir : Path
        The conversion output folder (the object lands in ``objects/<name>``).
    name : str
        The object's folder name.
    key : str
        Its cache key (`cache.cache_key` of its input files and parameters).
    cache_dir : str, Path or None
        The cache root (None: the default `cache.cache_root`).
    source : str
        The source recorded in the asset (run-relative where possible).
    t0 : float
        `time.perf_counter()` at the start of the conversion (the returned info's seconds).
    build : callable
        ``build(work_dir) -> (asset, info)`` writes the object's files into work_dir.
    """
    root = cache.cache_root(cache_dir)
    target = out_dir / "objects" / name
    hit = cache.lookup(root, key)
    if hit is not None:
        cache.link_tree(hit, target)
        asset = load_converted(out_dir, name)
        info = dict(_read_info(target))
        info.update(cache_hit=True, seconds=time.perf_counter() - t0)
        return asset, info
    tmp = cache.scratch_dir(_mkdir(out_dir / "objects") / name)
    try:
        asset, info = build(tmp)
        asset.content_hash = key
        asset.source = source
        atomic_write_text(tmp / "asset.json", dumps(asset.to_dict()))
        # the stored report holds figures of the object only: wall seconds stay in the returned info (a run
        # folder's bytes must not depend on how long CoACD took)
        atomic_write_text(tmp / "report.json", dumps({k: v for k, v in info.items() if k != "hull_seconds"}))
        cache.store(root, key, tmp)
        cache.replace_dir(tmp, target)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    asset.mjcf = (Path("objects") / name / "model.xml").as_posix()
    return asset, dict(info, cache_hit=False, seconds=time.perf_counter() - t0)


def load_converted(out_dir: str | Path, name: str) -> ObjectAsset:
    """Return the ObjectAsset of an object converted into `out_dir` (its mjcf relative to out_dir)."""
    stored = json.loads((Path(out_dir) / "objects" / name / "asset.json").read_text(encoding="utf-8"))
    asset = ObjectAsset.from_dict(stored)
    asset.mjcf = (Path("objects") / name / "model.xml").as_posix()
    return asset


def _read_info(folder: Path) -> dict[str, Any]:
    """Return the stored report figures of a converted object folder."""
    p = folder / "report.json"
    return json.loads(p.read_text(encoding="utf-8")) if p.is_file() else {}


def _mkdir(p: Path) -> Path:
    """Create a folder (and parents) and return it."""
    p.mkdir(parents=True, exist_ok=True)
    return p
