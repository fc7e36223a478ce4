"""A scene's first visit (the exploration phase an agent with a scene prior gets before the scene's episodes): the
evaluator's seeded start on each floor with episodes, no goal, the declared budget, and what the visit took. Each
floor's visit is granted once per run (its record written before it begins), whatever fails or resumes."""

from __future__ import annotations

import json
import time
import zlib
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ... import metrics
from ...config import AgentConfig, NavConfig
from ...errors import InputError
from ...store import atomic_write_text, json_safe
from ..bundle import Bundle
from ..objectnav import make_environment
from ..observation import ObservationBuilder, Vocabulary, rendered_images
from ..protocol import AgentError, Phase, SceneStart
from .phases import LiveAgent, run_phase


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


def first_visit_floors(bundle: Bundle, floors: set[int]) -> list[int]:
    """Return the floors a scene's first visits cover, in visit order: that of the bundle's first episode, then the
    other floors with episodes to run, ascending (a robot carried to each floor; episodes stay on one floor)."""
    first = int(bundle.episodes[0].floor)
    return [first] + sorted(int(f) for f in floors if int(f) != first)


def _explore(session: Any, bundle: Bundle, know: Any, nav: NavConfig, body: AgentConfig, vocab: Vocabulary,
             seed: int, floor: int | None = None, scene: str | None = None) -> dict:
    """Run a scene's first visit of one floor (the exploration phase; default: the floor of the bundle's first
    episode): the evaluator's seeded start, no goal, the declared budget; return what it took (steps, metres,
    seconds, whether the agent stopped, its info; ``failure`` with its cause when the agent failed in it: its
    session is then broken). ``scene``: the scene's token sent to the agent (default its name)."""
    t0 = time.perf_counter()
    env = make_environment(bundle, nav=replace(nav, max_steps=int(know.explore_steps)), agent=body,
                           **rendered_images(know))
    floor = int(bundle.episodes[0].floor) if floor is None else int(floor)
    try:
        start, yaw = exploration_start(bundle, seed, floor)
        env.task.set_exploration(start, yaw, floor)
        builder = ObservationBuilder(know, vocab, bundle.detector_labels())
        name = str(bundle.episodes[0].scene)
        failure = None
        try:
            info = run_phase(session, env, builder, Phase("explore", scene or name, "", -1, int(know.explore_steps)))
        except AgentError as e:
            info, failure = {}, {"cause": e.cause, "message": str(e)[-2000:]}
        task = env.task
        return {"scene": name, "variant": bundle.name, "floor": floor,
                "start": [round(float(v), 4) for v in start], "yaw": yaw,
                "budget": int(know.explore_steps), "steps": int(task.steps),
                "metres": round(metrics.path_length(np.array(task.trajectory)), 3), "stopped": bool(task.stop_called),
                "seconds": round(time.perf_counter() - t0, 2), "info": info} | ({"failure": failure} if failure else {})
    finally:
        env.task.close()


def run_first_visits(live: Any, bundle: Bundle, floors: set[int], know: Any, nav: NavConfig, body: AgentConfig,
                     vocab: Vocabulary, seed: int, start: SceneStart | None = None, record: Path | None = None,
                     key: str = "") -> dict:
    """Run a scene's first visits, one per floor with episodes to run (`first_visit_floors`, each floor's budget its
    own), and return the scene's visit (`scene_visit`; empty when no floor is left to visit).

    Each floor's visit is granted once per run: with ``record`` (the scene's exploration JSON) a floor's visit is
    written before it begins (as a failure: the evaluation stopped in it) and again when it ends, and the floors
    that record already holds for this run (``key``) are not visited again; the scene's visit sums the steps of all.
    An agent that fails in a visit has it recorded with its ``failure`` and gets a new process (`LiveAgent`).

    Parameters
    ----------
    live
        The evaluation's agent (`phases.LiveAgent`), or a session with the scene started.
    bundle : Bundle
        The scene's first variant (its environment hosts the visits).
    floors : set of int
        The floors of the scene's episodes to run.
    know, nav, body, vocab, seed
        The agent's knowledge, actions, body, the dataset's vocabulary and the evaluation seed (as `evaluate`).
    start : SceneStart, optional
        The scene as announced to the agent (its token and oracle parts).
    record : Path, optional
        The scene's exploration record (None: nothing written, nothing resumed).
    key : str
        The run's key (`results.run_key`): a record of another run is not this run's.
    """
    visits: list[dict] = []
    if record is not None and record.is_file():
        try:
            old = json.loads(record.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            old = {}
        if isinstance(old, dict) and old.get("run_key") == key:
            visits = list(old["floors"]) if "floors" in old else [{k: v for k, v in old.items() if k != "run_key"}]
    granted = {int(v.get("floor", -1)) for v in visits}
    scene = str(bundle.episodes[0].scene)
    for f in first_visit_floors(bundle, floors):
        if f in granted:
            continue
        visits.append({"scene": scene, "variant": bundle.name, "floor": f, "budget": int(know.explore_steps),
                       "steps": 0, "metres": 0.0, "stopped": False, "seconds": 0.0, "info": {},
                       "failure": {"cause": "crash", "message": "the evaluation stopped during this first visit"}})
        _write_visits(record, visits, key)
        session = live.get(start) if isinstance(live, LiveAgent) else live
        visits[-1] = _explore(session, bundle, know, nav, body, vocab, seed, f, start.scene if start else None)
        if visits[-1].get("failure") and isinstance(live, LiveAgent):
            live.fail()
        _write_visits(record, visits, key)
    return scene_visit(visits) if visits else {}


def _write_visits(record: Path | None, visits: list[dict], key: str) -> None:
    """Write a scene's first visits so far (with the run's key) to its exploration record."""
    if record is not None:
        atomic_write_text(record, json.dumps(json_safe({"run_key": key, **scene_visit(visits)}), sort_keys=True) + "\n")


def scene_visit(visits: list[dict]) -> dict:
    """Return a scene's first visit from those of its floors: steps, metres and seconds summed, the budget per
    floor; one floor's visit is returned as it is (its record unchanged)."""
    if len(visits) == 1:
        return visits[0]
    failed = [v["failure"] for v in visits if v.get("failure")]
    return {"scene": visits[0]["scene"], "variant": visits[0]["variant"], "budget": int(visits[0]["budget"]),
            "steps": int(sum(v["steps"] for v in visits)), "metres": round(sum(v["metres"] for v in visits), 3),
            "seconds": round(sum(v["seconds"] for v in visits), 2), "stopped": all(v["stopped"] for v in visits),
            "floors": visits} | ({"failure": failed[0]} if failed else {})
