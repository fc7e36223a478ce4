"""The lifelong order of a chain dataset (days in a home, bundles with `Bundle.day`): each scene's days in order, each
day's episodes in order, one agent process per scene; what the evaluator adds to such an episode's result (its day,
its goal's history, whether a STOP was stale) and the record of an episode a broken sequence leaves unrun.

The evaluator knows every day's records: a *stale stop* is a STOP that failed where an object of the goal category
rested on an earlier day of the scene and none rests now (`stale_stop`), the mistake an agent that trusts yesterday
makes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...records import MOVED, NEW, UNMOVED, Episode
from ..bundle import Bundle

# The order of preference of an episode's goal histories: an episode whose category has an unmoved instance could be
# solved from yesterday's memory, one with only moved or new instances could not (`goal_history`).
HISTORIES = (UNMOVED, MOVED, NEW)
NOT_RUN = "sequence broken"  # the failure cause of an episode a broken lifelong sequence leaves unrun


def is_chain(bundles: list[Bundle]) -> bool:
    """Return whether the bundles are days of chains (a lifelong evaluation) rather than independent variants."""
    return any(b.day is not None for b in bundles)


def sequence_key(scene: str, bundle: Bundle, chain: bool) -> str:
    """Return the evaluation group a bundle's episodes run in: its scene; in a chain dataset, a scene's days form one
    sequence (``<scene>_days``: its own agent process and first visit, its own first-visit record) and the scene's
    independent variants, exported beside them, another (the scene, evaluated as usual)."""
    return f"{scene}_days" if chain and bundle.day is not None else scene


def day_order(items: list[tuple[Bundle, int]]) -> list[tuple[Bundle, int]]:
    """Return a scene's (bundle, episode index) items in the lifelong order: days ascending, each day's episodes in
    their order (a stable sort: bundles of one day keep theirs)."""
    return sorted(items, key=lambda t: -1 if t[0].day is None else int(t[0].day))


def goal_history(ep: Episode) -> str | None:
    """Return an episode's goal history: the most favourable of its goals' histories for an agent that remembers
    (`HISTORIES` order: any unmoved instance makes it "unmoved", else any moved one "moved", else "new"); None for an
    episode outside a chain."""
    seen = {g.history for g in ep.goals if g.history}
    return next((h for h in HISTORIES if h in seen), None)


def day_objects(physics: Any, bundle: Bundle) -> dict[str, np.ndarray]:
    """Return where the day's placed objects rest, by category: category -> (N, 3) positions (m), read from the
    bundle's model (bodies ``obj_<n>``, categories from `Bundle.detector_labels`) at its initial state."""
    import mujoco

    from ...sim.model import object_segment_id

    labels = bundle.detector_labels()
    m = physics.model.ptr
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    out: dict[str, list[np.ndarray]] = {}
    for b in range(m.nbody):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or ""
        if not name.startswith("obj_"):
            continue
        try:
            cat = labels.get(object_segment_id(name))
        except ValueError:
            continue
        if cat:
            out.setdefault(cat, []).append(d.xpos[b].copy())
    return {k: np.array(v, float).reshape(-1, 3) for k, v in out.items()}


def stale_stop(result: dict, category: str, earlier: list[dict[str, np.ndarray]], now: dict[str, np.ndarray],
               radius: float) -> bool:
    """Return whether an episode ended in a stale stop: the agent called STOP without success within `radius` (m, in
    the plane) of where an object of the goal category rested on an earlier day, and no object of that category
    rests within `radius` of the stop now.

    Parameters
    ----------
    result : dict
        The episode's result (``stop_called``, ``success``, ``trajectory``: XY per step in the scene frame).
    category : str
        The goal category.
    earlier : list of dict
        `day_objects` of the scene's earlier days.
    now : dict
        `day_objects` of the episode's day.
    radius : float
        The distance within which a STOP counts as aimed at an object: the view points' radius (a STOP aimed at an
        object lands at one of them).
    """
    if not result.get("stop_called") or result.get("success") or not result.get("trajectory"):
        return False
    p = np.asarray(result["trajectory"][-1], float)[:2]

    def near(objs: dict[str, np.ndarray]) -> bool:
        x = objs.get(category)
        return x is not None and len(x) > 0 and bool((np.linalg.norm(x[:, :2] - p, axis=1) <= radius).any())

    return any(near(d) for d in earlier) and not near(now)


def not_run_record(base: dict, ep: Episode, cause: str, message: str) -> dict:
    """Return the result of an episode a broken lifelong sequence leaves unrun: the episode's fields (``base``: what
    `loop.run_episode` records before an episode begins), success and SPL 0 (an episode not run counts as failed:
    nothing overstates the agent), ``not_run`` and ``failure`` (cause `NOT_RUN`, the message naming what broke it)."""
    g = float(ep.geodesic_distance)
    return {**base, "success": 0.0, "spl": 0.0, "soft_spl": 0.0, "distance_to_goal": g, "shortest": g,
            "path_length": 0.0, "steps": 0, "stop_called": False, "start_geodesic": g, "info": {}, "trajectory": [],
            "failure": {"cause": cause, "message": message}, "not_run": True, "outcome": "not run"}
