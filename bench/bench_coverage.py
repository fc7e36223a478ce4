"""Viewpoints needed to reach the coverage threshold: Gaussian coverage sampling vs uniform sampling.

Both samplers draw candidates over navigable cells, reject those closer than min_obstacle_distance
to an obstacle, overlay the same Gaussians on M_P and stop at the same threshold; the coverage
sampler draws proportional to (1 - M_P) (paper section 3.1), the baseline uniformly.

    python bench/bench_coverage.py [--seeds 5] [--threshold 0.9]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))  # tests/support: the fixture scenes (not installed with the package)

import numpy as np  # noqa: E402

from sdovon_mj.config import ObserveConfig  # noqa: E402
from sdovon_mj.observe import coverage_viewpoints, scene_floors_and_maps, uniform_viewpoints  # noqa: E402
from sdovon_mj.observe.stage import load_mesh  # noqa: E402
from support.scenes import apartment_boxes, living_room_parts, write_box_scene, write_mesh_scene  # noqa: E402

SHARED = Path(os.environ.get("SDOVON_SHARED_ASSETS", REPO.parent / "shared" / "assets"))


def scenes(work: Path) -> list[tuple[str, object, Path]]:
    """Return (label, SceneAsset, root) of the benchmark scenes."""
    out = []
    try:  # default-world apartments once the world generator and scene converter have landed
        from assets_convert import convert_scene  # type: ignore[attr-defined]
        from sdovon_mj.world import generate_apartment, write_apartment  # type: ignore[attr-defined]

        for seed in (0, 1):
            src = write_apartment(generate_apartment(seed), work / f"apt{seed}_src")
            out.append((f"default apartment {seed}", convert_scene(src, work / f"apt{seed}"), work / f"apt{seed}"))
    except ImportError:
        pass
    out.append(("synthetic 8x6 m 2-storey", write_box_scene(apartment_boxes(2), work / "s1"), work / "s1"))
    out.append(("synthetic 16x12 m", write_box_scene(apartment_boxes(1, size=(16.0, 12.0)), work / "s2"), work / "s2"))
    if (SHARED / "scenes" / "furnished_living_room" / "placements.json").exists():
        out.append(("furnished living room", write_mesh_scene(living_room_parts(SHARED), work / "lr", "living_room"), work / "lr"))
    return out


def main() -> int:
    """Print viewpoint counts per seed for both samplers on every scene and floor."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--threshold", type=float, default=0.9, help="coverage_threshold")
    ap.add_argument("--combine", default="add", choices=("add", "max"), help="coverage_combine")
    a = ap.parse_args()
    cfg = dataclasses.replace(ObserveConfig(), coverage_threshold=a.threshold, coverage_combine=a.combine)
    print(f"threshold {cfg.coverage_threshold}, eps_p_obs {cfg.eps_p_obs}, r_min {cfg.r_min}, r_max {cfg.r_max}, combine {cfg.coverage_combine}")
    with tempfile.TemporaryDirectory() as tmp:
        for label, scene, root in scenes(Path(tmp)):
            _p, v, f, _fi = load_mesh(scene, root)
            _fl, maps, _sk = scene_floors_and_maps(v, f, cfg)
            for nm in maps:
                t0 = time.perf_counter()
                cov = [coverage_viewpoints(nm, cfg, s) for s in range(a.seeds)]
                uni = [uniform_viewpoints(nm, cfg, s) for s in range(a.seeds)]
                dt = (time.perf_counter() - t0) / (2 * a.seeds)
                nc = [len(c[0]) for c in cov]
                nu = [len(u[0]) for u in uni]
                area = nm.navigable.sum() * nm.resolution ** 2
                print(f"{label}, floor {nm.floor} ({area:.1f} m^2 navigable):")
                print(f"  coverage sampling: {nc} mean {np.mean(nc):.1f}  (reached {sum(c[2].reached for c in cov)}/{a.seeds})")
                print(f"  uniform sampling:  {nu} mean {np.mean(nu):.1f}  (reached {sum(u[2].reached for u in uni)}/{a.seeds})")
                print(f"  ratio {np.mean(nc) / np.mean(nu):.2f}, {dt * 1000:.0f} ms per sampling run")
    return 0


if __name__ == "__main__":
    sys.exit(main())
