"""Perceive + receptacle benchmark: fusion time per observation, plane detection time per receptacle.

Runs on the hand-built test room (tests/test_perceive_scenes.py) rendered from --views poses, with the
gt detector, optionally with depth noise; prints timings and the quality figures of the tests.
    python bench/bench_perceive.py [--width 320 --height 240] [--sigma 0.005] [--preset paper]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import numpy as np  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--sigma", type=float, default=0.0, help="depth noise std (m)")
    ap.add_argument("--preset", default="paper", help="fusion preset: paper, conceptgraphs")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    from test_perceive_scenes import (camera_poses, default_instances, match_instances, match_surfaces, mjcf,
                                      render_observations, scene_asset)

    from sdovon_mj.config import PerceiveConfig, ReceptacleConfig
    from sdovon_mj.perceive import InstanceFuser, backproject_detections, correct_fusion, make_detector
    from sdovon_mj.perceive.fusion import embed_labels
    from sdovon_mj.receptacles import detect_planes, receptacle_instances

    insts = default_instances()
    scene = scene_asset(insts)
    t = time.perf_counter()
    obs = render_observations(mjcf(insts), camera_poses(insts), args.width, args.height)
    print(f"render: {len(obs)} views {args.width}x{args.height} in {time.perf_counter() - t:.2f} s")
    cfg = PerceiveConfig(depth_noise_sigma=args.sigma, fusion_preset=args.preset)
    det = make_detector(cfg, scene, args.seed)
    embed_labels(sorted({i.label for i in scene.instances}))  # model load is a one-off, not per observation
    fuser = InstanceFuser(cfg)
    t_det = t_bp = t_fuse = 0.0
    for o in obs:
        t0 = time.perf_counter()
        dets = det.detect(o)
        t1 = time.perf_counter()
        parts = backproject_detections(o, dets, cfg, seed=args.seed)
        t2 = time.perf_counter()
        fuser.add_view(parts)
        t3 = time.perf_counter()
        t_det, t_bp, t_fuse = t_det + t1 - t0, t_bp + t2 - t1, t_fuse + t3 - t2
    t0 = time.perf_counter()
    fused = correct_fusion(fuser.instances(), cfg)
    t_end = time.perf_counter() - t0
    n = len(obs)
    print(f"per observation: detect {1e3 * t_det / n:.1f} ms, back-project {1e3 * t_bp / n:.1f} ms, "
          f"fuse {1e3 * t_fuse / n:.1f} ms (+ consolidate/correct {1e3 * t_end:.0f} ms once)")
    labels = ReceptacleConfig().labels
    p, r = match_instances(fused, insts, labels)
    print(f"fused instances: {len(fused)}; receptacles precision {p:.2f} recall {r:.2f} (3D IoU >= 0.5)")
    rcfg = ReceptacleConfig()
    planes = []
    for inst in receptacle_instances(fused, labels):
        t0 = time.perf_counter()
        got = detect_planes(inst, rcfg, first_id=len(planes))
        dt = time.perf_counter() - t0
        planes += got
        print(f"planes: {inst.label:<10s} {len(inst.points):6d} points -> {len(got)} planes in {1e3 * dt:.0f} ms")
    tol = 0.02 if args.sigma <= 0 else 0.03
    for iid, h, err, iou in match_surfaces(planes, scene, tol):
        print(f"surface of instance {iid} at {h:.2f} m: height error {100 * err:.1f} cm, polygon IoU {iou:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
