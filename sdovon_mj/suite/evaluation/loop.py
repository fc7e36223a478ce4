"""The evaluation loop: an agent over a dataset's episodes, scene by scene (its first visit where it has a scene
prior, then the episodes of each variant), one result dict per episode, written at once and read back on a rerun.

Agents are plugins (`plugins.load("agent", name)`: built-ins random-astar, semantic-astar, semantic-frontier, oracle,
random; others from the ``sdovon_mj.agents`` entry points), built as ``factory(nav=NavConfig, agent=AgentConfig,
seed=int)``, by default in their own sealed process (`protocol.SealedSession`): the evaluator never imports an agent
named by an `AgentSpec`. Each episode's result records the mode it ran in and whether the agent's file system was
sealed.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from ...config import AgentConfig, NavConfig
from ...progress import Progress
from ...gl import use as use_renderer
from ...store import atomic_write_text, json_safe
from ..boundary import oracle_episode_parts, oracle_scene_parts
from ..bundle import Bundle, find_bundles, load_bundle
from ..objectnav import make_environment
from ..observation import ObservationBuilder, dataset_vocabulary, make_sensors
from ..protocol import AgentSpec, Phase, SceneStart
from ..video import EpisodeVideo
from .exploration import run_first_visits
from .outcomes import episode_outcome
from .phases import open_session, run_phase
from .results import exploration_path, load_done, result_path, run_key, video_path


def dataset_root(bundles: list[Bundle]) -> Path | None:
    """Return the folder all bundles sit in (the dataset, with its index.json), or None."""
    parents = {b.root.resolve().parent for b in bundles}
    return parents.pop() if len(parents) == 1 else None


def evaluate(dataset: str | Path | list[Path | Bundle], agent: Any, nav: NavConfig | None = None, episodes: int | None = None,
             out: Path | None = None, label: str | None = None, progress: bool = True, mode: str = "sealed",
             seed: int = 0, body: AgentConfig | None = None, seal: bool = True, read: tuple[str, ...] = (),
             videos: tuple[str, ...] = (), render: str = "auto") -> list[dict]:
    """Run an agent over a dataset's episodes through the agent protocol; return (and optionally write) one result
    dict per episode. A run with ``out`` resumes: episodes whose result of the same run is there are not run again
    (unless their video is asked for and missing: then they run again).

    Parameters
    ----------
    dataset
        MJCF bundle dataset folder (variant folders with episodes.json), one variant folder, or a list of variant
        folders (a subset of a dataset, e.g. `select_bundles`) or loaded `Bundle`s.
    agent
        An `AgentSpec` (plugin name or ``module:Class`` and its arguments: built only in the agent's process) or an
        agent object (pickled into it; its class's code has run in this process already).
    nav
        Actions, step limit and success radius of the environments (default: the agent's ``nav``).
    episodes
        Evaluate at most this many episodes (default: all).
    out
        Folder for ``episodes/<label>/<episode id>.json`` and ``exploration/<label>/<scene>.json`` (None: nothing).
    label
        Name of this run in results and folders (default: the agent's name).
    progress
        Show a progress bar.
    mode
        ``sealed`` (default: the agent in its own process, file system sealed where Landlock is available) or
        ``in-process`` (debugging; labelled in every table).
    seed
        Seed of the first visits' start poses.
    body
        The agent's body and camera in the environments (default: the agent's ``agent_config`` / ``agent``).
    seal
        Seal the agent process's file system (sealed mode; False only for debugging, and tables say so).
    read
        More paths the sealed agent may read (its weights or data).
    videos
        Episode ids to record as MP4 (`suite.video`: the agent's view beside the top-down map) in
        ``out/videos/<label>/<episode id>.mp4``; each result names its file (``video``, relative to `out`).
    render
        Which renderer draws the observations (`gl.use`): ``auto`` (default: the GPU's EGL when there is one, else
        Mesa's llvmpipe), ``cpu`` or ``gpu`` (`RendererError` without one). Each result records what drew
        (``render``: cpu or gpu, ``renderer``: the GL string) and, for ``auto`` on the CPU, ``render_fallback``.
    """
    drawn = drawn_by(render)  # before any work: `gpu` without a GPU stops here
    kw = agent.kwargs if isinstance(agent, AgentSpec) else {}
    nav = nav or getattr(agent, "nav", None) or kw.get("nav") or NavConfig()
    body = body or getattr(agent, "agent_config", None) or kw.get("agent") or AgentConfig()
    paths = find_bundles(dataset) if isinstance(dataset, (str, Path)) else list(dataset)
    bundles = [p if isinstance(p, Bundle) else load_bundle(p) for p in paths]
    root = dataset_root(bundles)
    vocab = dataset_vocabulary(root, bundles)
    total = sum(len(b.episodes) for b in bundles)
    limit = total if episodes is None else min(int(episodes), total)
    plan: list[tuple[Bundle, int]] = [(b, i) for b in bundles for i in range(len(b.episodes))][:limit]
    scenes: dict[str, list[tuple[Bundle, int]]] = {}
    for b, i in plan:
        scenes.setdefault(str(b.episodes[i].scene), []).append((b, i))
    label = label or (agent.name if isinstance(agent, AgentSpec) else str(getattr(agent, "name", type(agent).__name__)))
    key = run_key(label, agent, nav, body, mode, seed)
    out = Path(out) if out is not None else None
    videos = set(videos)
    if videos and out is None:
        raise ValueError("videos are written into the results folder: give out")
    protect = tuple(sorted({b.root.resolve() for b in bundles} | ({root} if root else set()) | ({out.resolve()} if out else set())))
    results: list[dict] = []
    session = None
    try:
        with Progress(limit, f"eval {label}", enabled=progress) as bar:
            for scene, items in scenes.items():
                done = {(b.name, i): load_done(out, label, key, b.episodes[i].episode_id) for b, i in items}
                for b, i in items:  # a video asked for and missing: the episode runs again to record it
                    eid = b.episodes[i].episode_id
                    if eid in videos and not (out / video_path(label, eid)).is_file():
                        done[(b.name, i)] = None
                if all(done.values()):
                    results += [done[(b.name, i)] for b, i in items]
                    bar.update(len(items), scene)
                    continue
                if session is None:
                    session = open_session(agent, mode, body.sensor_width, body.sensor_height, seal, tuple(read), protect)
                    know = session.knowledge
                    session.setup(make_sensors(body, nav, vocab, know))
                first = items[0][0]
                session.scene(SceneStart(scene, oracle_scene_parts(first, know)))
                visit = None
                if know.prior == "scene":
                    floors = {int(b.episodes[i].floor) for b, i in items}
                    visit = run_first_visits(session, first, floors, know, nav, body, vocab, seed)
                    if out is not None:
                        atomic_write_text(exploration_path(out, label, scene),
                                          json.dumps(json_safe(visit), sort_keys=True) + "\n")
                by_bundle: dict[str, list[tuple[Bundle, int]]] = {}
                for b, i in items:
                    by_bundle.setdefault(b.name, []).append((b, i))
                for group in by_bundle.values():
                    b = group[0][0]
                    env = make_environment(b, nav=nav, agent=body, semantic=know.detector == "gt")
                    builder = ObservationBuilder(know, vocab, b.detector_labels())
                    try:
                        for _b, i in group:
                            if done[(b.name, i)]:
                                results.append(done[(b.name, i)])
                                bar.update(1, b.episodes[i].episode_id)
                                continue
                            eid = b.episodes[i].episode_id
                            r = run_episode(session, env, builder, b, i, know, label, key, visit,
                                         (out, video_path(label, eid)) if eid in videos else None) | drawn
                            results.append(r)
                            if out is not None:
                                atomic_write_text(result_path(out, label, r["episode_id"]),
                                                  json.dumps(json_safe(r), sort_keys=True) + "\n")
                            bar.update(1, r["episode_id"])
                    finally:
                        env.task.close()
    finally:
        if session is not None:
            session.close()
    return results


def drawn_by(render: str) -> dict[str, str]:
    """Choose this process's renderer (`gl.use`) and return what each result records of it."""
    rec = use_renderer(render)
    return {"render": rec["render"], "renderer": rec["renderer"],
            **({"render_fallback": rec["fallback"]} if rec.get("fallback") else {})}


def run_episode(session: Any, env: Any, builder: ObservationBuilder, b: Bundle, i: int, know: Any, label: str, key: str,
                visit: dict | None, video: tuple[Path, str] | None = None) -> dict:
    """Run episode `i` of bundle `b`; return its result dict.

    Parameters
    ----------
    session
        The agent's session (`phases.open_session`), its scene started.
    env
        The environment of bundle `b` (`objectnav.make_environment`).
    builder : ObservationBuilder
        Builds the agent's observations within its knowledge.
    b : Bundle
        The variant the episode belongs to.
    i : int
        The episode's index in ``b.episodes``.
    know
        The agent's `Knowledge`.
    label : str
        The row's name, written into the result.
    key : str
        The run key (`results.run_key`), written into the result.
    visit : dict or None
        The scene's first visit (`exploration.run_first_visits`), summarized into the result.
    video : (Path, str), optional
        The results folder and the MP4's path relative to it: the episode is recorded there.
    """
    t0 = time.perf_counter()
    ep = b.episodes[i]
    env.task.set_next_episode(i)
    phase = Phase("episode", str(ep.scene), ep.episode_id, i, int(env.task.nav.max_steps), oracle_episode_parts(ep, know))
    start: dict = {}
    recorder = EpisodeVideo(video[0] / video[1], b.navmap(ep.floor), ep, label=label) if video else None
    try:
        info = run_phase(session, env, builder, phase, start, recorder)
    except BaseException:
        if recorder is not None:
            recorder.abort()
        raise
    if recorder is not None:
        recorder.close()
    task = env.task
    in_view, visible = start["in_view"], start["visible"]
    m = task.metrics()
    r = {"agent": label, "knowledge": know.describe(), "oracle": know.is_oracle, "mode": session.mode,
         "seal": session.seal.describe(), "sealed": bool(session.seal.sealed), "run_key": key,
         "episode_id": ep.episode_id, "variant": b.name, "scene": ep.scene, "category": ep.object_category,
         **m.to_dict(), "collisions": task.collisions, "inside": any(g.open_part for g in ep.goals),
         "must_open": bool(ep.goals) and all(g.open_part for g in ep.goals),
         "part_moves": [list(t) for t in task.part_moves], "start_geodesic": float(task.shortest),
         "goal_in_view": bool(in_view), "goal_visible_from_start": bool(visible),
         "first_visit": None if visit is None else {k: visit[k] for k in ("steps", "metres", "budget", "seconds")}
         | ({"floors": len(visit["floors"])} if "floors" in visit else {}),
         "info": info, "seconds": round(time.perf_counter() - t0, 3),
         "trajectory": np.round(np.array(task.trajectory)[:, :2], 4).tolist()}
    if video:
        r["video"] = video[1]
    r["outcome"] = episode_outcome(r, ep, know.pose)
    return r
