"""Why an episode ended as it did: success, the step limit, a search exhausted, another instance of the goal category,
a STOP near the goal that missed its view points, or the agent's failure (`episode_outcome`, read by the statistics
and the tables)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...geometry import quat_yaw
from ..boundary import scene_frame_point


# Why an episode ended as it did (`episode_outcome`), in table order.
OUTCOMES = ("success", "step limit", "not found", "other instance", "missed stop", "agent failure", "not run")
OUTCOME_HELP = {
    "success": "STOP within the success distance of a goal's view point",
    "step limit": "the step limit ended the episode (no STOP)",
    "not found": "STOP without having detected the goal category (the agent's search was exhausted)",
    "other instance": "STOP at an object of the goal category that is no goal (nowhere within the view radius sees it)",
    "missed stop": "STOP near a detected goal object, not within the success distance of its view points",
    "agent failure": "the agent crashed, timed out or broke the protocol during the episode (its cause is recorded; "
                     "the episode is not run again)",
    "not run": "a lifelong sequence broke before the episode (the agent failed earlier in its scene's days, or the "
               "evaluation stopped there): its memory is gone, so the episode is recorded with the cause, never run",
}


# A detected object's reconstructed centre (the median of its depth points, `nav.goal.object_centre`) lies on the
# object's surface, so within its box up to the depth pixels at its rim; 0.3 m leaves room for those and for a
# partly occluded object while staying below the spacing of two receptacles (an object on another piece).
OTHER_INSTANCE_M = 0.3


def episode_outcome(result: dict, episode: Any, pose: str = "absolute") -> str:
    """Return why an episode ended as it did: one of `OUTCOMES` (evaluation only: it reads the episode's goals).

    ``result`` holds the suite's metrics (``success``, ``stop_called``) and the agent's ``info``: ``detected``
    (whether it saw the goal category) and ``goal`` (the reconstructed centre it drove to, XYZ in the agent's
    frame), as the built-in agents report them. ``pose`` is the agent's pose sensor (`Knowledge.pose`): with
    ``gps+compass`` the centre is in the episode's start frame and is taken back to the scene frame here.
    Agents that report neither end as "missed stop" when they STOP elsewhere.
    """
    if result.get("not_run"):
        return "not run"
    if result.get("failure"):
        return "agent failure"
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
