"""Agents for the ObjectNav suite: Random A* and Semantic A* (paper appendix D), Oracle and Random.

Agents are plugins (`plugins.load("agent", name)`, entry point group ``sdovon_mj.agents``); the
suite builds them as ``factory(nav=NavConfig, agent=AgentConfig, seed=int)`` (``nav.final_nav``
switches final point-goal navigation). This package never imports the suite: environments come in
through ``make_env`` and ``env``.

Protocol (what `suite.evaluate` and any plugin agent follow):
    agent.prepare(bundle, make_env)   once per bundle; A* agents explore a scene they do not know yet
    agent.reset(env, timestep)        at each episode start
    action = agent.act(timestep)      one discrete action per step
    agent.wants_frame                 whether the next observation needs rendered images (runners
                                      may skip rendering otherwise; dm_env specs still hold)
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import math
from typing import Callable, Generator

import numpy as np

from ..actions import LOOK_DOWN, LOOK_UP, STOP, TURN_LEFT
from ..config import AgentConfig, NavConfig, ReceptacleConfig
from ..errors import InputError
from ..grid import GeodesicField
from ..perceive.gt_detector import GroundTruthDetector
from ..records import Relevance, ReceptaclePlane
from ..sim.camera import pose_cv
from ..sim.model import object_segment_id
from .control import Navigator, blocked_cells, lattice_approach, segment_checker
from .frontier import explore
from .goal import goal_points, infer_view_points, object_centre
from .memory import SceneMemory, build_memory

# Scene memories built by exploration, shared by every A* agent of a process (eval runs four agents
# over the same scenes); keyed by scene, navmap, labels and exploration settings.
_MEMORY_CACHE: dict[tuple, tuple[SceneMemory, dict]] = {}
_MEMORY_CACHE_SIZE = 32


class Agent:
    """Base agent: generator-driven policies; `_run` yields actions and reads `self.ts`."""

    name = "agent"
    needs_semantic = False

    def __init__(self, nav: NavConfig | None = None, seed: int = 0, agent: AgentConfig | None = None) -> None:
        self.nav = nav or NavConfig()
        self.agent_config = agent or AgentConfig()  # body, camera and eta_gt; environments are made with it
        self.seed = seed
        self.wants_frame = True
        self._gen: Generator[int, object, None] | None = None
        self.ts = None
        self.info: dict = {}

    def prepare(self, bundle, make_env: Callable[..., object]) -> None:
        """Prepare for a bundle's episodes (default: nothing)."""

    def reset(self, env, ts) -> None:
        """Start an episode."""
        self.env, self.ts = env, ts
        self.info = {}
        self._gen = self._run(env)
        self._started = False
        self.frame_fresh = False  # whether the current observation's images were rendered
        self._render_next = False

    def act(self, ts) -> int:
        """Return the next action for the current timestep (STOP once the policy is done)."""
        self.ts = ts
        self.frame_fresh = self._render_next
        try:
            a = next(self._gen) if not self._started else self._gen.send(ts)
        except StopIteration:
            a = STOP
        self._started = True
        self._render_next = bool(self.wants_frame)
        return int(a)

    def _run(self, env) -> Generator[int, object, None]:
        yield STOP


class RandomAgent(Agent):
    """Uniformly random moves; STOP with probability `p_stop` per step."""

    name = "random"

    def __init__(self, nav: NavConfig | None = None, seed: int = 0, p_stop: float = 0.0,
                 agent: AgentConfig | None = None) -> None:
        super().__init__(nav, seed, agent)
        self.p_stop = p_stop
        self.wants_frame = False

    def _run(self, env) -> Generator[int, object, None]:
        rng = np.random.default_rng([self.seed, abs(hash(env.task.episode.episode_id)) % (2 ** 31)])
        while True:
            yield STOP if rng.random() < self.p_stop else int(rng.integers(1, 6))


class OracleAgent(Agent):
    """Walks the shortest grid path to the nearest view point, lines up exactly, and stops (privileged)."""

    name = "oracle"

    def __init__(self, nav: NavConfig | None = None, seed: int = 0, stop: bool = True,
                 agent: AgentConfig | None = None) -> None:
        super().__init__(nav, seed, agent)
        self.stop = stop
        self.wants_frame = False

    def _run(self, env) -> Generator[int, object, None]:
        task = env.task
        mask, frame = task.navmap.navigable, task.frame
        pos = np.asarray(self.ts.observation["position"], float)[:2]
        from_agent = GeodesicField(mask, frame, pos[None])
        vps = task.view_points[:, :2]
        d = np.array([from_agent.distance(v) for v in vps])
        target = vps[int(np.argmin(d))]
        nv = Navigator(self.nav, lambda: mask, frame)
        yield from nv.goto(target, 0.3, self.ts)
        pos = np.asarray(self.ts.observation["position"], float)[:2]
        yaw = math.degrees(float(self.ts.observation["heading"][0]))
        acts = lattice_approach(pos, yaw, target, segment_checker(mask, frame), self.nav, radius=0.05)
        for a in acts or []:
            yield a
        if self.stop:
            yield STOP
        while True:
            yield TURN_LEFT


def goal_labels(bundle) -> dict[int, str]:
    """Return segmentation id -> category of every goal object in a bundle (what the gt detector may see)."""
    return {object_segment_id(g.object_id): g.category for e in bundle.episodes for g in e.goals}


class ReceptacleAStar(Agent):
    """Receptacle search with A* (paper algorithms 3/4); subclasses choose the receptacle order."""

    name = "receptacle-astar"
    needs_semantic = True

    def __init__(self, nav: NavConfig | None = None, seed: int = 0, final_nav: bool | None = None,
                 detector: Callable[[dict, str], np.ndarray | None] | None = None,
                 receptacle_labels: tuple[str, ...] | None = None, relevance: Relevance | None = None,
                 planes: list[ReceptaclePlane] | None = None, region_of: Callable[[np.ndarray], str] | None = None,
                 explore_steps: int = 3000, explore_size: tuple[int, int] = (160, 120), planning: str = "explored",
                 agent: AgentConfig | None = None) -> None:
        """Build the agent.

        Parameters
        ----------
        nav
            Actions, tolerances and FN settings (default `NavConfig()`).
        seed
            Seed of the receptacle order's random choices.
        final_nav
            Final point-goal navigation after a detection; default ``nav.final_nav``.
        detector
            ``detector(observation, category) -> (H, W) bool mask | None``; default: the gt detector
            (`perceive.gt_detector.GroundTruthDetector` on the bundle's goal objects).
        receptacle_labels
            Labels of receptacles to visit (default `ReceptacleConfig().labels`).
        relevance
            Relevance tables (default: the bundle's).
        planes
            Receptacle planes to use instead of the built-in top planes of explored instances.
        region_of
            World XY -> region label (default: the bundle's region map).
        explore_steps
            Step budget of the frontier exploration per scene.
        explore_size
            (width, height) in pixels of the exploration camera.
        planning
            ``explored`` (plan on what exploration saw) or ``navmap`` (the bundle's navigable map).
        agent
            The agent's body, camera and ``eta_gt`` (default `AgentConfig()`).
        """
        super().__init__(nav, seed, agent)
        self.final_nav = self.nav.final_nav if final_nav is None else bool(final_nav)
        self.detector = detector
        self._gt: GroundTruthDetector | None = None
        self.receptacle_labels = receptacle_labels or ReceptacleConfig().labels
        self.relevance = relevance
        self.planes = planes
        self.region_of = region_of
        self.explore_steps = explore_steps
        self.explore_size = explore_size
        self.planning = planning
        self.memories: dict[str, SceneMemory] = {}
        self.wants_frame = False

    # -- memory (once per scene) -----------------------------------------------------------------

    def prepare(self, bundle, make_env: Callable[..., object]) -> None:
        """Explore the bundle's scene the first time it is seen and build the memory."""
        self.bundle = bundle
        if self.detector is None:
            self._gt = GroundTruthDetector(labels=goal_labels(bundle), agent=self.agent_config)
        if self.relevance is None and bundle.relevance is not None:
            self._relevance = bundle.relevance
        else:
            self._relevance = self.relevance
        scene = bundle.episodes[0].scene if bundle.episodes else bundle.name
        if scene in self.memories:
            return
        labels = bundle.instance_labels()
        if not labels and self.planes is None:
            raise InputError(bundle.root, "no instance labels (scene*.json SceneAsset) and no receptacle planes given")
        key = None
        if self.planes is None and self.region_of is None:  # memories of the built-in stages are shared by agents
            nm = bundle.navmap(bundle.episodes[0].floor if bundle.episodes else 0)
            key = (scene, hashlib.sha1(np.ascontiguousarray(nm.navigable).tobytes()).hexdigest(),
                   tuple(sorted(labels.items())), tuple(self.receptacle_labels), self.explore_steps,
                   tuple(self.explore_size), self.planning, dataclasses.replace(self.nav, final_nav=True),
                   self.agent_config)
            if key in _MEMORY_CACHE:
                mem, self.explored = _MEMORY_CACHE[key]
                self.memories[scene] = copy.copy(mem)  # own planning map: cells learned blocked stay with this agent
                return
        w, h = self.explore_size
        env = make_env(bundle, nav=self.nav, agent=self.agent_config, semantic=True, width=w, height=h,
                       max_steps=self.explore_steps + 100)
        frames, occ = explore(env, env.task.nav, max_steps=self.explore_steps)
        frame = env.task.navmap.frame
        trav = occ.traversable() if self.planning == "explored" else env.task.navmap.navigable
        region_of = self.region_of
        if region_of is None and bundle.region_map() is not None:
            region_of = bundle.region_map().region_at
        self.memories[scene] = build_memory(scene, frames, labels, trav, frame, self.receptacle_labels, self.planes,
                                            region_of, env.task.nav.depth_max)
        self.explored = {"frames": len(frames), "free_cells": int((occ.state == 1).sum()),
                         "steps": int(env.task.steps)}
        env.task.close()
        if key is not None:
            while len(_MEMORY_CACHE) >= _MEMORY_CACHE_SIZE:
                _MEMORY_CACHE.pop(next(iter(_MEMORY_CACHE)))
            _MEMORY_CACHE[key] = (copy.copy(self.memories[scene]), self.explored)

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the memory entries in visiting order."""
        raise NotImplementedError

    # -- one episode ---------------------------------------------------------------------------------

    def _detect(self) -> np.ndarray | None:
        """Return the goal mask in the current observation (None when not detected or not rendered)."""
        if not self.frame_fresh:
            return None
        category = str(self.ts.observation["objectgoal_text"])
        if self.detector is not None:
            return self.detector(self.ts.observation, category)
        return self._gt.category_mask(self.ts.observation.get("semantic"), category)

    def _rendered(self, action: int) -> Generator[int, object, None]:
        """Yield one action whose observation is rendered."""
        self.wants_frame = True
        yield action
        self.wants_frame = False

    def _observe(self) -> Generator[int, object, np.ndarray | None]:
        """Detect at pitches 0 and -tilt (current frame first); return the goal mask of a detection (or None)."""
        mask = self._detect()
        if mask is not None:
            return mask
        pitch = math.degrees(float(self.ts.observation["pitch"][0]))
        low = -self.nav.tilt_angle
        if self.frame_fresh:  # the current pitch is seen: look at the other one
            seq = [LOOK_DOWN] if pitch > low / 2 else [LOOK_UP]
        else:
            seq = [LOOK_DOWN, LOOK_UP] if pitch > low / 2 else [LOOK_UP, LOOK_DOWN]
        for a in seq:
            yield from self._rendered(a)
            mask = self._detect()
            if mask is not None:
                return mask
        return None

    def _camera(self) -> np.ndarray:
        o = self.ts.observation
        pos = np.asarray(o["position"], float)
        return pose_cv(pos + np.array([0.0, 0.0, self.agent_config.camera_height]), math.degrees(float(o["heading"][0])),
                       math.degrees(float(o["pitch"][0])))

    def _reconstruct(self, mask: np.ndarray) -> np.ndarray:
        """Return the goal object's world points (N, 3) from the masked depth (paper eq. 1-2)."""
        o = self.ts.observation
        return goal_points(o["depth"], mask, self.env.task.K, self._camera(), self.nav.depth_min, self.nav.depth_max)

    def _face(self, nv: Navigator, point: np.ndarray) -> Generator[int, object, None]:
        """Turn towards a point, rendering every turn's observation."""
        self.wants_frame = True
        yield from nv.face(np.asarray(point, float)[:2], self.ts)
        self.wants_frame = False

    def _reach(self, target: np.ndarray, nv: Navigator) -> Generator[int, object, bool]:
        """Walk onto a point within a few centimetres (exact forward/turn lattice plan); return success."""
        radius = 0.45 * self.nav.success_distance
        ok = yield from nv.goto(target, radius, self.ts)
        pos = np.asarray(self.ts.observation["position"], float)[:2]
        return bool(ok and np.linalg.norm(pos - target) <= radius + 1e-6)

    def _navigator(self, memory: SceneMemory) -> Navigator:
        """Return a navigator on the memory's planning map that learns cells the world refuses."""
        def blocked(pos: np.ndarray, yaw: float) -> None:
            cells = blocked_cells(memory.frame, pos, yaw, self.nav.forward_step)
            trav = memory.traversable.copy()  # a new array: planners cache graphs per mask object
            trav[cells[:, 0], cells[:, 1]] = False
            memory.traversable = trav

        return Navigator(self.nav, lambda: memory.traversable, memory.frame, on_blocked=blocked)

    def _verify(self, centre: np.ndarray, nv: Navigator) -> Generator[int, object, bool]:
        """Face the goal, tilt towards it and look: return whether the detector sees it from here."""
        self.frame_fresh = False
        yield from self._face(nv, centre)
        o = self.ts.observation
        cam = np.asarray(o["position"], float) + np.array([0.0, 0.0, self.agent_config.camera_height])
        want = math.degrees(math.atan2(centre[2] - cam[2], float(np.linalg.norm(centre[:2] - cam[:2]))))
        t = self.nav.tilt_angle
        want = float(np.clip(round(want / t) * t, -self.nav.max_tilt, self.nav.max_tilt))
        for _ in range(int(2 * self.nav.max_tilt / t) + 1):
            pitch = math.degrees(float(self.ts.observation["pitch"][0]))
            if abs(pitch - want) < t / 2:
                break
            yield from self._rendered(LOOK_UP if want > pitch else LOOK_DOWN)
        if self._detect() is not None:
            return True
        pitch = math.degrees(float(self.ts.observation["pitch"][0]))
        for a in ((LOOK_DOWN, LOOK_UP) if pitch > -self.nav.max_tilt + 1e-6 else (LOOK_UP,)):
            yield from self._rendered(a)
            if self._detect() is not None:
                return True
        return False

    def _final_nav(self, memory: SceneMemory, nv: Navigator, pts: np.ndarray) -> Generator[int, object, dict]:
        """FN: walk to the nearest inferred view point of the detected goal that the detector confirms."""
        centre = object_centre(pts)
        pos = np.asarray(self.ts.observation["position"], float)[:2]
        cands, _d = infer_view_points(pts, memory.traversable, memory.frame, pos, self.nav.fn_viewpoint_radius,
                                      self.nav.fn_viewpoint_step)
        tried = 0
        for c in cands:
            if tried >= self.nav.fn_max_checks:
                break
            if not (yield from self._reach(c, nv)):
                continue
            tried += 1
            if (yield from self._verify(centre, nv)):
                return {"fn_candidates": int(len(cands)), "fn_checks": tried, "fn_verified": True}
        return {"fn_candidates": int(len(cands)), "fn_checks": tried, "fn_verified": False}

    def _run(self, env) -> Generator[int, object, None]:
        scene = env.task.episode.scene
        memory = self.memories.get(scene)
        if memory is None:
            raise InputError(scene, "agent.prepare(bundle, make_env) was not called for this scene")
        rng = np.random.default_rng([self.seed, int(env.task.episode_index)])
        nv = self._navigator(memory)
        visited = 0
        for entry in self.order(memory, str(self.ts.observation["objectgoal_text"]), rng):
            pts = [p for p in entry.nav_points]
            while pts:
                pos = np.asarray(self.ts.observation["position"], float)[:2]
                k = int(np.argmin([np.linalg.norm(p - pos) for p in pts]))
                p_nav = pts.pop(k)
                yield from nv.goto(p_nav, self.nav.eps_nav, self.ts)
                self.frame_fresh = False
                yield from self._face(nv, entry.centre)
                visited += 1
                mask = yield from self._observe()
                if mask is not None:
                    goal = self._reconstruct(mask)
                    self.info = {"detected": True, "goal": object_centre(goal).tolist() if len(goal) else None,
                                 "nav_points": visited, "receptacle": entry.plane.label, "region": entry.region}
                    if self.final_nav and len(goal):
                        self.info.update((yield from self._final_nav(memory, nv, goal)))
                    yield STOP
                    return
                pos = np.asarray(self.ts.observation["position"], float)[:2]
                pts = [p for p in pts if np.linalg.norm(p - pos) >= self.nav.d_next]
        self.info = {"detected": False, "nav_points": visited}
        yield STOP


class RandomAStar(ReceptacleAStar):
    """Random A*: receptacles in a random order each episode (algorithm 3)."""

    name = "random-astar"

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the entries shuffled."""
        return [memory.entries[i] for i in rng.permutation(len(memory.entries))]


class SemanticAStar(ReceptacleAStar):
    """Semantic A*: receptacles by decreasing joint relevance P(g|region) * P(g|receptacle) (algorithm 4)."""

    name = "semantic-astar"

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the entries ranked by joint relevance (random among ties)."""
        return memory.ranked(category, self._relevance, rng)

