"""Environment steps per second of the ObjectNav suite with rgb + depth at 640x480 and 128x128.

    python bench/bench_suite.py [--bundle VARIANT_DIR] [--steps 200] [--threads 2]

Without --bundle the built-in fixture apartment is used. Prints one line per resolution: steps/s
with rgb+depth rendered every step, with segmentation added, and with rendering skipped
(`task.render_frames = False`, what the A* baselines use between observations).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # tests/support: the fixture scenes (not installed)


def main() -> None:
    """Run the benchmark and print figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bundle", default=None, help="variant folder (default: fixture apartment)")
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--threads", type=int, default=2, help="CPU threads for Mesa llvmpipe (LP_NUM_THREADS)")
    args = ap.parse_args()
    os.environ.setdefault("LP_NUM_THREADS", str(args.threads))
    import numpy as np

    from sdovon_mj import suite
    from support.bundles import fixture_bundle

    bundle = args.bundle or (fixture_bundle() / "fixture_apartment_v000")
    print(f"bundle: {bundle}  MUJOCO_GL={os.environ.get('MUJOCO_GL')}  LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS')}")
    for (w, h) in ((640, 480), (128, 128)):
        for label, semantic, render in (("rgb+depth", False, True), ("rgb+depth+seg", True, True), ("no render", False, False)):
            env = suite.make_environment(bundle, semantic=semantic, width=w, height=h, max_steps=10 ** 9)
            env.task.render_frames = render
            rng = np.random.default_rng(0)
            env.reset()
            for _ in range(5):
                env.step(int(rng.integers(1, 6)))
            t0 = time.perf_counter()
            for _ in range(args.steps):
                env.step(int(rng.integers(1, 6)))
            dt = time.perf_counter() - t0
            print(f"{w}x{h} {label:14s} {args.steps / dt:8.1f} steps/s")
            env.task.close()


if __name__ == "__main__":
    main()
