"""Perceive + receptacle benchmark: fusion time per observation, plane detection time per receptacle.

Default: the hand-built test room (tests/test_perceive_scenes.py), gt detector, optionally with depth
noise; prints timings and the quality figures of the tests. With --world SEED: a default-world
apartment observed by the observe stage (default viewpoints and cameras), then receptacle P/R, height
errors and polygon IoUs per receptacle type (and how much of each true surface the coverage views
showed), without and with the targeted views of the perceive stage.
    python bench/bench_perceive.py [--width 320 --height 240] [--sigma 0.005] [--preset paper]
    python bench/bench_perceive.py --world 0 [--sigma 0.005]
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
    ap.add_argument("--world", type=int, default=None, metavar="SEED", help="a default-world apartment instead of the test room")
    ap.add_argument("--out", default=None, help="work folder for --world (default: a temporary folder)")
    args = ap.parse_args()
    if args.world is not None:
        return world(args)

    from test_perceive_scenes import (camera_poses, default_instances, match_instances, match_surfaces, mjcf,
                                      render_observations, scene_asset)

    from sdovon_mj.config import PerceiveConfig, ReceptacleConfig
    from sdovon_mj.perceive import InstanceFuser, backproject_detections, correct_fusion, make_detector
    from sdovon_mj.embeddings import embed_labels
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


def world(args: argparse.Namespace) -> int:
    """Observe + perceive (+ targeted views) + planes on one default-world apartment; print timings and quality."""
    import dataclasses
    import tempfile

    import test_perceive_world as W

    from sdovon_mj.config import AgentConfig, ObserveConfig, PerceiveConfig, ReceptacleConfig, RunConfig
    from sdovon_mj.observe import load_shards, observe_scene
    from sdovon_mj.embeddings import embed_labels
    from sdovon_mj.geometry import ensure_ccw
    from sdovon_mj.records import NavMap, load_json
    from sdovon_mj.perceive.surfaces import perceive_and_find_planes

    root = Path(args.out or tempfile.mkdtemp(prefix="bench_perceive_"))
    scene = W.scene_from_apartment(args.world, root)
    t = time.perf_counter()
    ocfg = ObserveConfig(width=args.width, height=args.height)
    s = observe_scene(scene, root, "observe", ocfg, seed=args.world)
    obs = list(load_shards([root / p for p in s["shards"]]))
    navmaps = [load_json(p, NavMap) for p in sorted((root / "observe").glob("navmap_*.json"))]
    t_obs = time.perf_counter() - t
    embed_labels(sorted({i.label for i in scene.instances}))  # model load: a one-off
    rcfg = ReceptacleConfig()
    tol = 0.02 if args.sigma <= 0 else 0.03
    print(f"apartment {args.world}: {len(scene.floors)} floor(s), {s['viewpoints']} viewpoints x {s['views_per_viewpoint']} views "
          f"= {len(obs)} observations {args.width}x{args.height} (camera heights {AgentConfig().camera_height} + {list(ocfg.camera_heights)}); "
          f"observe {t_obs:.1f} s")
    for views in (0, ocfg.targeted_views):
        cfg = RunConfig(observe=dataclasses.replace(ocfg, targeted_views=views), receptacles=rcfg,
                        perceive=PerceiveConfig(depth_noise_sigma=args.sigma, fusion_preset=args.preset))
        t = time.perf_counter()
        fused, planes, poses = perceive_and_find_planes(obs, scene, root, navmaps, cfg, args.world)
        t_all = time.perf_counter() - t
        from sdovon_mj.receptacles import find_receptacle_planes

        t = time.perf_counter()
        find_receptacle_planes(fused, rcfg)
        t_pl = time.perf_counter() - t
        n_rec = len({p.instance_id for p in planes}) or 1
        n_obs = len(obs) + len(poses)
        print(f"\n-- targeted views per surface: {views} -> {len(poses)} views added")
        print(f"perceive + targeted views + planes {t_all:.1f} s = {1e3 * (t_all - t_pl) / n_obs:.0f} ms per observation "
              f"(incl. view planning); planes {t_pl:.2f} s = {1e3 * t_pl / n_rec:.0f} ms per receptacle")
        p, r = W.instance_scores(scene, fused, rcfg.labels)
        print(f"{len(fused)} fused instances; receptacles precision {p:.2f} recall {r:.2f} (3D box IoU >= 0.5)")
        by_type: dict[str, list] = {}
        for (iid, label, h, err, iou), (_i, _h, poly) in zip(W.surface_scores(scene, planes, tol), W.true_regions(scene)):
            seen = W.observed_fraction(obs, iid, h, ensure_ccw(poly))
            by_type.setdefault(label, []).append((err, iou, seen))
            print(f"  {label:<13s} #{iid:<3d} at {h:.3f} m: height error {100 * err:5.2f} cm, polygon IoU {iou:.2f}, "
                  f"coverage views showed {seen:.2f}")
        print(f"{'type':<13s} {'regions':>7s} {'found':>5s} {'max err cm':>10s} {'mean IoU':>8s} {'IoU>=0.8':>8s}")
        for label, rows in sorted(by_type.items()):
            e = np.array([x[0] for x in rows])
            u = np.array([x[1] for x in rows])
            found = e <= tol
            print(f"{label:<13s} {len(rows):7d} {found.sum():5d} {100 * e[found].max() if found.any() else float('nan'):10.2f} "
                  f"{u.mean():8.2f} {(u >= 0.8).sum():8d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
