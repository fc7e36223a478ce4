"""A scene's first visit (the exploration phase an agent with a scene prior gets before the scene's episodes): the
evaluator's seeded start on each floor with episodes, no goal, the declared budget, and what the visit took."""

from __future__ import annotations

import time
import zlib
from dataclasses import replace
from typing import Any

import numpy as np

from ... import metrics
from ...config import AgentConfig, NavConfig
from ...errors import InputError
from ..bundle import Bundle
from ..objectnav import make_environment
from ..observation import ObservationBuilder, Vocabulary
from .phases import run_phase
from ..protocol import Phase


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
        info = run_phase(session, env, builder, Phase("explore", scene, "", -1, int(know.explore_steps)))
        task = env.task
        return {"scene": scene, "variant": bundle.name, "floor": floor,
                "start": [round(float(v), 4) for v in start], "yaw": yaw,
                "budget": int(know.explore_steps), "steps": int(task.steps),
                "metres": round(metrics.path_length(np.array(task.trajectory)), 3), "stopped": bool(task.stop_called),
                "seconds": round(time.perf_counter() - t0, 2), "info": info}
    finally:
        env.task.close()


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
