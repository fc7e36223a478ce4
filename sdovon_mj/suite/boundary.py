"""The knowledge boundary, evaluator side: what of the generator's data may cross to an agent (paper appendix D).

An agent declares its `sdovon_mj.knowledge.Knowledge`. The evaluation (`suite.evaluation`, over the protocol of
`suite.protocol`) then sends it observations built within that declaration (`suite.observation`: rgb, depth, GPS +
compass from the episode start, its camera pitch, the goal category; the category image of the current frame for the
ground-truth detector; the scene-frame pose for ``pose="absolute"``, printed as "localized") and nothing else of the
evaluator's: no reward, no environment, no bundle.

Generator artefacts (navmaps, region maps, relevance, instance labels, view points) cross only for a declared oracle
(`Knowledge.oracle`: a labelled upper bound), and only the parts it declared: `oracle_scene_parts` and
`oracle_episode_parts` pick them; the agent reads them through `protocol.OracleParts`, which raises `KnowledgeError`
for anything else. What an agent keeps between episodes of a scene (its own first visit, the paper's prior-knowledge
setting) is its own business; ``Knowledge.prior`` says whether it gets a first visit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..knowledge import Knowledge


def oracle_scene_parts(bundle: Any, knowledge: Knowledge) -> dict:
    """Return the scene-level generator artefacts a declared oracle may read (empty for every other agent)."""
    parts = set(knowledge.oracle)
    out: dict = {}
    if "navmap" in parts:
        out["navmap"] = list(bundle.navmaps)
    if parts & {"navmap", "region_map"}:  # which floor's maps: the agent knows its height, the maps their floor
        out["floor_heights"] = {int(nm.floor): float(nm.height) for nm in bundle.navmaps}
    if "region_map" in parts:
        out["region_map"] = list(bundle.region_maps)
    if "relevance" in parts:
        out["relevance"] = bundle.relevance
    if "instance_labels" in parts:
        out["instance_labels"] = bundle.instance_labels()
    return out


def oracle_episode_parts(episode: Any, knowledge: Knowledge) -> dict:
    """Return the episode-level generator artefacts a declared oracle may read: its goals' view points and floor."""
    if "view_points" not in knowledge.oracle:
        return {}
    vps = np.array([vp.position for g in episode.goals for vp in g.view_points], float).reshape(-1, 3)
    return {"view_points": vps, "floor": int(episode.floor)}


def start_frame_pose(position: np.ndarray, yaw_deg: float, start: np.ndarray, start_yaw_deg: float) -> tuple[np.ndarray, float]:
    """Return a world pose expressed in an episode's start frame (x forward, y left; degrees)."""
    c, s = math.cos(math.radians(start_yaw_deg)), math.sin(math.radians(start_yaw_deg))
    d = np.asarray(position, float)[:2] - np.asarray(start, float)[:2]
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]]), (yaw_deg - start_yaw_deg + 180.0) % 360.0 - 180.0


def scene_frame_point(point: np.ndarray, start: np.ndarray, start_yaw_deg: float) -> np.ndarray:
    """Return a point given in an episode's start frame (x forward, y left, z from the start's floor) in the scene
    frame: the inverse of `start_frame_pose` for positions (XY, or XYZ with the start's height added)."""
    c, s = math.cos(math.radians(start_yaw_deg)), math.sin(math.radians(start_yaw_deg))
    p = np.asarray(point, float).copy()
    st = np.asarray(start, float)
    p[:2] = st[:2] + np.array([c * p[0] - s * p[1], s * p[0] + c * p[1]])
    if len(p) > 2:
        p[2] += float(st[2]) if len(st) > 2 else 0.0
    return p


__all__ = ["oracle_episode_parts", "oracle_scene_parts", "scene_frame_point", "start_frame_pose"]
