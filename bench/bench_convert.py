"""Conversion benchmark: our convert_object vs obj2mjcf (own venv) on the same OBJs, same CoACD threshold.

Prints per object and median: seconds, hull count, hull-volume / mesh-volume ratio, and our cached
re-conversion time. obj2mjcf is installed into /tmp/obj2mjcf-venv on first use (python -m venv + pip).

    python bench/bench_convert.py                      # 4 shared OBJs
    python bench/bench_convert.py --objects ycb_025_mug bullet_teddy --threshold 0.05
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared" / "assets"
VENV = Path("/tmp/obj2mjcf-venv")
DEFAULT = ["bullet_banana", "pybullet_mug", "ycb_004_sugar_box", "ycb_006_mustard_bottle"]


def ensure_obj2mjcf() -> Path:
    """Return the obj2mjcf executable, creating its venv when missing."""
    exe = VENV / "bin" / "obj2mjcf"
    if not exe.exists():
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
        subprocess.run([str(VENV / "bin" / "pip"), "install", "-q", "obj2mjcf"], check=True)
    return exe


def mesh_ratio(hull_files: list[Path], source: Path) -> float:
    """Return summed hull volume / source mesh volume (same units, unit-free)."""
    import trimesh

    from assets_convert.object import mesh_volume

    src = trimesh.load(source, force="mesh", process=False)
    mvol, _ = mesh_volume(np.asarray(src.vertices), np.asarray(src.faces))
    hv = sum(trimesh.load(h, force="mesh", process=False).convex_hull.volume for h in hull_files)
    return hv / mvol if mvol > 0 else float("nan")


def run_obj2mjcf(exe: Path, obj: Path, threshold: float, work: Path) -> dict:
    """Convert one OBJ (copied with its MTL/textures into its own folder) with obj2mjcf --decompose."""
    d = work / "obj2mjcf" / obj.parent.name
    shutil.copytree(obj.parent, d, dirs_exist_ok=True)
    for other in d.glob("*.obj"):
        if other.name != obj.name:
            other.unlink()
    t0 = time.perf_counter()
    r = subprocess.run([str(exe), "--obj-dir", str(d), "--decompose", "--overwrite", "--save-mjcf",
                        "--coacd-args.threshold", str(threshold)], capture_output=True, text=True)
    secs = time.perf_counter() - t0
    if r.returncode != 0:
        return {"seconds": secs, "hulls": 0, "ratio": float("nan"), "error": r.stderr.strip().splitlines()[-1:]}
    hulls = sorted((d / obj.stem).glob(f"{obj.stem}_collision_*.obj"))
    return {"seconds": secs, "hulls": len(hulls), "ratio": mesh_ratio(hulls, obj)}


def run_ours(obj: Path, category: str, threshold: float, work: Path) -> dict:
    """Convert one OBJ with our converter: cold (fresh cache) and again (cache hit)."""
    from dataclasses import replace

    from assets_convert.object import convert_object_report
    from sdovon_mj.config import ConvertConfig

    cfg = replace(ConvertConfig(), coacd_threshold=threshold)
    cache = work / "cache"
    t0 = time.perf_counter()
    a, info = convert_object_report(obj, work / "ours", category=category, config=cfg, cache_dir=cache)
    cold = time.perf_counter() - t0
    t1 = time.perf_counter()
    _b, info2 = convert_object_report(obj, work / "ours_again", category=category, config=cfg, cache_dir=cache)
    hit = time.perf_counter() - t1
    assert info2["cache_hit"], "second conversion should hit the cache"
    hulls = sorted((work / "ours" / a.mjcf).parent.glob("assets/collision_*.obj"))
    # our hulls are in metres, Z up, recentred: compare volumes in the same frame via the stored ratio
    return {"seconds": cold, "hulls": a.hull_count, "ratio": a.volume_ratio, "cached_seconds": hit,
            "method": info["hull_method"], "files": len(hulls)}


def main() -> int:
    """Run the benchmark and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", nargs="*", default=DEFAULT, help="MANIFEST ids of OBJ objects")
    ap.add_argument("--threshold", type=float, default=0.05, help="CoACD concavity threshold for both")
    ap.add_argument("--skip-obj2mjcf", action="store_true", help="only time our converter")
    args = ap.parse_args()
    man = {it["id"]: it for it in json.loads((SHARED / "MANIFEST.json").read_text())["items"]}
    exe = None if args.skip_obj2mjcf else ensure_obj2mjcf()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for oid in args.objects:
            item = man[oid]
            obj = SHARED / item["main_file"]
            if obj.suffix.lower() != ".obj":
                print(f"skip {oid}: obj2mjcf reads OBJ only", file=sys.stderr)
                continue
            ours = run_ours(obj, item["category"], args.threshold, work)
            theirs = run_obj2mjcf(exe, obj, args.threshold, work) if exe else {}
            rows.append((oid, item.get("faces", 0), ours, theirs))
            print(f"{oid:26s} faces {item.get('faces', 0):6d} | ours {ours['seconds']:7.2f} s {ours['hulls']:3d} hulls "
                  f"ratio {ours['ratio']:5.2f} ({ours['method']}) cached {ours['cached_seconds'] * 1000:6.1f} ms"
                  + (f" | obj2mjcf {theirs['seconds']:7.2f} s {theirs['hulls']:3d} hulls ratio {theirs['ratio']:5.2f}"
                     if theirs else ""), flush=True)
    if not rows:
        return 1

    def med(key: str, which: int) -> float:
        vals = [r[which][key] for r in rows if r[which] and np.isfinite(r[which].get(key, np.nan))]
        return statistics.median(vals) if vals else float("nan")

    print(f"{'median':26s}              | ours {med('seconds', 2):7.2f} s {med('hulls', 2):5.1f} hulls "
          f"ratio {med('ratio', 2):5.2f} cached {med('cached_seconds', 2) * 1000:6.1f} ms"
          + (f" | obj2mjcf {med('seconds', 3):7.2f} s {med('hulls', 3):5.1f} hulls ratio {med('ratio', 3):5.2f}"
             if exe else ""))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(REPO))
    sys.exit(main())
