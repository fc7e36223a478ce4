"""Bench the place stage: wall seconds per variant (sampling + settling) for 10 and 30 objects, and
the same boxes and mugs on the same table placed by NVlabs scene-synthesizer (its own venv), with a
side-by-side figure.

    python bench/bench_place.py [--variants 5] [--out /tmp/bench_place] [--no-peer]

Goal (issue 7): at most 0.2 s per 10-object variant on 2 cores, with physics.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # tests/support: the fixture scenes (not installed)

from sdovon_mj.config import PlaceConfig  # noqa: E402
from support.placement import hand_relevance, write_primitive_library, write_primitive_object, write_table_scene  # noqa: E402
from sdovon_mj.place.variants import run_variant  # noqa: E402
from sdovon_mj.seeds import variant_seed  # noqa: E402
from sdovon_mj.records import Relevance  # noqa: E402

VENV = Path("/tmp/scene-synth-venv")
TABLE = (("table", 0, (0.0, 0.0), (0.5, 0.7), 0.7),)  # scene-synthesizer's TableAsset(1.0, 1.4, 0.7)
ROOM = ((0, "kitchen", (-2.0, -2.0, 2.0, 2.0)),)

PEER_SCRIPT = r"""
import json, sys, time
import numpy as np
import scene_synthesizer as synth
from scene_synthesizer import procedural_assets as pa
n, seeds = int(sys.argv[1]), [int(s) for s in sys.argv[2].split(",")]
out = {"version": getattr(synth, "__version__", "?"), "runs": []}
for seed in seeds:
    s = synth.Scene(seed=seed)
    s.add_object(pa.TableAsset(1.0, 1.4, 0.7), "table")
    s.label_support("support", obj_ids=["table"])
    t0 = time.perf_counter()
    for i in range(n):
        bottom = ("center", "center", "bottom")
        asset = synth.BoxAsset(extents=[0.08, 0.08, 0.08], origin=bottom) if i % 2 == 0 else pa.MugAsset(width=0.08, height=0.09, origin=bottom)
        s.place_object(("box_%d" if i % 2 == 0 else "mug_%d") % i, asset, support_id="support")
    dt = time.perf_counter() - t0
    b = np.asarray(s.get_bounds(query="table/top"))
    c = (b[0] + b[1]) / 2.0
    poses = {}
    for name in s.get_object_names():
        if name == "table":
            continue
        T = s.get_transform(name)
        poses[name] = [float(T[0, 3] - c[0]), float(T[1, 3] - c[1]), float(T[2, 3] - b[0][2])]
    out["runs"].append({"seed": seed, "seconds": dt, "placed": len(poses), "asked": n, "poses": poses})
print(json.dumps(out))
"""


def bench_ours(root: Path, n: int, mode: str, variants: int, scene: str = "flat", kinds: tuple[str, ...] = ("box", "mug", "ball", "can")) -> dict:
    """Place `variants` variants with n objects; return timing and outcome figures."""
    if scene == "table":
        sc, planes = write_table_scene(root / "table_scene", root, "table", TABLE, ROOM)
        lib = [write_primitive_object(root / "objects", root, "cube", "cube_8cm"), write_primitive_object(root / "objects", root, "mug", "mug_b")]
        rel = Relevance(objects=["cube", "mug"], regions=["kitchen"], receptacles=["table"], p_obj_region=np.array([[0.5], [0.5]]),
                        p_obj_receptacle=np.array([[0.5], [0.5]]))
    else:
        sc, planes = write_table_scene(root / "flat_scene", root)
        lib = [a for a in write_primitive_library(root / "objects", root, per_kind=2) if a.category in kinds]
        rel = hand_relevance()
    cfg = PlaceConfig(m=n, max_objects=n, spawn_mode=mode)
    rows = []
    last = None
    for k in range(variants):
        v, st = run_variant(sc, planes, rel, lib, root, cfg, variant_seed(123, k), k, write=False)
        rows.append((st.place_s, st.sample_s, st.compose_s, st.settle_s, st.sim_time, len(v.resting), len(v.placements), st.rounds, st.cpu_s))
        last = v
    a = np.array(rows, dtype=float)
    return {"n": n, "mode": mode, "scene": scene, "place_s": a[:, 0], "sample_s": a[:, 1].mean(), "compose_s": a[:, 2].mean(),
            "settle_s": a[:, 3].mean(), "sim": a[:, 4].mean(), "resting": int(a[:, 5].sum()), "placed": int(a[:, 6].sum()),
            "rounds": a[:, 7].mean(), "cpu_s": a[:, 8], "variant": last, "planes": planes}


def run_peer(n: int, seeds: list[int]) -> dict | str:
    """Run scene-synthesizer in its own venv (installing it there if needed); return its figures or why not."""
    py = VENV / "bin" / "python"
    if not py.exists():
        r = subprocess.run([sys.executable, "-m", "venv", str(VENV)], capture_output=True, text=True)
        if r.returncode:
            return f"could not create {VENV}: {r.stderr.strip()[-300:]}"
    chk = subprocess.run([str(py), "-c", "import scene_synthesizer"], capture_output=True, text=True)
    if chk.returncode:
        r = subprocess.run([str(VENV / "bin" / "pip"), "install", "-q", "scene-synthesizer"], capture_output=True, text=True)
        if r.returncode:
            return "pip install scene-synthesizer failed: " + (r.stderr.strip().splitlines() or ["?"])[-1]
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
        f.write(PEER_SCRIPT)
    r = subprocess.run([str(py), f.name, str(n), ",".join(map(str, seeds))], capture_output=True, text=True, timeout=600)
    os.unlink(f.name)
    if r.returncode:
        return "scene-synthesizer run failed: " + (r.stderr.strip().splitlines() or ["?"])[-1]
    return json.loads(r.stdout.strip().splitlines()[-1])


def figure(ours: dict, peer: dict | str, out: Path) -> Path:
    """Draw ours (settled) and scene-synthesizer's placements on the same table, top-down, side by side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, axes = plt.subplots(1, 2, figsize=(10, 6))
    for ax in axes:
        ax.add_patch(Rectangle((-0.5, -0.7), 1.0, 1.4, fc="#c8a27a", ec="k"))
        ax.set_xlim(-0.7, 0.7)
        ax.set_ylim(-0.9, 0.9)
        ax.set_aspect("equal")
    v = ours["variant"]
    for p in v.placements:
        pos = p.settled_pos if p.settled_pos is not None else p.spawn_pos
        c = "tab:blue" if p.category == "mug" else "tab:red"
        axes[0].plot(pos[0], pos[1], "o" if p.status == "resting" else "x", color=c, ms=9)
    axes[0].set_title(f"sdovon-mj (physics, {ours['mode']} spawn)\n{len(v.resting)}/{len(v.placements)} resting, "
                      f"{np.median(ours['place_s']):.3f} s/variant")
    if isinstance(peer, dict):
        run = peer["runs"][-1]
        for name, pos in run["poses"].items():
            axes[1].plot(pos[0], pos[1], "o", color="tab:blue" if "mug" in name else "tab:red", ms=9)
        axes[1].set_title(f"scene-synthesizer {peer['version']} (kinematic)\n{run['placed']}/{run['asked']} placed, "
                          f"{np.median([r['seconds'] for r in peer['runs']]):.3f} s/variant")
    else:
        axes[1].set_title("scene-synthesizer: not run\n" + peer[:60])
    fig.suptitle("the same 8 cm boxes (red) and mugs (blue) on a 1.0 x 1.4 m table at 0.7 m")
    path = out / "place_side_by_side.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def main() -> int:
    """Run the bench and print the figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", type=int, default=5, help="variants per setting")
    ap.add_argument("--out", default="/tmp/bench_place", help="folder for the figure and scratch assets")
    ap.add_argument("--no-peer", action="store_true", help="skip scene-synthesizer")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    root = Path(tempfile.mkdtemp(prefix="store_", dir=out))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"cores: {os.cpu_count()}, load average {load:.1f} (wall seconds inflate when the box is shared; "
          "cpu s = this process's CPU seconds)")
    print(f"{'objects':>7} {'spawn':>6} {'scene':>6} {'median s':>9} {'mean s':>7} {'cpu s':>6} {'sample':>7} {'compose':>8} {'settle':>7} "
          f"{'sim s':>6} {'rounds':>6} {'resting':>9}")
    table10 = None
    for scene in ("flat", "table"):
        for n in (10, 30):
            if scene == "table" and n == 30:
                continue
            for mode in ("paper", "stable"):
                r = bench_ours(root, n, mode, args.variants, scene)
                if scene == "table" and mode == "paper":
                    table10 = r
                print(f"{n:>7} {mode:>6} {scene:>6} {np.median(r['place_s']):>9.3f} {r['place_s'].mean():>7.3f} {np.median(r['cpu_s']):>6.3f} {r['sample_s']:>7.3f} "
                      f"{r['compose_s']:>8.3f} {r['settle_s']:>7.3f} {r['sim']:>6.2f} {r['rounds']:>6.1f} {r['resting']:>4}/{r['placed']:<4}")
    peer: dict | str = "skipped (--no-peer)"
    if not args.no_peer:
        t0 = time.perf_counter()
        peer = run_peer(10, [0, 1, 2])
        if isinstance(peer, dict):
            secs = [r["seconds"] for r in peer["runs"]]
            placed = [r["placed"] for r in peer["runs"]]
            print(f"scene-synthesizer {peer['version']}: 10 objects (5 boxes + 5 mugs) on the table: median {np.median(secs):.3f} s "
                  f"per variant, placed {placed} of 10, no physics (setup incl. import {time.perf_counter() - t0:.1f} s)")
        else:
            print(f"scene-synthesizer: {peer}")
    if table10 is not None:
        print(f"figure: {figure(table10, peer, out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
