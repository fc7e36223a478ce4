"""Renderer speed on this machine: environment steps/s and our agents' episodes/min, drawn by the CPU (Mesa llvmpipe)
and by the GPU (its EGL), each in a fresh process (a process keeps the renderer it made first: `sdovon_mj.gl`).

    python bench/bench_device.py [--dataset DIR] [--agents random-astar semantic-astar] [--episodes 6]
                                 [--width 640 --height 480] [--steps 100] [--jobs 1 4]

Without --dataset the built-in fixture apartment is used (a default-world export such as the demo's
``out/demo/export/mjcf`` is the closer figure). Per renderer it prints one line naming the GL renderer, then
environment steps/s (rgb + depth + segmentation rendered, random moves) and, per agent and per --jobs value,
episodes/min: the agents run sealed as `sdovon-mj eval` runs them, ``--jobs N`` is N processes whose environments
share the renderer (the GPU) at once, and the figure is the run's episodes over its wall time (start-up included).
A machine without a GPU prints ``gpu: skipped`` and why (no GPU EGL device); one without Mesa's EGL likewise skips
the CPU part.

On a GPU machine lent through the device tool (NVIDIA EGL, no Mesa, our wheels absent): download the project's
wheels here for its Python (``pip download --only-binary=:all: --python-version 3.12 ...`` of the packages in
pyproject.toml), carry them and this checkout, and start the command there with
``pip install --no-index --no-deps --target /tmp/site .whl/*.whl && export PYTHONPATH=/tmp/site:$PWD``; glvnd
must see NVIDIA's vendor file (``export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/
10_nvidia.json`` where the container keeps it there) and ``MUJOCO_GL=egl``. For the CPU part, carry Mesa's EGL
packages too (libegl-mesa0, libgl1-mesa-dri, libglapi-mesa, unpacked with ``dpkg -x``), else it is skipped. Label
the figures with the machine (``nvidia-smi -L``, CPU model, cores) where you publish them.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # tests/support: the fixture scenes (not installed)


def env_steps_per_second(bundle: Path, width: int, height: int, steps: int) -> float:
    """Return environment steps per second with rgb + depth + segmentation rendered (random moves, seed 0)."""
    import numpy as np

    from sdovon_mj import suite

    env = suite.make_environment(bundle, semantic=True, width=width, height=height, max_steps=10 ** 9)
    try:
        env.task.render_frames = True
        rng = np.random.default_rng(0)
        env.reset()
        for _ in range(3):  # the first renders build the context and upload meshes: not counted
            env.step(int(rng.integers(1, 6)))
        t0 = time.perf_counter()
        for _ in range(steps):
            env.step(int(rng.integers(1, 6)))
        return steps / (time.perf_counter() - t0)
    finally:
        env.task.close()


def episodes_per_minute(dataset: Path, agent: str, episodes: int, width: int, height: int, jobs: int,
                        max_steps: int | None = None) -> dict:
    """Evaluate `agent` sealed over the first `episodes` episodes on `jobs` processes; return episodes/min (wall).

    Parameters
    ----------
    dataset : Path
        MJCF dataset folder.
    agent : str
        Agent plugin name.
    episodes : int
        Episodes evaluated.
    width, height : int
        Camera image size, pixels.
    jobs : int
        Evaluation processes.
    max_steps : int, optional
        Episode step limit (default NavConfig's).
    """
    from dataclasses import replace

    from sdovon_mj.config import AgentConfig, NavConfig
    from sdovon_mj.suite.evaluation.runner import Row, agent_spec, run_rows

    body = replace(AgentConfig(), sensor_width=width, sensor_height=height)
    nav = NavConfig() if max_steps is None else replace(NavConfig(), max_steps=int(max_steps))
    row = Row(agent, agent_spec(agent, nav, 0, agent=body), "sealed")
    t0 = time.perf_counter()
    res = run_rows(dataset, [row], None, jobs=jobs, episodes=episodes, nav=nav, body=body, progress=False)[agent]
    dt = time.perf_counter() - t0
    return {"agent": agent, "jobs": jobs, "episodes": len(res), "seconds": round(dt, 2),
            "episodes_per_minute": round(60.0 * len(res) / dt, 2) if dt > 0 else float("nan"),
            "success": round(sum(float(r["success"]) for r in res) / max(len(res), 1), 3)}


def child(args: argparse.Namespace) -> int:
    """Measure one renderer in this (fresh) process; print one JSON line per figure."""
    from sdovon_mj.errors import RendererError
    from sdovon_mj import gl
    from sdovon_mj.suite import find_bundles
    from support.bundles import fixture_bundle

    try:
        rec = gl.use(args.child)
    except RendererError as e:
        print(json.dumps({"skipped": str(e)}), flush=True)
        return 0
    print(json.dumps({"renderer": rec}), flush=True)
    dataset = Path(args.dataset) if args.dataset else fixture_bundle()
    bundle = find_bundles(dataset)[0]
    sps = env_steps_per_second(bundle, args.width, args.height, args.steps)
    print(json.dumps({"env_steps_per_second": round(sps, 1)}), flush=True)
    for agent in args.agents:
        for jobs in args.jobs:
            print(json.dumps(episodes_per_minute(dataset, agent, args.episodes, args.width, args.height, jobs,
                                                 args.max_steps)), flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark: the CPU, then the GPU, each in a fresh process; print the figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default=None, help="MJCF dataset (default: the fixture apartment)")
    ap.add_argument("--agents", nargs="*", default=["random-astar", "semantic-astar"])
    ap.add_argument("--episodes", type=int, default=6, help="episodes per agent and --jobs value")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--steps", type=int, default=100, help="environment steps timed")
    ap.add_argument("--jobs", type=int, nargs="*", default=[1], help="evaluation processes (one run per value)")
    ap.add_argument("--max-steps", type=int, default=None, help="episode step limit (default: NavConfig's 500)")
    ap.add_argument("--renders", nargs="*", default=["cpu", "gpu"], choices=("cpu", "gpu"))
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        return child(args)
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}; {args.width}x{args.height}, "
          f"{args.episodes} episodes per agent and jobs value", flush=True)
    env = {k: v for k, v in os.environ.items() if k != "SDOVON_RENDER"}
    for render in args.renders:
        cmd = [sys.executable, str(Path(__file__).resolve()), *(argv if argv is not None else sys.argv[1:]),
               "--child", render]
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
        lines = [json.loads(ln) for ln in proc.stdout.splitlines() if ln.startswith("{")]
        if proc.returncode != 0:
            print(f"{render}: failed (exit {proc.returncode}): {proc.stderr.strip().splitlines()[-1:]}")
            continue
        for d in lines:
            if "skipped" in d:
                print(f"{render}: skipped: {d['skipped']}")
            elif "renderer" in d:
                r = d["renderer"]
                print(f"{render}: {r['renderer']} ({r['vendor']}; {r['version']})")
            elif "env_steps_per_second" in d:
                print(f"{render}: environment {d['env_steps_per_second']:.1f} steps/s (rgb+depth+segmentation)")
            else:
                print(f"{render}: {d['agent']} --jobs {d['jobs']}: {d['episodes_per_minute']:.1f} episodes/min "
                      f"({d['episodes']} episodes in {d['seconds']:.1f} s, SR {d['success']:.3f})")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
