"""The knowledge boundary: what an agent may know, granted and enforced by the suite (paper appendix D).

An agent declares its `sdovon_mj.knowledge.Knowledge` (class attribute ``knowledge``). The suite then gives it

- an `AgentEnv` instead of the dm_control environment: reset/step and the sensor's intrinsics, no task
  internals. Observations: rgb, depth, the goal category (``objectgoal``, ``objectgoal_text``), GPS +
  compass relative to the episode start (habitat-lab's convention), the camera pitch (its own actuator
  state) and, in that start frame, ``position`` = (gps x, gps y, 0) and ``heading`` = compass, so planners
  can work in the agent's own frame. The ``semantic`` image only when its detector is the ground-truth one.
  With ``pose="absolute"`` (declared and printed in every table: the agent is localized in the scene's
  frame, as the paper's A* agents) ``position``/``heading`` are the world pose instead.
- an `AgentBundle`: the bundle's name, scene id, goal categories and the agent's detector. Generator
  artefacts (navmaps, region maps, relevance, instance and object labels, view points) live behind
  ``AgentBundle.oracle``, which raises `KnowledgeError` unless the agent declared the part it reads in
  ``Knowledge.oracle`` (oracle agents: labelled upper bounds).

What an agent keeps between episodes of a scene (its own exploration, the paper's prior-knowledge setting)
is its own business: ``Knowledge.prior`` says whether it explores a scene before its episodes.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..knowledge import ORACLE_PARTS, Knowledge, KnowledgeError, knowledge_of

class OracleView:
    """Generator artefacts of a bundle, each part readable only when declared."""

    def __init__(self, bundle: Any, knowledge: Knowledge) -> None:
        self._bundle = bundle
        self._knowledge = knowledge

    def _grant(self, part: str) -> None:
        if part not in self._knowledge.oracle:
            raise KnowledgeError(f"oracle part '{part}' of bundle {self._bundle.name} is not declared in this agent's "
                                 f"Knowledge.oracle {self._knowledge.oracle}")

    def navmap(self, floor: int = 0) -> Any:
        """Return the generator's navigable map of a floor."""
        self._grant("navmap")
        return self._bundle.navmap(floor)

    def region_map(self, floor: int = 0) -> Any:
        """Return the generator's region map of a floor (None without one)."""
        self._grant("region_map")
        return self._bundle.region_map(floor)

    @property
    def relevance(self) -> Any:
        """Return the relevance table that drove placement (None without one)."""
        self._grant("relevance")
        return self._bundle.relevance

    def instance_labels(self) -> dict[int, str]:
        """Return scene instance id -> true label."""
        self._grant("instance_labels")
        return self._bundle.instance_labels()

    def episode_floor(self, episode_id: str) -> int:
        """Return the floor an episode is on."""
        self._grant("view_points")
        return int(next(e for e in self._bundle.episodes if e.episode_id == episode_id).floor)

    def view_points(self, episode_id: str) -> np.ndarray:
        """Return the goal view points (N, 3) of an episode."""
        self._grant("view_points")
        ep = next(e for e in self._bundle.episodes if e.episode_id == episode_id)
        return np.array([vp.position for g in ep.goals for vp in g.view_points], float).reshape(-1, 3)


class AgentBundle:
    """The view of a bundle an agent gets: name, scene, goal categories, its detector; generator data guarded."""

    def __init__(self, bundle: Any, knowledge: Knowledge, detector: Any) -> None:
        self._bundle = bundle
        self.knowledge = knowledge
        self.name = bundle.name
        self.scene = bundle.episodes[0].scene if bundle.episodes else bundle.name
        self.categories = bundle.categories()
        self.detector = detector

    @property
    def oracle(self) -> OracleView:
        """Return the generator artefacts (`KnowledgeError` for an agent that declared none)."""
        if not self.knowledge.is_oracle:
            raise KnowledgeError(f"bundle {self.name}: this agent is not an oracle (Knowledge.oracle is empty); "
                                 f"generator artefacts ({', '.join(ORACLE_PARTS)}) are out of its reach")
        return OracleView(self._bundle, self.knowledge)

    def __getattr__(self, name: str) -> Any:
        if name in ("root", "mjcf", "episodes", "navmaps", "navmap", "region_maps", "region_map", "relevance",
                    "scene_asset", "labels", "instance_labels", "objects", "object_labels"):
            raise KnowledgeError(f"bundle {self.__dict__.get('name', '?')}: '{name}' is generator data; "
                                 "agents read it only through `oracle` when declared")
        raise AttributeError(name)


class AgentEnv:
    """The environment as an agent drives it: reset, step, intrinsics; observations within its knowledge."""

    def __init__(self, env: Any, knowledge: Knowledge) -> None:
        self._env = env
        self.knowledge = knowledge
        task = env.task
        self.K = task.K
        self.agent = task.agent
        self.nav = task.nav

    @property
    def scene(self) -> str:
        """Return the scene id of the current episode (what the agent knows it is in)."""
        return self._env.task.episode.scene

    @property
    def episode_id(self) -> str:
        """Return the current episode's id."""
        return self._env.task.episode.episode_id

    @property
    def episode_index(self) -> int:
        """Return the current episode's index in its bundle."""
        return int(self._env.task.episode_index)

    @property
    def steps(self) -> int:
        """Return the steps taken in the current episode."""
        return int(self._env.task.steps)

    def set_render(self, on: bool) -> None:
        """Ask for rendered images on the next step (blank frames otherwise: a speed-up, specs unchanged)."""
        self._env.task.render_frames = bool(on)

    def _filter(self, ts: Any) -> Any:
        o = dict(ts.observation)
        if self.knowledge.detector != "gt":
            o.pop("semantic", None)
        if self.knowledge.pose != "absolute":
            gps = np.asarray(o["gps"], float)
            o["position"] = np.array([gps[0], gps[1], 0.0], np.float32)
            o["heading"] = np.asarray(o["compass"], np.float32).copy()
        return ts._replace(observation=o)

    def reset(self) -> Any:
        """Start the next episode; return its first (filtered) timestep."""
        return self._filter(self._env.reset())

    def step(self, action: int) -> Any:
        """Apply one action; return the (filtered) timestep."""
        return self._filter(self._env.step(action))

    def close(self) -> None:
        """Free the environment's renderer."""
        self._env.task.close()


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


__all__ = ["AgentBundle", "AgentEnv", "Knowledge", "KnowledgeError", "OracleView", "knowledge_of", "scene_frame_point",
           "start_frame_pose"]
