"""Speed of the ObjectNav suite: environment steps per second, and evaluated episodes per minute per agent in-process
against the sealed protocol (issue 30: the agent in its own process, frames through shared memory).

    python bench/bench_suite.py [--dataset DIR] [--episodes 12] [--agents random-astar semantic-astar ...]
                                [--width 640 --height 480] [--steps 200] [--threads 2] [--no-env]
                                [--split VARIANT ... --split-sizes 320x240 640x480 --split-steps 200]
                                [--record FILE [--against FILE]]

Without --dataset the built-in fixture apartment is used (a default-world export, e.g. the demo's
``out/demo/export/mjcf``, is the closer figure). Part 1 prints steps/s of the bare environment (rgb+depth rendered,
with segmentation, rendering skipped). Part 2 runs each agent over the same episodes in both modes in one run,
interleaved episode by episode (in-process then sealed, then the next episode the other way round), so machine load
hits both alike; it prints episodes per minute of the episode phase for each mode and the sealed cost (1 - sealed /
in-process), then the one-off costs: the agent process's start and the first visit (prior="scene" agents), each mode.
Figures from a shared, loaded machine vary run to run: compare the two modes of one run, not runs.

The step split (issue 47) prints, per variant, image size and mode, the rendered step's wall milliseconds in render,
physics, observation building and protocol (`step_split`). ``--record`` runs the agents in-process only and records
their trajectories and CPU seconds; ``--against`` an older code version's record prints both side by side and counts
identical trajectories (`record_cpu`).
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


def _timed(obj, attr: str, acc: dict, key: str) -> None:
    """Replace ``obj.attr`` (a bound method) by a wrapper adding its wall seconds to ``acc[key]``.

    The phases are timed from outside (the instance's attribute is wrapped here, the library has no timing hook), so
    the code measured is the code evaluations run.
    """
    fn = getattr(obj, attr)

    def wrapped(*a, **k):
        t0 = time.perf_counter()
        try:
            return fn(*a, **k)
        finally:
            acc[key] += time.perf_counter() - t0

    setattr(obj, attr, wrapped)


def step_split(bundle, mode: str, width: int, height: int, steps: int) -> dict:
    """Run the random agent's moves for `steps` steps on one variant, every frame rendered; return seconds per phase.

    Phases (wall seconds, summed over the steps): ``render`` (the task's render: rgb, depth, segmentation, the
    segment lookup), ``physics`` (``env.step`` less the task's observation: the action, kinematics, the collision
    checks, metrics), ``observation`` (the task's observation dict less the render, and the evaluator's
    `ObservationBuilder`: the agent's keys, the category image), ``protocol`` (the session's step: frames to the agent
    and its reply; for ``sealed`` through shared memory to its own process). The random agent thinks for microseconds,
    so ``protocol`` is the boundary's own cost. Every step is rendered whatever the agent asks (the A* agents ask for
    most frames), so the figure is the rendered step's.
    """
    from dataclasses import replace

    from sdovon_mj.config import AgentConfig, NavConfig
    from sdovon_mj.suite import load_bundle
    from sdovon_mj.suite.evaluation.phases import open_session
    from sdovon_mj.suite.evaluation.runner import agent_spec
    from sdovon_mj.suite.objectnav import make_environment
    from sdovon_mj.suite.observation import ObservationBuilder, Vocabulary, make_sensors, rendered_images
    from sdovon_mj.suite.protocol import Phase

    b = load_bundle(bundle)
    body = replace(AgentConfig(), sensor_width=width, sensor_height=height)
    nav = replace(NavConfig(), max_steps=10 ** 9)
    vocab = Vocabulary.of_bundles([b])
    session = open_session(agent_spec("random", nav, 0, agent=body), mode, width, height)
    env = make_environment(b, nav=nav, agent=body, **rendered_images(session.knowledge))
    try:
        session.setup(make_sensors(body, nav, vocab, session.knowledge))
        builder = ObservationBuilder(session.knowledge, vocab, b.detector_labels())
        acc = dict.fromkeys(("render", "task_obs", "step", "observation", "protocol"), 0.0)
        _timed(env.task, "render", acc, "render")
        _timed(env.task, "get_observation", acc, "task_obs")
        _timed(env, "step", acc, "step")
        _timed(session, "step", acc, "protocol")
        env.task.set_next_episode(0)
        env.task.render_frames = True
        obs = builder(env.reset().observation, True)
        reply = session.begin(Phase("episode", "bench", "bench", 0, nav.max_steps), obs, True)
        for _ in range(5):  # warm-up: first frames, caches
            reply = session.step(builder(env.step(reply.action).observation, True), True)
        acc.update(dict.fromkeys(acc, 0.0))
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(steps):
            ts = env.step(reply.action)
            t1 = time.perf_counter()
            obs = builder(ts.observation, True)
            acc["observation"] += time.perf_counter() - t1
            reply = session.step(obs, True)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        session.end(obs, True)
    finally:
        env.task.close()
        session.close()
    return {"steps": steps, "wall": wall, "cpu": cpu, "render": acc["render"], "physics": acc["step"] - acc["task_obs"],
            "observation": acc["observation"] + acc["task_obs"] - acc["render"], "protocol": acc["protocol"]}


def print_step_split(bundles: list, sizes: list[tuple[int, int]], steps: int) -> None:
    """Print the environment step split into render, physics, observation and protocol, per variant, size and mode."""
    print(f"\nEnvironment step split ({steps} steps each, every frame rendered, random moves; ms per step, wall; "
          "phases timed from outside by wrapping the instance's methods):\n")
    print("| Variant | Size | Mode | Steps/s | Render (ms) | Physics (ms) | Observation (ms) | Protocol (ms) | "
          "Evaluator CPU (ms) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for bundle in bundles:
        for (w, h) in sizes:
            for mode in ("in-process", "sealed"):
                t = step_split(bundle, mode, w, h, steps)
                ms = {k: 1000.0 * t[k] / t["steps"] for k in ("render", "physics", "observation", "protocol", "cpu")}
                print(f"| {Path(bundle).parent.name}/{Path(bundle).name} | {w}x{h} | {mode} | {t['steps'] / t['wall']:.1f} | {ms['render']:.2f} | "
                      f"{ms['physics']:.2f} | {ms['observation']:.2f} | {ms['protocol']:.2f} | {ms['cpu']:.2f} |",
                      flush=True)


def modes(dataset, name: str, episodes: int, width: int, height: int,
          which: tuple[str, ...] = ("in-process", "sealed")) -> dict:
    """Run one agent over the same episodes in the modes `which` (interleaved per episode); return the timings.

    Each mode's entry also holds ``cpu_visit`` / ``cpu_episodes`` (this process's CPU seconds: the agent's own only
    in-process) and ``trajectories`` (per episode id: the XY path and the steps, what `--record` stores).
    """
    from dataclasses import replace

    from sdovon_mj.config import AgentConfig, NavConfig
    from sdovon_mj.suite import find_bundles, load_bundle
    from sdovon_mj.suite.boundary import oracle_scene_parts
    from sdovon_mj.suite.evaluation.exploration import run_first_visits
    from sdovon_mj.suite.evaluation.loop import dataset_root, run_episode
    from sdovon_mj.suite.evaluation.phases import LiveAgent, open_session
    from sdovon_mj.suite.evaluation.runner import agent_spec
    from sdovon_mj.suite.objectnav import make_environment
    from sdovon_mj.suite.observation import ObservationBuilder, dataset_vocabulary, make_sensors, rendered_images
    from sdovon_mj.suite.protocol import SceneStart

    body = replace(AgentConfig(), sensor_width=width, sensor_height=height)
    nav = NavConfig()
    bundles = [load_bundle(p) for p in find_bundles(dataset)]
    vocab = dataset_vocabulary(dataset_root(bundles), bundles)
    plan = [(b, i) for b in bundles for i in range(len(b.episodes))][:episodes]
    spec = agent_spec(name, nav, 0, agent=body)
    out = {m: {"episodes": 0, "seconds": 0.0, "start": 0.0, "visit": 0.0, "success": 0.0, "cpu_visit": 0.0,
               "cpu_episodes": 0.0, "trajectories": {}} for m in which}
    sessions, envs = {}, {}
    try:
        for m in out:
            t0 = time.perf_counter()
            sessions[m] = s = open_session(spec, m, width, height)
            s.setup(make_sensors(body, nav, vocab, s.knowledge))
            out[m]["start"] = time.perf_counter() - t0
        lives = {m: LiveAgent(None, None, sessions[m]) for m in out}
        know = sessions[which[0]].knowledge
        scene = None
        for k, (b, i) in enumerate(plan):
            order = list(out) if k % 2 == 0 else list(out)[::-1]
            if b.episodes[i].scene != scene:
                scene = b.episodes[i].scene
                visits = {}
                start = SceneStart(str(scene), oracle_scene_parts(b, know))
                for m in order:
                    lives[m].get(start)
                    if know.prior == "scene":
                        t0, c0 = time.perf_counter(), time.process_time()
                        floors = {int(bb.episodes[j].floor) for bb, j in plan if bb.episodes[j].scene == scene}
                        visits[m] = run_first_visits(lives[m], b, floors, know, nav, body, vocab, 0, start)
                        out[m]["visit"] += time.perf_counter() - t0
                        out[m]["cpu_visit"] += time.process_time() - c0
            if b.name not in envs:
                for e, _bd in envs.values():
                    e.task.close()
                envs.clear()
                envs[b.name] = (make_environment(b, nav=nav, agent=body, **rendered_images(know)),
                                ObservationBuilder(know, vocab, b.detector_labels()))
            env, builder = envs[b.name]
            for m in order:
                t0, c0 = time.perf_counter(), time.process_time()
                r = run_episode(lives[m], start, env, builder, b, i, name, "bench", visits.get(m))
                out[m]["seconds"] += time.perf_counter() - t0
                out[m]["cpu_episodes"] += time.process_time() - c0
                out[m]["trajectories"][r["episode_id"]] = {"steps": r["steps"], "success": r["success"],
                                                          "trajectory": r["trajectory"]}
                out[m]["episodes"] += 1
                out[m]["success"] += r["success"]
    finally:
        for e, _bd in envs.values():
            e.task.close()
        for s in sessions.values():
            s.close()
    out["seal"] = sessions[which[-1]].seal.describe()
    return out


def record_cpu(dataset, args) -> None:
    """Run each agent in-process on the episodes; print and record its CPU per episode and first visit; compare.

    The side-by-side check of two code versions: run this once with the old code on the path (e.g. ``PYTHONPATH`` at
    a clone of the old commit) writing one record, then with the new one ``--against`` it, on the same machine in
    one session. The trajectories (XY per step and step counts) must be identical; CPU seconds (this process's, the
    agent's included in-process) are less sensitive to the machine's load than wall seconds.
    """
    import json

    import sdovon_mj

    from sdovon_mj import native

    rec = {"code": str(Path(sdovon_mj.__file__).resolve().parents[1]), "kernels": native.status(), "agents": {}}
    old = json.loads(Path(args.against).read_text()) if args.against else None
    print(f"\nCPU seconds in-process at {args.width}x{args.height} (this code: {rec['code']}):\n")
    print("| Agent | Episodes | Episodes/min (CPU) | First visit CPU (s) | Before: episodes/min (CPU) | "
          "Before: first visit CPU (s) | Identical trajectories |")
    print("|---|---|---|---|---|---|---|")
    for name in args.agents:
        t = modes(dataset, name, args.episodes, args.width, args.height, which=("in-process",))["in-process"]
        rec["agents"][name] = r = {k: t[k] for k in ("episodes", "cpu_visit", "cpu_episodes", "trajectories")}
        rate = 60.0 * r["episodes"] / max(r["cpu_episodes"], 1e-9)
        line = f"| {name} | {r['episodes']} | {rate:.1f} | {r['cpu_visit']:.1f} |"
        o = (old or {}).get("agents", {}).get(name)
        if o is None:
            line += " - | - | - |"
        else:
            same = sum(o["trajectories"].get(k) == v for k, v in r["trajectories"].items())
            line += (f" {60.0 * o['episodes'] / max(o['cpu_episodes'], 1e-9):.1f} | {o['cpu_visit']:.1f} | "
                     f"{same} / {len(r['trajectories'])} |")
        print(line, flush=True)
    Path(args.record).write_text(json.dumps(rec) + "\n")
    print(f"\nRecorded to {args.record}. Load average now {os.getloadavg()[0]:.1f}.")


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
    ap.add_argument("--split", nargs="*", default=None, metavar="VARIANT",
                    help="variant folders for the step split (default: the part 1 variant; none given: skip it)")
    ap.add_argument("--split-sizes", nargs="*", default=["320x240", "640x480"], help="image sizes of the step split")
    ap.add_argument("--split-steps", type=int, default=200, help="steps per variant, size and mode in the step split")
    ap.add_argument("--record", default=None, metavar="FILE",
                    help="agents in-process only: write each agent's trajectories and CPU seconds to FILE (JSON)")
    ap.add_argument("--against", default=None, metavar="FILE",
                    help="with --record: compare with a record another code version wrote (same episodes): identical "
                         "trajectories, CPU figures side by side")
    args = ap.parse_args()
    os.environ.setdefault("LP_NUM_THREADS", str(args.threads))
    from sdovon_mj.suite import find_bundles
    from support.bundles import fixture_bundle

    dataset = args.dataset or fixture_bundle()
    bundle = args.bundle or find_bundles(dataset)[0]
    print(f"dataset: {dataset}  MUJOCO_GL={os.environ.get('MUJOCO_GL')}  LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS')}  "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    from sdovon_mj import native

    print(f"agent kernels: {native.status()}")
    if not args.no_env:
        env_steps(bundle, args.steps)
    if args.split is None or args.split:
        sizes = [tuple(int(v) for v in x.lower().split("x")) for x in args.split_sizes]
        print_step_split(args.split or [bundle], sizes, args.split_steps)
    if not args.agents:
        return
    if args.record:
        record_cpu(dataset, args)
        return
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
