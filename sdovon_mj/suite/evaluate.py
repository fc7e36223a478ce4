"""The evaluation loop and `sdovon-mj eval DATASET --agent ...`: run agents over MJCF bundles through the agent
protocol, write per-episode JSON, print tables.

Agents are plugins (`plugins.load("agent", name)`: built-ins random-astar, semantic-astar, semantic-frontier, oracle,
random; others from the ``sdovon_mj.agents`` entry points), built as ``factory(nav=NavConfig, agent=AgentConfig,
seed=int)``, by default in their own sealed process (`protocol.SealedSession`): the evaluator never imports an agent
named by an `AgentSpec`. Each episode's result records the mode it ran in and whether the agent's file system was
sealed; the tables print both, the episodes' difficulty and, for agents with a scene prior, the first visit's budget.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import pickle
import time
import zlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import metrics as M
from .. import plugins
from ..config import AgentConfig, NavConfig, to_dict
from ..errors import InputError
from ..geometry import quat_yaw
from ..progress import Progress
from ..store import atomic_write_bytes, atomic_write_text, json_safe
from .boundary import oracle_episode_parts, oracle_scene_parts, scene_frame_point
from .bundle import Bundle, find_bundles, load_bundle
from .objectnav import make_environment
from .observation import ObservationBuilder, Vocabulary, dataset_vocabulary, make_sensors
from .protocol import MODES, AgentSpec, InProcessSession, Phase, SceneStart, SealedSession
from .video import EpisodeVideo

PAPER = {  # SD-OVON tables 4 and 5 (ground-truth detector), for the closing comparison
    "random-astar": {"success": 0.7503, "spl": 0.3494, "soft_spl": 0.3931, "distance_to_goal": 1.5437},
    "random-astar no-FN": {"success": 0.3041, "spl": 0.1471, "soft_spl": 0.3748, "distance_to_goal": 2.1105},
    "semantic-astar": {"success": 0.8081, "spl": 0.4270, "soft_spl": 0.4700, "distance_to_goal": 1.0989},
    "semantic-astar no-FN": {"success": 0.3752, "spl": 0.2111, "soft_spl": 0.4742, "distance_to_goal": 1.5230},
}


# Why an episode ended as it did (`episode_outcome`), in table order.
OUTCOMES = ("success", "step limit", "not found", "other instance", "missed stop")
OUTCOME_HELP = {
    "success": "STOP within the success distance of a goal's view point",
    "step limit": "the step limit ended the episode (no STOP)",
    "not found": "STOP without having detected the goal category (the agent's search was exhausted)",
    "other instance": "STOP at an object of the goal category that is no goal (nowhere within the view radius sees it)",
    "missed stop": "STOP near a detected goal object, not within the success distance of its view points",
}
# A detected object's reconstructed centre (the median of its depth points, `nav.goal.object_centre`) lies on the
# object's surface, so within its box up to the depth pixels at its rim; 0.3 m leaves room for those and for a
# partly occluded object while staying below the spacing of two receptacles (an object on another piece).
OTHER_INSTANCE_M = 0.3
INTERVALS = "95 % intervals: cluster bootstrap (scenes, then variants within them, then episodes)"


def episode_outcome(result: dict, episode: Any, pose: str = "absolute") -> str:
    """Return why an episode ended as it did: one of `OUTCOMES` (evaluation only: it reads the episode's goals).

    ``result`` holds the suite's metrics (``success``, ``stop_called``) and the agent's ``info``: ``detected``
    (whether it saw the goal category) and ``goal`` (the reconstructed centre it drove to, XYZ in the agent's
    frame), as the built-in agents report them. ``pose`` is the agent's pose sensor (`Knowledge.pose`): with
    ``gps+compass`` the centre is in the episode's start frame and is taken back to the scene frame here.
    Agents that report neither end as "missed stop" when they STOP elsewhere.
    """
    if result.get("success"):
        return "success"
    if not result.get("stop_called"):
        return "step limit"
    info = result.get("info") or {}
    if info.get("detected") is False:
        return "not found"
    centre, goals = info.get("goal"), list(getattr(episode, "goals", []) or [])
    try:
        c = np.asarray(centre, float)[:3] if centre is not None else None
    except (TypeError, ValueError):  # an agent's info is its own: a malformed centre counts as none
        c = None
    if c is not None and c.shape == (3,) and np.isfinite(c).all() and goals:
        if pose != "absolute":  # start frame (x forward, y left at the start pose) -> scene frame
            c = scene_frame_point(c, episode.start_position, quat_yaw(episode.start_rotation))
        d = []
        for g in goals:
            lo, hi = (np.asarray(g.bounds, float) if g.bounds is not None else np.stack([g.position, g.position]))
            d.append(float(np.linalg.norm(np.maximum(np.maximum(lo - c, c - hi), 0.0))))
        if min(d) > OTHER_INSTANCE_M:
            return "other instance"
    return "missed stop"


def make_agent(name: str, nav: NavConfig, seed: int = 0, final_nav: bool = True, agent: AgentConfig | None = None) -> Any:
    """Return the agent plugin `name` built here (the plugin's code runs in this process: for a sealed evaluation
    name it with `agent_spec`).

    Parameters
    ----------
    name : str
        The plugin's name.
    nav : NavConfig
        Actions, FN and step limit (``final_nav`` sets ``nav.final_nav``).
    seed : int
        The agent's seed.
    final_nav : bool
        Final point-goal navigation after a detection.
    agent : AgentConfig, optional
        Its body and camera (default `AgentConfig()`).
    """
    factory = plugins.load("agent", name)
    return factory(nav=replace(nav, final_nav=bool(final_nav)), agent=agent or AgentConfig(), seed=seed)


def agent_spec(name: str, nav: NavConfig, seed: int = 0, final_nav: bool = True, agent: AgentConfig | None = None,
               **kwargs: Any) -> AgentSpec:
    """Return the `AgentSpec` of plugin `name` (or ``module:Class``) with the plugin factory's arguments.

    Parameters
    ----------
    name : str
        The plugin's name or ``module:Class``.
    nav, seed, final_nav, agent : as in `make_agent`
    **kwargs
        More keyword arguments of the agent's class (``explore_steps``, ``per_metre``, ``semantics``, ...).
    """
    return AgentSpec(name, {"nav": replace(nav, final_nav=bool(final_nav)), "agent": agent or AgentConfig(),
                            "seed": int(seed), **kwargs})


def exploration_start(bundle: Bundle, seed: int = 0, floor: int | None = None) -> tuple[np.ndarray, float]:
    """Return the evaluator's start pose of a scene's first visit of `floor` (default: the floor of the bundle's first
    episode): a navigable cell of the largest connected part of the floor and a heading on the 30-degree lattice,
    seeded by (seed, scene) on that first floor and by (seed, scene, floor) on the others."""
    from scipy import ndimage

    ep = bundle.episodes[0]
    floor = int(ep.floor) if floor is None else int(floor)
    nm = bundle.navmap(floor)
    lab, n = ndimage.label(nm.navigable, structure=np.ones((3, 3), bool))
    if n == 0:
        raise InputError(bundle.root, "the navigable map is empty: no first visit can start")
    big = 1 + int(np.argmax(np.bincount(lab.ravel())[1:]))
    cells = np.argwhere(lab == big)
    key = [int(seed), zlib.crc32(str(ep.scene).encode("utf-8"))] + ([] if floor == int(ep.floor) else [floor])
    rng = np.random.default_rng(key)
    xy = nm.frame.to_world(cells[int(rng.integers(len(cells)))][None])[0]
    return np.array([xy[0], xy[1], float(nm.height)]), float(rng.integers(12) * 30.0 - 180.0)


def _dataset_root(bundles: list[Bundle]) -> Path | None:
    """Return the folder all bundles sit in (the dataset, with its index.json), or None."""
    parents = {b.root.resolve().parent for b in bundles}
    return parents.pop() if len(parents) == 1 else None


def _run_key(label: str, agent: Any, nav: NavConfig, body: AgentConfig, mode: str, seed: int) -> str:
    """Return the digest that marks one run's per-episode results (a resumed run reuses only its own)."""
    who = [agent.target, sorted((k, repr(v)) for k, v in agent.kwargs.items())] if isinstance(agent, AgentSpec) \
        else [type(agent).__module__, type(agent).__qualname__, hashlib.sha256(pickle.dumps(agent)).hexdigest()]
    from .. import __version__

    blob = json.dumps([label, who, to_dict(nav), to_dict(body), mode, int(seed), __version__], sort_keys=True, default=str)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()[:16]


def _result_path(out: Path, label: str, episode_id: str) -> Path:
    return out / "episodes" / label.replace(" ", "_") / f"{episode_id}.json"


def _load_done(out: Path | None, label: str, key: str, episode_id: str) -> dict | None:
    """Return a finished episode's result of this run (same run key), or None."""
    if out is None:
        return None
    p = _result_path(out, label, episode_id)
    try:
        r = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None
    return r if isinstance(r, dict) and r.get("run_key") == key else None


def open_session(agent: Any, mode: str, width: int, height: int, seal: bool = True, read: tuple[str, ...] = (),
                 protect: tuple[Path, ...] = ()) -> Any:
    """Return a protocol session with the agent: ``sealed`` (its own process) or ``in-process``.

    Parameters
    ----------
    agent : AgentSpec or agent object
        The agent to run.
    mode : str
        ``sealed`` or ``in-process``.
    width, height : int
        The camera's image size, pixels (the frame buffer's layout).
    seal : bool
        Seal the agent process's file system (sealed mode).
    read : tuple of str
        More paths a sealed agent may read.
    protect : tuple of Path
        Folders no path the agent may read may contain (the dataset, the results).
    """
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r} ({' or '.join(MODES)})")
    if mode == "in-process":
        return InProcessSession(agent)
    return SealedSession(agent, width, height, seal=seal, read=read, protect=protect)


def _record(video: EpisodeVideo | None, env: Any, obs: dict, rendered: bool) -> None:
    """Add the frame of this step to an episode's video: the view the agent got, or (it asked for no frame and got a
    blank one) the view rendered here for the video alone; the pose from the evaluator's physics."""
    if video is not None:
        rgb = obs["rgb"] if rendered else env.task.render(env.physics, segmentation=False)[0]
        video.add(rgb, env.task.state.position, env.task.state.yaw)


def _phase(session: Any, env: Any, builder: ObservationBuilder, phase: Phase, at_reset: dict | None = None,
           video: EpisodeVideo | None = None) -> dict:
    """Run one phase (a first visit or an episode) from the environment's reset to its end; return the agent's info.

    With ``at_reset``, the episode's difficulty is measured after the reset, before the agent acts (`start_visibility`);
    with ``video``, a frame is recorded after the reset and after every step (steps + 1), here in the evaluator.
    """
    env.task.render_frames = True  # every phase's first observation is rendered
    ts = env.reset()
    if at_reset is not None:
        at_reset["in_view"], at_reset["visible"] = env.task.start_visibility(env.physics)
    obs = builder(ts.observation, True)
    _record(video, env, obs, True)
    reply = session.begin(phase, obs, True)
    while True:
        env.task.render_frames = reply.frame
        ts = env.step(reply.action)
        obs = builder(ts.observation, reply.frame)
        _record(video, env, obs, reply.frame)
        if ts.last():
            return session.end(obs, reply.frame)
        reply = session.step(obs, reply.frame)


def first_visit_floors(bundle: Bundle, floors: set[int]) -> list[int]:
    """Return the floors a scene's first visits cover, in visit order: that of the bundle's first episode, then the
    other floors with episodes to run, ascending (a robot carried to each floor; episodes stay on one floor)."""
    first = int(bundle.episodes[0].floor)
    return [first] + sorted(int(f) for f in floors if int(f) != first)


def _explore(session: Any, bundle: Bundle, know: Any, nav: NavConfig, body: AgentConfig, vocab: Vocabulary,
             seed: int, floor: int | None = None) -> dict:
    """Run a scene's first visit of one floor (the exploration phase; default: the floor of the bundle's first
    episode): the evaluator's seeded start, no goal, the declared budget; return what it took (steps, metres,
    seconds, whether the agent stopped, its info)."""
    t0 = time.perf_counter()
    env = make_environment(bundle, nav=replace(nav, max_steps=int(know.explore_steps)), agent=body,
                           semantic=know.detector == "gt")
    floor = int(bundle.episodes[0].floor) if floor is None else int(floor)
    try:
        start, yaw = exploration_start(bundle, seed, floor)
        env.task.set_exploration(start, yaw, floor)
        builder = ObservationBuilder(know, vocab, bundle.detector_labels())
        scene = str(bundle.episodes[0].scene)
        info = _phase(session, env, builder, Phase("explore", scene, "", -1, int(know.explore_steps)))
        task = env.task
        return {"scene": scene, "variant": bundle.name, "floor": floor,
                "start": [round(float(v), 4) for v in start], "yaw": yaw,
                "budget": int(know.explore_steps), "steps": int(task.steps),
                "metres": round(M.path_length(np.array(task.trajectory)), 3), "stopped": bool(task.stop_called),
                "seconds": round(time.perf_counter() - t0, 2), "info": info}
    finally:
        env.task.close()


def evaluate(dataset: str | Path | list[Path | Bundle], agent: Any, nav: NavConfig | None = None, episodes: int | None = None,
             out: Path | None = None, label: str | None = None, progress: bool = True, mode: str = "sealed",
             seed: int = 0, body: AgentConfig | None = None, seal: bool = True, read: tuple[str, ...] = (),
             videos: tuple[str, ...] = ()) -> list[dict]:
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
    """
    kw = agent.kwargs if isinstance(agent, AgentSpec) else {}
    nav = nav or getattr(agent, "nav", None) or kw.get("nav") or NavConfig()
    body = body or getattr(agent, "agent_config", None) or kw.get("agent") or AgentConfig()
    paths = find_bundles(dataset) if isinstance(dataset, (str, Path)) else list(dataset)
    bundles = [p if isinstance(p, Bundle) else load_bundle(p) for p in paths]
    root = _dataset_root(bundles)
    vocab = dataset_vocabulary(root, bundles)
    total = sum(len(b.episodes) for b in bundles)
    limit = total if episodes is None else min(int(episodes), total)
    plan: list[tuple[Bundle, int]] = [(b, i) for b in bundles for i in range(len(b.episodes))][:limit]
    scenes: dict[str, list[tuple[Bundle, int]]] = {}
    for b, i in plan:
        scenes.setdefault(str(b.episodes[i].scene), []).append((b, i))
    label = label or (agent.name if isinstance(agent, AgentSpec) else str(getattr(agent, "name", type(agent).__name__)))
    key = _run_key(label, agent, nav, body, mode, seed)
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
                done = {(b.name, i): _load_done(out, label, key, b.episodes[i].episode_id) for b, i in items}
                for b, i in items:  # a video asked for and missing: the episode runs again to record it
                    eid = b.episodes[i].episode_id
                    if eid in videos and not (out / _video_path(label, eid)).is_file():
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
                        atomic_write_text(out / "exploration" / label.replace(" ", "_") / f"{scene}.json",
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
                            r = _episode(session, env, builder, b, i, know, label, key, visit,
                                         (out, _video_path(label, eid)) if eid in videos else None)
                            results.append(r)
                            if out is not None:
                                atomic_write_text(_result_path(out, label, r["episode_id"]),
                                                  json.dumps(json_safe(r), sort_keys=True) + "\n")
                            bar.update(1, r["episode_id"])
                    finally:
                        env.task.close()
    finally:
        if session is not None:
            session.close()
    return results


def run_first_visits(session: Any, bundle: Bundle, floors: set[int], know: Any, nav: NavConfig,
                     body: AgentConfig, vocab: Vocabulary, seed: int) -> dict:
    """Run a scene's first visits, one per floor with episodes to run (`first_visit_floors`, each floor's budget its
    own), and return the scene's visit (`scene_visit`).

    Parameters
    ----------
    session
        The agent's session (`open_session`), its scene started.
    bundle : Bundle
        The scene's first variant (its environment hosts the visits).
    floors : set of int
        The floors of the scene's episodes to run.
    know, nav, body, vocab, seed
        The agent's knowledge, actions, body, the dataset's vocabulary and the evaluation seed (as `evaluate`).
    """
    return scene_visit([_explore(session, bundle, know, nav, body, vocab, seed, f)
                        for f in first_visit_floors(bundle, floors)])


def scene_visit(visits: list[dict]) -> dict:
    """Return a scene's first visit from those of its floors: steps, metres and seconds summed, the budget per
    floor; one floor's visit is returned as it is (its record unchanged)."""
    if len(visits) == 1:
        return visits[0]
    return {"scene": visits[0]["scene"], "variant": visits[0]["variant"], "budget": int(visits[0]["budget"]),
            "steps": int(sum(v["steps"] for v in visits)), "metres": round(sum(v["metres"] for v in visits), 3),
            "seconds": round(sum(v["seconds"] for v in visits), 2), "stopped": all(v["stopped"] for v in visits),
            "floors": visits}


def _video_path(label: str, episode_id: str) -> str:
    """Return an episode's video file, relative to the results folder (it names the agent and the episode)."""
    return f"videos/{label.replace(' ', '_')}/{episode_id}.mp4"


def _episode(session: Any, env: Any, builder: ObservationBuilder, b: Bundle, i: int, know: Any, label: str, key: str,
             visit: dict | None, video: tuple[Path, str] | None = None) -> dict:
    """Run episode `i` of bundle `b`; return its result dict. With ``video`` (results folder, relative MP4 path) the
    episode is recorded there."""
    t0 = time.perf_counter()
    ep = b.episodes[i]
    env.task.set_next_episode(i)
    phase = Phase("episode", str(ep.scene), ep.episode_id, i, int(env.task.nav.max_steps), oracle_episode_parts(ep, know))
    start: dict = {}
    recorder = EpisodeVideo(video[0] / video[1], b.navmap(ep.floor), ep, label=label) if video else None
    try:
        info = _phase(session, env, builder, phase, start, recorder)
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


def select_bundles(dataset: str | Path, per_scene: int) -> list[Bundle]:
    """Return the first `per_scene` variants of every scene of a dataset, loaded (scenes and variant folders sorted).

    A balanced subset for evaluating on many scenes at once (`evaluate` takes the list, and every run over it reuses
    the loaded bundles): the first N episodes of a dataset all come from its first scene.
    """
    by_scene: dict[str, list[Bundle]] = {}
    for p in find_bundles(dataset):
        b = load_bundle(p)
        kept = by_scene.setdefault(str(b.episodes[0].scene) if b.episodes else p.name, [])
        if len(kept) < per_scene:
            kept.append(b)
    return [b for scene in sorted(by_scene) for b in by_scene[scene]]


def summarize(results: list[dict], bootstrap: int = 1000, seed: int = 0) -> dict[str, Any]:
    """Return SR, SPL, Soft SPL and mean DTG over result dicts, with 95 % cluster-bootstrap intervals, the episodes'
    difficulty and, for agents with a first visit, its budget and use.

    The intervals resample scenes, then variants within them, then episodes (`metrics.cluster_bootstrap`,
    ``bootstrap`` resamples, percentile method; results without ``scene``/``variant`` count as clusters of one);
    ``<m>_ci`` holds (low, high) for each metric. Non-finite distances to goal are left out of the DTG mean.
    ``difficulty`` (`difficulty`) and ``first_visit`` (`first_visit`) describe the episodes and the exploration;
    ``mode`` and ``seal`` how the agent ran. When some episodes are "inside" ones (a goal hidden in a closed
    articulated part, ``Goal.open_part``), ``inside`` holds the same summary over those episodes alone (without it
    when there are none), ``must_open`` over the episodes whose every goal is hidden.
    """
    out = _summary(results, bootstrap, seed)
    for key in ("inside", "must_open"):
        sub = [r for r in results if r.get(key)]
        if sub:
            out[key] = _summary(sub, bootstrap, seed)
    return out


def _clusters(results: list[dict]) -> tuple[list[str], list[str]]:
    """Return each result's scene and variant (an episode of its own where they are not recorded)."""
    sc = [str(r.get("scene", r.get("episode_id", i))) for i, r in enumerate(results)]
    va = [str(r.get("variant", r.get("episode_id", i))) for i, r in enumerate(results)]
    return sc, va


def _summary(results: list[dict], bootstrap: int, seed: int) -> dict[str, Any]:
    """Return the metric means and cluster-bootstrap intervals of `summarize` over result dicts."""
    ms = [M.EpisodeMetrics(r["success"], r["spl"], r["soft_spl"], _num(r["distance_to_goal"]), _num(r["shortest"]),
                           r["path_length"]) for r in results]
    out: dict[str, Any] = dict(M.aggregate(ms))
    keys = ("success", "spl", "soft_spl", "distance_to_goal")
    if results and bootstrap > 0:
        x = np.array([[_num(r[k]) for k in keys] for r in results], float)
        means = M.cluster_bootstrap(x, *_clusters(results), resamples=bootstrap, seed=seed)
        for j, k in enumerate(keys):
            lo, hi = M.percentile_interval(means[:, j])
            out[f"{k}_ci"] = (round(lo, 4), round(hi, 4))
    if results:
        out["knowledge"] = results[0].get("knowledge", "")
        out["mode"] = results[0].get("mode", "")
        out["seal"] = results[0].get("seal", "")
        if all("outcome" in r for r in results):
            out["outcomes"] = {k: round(sum(r["outcome"] == k for r in results) / len(results), 4) for k in OUTCOMES}
        out["difficulty"] = difficulty(results)
        visit = first_visit(results)
        if visit:
            out["first_visit"] = visit
        secs = [r["seconds"] for r in results if isinstance(r.get("seconds"), (int, float))]
        if secs:
            out["episodes_per_minute"] = round(episodes_per_minute(results, float(sum(secs))), 2)
    return out


def _num(x: Any) -> float:
    """Return a JSON number as float (None, as written for non-finite values, is inf)."""
    return math.inf if x is None else float(x)


def difficulty(results: list[dict]) -> dict[str, Any]:
    """Return how hard the episodes are: quartiles of the start-to-goal geodesic (m), the share whose goal is in view
    at the start pose and the share visible from the start point turning in place (the episodes' own visibility
    definition, measured by the evaluator at each reset)."""
    geo = np.array([_num(r.get("start_geodesic", r.get("shortest"))) for r in results], float)
    geo = geo[np.isfinite(geo)]
    q = [round(float(v), 2) for v in np.percentile(geo, [25, 50, 75])] if len(geo) else [math.nan] * 3
    seen = [r for r in results if "goal_in_view" in r]
    return {"episodes": len(results), "geodesic_quartiles": q,
            "in_view": round(float(np.mean([r["goal_in_view"] for r in seen])), 4) if seen else None,
            "visible_from_start": round(float(np.mean([r["goal_visible_from_start"] for r in seen])), 4) if seen else None}


def first_visit(results: list[dict]) -> dict[str, Any] | None:
    """Return the first visits behind results (one per scene): their count, budget per floor, mean floors, steps,
    metres and seconds per scene."""
    visits = {str(r.get("scene")): r["first_visit"] for r in results if r.get("first_visit")}
    if not visits:
        return None
    v = list(visits.values())
    return {"scenes": len(v), "budget": int(max(x["budget"] for x in v)),
            "floors": round(float(np.mean([x.get("floors", 1) for x in v])), 2),
            "steps": round(float(np.mean([x["steps"] for x in v])), 1),
            "metres": round(float(np.mean([x["metres"] for x in v])), 1),
            "seconds": round(float(np.mean([x.get("seconds", math.nan) for x in v])), 1)}


def paired_difference(a: list[dict], b: list[dict], key: str = "success", bootstrap: int = 2000,
                      seed: int = 0) -> dict[str, Any]:
    """Return the mean per-episode difference a - b of a metric over the episodes both agents ran, with a 95 % interval.

    The agents ran the same episodes, so the comparison is paired: the cluster bootstrap (scenes, variants,
    episodes; `metrics.cluster_bootstrap`) resamples episode differences, each carrying both agents' results, which
    removes the episode-to-episode spread the two unpaired intervals of `summarize` both hold. Returns
    ``{"diff", "ci": (low, high), "episodes"}``; an interval that excludes 0 orders the two agents on these episodes.

    Parameters
    ----------
    a, b : list of dict
        Two rows' per-episode results (``episode_id``, ``scene``, ``variant`` and the metric).
    key : str
        The metric.
    bootstrap : int
        Resamples.
    seed : int
        Seed of the resampling.
    """
    bx = {r["episode_id"]: float(r[key]) for r in b}
    pairs = [(float(r[key]) - bx[r["episode_id"]], r) for r in a if r["episode_id"] in bx]
    if not pairs:
        return {"diff": float("nan"), "ci": (float("nan"), float("nan")), "episodes": 0}
    d = np.array([x for x, _r in pairs])
    means = M.cluster_bootstrap(d, *_clusters([r for _x, r in pairs]), resamples=bootstrap, seed=seed)
    lo, hi = M.percentile_interval(means)
    return {"diff": round(float(d.mean()), 4), "ci": (round(lo, 4), round(hi, 4)), "episodes": len(d)}


def paired_table(per_episode: dict[str, list[dict]], pairs: list[tuple[str, str]]) -> str:
    """Return the markdown table of paired differences (SR, SPL) for agent pairs present in ``per_episode``."""
    shown = [(x, y) for x, y in pairs if x in per_episode and y in per_episode]
    if not shown:
        return ""
    lines = ["| A - B | Episodes | SR difference [95% CI] | SPL difference [95% CI] |", "|---|---|---|---|"]
    for x, y in shown:
        sr, spl = (paired_difference(per_episode[x], per_episode[y], k) for k in ("success", "spl"))
        lines.append(f"| {x} - {y} | {sr['episodes']} | {sr['diff']:+.3f} [{sr['ci'][0]:+.3f}, {sr['ci'][1]:+.3f}] | "
                     f"{spl['diff']:+.3f} [{spl['ci'][0]:+.3f}, {spl['ci'][1]:+.3f}] |")
    return "\n".join(lines)


def episodes_per_minute(results: list[dict], seconds: float) -> float:
    """Return evaluation speed: episodes per wall minute."""
    return 60.0 * len(results) / seconds if seconds > 0 else float("nan")


def _cell(s: dict, k: str) -> str:
    ci = s.get(f"{k}_ci")
    return f"{s[k]:.3f} [{ci[0]:.3f}, {ci[1]:.3f}]" if ci else f"{s[k]:.3f}"


def inside_table(rows: dict[str, dict[str, Any]]) -> str:
    """Return the markdown table of "inside" episodes per agent ('' when none).

    Rows: a goal hidden in a closed part (``inside``) and every goal hidden (``must_open``: no success without OPEN).
    """
    shown = [(n, k, s[k]) for n, s in rows.items() for k in ("inside", "must_open") if s.get(k)]
    if not shown:
        return ""
    lines = ["| Agent | Episodes | Count | Success Rate [95% CI] | SPL [95% CI] | Soft SPL [95% CI] | Dist2Goal (m) |",
             "|---|---|---|---|---|---|---|"]
    for name, key, s in shown:
        what = "a goal hidden" if key == "inside" else "every goal hidden"
        lines.append(f"| {name} | {what} | {s['episodes']} | {_cell(s, 'success')} | {_cell(s, 'spl')} | "
                     f"{_cell(s, 'soft_spl')} | {s['distance_to_goal']:.3f} |")
    return "\n".join(lines)


def outcome_table(rows: dict[str, dict[str, Any]]) -> str:
    """Return the markdown table of why episodes ended (shares of `OUTCOMES` per agent; '' when none recorded)."""
    shown = {n: s["outcomes"] for n, s in rows.items() if s.get("outcomes")}
    if not shown:
        return ""
    lines = ["| Agent | Episodes | " + " | ".join(OUTCOMES) + " |", "|---" * (len(OUTCOMES) + 2) + "|"]
    for name, o in shown.items():
        lines.append(f"| {name} | {rows[name]['episodes']} | " + " | ".join(f"{o.get(k, 0.0):.3f}" for k in OUTCOMES) + " |")
    lines += ["", "; ".join(f"{k}: {OUTCOME_HELP[k]}" for k in OUTCOMES) + "."]
    return "\n".join(lines)


def _mode(s: dict[str, Any]) -> str:
    """Return how an agent ran, for the tables: sealed (file system sealed or not) or in-process."""
    mode = s.get("mode", "")
    if mode == "sealed":
        return "sealed" + ("" if "NOT" not in s.get("seal", "") else ", file system not sealed")
    return mode or "-"


def overall_table(rows: dict[str, dict[str, Any]], paper: bool = True) -> str:
    """Return the overall markdown table: each agent's knowledge, how it ran, metrics with 95 % intervals, and below
    it the episodes' difficulty, the first visits' budget and use, and the file-system seal of each sealed row.

    With ``paper``, the paper's GT-detector rows follow under their own heading: its scenes (HM3D/MP3D scans),
    objects and detector differ from ours, so its numbers are context, not a comparison.
    """
    lines = ["| Agent | Knowledge | Ran | Episodes | Success Rate [95% CI] | SPL [95% CI] | Soft SPL [95% CI] | Dist2Goal (m) |",
             "|---|---|---|---|---|---|---|---|"]
    for name, s in rows.items():
        lines.append(f"| {name} | {s.get('knowledge', '')} | {_mode(s)} | {s['episodes']} | {_cell(s, 'success')} | "
                     f"{_cell(s, 'spl')} | {_cell(s, 'soft_spl')} | {s['distance_to_goal']:.3f} |")
    lines += ["", INTERVALS + "."]
    diff = difficulty_table(rows)
    if diff:
        lines += ["", diff]
    visits = first_visit_table(rows)
    if visits:
        lines += ["", visits]
    seals = sorted({s.get("seal", "") for s in rows.values() if s.get("mode") == "sealed"} - {""})
    if seals:
        lines += ["", "Sealed rows: " + "; ".join(seals) + "."]
    shown = [n for n in rows if paper and n in PAPER]
    if shown:
        lines += ["", "Paper (SD-OVON-3k, tables 4-5, GT detector): other scenes (HM3D/MP3D scans), other objects, the",
                  "paper's own agents and FN; context only, not comparable with the rows above.", "",
                  "| Baseline | Episodes | Success Rate | SPL | Soft SPL | Dist2Goal |", "|---|---|---|---|---|---|"]
        for name in shown:
            pp = PAPER[name]
            lines.append(f"| paper: {name} GT | 3k | {pp['success']:.4f} | {pp['spl']:.4f} | {pp['soft_spl']:.4f} | "
                         f"{pp['distance_to_goal']:.4f} |")
    return "\n".join(lines)


def _share(x: Any) -> str:
    return "-" if x is None else f"{100.0 * float(x):.1f} %"


def difficulty_table(rows: dict[str, dict[str, Any]]) -> str:
    """Return the difficulty of each distinct set of episodes the rows ran ('' when none is recorded)."""
    groups: dict[str, list[str]] = {}
    for name, s in rows.items():
        d = s.get("difficulty")
        if d:
            groups.setdefault(json.dumps(d, sort_keys=True), []).append(name)
    if not groups:
        return ""
    lines = ["| Episodes of | Episodes | Start-to-goal geodesic quartiles (m) | Goal in view at the start pose | "
             "Goal visible from the start point |", "|---|---|---|---|---|"]
    for text, names in groups.items():
        d = json.loads(text)
        q = " / ".join("-" if v is None else f"{float(v):.2f}" for v in d["geodesic_quartiles"])
        lines.append(f"| {', '.join(names) if len(groups) > 1 else 'every row'} | {d['episodes']} | {q} | "
                     f"{_share(d['in_view'])} | {_share(d['visible_from_start'])} |")
    lines += ["", "Difficulty: the evaluator's own measure at each reset (the episodes' visibility definition; "
                  "\"visible from the start point\": at one of 12 headings turning in place)."]
    return "\n".join(lines)


def first_visit_table(rows: dict[str, dict[str, Any]]) -> str:
    """Return the first visits of the rows with a scene prior: budget, mean steps and metres per scene ('' if none)."""
    shown = {n: s["first_visit"] for n, s in rows.items() if s.get("first_visit")}
    if not shown:
        return ""
    lines = ["| First visit of | Scenes | Floors per scene | Budget (steps per floor) | Steps per scene | Metres per scene "
             "| Seconds per scene |", "|---|---|---|---|---|---|---|"]
    for name, v in shown.items():
        lines.append(f"| {name} | {v['scenes']} | {v.get('floors', 1):g} | {v['budget']} | {v['steps']:.0f} | "
                     f"{v['metres']:.1f} | {v['seconds']:.1f} |")
    lines += ["", "First visit: the exploration phase an agent with a scene prior gets before a scene's episodes "
                  "(the evaluator's seeded start on each floor with episodes, no goal, no reward, placed objects "
                  "hidden)."]
    return "\n".join(lines)


def category_table(per_agent: dict[str, list[dict]], k: int = 5, min_successes: int = 2) -> str:
    """Return the top-k categories by success rate (with at least `min_successes` successes) per agent."""
    tops = {}
    for name, res in per_agent.items():
        cats: dict[str, list[float]] = {}
        for r in res:
            cats.setdefault(r["category"], []).append(r["success"])
        ok = [(c, float(np.mean(v))) for c, v in cats.items() if sum(v) >= min_successes]
        tops[name] = sorted(ok, key=lambda t: (-t[1], t[0]))[:k]
    names = list(per_agent)
    lines = ["| Top-k / Cat. (SR) | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for i in range(k):
        cells = [f"{tops[n][i][0]} ({tops[n][i][1]:.4f})" if i < len(tops[n]) else "-" for n in names]
        lines.append(f"| Top-{i + 1} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def trajectory_picture(dataset: str | Path, result: dict, path: Path, scale: int = 4) -> None:
    """Draw an episode's trajectory, start and goal view points on the top-down navigable map (PNG)."""
    import cv2

    match = [p for p in find_bundles(dataset) if p.name == result["variant"]]
    b = load_bundle(match[0] if match else dataset)
    ep = next(e for e in b.episodes if e.episode_id == result["episode_id"])
    nm = b.navmap(ep.floor)
    img = np.full(nm.navigable.shape + (3,), 40, np.uint8)
    img[nm.free] = (150, 150, 150)
    img[nm.navigable] = (220, 220, 220)
    img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)

    def px(xy):
        rc = (np.asarray(xy, float)[:2] - nm.origin) / nm.resolution * scale
        return int(rc[0]), int(rc[1])

    for g in ep.goals:
        for vp in g.view_points:
            cv2.circle(img, px(vp.position), 1, (80, 200, 80), -1)
        cv2.circle(img, px(g.position), 4, (0, 140, 0), -1)
    traj = result["trajectory"]
    for a, c in zip(traj[:-1], traj[1:]):
        cv2.line(img, px(a), px(c), (40, 40, 230), 2)
    cv2.circle(img, px(traj[0]), 5, (230, 120, 20), -1)
    cv2.circle(img, px(traj[-1]), 4, (0, 0, 255) if not result["success"] else (0, 200, 0), 2)
    img = img[::-1].copy()  # north (+Y) up
    cv2.putText(img, f"{result['agent']} {result['category']} S={result['success']:.0f} SPL={result['spl']:.2f}",
                (5, 15), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1)
    ok, buf = cv2.imencode(".png", img)
    atomic_write_bytes(path, buf.tobytes())


@dataclass(frozen=True)
class Row:
    """One row of a results table: its label, the agent (an `AgentSpec`, or an agent object) and how it runs."""

    label: str
    agent: Any
    mode: str = "sealed"


def _row_task(task: tuple) -> list[dict]:
    """Evaluate one row on one scene's bundles (a worker's unit of `run_rows`)."""
    bundles, row, nav, body, out, seed, seal, read, videos = task
    return evaluate(bundles, row.agent, nav=nav, out=out, label=row.label, progress=False, mode=row.mode, seed=seed,
                    body=body, seal=seal, read=read, videos=videos)


def run_rows(dataset: str | Path | list[Path | Bundle], rows: list[Row], out: Path | None = None, jobs: int = 1,
             episodes: int | None = None, seed: int = 0, nav: NavConfig | None = None, body: AgentConfig | None = None,
             seal: bool = True, read: tuple[str, ...] = (), progress: bool = True, video: int = 0) -> dict[str, list[dict]]:
    """Evaluate table rows over the same episodes; return each row's results (episode order).

    The work is cut into tasks of one row on one scene (its first visit, then its episodes), run on `jobs`
    processes (``spawn``) in row-major order; with ``out`` every finished episode is written at once, and running
    the same call again resumes (finished episodes are read back, not run). ``episodes``: the first N episodes of the
    dataset (bundles in order), the same for every row.

    Parameters
    ----------
    dataset
        As `evaluate`'s.
    rows
        The rows (labels unique).
    out
        Results folder (None: nothing written, no resume).
    jobs
        Worker processes (1: this process).
    episodes
        Evaluate at most this many episodes per row.
    seed
        Seed of the first visits' start poses.
    nav, body
        Environment settings (default: each row's agent's).
    seal, read
        As `evaluate`'s.
    progress
        Print one line per finished task.
    video
        Record the first N episodes (in results order) of every row as MP4 (needs ``out``; `evaluate`'s ``videos``).
    """
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    paths = find_bundles(dataset) if isinstance(dataset, (str, Path)) else list(dataset)
    bundles = [p if isinstance(p, Bundle) else load_bundle(p) for p in paths]
    left = sum(len(b.episodes) for b in bundles) if episodes is None else int(episodes)
    kept: list[Bundle] = []
    for b in bundles:
        if left <= 0:
            break
        kept.append(b if len(b.episodes) <= left else replace(b, episodes=b.episodes[:left]))
        left -= len(kept[-1].episodes)
    scenes: dict[str, list[Bundle]] = {}
    for b in kept:
        scenes.setdefault(str(b.episodes[0].scene) if b.episodes else b.name, []).append(b)
    if len({r.label for r in rows}) != len(rows):
        raise ValueError("row labels must be unique")
    videos = tuple([e.episode_id for sc in scenes for b in scenes[sc] for e in b.episodes][:max(int(video), 0)])
    tasks = [(row, sc, (scenes[sc], row, nav, body, out, seed, seal, tuple(read), videos)) for row in rows for sc in scenes]
    got: dict[tuple[str, str], list[dict]] = {}
    t0 = time.perf_counter()
    if jobs <= 1:
        for row, sc, task in tasks:
            got[(row.label, sc)] = _row_task(task)
            if progress:
                print(f"{row.label} / {sc}: {len(got[(row.label, sc)])} episodes ({time.perf_counter() - t0:.0f} s)", flush=True)
    else:
        with ProcessPoolExecutor(max_workers=int(jobs), mp_context=get_context("spawn")) as pool:
            futures = {pool.submit(_row_task, task): (row.label, sc) for row, sc, task in tasks}
            for f, key in futures.items():
                got[key] = f.result()
                if progress:
                    print(f"{key[0]} / {key[1]}: {len(got[key])} episodes ({time.perf_counter() - t0:.0f} s)", flush=True)
    return {row.label: [r for sc in scenes for r in got[(row.label, sc)]] for row in rows}


def tables_markdown(per_agent: dict[str, list[dict]], pairs: list[tuple[str, str]] | None = None, paper: bool = True,
                    categories: bool = True) -> tuple[str, dict[str, dict[str, Any]]]:
    """Return the markdown of every table over rows' results (overall with difficulty and first visits, per category,
    paired differences, how episodes ended, inside articulated receptacles) and the rows' summaries."""
    rows = {label: summarize(res) for label, res in per_agent.items() if res}
    md = "## Overall\n\n" + overall_table(rows, paper) + "\n"
    if categories:
        md += "\n## Per category (top-5, >= 2 successes)\n\n" + category_table(per_agent) + "\n"
    labels = list(rows)
    paired = paired_table(per_agent, pairs if pairs is not None else
                          [(x, y) for i, x in enumerate(labels) for y in labels[i + 1:]])
    if paired:
        md += f"\n## Paired differences (same episodes; {INTERVALS})\n\n" + paired + "\n"
    ended, inside = outcome_table(rows), inside_table(rows)
    if ended:
        md += "\n## How episodes ended\n\n" + ended + "\n"
    if inside:
        md += "\n## Inside articulated receptacles (goal behind a closed door or drawer)\n\n" + inside + "\n"
    return md, rows


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
                        help="a file or folder a sealed agent may read (its weights; repeatable)")
    parser.add_argument("--jobs", type=int, default=1, help="processes evaluating (one row on one scene at a time)")
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
    per_agent = run_rows(args.dataset, rows, out, jobs=int(getattr(args, "jobs", 1) or 1), episodes=args.episodes,
                         seed=args.seed, nav=nav, body=body, read=tuple(getattr(args, "agent_read", []) or ()),
                         video=int(getattr(args, "video", 0) or 0))
    for label, res in per_agent.items():
        for r in res[: max(0, args.pictures)]:
            trajectory_picture(args.dataset, r, out / "pictures" / label.replace(" ", "_") / f"{r['episode_id']}.png")
    md, summaries = tables_markdown(per_agent)
    for label, sm in summaries.items():
        shot = [r["video"] for r in per_agent[label] if r.get("video")]
        if shot:
            sm["videos"] = shot
        print(f"{label}: {sm['episodes']} episodes, {sm.get('episodes_per_minute', float('nan')):.1f} episodes/min "
              f"(per process, episodes only); {_mode(sm)}" + (f"; videos: {', '.join(shot)}" if shot else ""))
    atomic_write_text(out / "tables.md", md)
    atomic_write_text(out / "summary.json", json.dumps(json_safe(summaries), indent=1, sort_keys=True) + "\n")
    print(md)
    return 0
