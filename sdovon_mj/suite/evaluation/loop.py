"""The evaluation loop: an agent over a dataset's episodes, scene by scene (its first visit where it has a scene
prior, then the episodes of each variant), one result dict per episode, written at once and read back on a rerun.

Agents are plugins (`plugins.load("agent", name)`: built-ins random-astar, semantic-astar, semantic-frontier, oracle,
random; others from the ``sdovon_mj.agents`` entry points), built as ``factory(nav=NavConfig, agent=AgentConfig,
seed=int)``, by default in their own sealed process (`protocol.SealedSession`): the evaluator never imports an agent
named by an `AgentSpec`. Each episode's result records the mode it ran in, whether the agent's file system was
sealed, the split (open or secret, `dataset_split`) and the agent's set-up time; an episode the agent failed in
is recorded with the failure's cause, and no begun episode or first visit is ever played again. A dataset of chains of
days runs in the lifelong order (`lifelong`): a scene's days in order in one agent process, "new day" between days.
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
from ..observation import ObservationBuilder, dataset_vocabulary, make_sensors, rendered_images
from ..protocol import REPLY_TIMEOUT, SETUP_TIMEOUT, AgentError, AgentSpec, Phase, SceneStart, opaque_token
from ..video import EpisodeVideo
from .exploration import run_first_visits
from .lifelong import (NOT_RUN, day_objects, day_order, goal_history, is_chain, not_run_record, sequence_key,
                       stale_stop)
from .outcomes import episode_outcome
from .phases import LiveAgent, open_session, run_phase
from .results import agent_log_path, exploration_path, load_done, result_path, run_key, video_path

SPLITS = ("open split", "secret split")  # how a row's episodes were made: public seeds, or a secret salt (`seeds`)


def dataset_root(bundles: list[Bundle]) -> Path | None:
    """Return the folder all bundles sit in (the dataset, with its index.json), or None."""
    parents = {b.root.resolve().parent for b in bundles}
    return parents.pop() if len(parents) == 1 else None


def dataset_split(root: Path | None) -> dict[str, str]:
    """Return how a dataset's episodes were made: ``{"split": "secret split" | "open split", "salt_digest"}`` from its
    ``index.json`` (`export.finish_export` records a secret salt's digest there). Bundles outside a dataset folder
    count as open: a secret split labelled open overstates nothing."""
    try:
        meta = json.loads((root / "index.json").read_text(encoding="utf-8")) if root is not None else {}
    except (OSError, json.JSONDecodeError):
        meta = {}
    secret = meta.get("secret_split") if isinstance(meta, dict) else None
    if isinstance(secret, dict) and secret.get("secret"):
        return {"split": SPLITS[1], "salt_digest": str(secret.get("salt_digest", ""))}
    return {"split": SPLITS[0], "salt_digest": ""}


def evaluate(dataset: str | Path | list[Path | Bundle], agent: Any, nav: NavConfig | None = None, episodes: int | None = None,
             out: Path | None = None, label: str | None = None, progress: bool = True, mode: str = "sealed",
             seed: int = 0, body: AgentConfig | None = None, seal: bool = True, read: tuple[str, ...] = (),
             videos: tuple[str, ...] = (), timeout: float = REPLY_TIMEOUT,
             setup_timeout: float = SETUP_TIMEOUT, render: str = "auto") -> list[dict]:
    """Run an agent over a dataset's episodes through the agent protocol; return (and optionally write) one result
    dict per episode. A run with ``out`` resumes: episodes whose result of the same run is there are not run again
    (a video asked for later is not recorded for them: an episode is never played twice).

    An episode that began is recorded with its outcome: when the agent fails in it (crash, timeout, protocol error:
    `protocol.AgentError`) its result holds ``failure`` (cause and message), its outcome is "agent failure", and the
    evaluation goes on with a new agent process (`phases.LiveAgent`). Each episode's record is written before it
    begins, so a resumed run never plays a begun episode again (one the evaluation stopped in is a failure), and a
    scene's first visit of a floor is granted once (`exploration.run_first_visits`). Episode and scene ids reach the
    agent as opaque tokens (`protocol.opaque_token`, keyed by the split's salt digest: stable within a scene, so the
    agent's memory of a scene works). The agent process's output goes to ``out/agents/<label>.log``.

    Days of chains (bundles with `Bundle.day`) run in the lifelong order (`lifelong.sequence_key`, `day_order`): a
    scene's days in order, each day's episodes in order, in one agent process per scene (the scene's independent
    variants in another), its first visit once before day 0 and `protocol.NEW_DAY` between days; once the agent
    fails in a scene's sequence, or a resumed run finds it begun, its remaining episodes are recorded as not run
    (`lifelong.not_run_record`). Their results carry ``day``, ``goal_history`` and ``stale_stop``.

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
    timeout, setup_timeout
        Seconds for one reply of a sealed agent and for its set-up (`protocol.REPLY_TIMEOUT`, `SETUP_TIMEOUT`).
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
    chain = is_chain(bundles)  # the lifelong order: days in order, one agent process per scene, "new day" between days
    scenes: dict[str, list[tuple[Bundle, int]]] = {}
    for b, i in plan:
        scenes.setdefault(sequence_key(str(b.episodes[i].scene), b, chain), []).append((b, i))
    label = label or (agent.name if isinstance(agent, AgentSpec) else str(getattr(agent, "name", type(agent).__name__)))
    key = run_key(label, agent, nav, body, mode, seed)
    out = Path(out) if out is not None else None
    videos = set(videos)
    if videos and out is None:
        raise ValueError("videos are written into the results folder: give out")
    protect = tuple(sorted({b.root.resolve() for b in bundles} | ({root} if root else set()) | ({out.resolve()} if out else set())))
    split = dataset_split(root)
    log = agent_log_path(out, label) if out is not None else None
    live = LiveAgent(lambda: open_session(agent, mode, body.sensor_width, body.sensor_height, seal, tuple(read), protect,
                                          timeout, setup_timeout, log),
                     lambda know: make_sensors(body, nav, vocab, know))
    results: list[dict] = []
    try:
        with Progress(limit, f"eval {label}", enabled=progress) as bar:
            for group_key, items in scenes.items():
                scene = str(items[0][0].episodes[items[0][1]].scene)
                seq = chain and items[0][0].day is not None  # a scene's days: the lifelong order
                items = day_order(items) if seq else items
                done = {(b.name, i): load_done(out, label, key, b.episodes[i].episode_id) for b, i in items}
                if all(done.values()):
                    results += [done[(b.name, i)] for b, i in items]
                    bar.update(len(items), group_key)
                    continue
                # a chain scene with some episodes recorded was begun before: its agent's memory is gone with that
                # process, so its sequence is broken and its remaining episodes are not run (never replayed)
                broken = ("the evaluation stopped in this scene's sequence of days (resumed): the agent's memory of "
                          "its earlier days is gone") if seq and any(done.values()) else ""
                first = items[0][0]
                live.get()
                know = live.knowledge
                start = SceneStart(opaque_token(split["salt_digest"], "scene", scene), oracle_scene_parts(first, know))
                visit = None
                if know.prior == "scene" and not broken:
                    floors = {int(b.episodes[i].floor) for b, i in items if not done[(b.name, i)]}
                    visit = run_first_visits(live, first, floors, know, nav, body, vocab, seed, start,
                                             exploration_path(out, label, group_key) if out is not None else None, key)
                    if seq and visit and visit.get("failure"):
                        broken = (f"the agent failed in the scene's first visit ({visit['failure']['cause']}): its "
                                  "memory of the scene is gone")
                held = live.session  # how the agent ran, for the records of episodes a broken sequence leaves unrun
                by_bundle: dict[str, list[tuple[Bundle, int]]] = {}
                for b, i in items:
                    by_bundle.setdefault(b.name, []).append((b, i))
                earlier: list[dict] = []  # the scene's earlier days' objects (stale stops)
                day = None
                for group in by_bundle.values():
                    b = group[0][0]
                    env = make_environment(b, nav=nav, agent=body, **rendered_images(know))
                    builder = ObservationBuilder(know, vocab, b.detector_labels())
                    now = day_objects(env.physics, b) if seq else {}
                    try:
                        if seq and day is not None and b.day != day and not broken and live.session is not None:
                            try:
                                live.get(start).new_day()
                            except AgentError as e:
                                live.fail()
                                broken = f"the agent failed at the new day ({e.cause}): {str(e)[-500:]}"
                        for _b, i in group:
                            if done[(b.name, i)]:
                                results.append(done[(b.name, i)])
                                bar.update(1, b.episodes[i].episode_id)
                                continue
                            eid = b.episodes[i].episode_id
                            if broken:  # no agent process is started for it
                                r = not_run_record(episode_record(live.session or held, know, label, key, split, b,
                                                                  b.episodes[i], visit), b.episodes[i], NOT_RUN, broken)
                            else:
                                r = run_episode(live, start, env, builder, b, i, label, key, visit,
                                                (out, video_path(label, eid)) if eid in videos else None, split,
                                                out) | drawn
                                held = live.session or held
                            if seq:
                                r["stale_stop"] = stale_stop(r, b.episodes[i].object_category, earlier, now,
                                                             float(nav.fn_viewpoint_radius))
                                if r.get("failure") and not broken:
                                    broken = (f"the agent failed in episode {eid} ({r['failure']['cause']}) earlier "
                                              "in this scene's sequence of days: its memory is gone")
                            results.append(r)
                            if out is not None:
                                atomic_write_text(result_path(out, label, r["episode_id"]),
                                                  json.dumps(json_safe(r), sort_keys=True) + "\n")
                            bar.update(1, r["episode_id"])
                    finally:
                        env.task.close()
                    earlier.append(now)
                    day = b.day
                if chain:  # one agent process per sequence: the next one's agent remembers nothing of this one
                    live.close()
    finally:
        live.close()
    return results


def drawn_by(render: str) -> dict[str, str]:
    """Choose this process's renderer (`gl.use`) and return what each result records of it."""
    rec = use_renderer(render)
    return {"render": rec["render"], "renderer": rec["renderer"],
            **({"render_fallback": rec["fallback"]} if rec.get("fallback") else {})}


def episode_record(session: Any, know: Any, label: str, key: str, split: dict, b: Bundle, ep: Any,
                   visit: dict | None) -> dict:
    """Return the fields of an episode's result known before it begins: the row, how the agent runs (``session``,
    its declared ``know``), the split, the episode (its day and goal history on a day of a chain) and the scene's
    first visit, summarized.

    Parameters
    ----------
    session : AgentSession
        The agent's session (sealed or in-process): its mode, seal and set-up seconds.
    know : Knowledge
        What the agent declared it knows.
    label : str
        The row's name.
    key : str
        The run key (`results.run_key`).
    split : dict
        The dataset's split record (``split``: open or secret split).
    b : Bundle
        The variant the episode belongs to.
    ep : Episode
        The episode (``b.episodes[i]``; its day and goal history on a day of a chain).
    visit : dict or None
        The scene's first visit (`exploration.run_first_visits`), summarized into the record.
    """
    return {"agent": label, "knowledge": know.describe(), "oracle": know.is_oracle, "mode": session.mode,
            "seal": session.seal.describe(), "sealed": bool(session.seal.sealed), "split": split["split"],
            "setup_seconds": session.setup_seconds, "run_key": key,
            "episode_id": ep.episode_id, "variant": b.name, "scene": ep.scene, "category": ep.object_category,
            "first_visit": None if not visit else {k: visit[k] for k in ("steps", "metres", "budget", "seconds")}
            | ({"floors": len(visit["floors"])} if "floors" in visit else {})
            | ({"failure": visit["failure"]["cause"]} if visit.get("failure") else {})} \
        | ({"day": int(ep.day), "goal_history": goal_history(ep)} if ep.day is not None else {})


def run_episode(live: LiveAgent, start: SceneStart, env: Any, builder: ObservationBuilder, b: Bundle, i: int,
                label: str, key: str, visit: dict | None, video: tuple[Path, str] | None = None,
                split: dict | None = None, out: Path | None = None) -> dict:
    """Run episode `i` of bundle `b` with the evaluation's agent; return its result dict.

    With ``out`` the episode's record is written before it begins (as a failure: the evaluation stopped in it), so a
    resumed run never plays it again. An agent failure (`protocol.AgentError`) is the episode's outcome ("agent
    failure", ``failure``: cause and message; success and SPL 0) and ends the agent's process. The difficulty (the
    goal in view at the start) is measured after the episode, on the physics state of its start.

    Parameters
    ----------
    live : LiveAgent
        The evaluation's agent (a session is opened when none is live).
    start : SceneStart
        The episode's scene as announced to the agent (its token and oracle parts).
    env
        The environment of bundle `b` (`objectnav.make_environment`).
    builder : ObservationBuilder
        Builds the agent's observations within its knowledge.
    b : Bundle
        The variant the episode belongs to.
    i : int
        The episode's index in ``b.episodes``.
    label : str
        The row's name, written into the result.
    key : str
        The run key (`results.run_key`), written into the result.
    visit : dict or None
        The scene's first visit (`exploration.run_first_visits`), summarized into the result.
    video : (Path, str), optional
        The results folder and the MP4's path relative to it: the episode is recorded there.
    split : dict, optional
        The dataset's split (`dataset_split`; default open).
    out : Path, optional
        The results folder: the begun episode's record is written there.
    """
    t0 = time.perf_counter()
    ep = b.episodes[i]
    session = live.get(start)
    know = live.knowledge
    split = split or dataset_split(None)
    env.task.set_next_episode(i)
    phase = Phase("episode", start.scene, opaque_token(split["salt_digest"], "episode", ep.episode_id), i,
                  int(env.task.nav.max_steps), oracle_episode_parts(ep, know))
    r = episode_record(session, know, label, key, split, b, ep, visit)
    if out is not None:  # begun: recorded as a failure until its outcome replaces it
        g = float(ep.geodesic_distance)
        begun = {**r, "success": 0.0, "spl": 0.0, "soft_spl": 0.0, "distance_to_goal": g, "shortest": g,
                 "path_length": 0.0, "steps": 0, "stop_called": False, "start_geodesic": g, "info": {},
                 "failure": {"cause": "crash", "message": "the evaluation stopped during this episode"},
                 "outcome": "agent failure", "trajectory": []}
        atomic_write_text(result_path(out, label, ep.episode_id), json.dumps(json_safe(begun), sort_keys=True) + "\n")
    recorder = EpisodeVideo(video[0] / video[1], b.navmap(ep.floor), ep, label=label) if video else None
    at_reset: dict = {}
    failure = None
    try:
        info = run_phase(session, env, builder, phase, at_reset, recorder)
    except AgentError as e:
        info, failure = {}, {"cause": e.cause, "message": str(e)[-2000:]}
        live.fail()
    except BaseException:
        if recorder is not None:
            recorder.abort()
        raise
    if recorder is not None:
        recorder.close()
    task = env.task
    m = task.metrics().to_dict()
    if failure:
        m.update(success=0.0, spl=0.0)
    if "qpos" in at_reset:  # the difficulty, on the start's physics state (parts the agent moved put back)
        env.physics.data.qpos[:] = at_reset["qpos"]
    in_view, visible = task.start_visibility(env.physics)
    r.update(**m, collisions=task.collisions, inside=any(g.open_part for g in ep.goals),
             must_open=bool(ep.goals) and all(g.open_part for g in ep.goals),
             part_moves=[list(t) for t in task.part_moves], start_geodesic=float(task.shortest),
             goal_in_view=bool(in_view), goal_visible_from_start=bool(visible), info=info,
             seconds=round(time.perf_counter() - t0, 3),
             trajectory=np.round(np.array(task.trajectory)[:, :2], 4).tolist(), failure=failure)
    if video:
        r["video"] = video[1]
    r["outcome"] = episode_outcome(r, ep, know.pose)
    return r
