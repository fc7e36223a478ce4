"""`sdovon-mj eval DATASET --agent ...`: run agents over MJCF bundles (`suite.evaluation.runner.run_rows`), write
per-episode JSON, trajectory pictures, ``tables.md`` and ``summary.json``, print the tables.

The tables print how each agent ran (sealed or in-process, file system sealed or not, on an open or a secret split),
its set-up time and failures, the episodes' difficulty and, for agents with a scene prior, the first visit's budget.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

from ..config import AgentConfig, NavConfig
from ..errors import InputError
from ..gl import RENDERS
from ..store import atomic_write_text, json_safe
from ..suite.evaluation.pictures import trajectory_picture
from ..suite.evaluation.results import picture_path
from ..suite.evaluation.runner import Row, agent_spec, run_rows
from ..suite.evaluation.tables import ran_as, tables_markdown
from ..suite.protocol import REPLY_TIMEOUT, SETUP_TIMEOUT


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the eval options."""
    parser.add_argument("dataset", help="MJCF bundle dataset folder (variant folders with episodes.json)")
    parser.add_argument("--agent", action="append", default=None,
                        help="random-astar | semantic-astar | semantic-frontier | oracle | random | <plugin> | "
                             "module:Class (repeatable; default both A* agents)")
    parser.add_argument("--episodes", type=int, default=None, help="evaluate at most N episodes")
    parser.add_argument("--no-fn", action="store_true", help="A* agents without final point-goal navigation")
    parser.add_argument("--fn-ablation", action="store_true", help="run A* agents with and without FN (paper table 5)")
    parser.add_argument("--fn-mode", choices=("paper", "retry", "lattice"), default=None,
                        help="FN variant: paper (Navigate(p_g|eps_nav), then STOP; default), retry (ours: STOP where "
                             "the object is in view within the view radius, trying other places) or lattice")
    parser.add_argument("--width", type=int, default=None, help="camera width (default AgentConfig.sensor_width: 640)")
    parser.add_argument("--height", type=int, default=None, help="camera height (default AgentConfig.sensor_height: 480)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pictures", type=int, default=5, help="trajectory pictures per agent")
    parser.add_argument("--video", type=int, default=0, metavar="N",
                        help="MP4s of the first N episodes per agent: its camera beside the top-down map with the path "
                             "so far (OUT/videos/<agent>/<episode id>.mp4)")
    parser.add_argument("--in-process", action="store_true",
                        help="run the agents in this process (debugging; every table says so) instead of sealed")
    parser.add_argument("--agent-read", action="append", default=[], metavar="PATH",
                        help="a file or folder a sealed agent may read (its weights; repeatable; not inside the dataset)")
    parser.add_argument("--agent-timeout", type=float, default=REPLY_TIMEOUT, metavar="S",
                        help=f"seconds a sealed agent has for each reply (default {REPLY_TIMEOUT:g}); then the episode "
                             "is recorded as its timeout")
    parser.add_argument("--agent-setup-timeout", type=float, default=SETUP_TIMEOUT, metavar="S",
                        help=f"seconds a sealed agent has to start and answer setup (default {SETUP_TIMEOUT:g})")
    parser.add_argument("--jobs", type=int, default=1,
                        help="processes evaluating (one row on one scene at a time; on a GPU they share it)")
    parser.add_argument("--render", choices=RENDERS, default="auto",
                        help="renderer of the agents' observations: auto (the GPU's EGL when there is one, else the "
                             "CPU's llvmpipe; default), cpu or gpu (an error without one); every table row says which")
    parser.add_argument("--out", required=True, help="output folder (a rerun resumes: finished episodes are kept)")


def run(args: argparse.Namespace) -> int:
    """Evaluate the agents and print the tables."""
    out = Path(args.out)
    if not Path(args.dataset).is_dir():
        raise InputError(args.dataset, "dataset folder not found")
    nav = NavConfig() if args.fn_mode is None else replace(NavConfig(), fn_mode=args.fn_mode)
    upd = {k: v for k, v in (("sensor_width", args.width), ("sensor_height", args.height)) if v}
    body = replace(AgentConfig(), **upd)
    mode = "in-process" if getattr(args, "in_process", False) else "sealed"
    names = args.agent or ["random-astar", "semantic-astar"]
    rows: list[Row] = []
    for n in names:
        astar = n in ("random-astar", "semantic-astar", "semantic-frontier")
        variants = [(n, True), (f"{n} no-FN", False)] if astar and args.fn_ablation else \
            [(f"{n} no-FN" if (astar and args.no_fn) else n, not args.no_fn)]
        rows += [Row(label, agent_spec(n, nav, args.seed, final_nav=fn, agent=body), mode) for label, fn in variants]
    if int(getattr(args, "video", 0) or 0) < 0:
        raise InputError("--video", "the number of videos must be >= 0")
    for flag in ("agent_timeout", "agent_setup_timeout"):
        if not float(getattr(args, flag, 1.0)) > 0:
            raise InputError("--" + flag.replace("_", "-"), "a limit must be > 0 seconds")
    per_agent = run_rows(args.dataset, rows, out, jobs=int(getattr(args, "jobs", 1) or 1), episodes=args.episodes,
                         seed=args.seed, nav=nav, body=body, read=tuple(getattr(args, "agent_read", []) or ()),
                         video=int(getattr(args, "video", 0) or 0),
                         timeout=float(getattr(args, "agent_timeout", REPLY_TIMEOUT)),
                         setup_timeout=float(getattr(args, "agent_setup_timeout", SETUP_TIMEOUT)),
                         render=getattr(args, "render", "auto"))
    for label, res in per_agent.items():
        for r in res[: max(0, args.pictures)]:
            trajectory_picture(args.dataset, r, picture_path(out, label, r["episode_id"]))
    md, summaries = tables_markdown(per_agent)
    for label, sm in summaries.items():
        shot = [r["video"] for r in per_agent[label] if r.get("video")]
        if shot:
            sm["videos"] = shot
        print(f"{label}: {sm['episodes']} episodes, {sm.get('episodes_per_minute', float('nan')):.1f} episodes/min "
              f"(per process, episodes only); {ran_as(sm)}" + (f"; videos: {', '.join(shot)}" if shot else ""))
    from .. import native

    # which form the built-in agents' inner loops ran in (the same actions either way; the speed differs)
    print(f"agent kernels: {native.status()}")
    atomic_write_text(out / "tables.md", md)
    atomic_write_text(out / "summary.json", json.dumps(json_safe(summaries), indent=1, sort_keys=True) + "\n")
    print(md)
    return 0
