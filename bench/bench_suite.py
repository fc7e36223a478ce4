"""Speed of the ObjectNav suite: environment steps per second, and evaluated episodes per minute per agent in-process
against the sealed protocol (issue 30: the agent in its own process, frames through shared memory).

    python bench/bench_suite.py [--dataset DIR] [--episodes 12] [--agents random-astar semantic-astar ...]
                                [--width 640 --height 480] [--steps 200] [--threads 2] [--no-env]

Without --dataset the built-in fixture apartment is used (a default-world export, e.g. the demo's
``out/demo/export/mjcf``, is the closer figure). Part 1 prints steps/s of the bare environment (rgb+depth rendered,
with segmentation, rendering skipped). Part 2 runs each agent over the same episodes in both modes in one run,
interleaved episode by episode (in-process then sealed, then the next episode the other way round), so machine load
hits both alike; it prints episodes per minute of the episode phase for each mode and the sealed cost (1 - sealed /
in-process), then the one-off costs: the agent process's start and the first visit (prior="scene" agents), each mode.
Figures from a shared, loaded machine vary run to run: compare the two modes of one run, not runs.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # tests/support: the fixture scenes (not installed)


def env_steps(bundle, steps: int) -> None:
    """Print environment steps per second at 640x480 and 128x128."""
    import numpy as np

    from sdovon_mj import suite

    for (w, h) in ((640, 480), (128, 128)):
        for label, semantic, render in (("rgb+depth", False, True), ("rgb+depth+seg", True, True), ("no render", False, False)):
            env = suite.make_environment(bundle, semantic=semantic, width=w, height=h, max_steps=10 ** 9)
            env.task.render_frames = render
            rng = np.random.default_rng(0)
            env.reset()
            for _ in range(5):
                env.step(int(rng.integers(1, 6)))
            t0 = time.perf_counter()
            for _ in range(steps):
                env.step(int(rng.integers(1, 6)))
            dt = time.perf_counter() - t0
            print(f"{w}x{h} {label:14s} {steps / dt:8.1f} steps/s")
            env.task.close()


def modes(dataset, name: str, episodes: int, width: int, height: int) -> dict:
    """Run one agent over the same episodes in-process and sealed, interleaved per episode; return the timings."""
    from dataclasses import replace

    from sdovon_mj.config import AgentConfig, NavConfig
    from sdovon_mj.suite import find_bundles, load_bundle
    from sdovon_mj.suite.boundary import oracle_scene_parts
    from sdovon_mj.suite.evaluation.exploration import run_first_visits
    from sdovon_mj.suite.evaluation.loop import dataset_root, run_episode
    from sdovon_mj.suite.evaluation.phases import open_session
    from sdovon_mj.suite.evaluation.runner import agent_spec
    from sdovon_mj.suite.objectnav import make_environment
    from sdovon_mj.suite.observation import ObservationBuilder, dataset_vocabulary, make_sensors
    from sdovon_mj.suite.protocol import SceneStart

    body = replace(AgentConfig(), sensor_width=width, sensor_height=height)
    nav = NavConfig()
    bundles = [load_bundle(p) for p in find_bundles(dataset)]
    vocab = dataset_vocabulary(dataset_root(bundles), bundles)
    plan = [(b, i) for b in bundles for i in range(len(b.episodes))][:episodes]
    spec = agent_spec(name, nav, 0, agent=body)
    out = {m: {"episodes": 0, "seconds": 0.0, "start": 0.0, "visit": 0.0, "success": 0.0} for m in ("in-process", "sealed")}
    sessions, envs = {}, {}
    try:
        for m in out:
            t0 = time.perf_counter()
            sessions[m] = s = open_session(spec, m, width, height)
            s.setup(make_sensors(body, nav, vocab, s.knowledge))
            out[m]["start"] = time.perf_counter() - t0
        know = sessions["sealed"].knowledge
        scene = None
        for k, (b, i) in enumerate(plan):
            order = list(out) if k % 2 == 0 else list(out)[::-1]
            if b.episodes[i].scene != scene:
                scene = b.episodes[i].scene
                visits = {}
                for m in order:
                    sessions[m].scene(SceneStart(str(scene), oracle_scene_parts(b, know)))
                    if know.prior == "scene":
                        t0 = time.perf_counter()
                        floors = {int(bb.episodes[j].floor) for bb, j in plan if bb.episodes[j].scene == scene}
                        visits[m] = run_first_visits(sessions[m], b, floors, know, nav, body, vocab, 0)
                        out[m]["visit"] += time.perf_counter() - t0
            if b.name not in envs:
                for e, _bd in envs.values():
                    e.task.close()
                envs.clear()
                envs[b.name] = (make_environment(b, nav=nav, agent=body, semantic=know.detector == "gt"),
                                ObservationBuilder(know, vocab, b.detector_labels()))
            env, builder = envs[b.name]
            for m in order:
                t0 = time.perf_counter()
                r = run_episode(sessions[m], env, builder, b, i, know, name, "bench", visits.get(m))
                out[m]["seconds"] += time.perf_counter() - t0
                out[m]["episodes"] += 1
                out[m]["success"] += r["success"]
    finally:
        for e, _bd in envs.values():
            e.task.close()
        for s in sessions.values():
            s.close()
    out["seal"] = sessions["sealed"].seal.describe()
    return out


def main() -> None:
    """Run the benchmark and print figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default=None, help="MJCF dataset (default: the fixture apartment)")
    ap.add_argument("--bundle", default=None, help="variant folder for part 1 (default: the dataset's first)")
    ap.add_argument("--episodes", type=int, default=12, help="episodes per agent and mode")
    ap.add_argument("--agents", nargs="*", default=["random-astar", "semantic-astar", "semantic-frontier", "oracle"])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--steps", type=int, default=200, help="steps per configuration in part 1")
    ap.add_argument("--threads", type=int, default=2, help="CPU threads for Mesa llvmpipe (LP_NUM_THREADS)")
    ap.add_argument("--no-env", action="store_true", help="skip part 1")
    args = ap.parse_args()
    os.environ.setdefault("LP_NUM_THREADS", str(args.threads))
    from sdovon_mj.suite import find_bundles
    from support.bundles import fixture_bundle

    dataset = args.dataset or fixture_bundle()
    bundle = args.bundle or find_bundles(dataset)[0]
    print(f"dataset: {dataset}  MUJOCO_GL={os.environ.get('MUJOCO_GL')}  LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS')}  "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    if not args.no_env:
        env_steps(bundle, args.steps)
    print(f"\nEpisodes per minute at {args.width}x{args.height}, in-process vs sealed, the same episodes interleaved:\n")
    print("| Agent | Episodes | In-process (episodes/min) | Sealed (episodes/min) | Sealed cost | SR in / sealed | "
          "Agent start in / sealed (s) | First visits in / sealed (s) |")
    print("|---|---|---|---|---|---|---|---|")
    seal = ""
    for name in args.agents:
        t = modes(dataset, name, args.episodes, args.width, args.height)
        seal = t.pop("seal")
        a, b = t["in-process"], t["sealed"]
        rate = {m: 60.0 * x["episodes"] / x["seconds"] if x["seconds"] > 0 else float("nan") for m, x in t.items()}
        cost = 1.0 - rate["sealed"] / rate["in-process"]
        print(f"| {name} | {a['episodes']} | {rate['in-process']:.1f} | {rate['sealed']:.1f} | {100 * cost:+.1f} % | "
              f"{a['success'] / max(a['episodes'], 1):.3f} / {b['success'] / max(b['episodes'], 1):.3f} | "
              f"{a['start']:.1f} / {b['start']:.1f} | {a['visit']:.1f} / {b['visit']:.1f} |", flush=True)
    print(f"\nSealed: {seal}. Load average now {os.getloadavg()[0]:.1f}.")


if __name__ == "__main__":
    main()
