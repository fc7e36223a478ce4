"""The toolbox's costs: the viewer's data files of a run (seconds to build, bytes, triangles) and episode-video
writing (seconds per frame beside the suite's own step).

    python bench/bench_toolbox.py RUN_DIR [--eval EVAL_DIR]     # every data file of the viewer for this run
    python bench/bench_toolbox.py --video [--size 640 480]      # 60 steps of the fixture apartment, with and without
                                                                 # recording them
Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))  # tests/support: the fixture bundles (not installed)


def bench_viewer(run: Path, evals: list[Path]) -> None:
    """Build every data file of the viewer of a run; print seconds, size and triangles of each."""
    from sdovon_mj.viewer.data import to_json  # noqa: F401  (import cost outside the timings)
    from sdovon_mj.viewer.site import Site

    t0 = time.perf_counter()
    site = Site(run, evals)
    print(f"site: {time.perf_counter() - t0:.2f} s to read the run's records")
    print("| data file | seconds | MB | triangles |")
    print("|---|---|---|---|")
    total = 0
    for key in site.data_keys():
        t = time.perf_counter()
        body = site.data_file(key)
        dt = time.perf_counter() - t
        total += len(body)
        p = site.payload(key) if key != "index" else {}
        tri = sum(p[k]["indices"]["shape"][0] for k in ("mesh", "ceiling", "parts") if k in p)
        tri += sum(a["indices"]["shape"][0] for a in p.get("assets", {}).values())
        print(f"| {key} | {dt:.2f} | {len(body) / 1e6:.2f} | {tri} |")
    print(f"total data: {total / 1e6:.2f} MB (plus the page's static files, 0.6 MB)")


def bench_video(width: int, height: int, steps: int = 60) -> None:
    """Step the fixture apartment `steps` times with and without recording; print seconds per step."""
    from sdovon_mj import suite
    from sdovon_mj.suite.video import EpisodeVideo
    from support.bundles import fixture_bundle

    with tempfile.TemporaryDirectory() as tmp:
        root = fixture_bundle(Path(tmp) / "fx", variants=1, seed=3)
        env = suite.load("objectnav", task_kwargs={"bundle": root / "fixture_apartment_v000", "width": width,
                                                    "height": height, "max_steps": 10_000})
        rng = np.random.default_rng(0)
        actions = [int(a) for a in rng.choice([suite.MOVE_FORWARD, suite.TURN_LEFT, suite.TURN_RIGHT], size=steps)]
        for record in (False, True):
            task = env.task
            ts = env.reset()
            video = EpisodeVideo(Path(tmp) / "v.mp4", task.navmap, task.episode) if record else None
            t0 = time.perf_counter()
            if video:
                video.add(ts.observation["rgb"], task.state.position, task.state.yaw)
            for a in actions:
                ts = env.step(a)
                if video:
                    video.add(ts.observation["rgb"], task.state.position, task.state.yaw)
            if video:
                video.close()
            dt = (time.perf_counter() - t0) / steps
            size = (Path(tmp) / "v.mp4").stat().st_size / 1e3 if record else 0
            print(f"{width}x{height}, {'recording' if record else 'no video'}: {dt * 1e3:.1f} ms per step"
                  + (f", {size:.0f} kB for {steps + 1} frames" if record else ""))
        env.task.close()


def main() -> int:
    """Run the benchmarks asked for."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", nargs="?", type=Path)
    ap.add_argument("--eval", dest="evals", action="append", type=Path, default=[])
    ap.add_argument("--video", action="store_true")
    ap.add_argument("--size", nargs=2, type=int, default=[640, 480])
    args = ap.parse_args()
    if args.run_dir:
        bench_viewer(args.run_dir, args.evals)
    if args.video:
        bench_video(*args.size)
    if not args.run_dir and not args.video:
        ap.print_help()
    return 0


if __name__ == "__main__":
    sys.exit(main())
