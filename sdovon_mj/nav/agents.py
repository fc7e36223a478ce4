"""Agents for the ObjectNav suite: Random A*, Semantic A* (paper appendix D), the no-prior Semantic Frontier
agent, and the labelled oracle and random references.

Agents are plugins (`plugins.load("agent", name)`, entry point group ``sdovon_mj.agents``); the
suite builds them as ``factory(nav=NavConfig, agent=AgentConfig, seed=int)`` (``nav.final_nav``
switches final point-goal navigation, ``nav.fn_mode`` picks the paper's FN or our lattice variant).
This package never imports the suite: environments come in through ``make_env`` and ``env``.

Every agent declares its `Knowledge` (detector, pose sensor, prior exploration, oracle parts, FN); the suite
grants exactly that (`sdovon_mj.suite.boundary`): the A* agents build receptacles, planes, regions and
relevance from the frames of their own exploration with the pipeline's stages (`memory.extract_planes`);
only agents that declare oracle parts read generator artefacts, and the tables label them.

Protocol (what `suite.evaluate` and any plugin agent follow):
    agent.knowledge                   what it uses (`sdovon_mj.knowledge.Knowledge`)
    agent.prepare(bundle, make_env)   once per bundle (an `AgentBundle`); A* agents explore a scene they do not
                                      know yet; ``make_env(bundle, **kwargs)`` returns an `AgentEnv`
    agent.reset(env, timestep)        at each episode start (``env``: an `AgentEnv`)
    action = agent.act(timestep)      one discrete action per step
    agent.wants_frame                 whether the next observation needs rendered images (runners
                                      may skip rendering otherwise; dm_env specs still hold)
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import math
from typing import Any, Callable, Generator

import numpy as np

from ..actions import LOOK_DOWN, LOOK_UP, OPEN, STOP, TURN_LEFT
from ..config import AgentConfig, NavConfig, PerceiveConfig, ReceptacleConfig, SemanticsConfig
from ..errors import InputError
from ..grid import segment_free
from ..gridgraph import GeodesicField
from ..knowledge import Knowledge
from ..records import Observation, Relevance
from ..sim.camera import pose_cv
from .control import Navigator, blocked_cells, lattice_approach, segment_checker
from .frontier import OccupancyMap, agent_frame, explore, scan_actions
from .goal import approach_point, footprint_distance, goal_points, infer_view_points, object_centre
from .memory import RANKINGS, SceneMemory, build_memory, container_planes, extract_planes

# Receptacles the A* agents try to open (OPEN) when they do not see the goal at them: furniture with doors or
# drawers, named by the labels their detector gives (what a robot that knows such furniture opens would try).
OPENABLE_LABELS = ("cabinet", "kitchen cabinet", "wall cabinet", "cupboard", "dresser", "chest of drawers", "drawer",
                   "wardrobe", "closet", "fridge", "refrigerator", "microwave", "nightstand", "oven", "dishwasher")

# Scene memories built by exploration, shared by every A* agent of a process (eval runs four agents
# over the same scenes); keyed by scene, navmap, labels and exploration settings.
_MEMORY_CACHE: dict[tuple, tuple[SceneMemory, dict]] = {}
_MEMORY_CACHE_SIZE = 32


class Agent:
    """Base agent: generator-driven policies; `_run` yields actions and reads `self.ts`."""

    name = "agent"
    knowledge = Knowledge()

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
        self.frame_fresh = True  # whether the current observation's images were rendered (the suite renders resets)
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
        digest = hashlib.sha256(env.episode_id.encode("utf-8")).hexdigest()
        rng = np.random.default_rng([self.seed, int(digest[:8], 16)])
        while True:
            yield STOP if rng.random() < self.p_stop else int(rng.integers(1, 6))


class OracleAgent(Agent):
    """ORACLE (labelled upper bound): walks the shortest path to the nearest view point, lines up, stops.

    It reads the generator's navigable map and view points (`Knowledge.oracle`).
    """

    name = "oracle"
    knowledge = Knowledge(pose="absolute", oracle=("navmap", "view_points"), fn="lattice")

    def __init__(self, nav: NavConfig | None = None, seed: int = 0, stop: bool = True,
                 agent: AgentConfig | None = None) -> None:
        super().__init__(nav, seed, agent)
        self.stop = stop
        self.wants_frame = False

    def prepare(self, bundle, make_env: Callable[..., object]) -> None:
        """Keep the bundle (its oracle part is read per episode)."""
        self.bundle = bundle

    def _run(self, env) -> Generator[int, object, None]:
        oracle = self.bundle.oracle
        vps3 = oracle.view_points(env.episode_id)
        nm = oracle.navmap(oracle.episode_floor(env.episode_id))
        mask, frame = nm.navigable, nm.frame
        pos = np.asarray(self.ts.observation["position"], float)[:2]
        from_agent = GeodesicField(mask, frame, pos[None])
        vps = vps3[:, :2]
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


class ReceptacleAStar(Agent):
    """Receptacle search with A* (paper algorithms 3/4); subclasses choose the receptacle order.

    Knowledge: the ground-truth detector, its pose in the scene frame (localized, as the paper's agents), and
    what it built itself when it first explored the scene (appendix D): receptacles, planes and regions from
    its own frames with the pipeline's stages, relevance from the semantics backend. Optional privileges
    (``oracle_parts``) make it a labelled oracle variant, for the ablation of what each was worth.
    """

    name = "receptacle-astar"

    def __init__(self, nav: NavConfig | None = None, seed: int = 0, final_nav: bool | None = None,
                 receptacle_labels: tuple[str, ...] | None = None, explore_steps: int = 3000,
                 explore_size: tuple[int, int] = (160, 120), semantics: SemanticsConfig | None = None,
                 perceive: PerceiveConfig | None = None, oracle_parts: tuple[str, ...] = (),
                 agent: AgentConfig | None = None, open_labels: tuple[str, ...] = OPENABLE_LABELS,
                 open_tries: int = 3) -> None:
        """Build the agent.

        Parameters
        ----------
        nav
            Actions, tolerances and FN settings (default `NavConfig()`).
        seed
            Seed of the receptacle order's random choices.
        final_nav
            Final navigation after a detection; default ``nav.final_nav`` (``nav.fn_mode``: paper or lattice).
        receptacle_labels
            Labels of receptacles to visit (default `ReceptacleConfig().labels`; empty: the semantics backend
            names them among the labels it detected, prompt C.1).
        explore_steps
            Step budget of the frontier exploration per scene.
        explore_size
            (width, height) in pixels of the exploration camera.
        semantics
            The semantics backend and region-map settings of its own ExtractPlanes (default `SemanticsConfig()`).
        perceive
            Fusion settings of its own ExtractPlanes (default `PerceiveConfig()`).
        oracle_parts
            Privileges, each making it a labelled oracle variant: ``navmap`` (plan on the generator's navigable
            map), ``region_map``, ``relevance`` (the table that drove placement), ``instance_labels``.
        agent
            The agent's body, camera and ``eta_gt`` (default `AgentConfig()`).
        open_labels
            Receptacle labels the agent treats as furniture with doors or drawers (default `OPENABLE_LABELS`): it
            keeps such pieces in its memory even when exploration found no plane on them (a closed fridge), and at
            each of their navigation points where it does not see the goal it tries OPEN (issue 17). Empty: never.
        open_tries
            OPEN actions tried at one navigation point at most; it stops trying when an OPEN changes nothing it
            sees (no part was in reach).
        """
        super().__init__(nav, seed, agent)
        self.open_labels = tuple(l.lower() for l in open_labels)
        self.open_tries = int(open_tries)
        self.opened = 0  # parts opened in the current episode (info['opened'])
        self.final_nav = self.nav.final_nav if final_nav is None else bool(final_nav)
        self.receptacle_labels = ReceptacleConfig().labels if receptacle_labels is None else tuple(receptacle_labels)
        self.explore_steps = explore_steps
        self.explore_size = explore_size
        self.semantics = semantics or SemanticsConfig()
        self.perceive = perceive or PerceiveConfig()
        self.oracle_parts = tuple(oracle_parts)
        self.knowledge = Knowledge(detector="gt", pose="absolute", prior="scene", oracle=self.oracle_parts,
                                   fn=self.nav.fn_mode if self.final_nav else "-")
        self.memories: dict[str, SceneMemory] = {}
        self._relevance: dict[tuple[str, str], Relevance] = {}
        self._backend = None
        self.wants_frame = False

    # -- memory (once per scene) -----------------------------------------------------------------

    def backend(self):
        """Return the semantics backend of the agent's own ExtractPlanes and relevance (built once)."""
        if self._backend is None:
            from ..semantics import get_backend

            self._backend = get_backend(self.semantics)
        return self._backend

    def prepare(self, bundle, make_env: Callable[..., object]) -> None:
        """Explore the bundle's scene the first time it is seen and build the memory (ExtractPlanes)."""
        self.bundle = bundle
        self.detector = bundle.detector
        scene = bundle.scene
        if scene in self.memories:
            return
        key = (scene, tuple(self.receptacle_labels), self.open_labels, self.explore_steps, tuple(self.explore_size), self.oracle_parts,
               dataclasses.replace(self.nav, final_nav=True, fn_mode="paper"), self.agent_config, self.semantics,
               self.perceive, tuple(sorted(getattr(self.detector, "labels", {}).items())))
        if key in _MEMORY_CACHE:
            mem, self.explored = _MEMORY_CACHE[key]
            self.memories[scene] = copy.copy(mem)  # own planning map: cells learned blocked stay with this agent
            return
        w, h = self.explore_size
        env = make_env(bundle, nav=self.nav, agent=self.agent_config, width=w, height=h,
                       max_steps=self.explore_steps + 100)
        frames, occ = explore(env, self.nav, max_steps=self.explore_steps)
        labels = self.receptacle_labels
        if not labels:  # the backend names the receptacles among what the agent detected (prompt C.1)
            from ..semantics import identify_receptacles

            seen = sorted({d.label for f in frames for d in self.detector.detect(f)})
            labels = tuple(identify_receptacles(seen, self.backend()))
        instances, planes, rm, navmap = extract_planes(frames, self.detector, labels, occ, self.backend(),
                                                       self.perceive, ReceptacleConfig(), self.semantics)
        if self.open_labels:  # furniture with doors or drawers but no plane seen (a closed fridge): keep it too
            planes = planes + container_planes(instances, planes, self.open_labels, navmap, rm)
        trav, frame = occ.traversable(), occ.frame
        if "navmap" in self.oracle_parts:  # ORACLE: plan on the generator's map
            nm = bundle.oracle.navmap(0)
            trav, frame = nm.navigable, nm.frame
        if "region_map" in self.oracle_parts:  # ORACLE: the generator's regions
            true_rm = bundle.oracle.region_map(0)
            if true_rm is not None:
                planes = [dataclasses.replace(pl, region=true_rm.region_at(np.asarray(pl.polygon, float).mean(axis=0))
                                              or pl.region) for pl in planes]
        self.memories[scene] = build_memory(scene, [], {}, trav, frame, labels, planes)
        self.memories[scene].instances = instances
        self.explored = {"frames": len(frames), "free_cells": int((occ.state == 1).sum()), "steps": int(env.steps),
                         "instances": len(instances), "planes": len(planes),
                         "regions": sorted({pl.region for pl in planes if pl.region})}
        env.close()
        while len(_MEMORY_CACHE) >= _MEMORY_CACHE_SIZE:
            _MEMORY_CACHE.pop(next(iter(_MEMORY_CACHE)))
        _MEMORY_CACHE[key] = (copy.copy(self.memories[scene]), self.explored)

    def relevance_for(self, memory: SceneMemory, category: str) -> Relevance | None:
        """Return the relevance of a goal category to the memory's (region, receptacle) pairs.

        From the semantics backend (cached per scene and category); the generator's table only for the
        ``relevance`` oracle variant.
        """
        if "relevance" in self.oracle_parts:
            return self.bundle.oracle.relevance
        key = (memory.scene, category, tuple(self.bundle.categories))
        if key not in self._relevance:
            from ..semantics import relevance

            regions = sorted({e.region for e in memory.entries if e.region} | set(self.semantics.region_labels))
            recs = sorted({e.plane.label for e in memory.entries})
            # over every goal category of the dataset: P(o|rec) and P(o|rgn) are normalised over the object list
            objects = sorted(set(self.bundle.categories) | {category})
            self._relevance[key] = relevance(objects, regions, recs, self.backend()) if recs else None
        return self._relevance[key]

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the memory entries in visiting order."""
        raise NotImplementedError

    # -- one episode ---------------------------------------------------------------------------------

    def _detect(self) -> np.ndarray | None:
        """Return the goal mask in the current observation (None when not detected or not rendered)."""
        if not self.frame_fresh:
            return None
        category = str(self.ts.observation["objectgoal_text"])
        return self.detector.category_mask(self.ts.observation.get("semantic"), category)

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

    def _look_around(self) -> Generator[int, object, np.ndarray | None]:
        """The rest of Observe o ~ O(p|s) at a navigation point: the other ``nav.look_yaws - 1`` yaws (360 deg /
        look_yaws apart, turning left), each seen at pitches 0 and -tilt (`_observe`); return the goal mask of the
        first detection (or None)."""
        n = int(self.nav.look_yaws)
        if n <= 1:
            return None
        turns = max(1, int(round(360.0 / n / self.nav.turn_angle)))
        for _ in range(n - 1):
            for _t in range(turns - 1):
                yield TURN_LEFT
            if self.env.steps >= self.nav.max_steps - 20:
                return None
            yield from self._rendered(TURN_LEFT)
            mask = yield from self._observe()
            if mask is not None:
                return mask
        return None

    def _open_and_look(self) -> Generator[int, object, np.ndarray | None]:
        """Try OPEN (up to ``open_tries`` times) at the piece in front and look after each; return a goal mask or None.

        The agent sees what an OPEN did: when its depth image does not change, nothing was in reach and it stops
        trying. Parts it opened stay open (``info['opened']`` counts them).
        """
        for _ in range(self.open_tries):
            if self.env.steps >= self.nav.max_steps - 20:
                return None
            before = np.asarray(self.ts.observation["depth"], float).copy()
            yield from self._rendered(OPEN)
            after = np.asarray(self.ts.observation["depth"], float)
            if not np.any(np.abs(after - before) > 0.02):
                return None
            self.opened += 1
            mask = self._detect()
            if mask is None:
                mask = yield from self._observe()
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
        return goal_points(o["depth"], mask, self.env.K, self._camera(), self.nav.depth_min, self.nav.depth_max)

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
        """FN after a detection: the paper's (default) or our lattice variant (``nav.fn_mode``)."""
        if self.nav.fn_mode == "lattice":
            return (yield from self._final_nav_lattice(memory, nv, pts))
        return (yield from self._final_nav_paper(memory, nv, pts))

    def _final_nav_paper(self, memory: SceneMemory, nv: Navigator, pts: np.ndarray) -> Generator[int, object, dict]:
        """The paper's FN: Navigate(p_g | eps_nav) to the detected object's centre, then STOP with it in view.

        p_g usually stands on furniture: the agent drives towards the reachable cell of its map nearest to p_g
        and stops as soon as it is within eps_nav of p_g, faces the object and looks. An agent whose map grows with
        what it sees (the no-prior agent) plans again from there while that brings it closer. Where Navigate ended
        counts when the agent sees the object from there and stands within eps_nav of p_g or within the view radius
        ``nav.fn_viewpoint_radius`` (less half a step) of the object's seen points (`footprint_distance`: the
        furniture under it can keep every free cell farther than eps_nav). Otherwise it tries other places of its map
        within the view radius of p_g (at most ``nav.fn_max_checks`` places in all, nearest by path first) and stops
        at the first that shows the object. ``fn_reached`` in the result: it came within eps_nav of p_g.
        """
        centre = object_centre(pts)
        half = self.nav.forward_step / 2.0

        def away() -> float:
            return float(np.linalg.norm(np.asarray(self.ts.observation["position"], float)[:2] - centre[:2]))

        seen = False
        looked = False
        while away() > self.nav.eps_nav + 1e-6 and self.env.steps < self.nav.max_steps - 10:
            # straight towards p_g when the agent's map shows that way free, else to the nearest reachable cell
            pos = np.asarray(self.ts.observation["position"], float)[:2]
            direct = centre[:2] + (pos - centre[:2]) / max(away(), 1e-9) * (self.nav.eps_nav - half)
            if segment_free(memory.traversable, memory.frame, pos, direct):
                target, tol = direct, half
            else:
                target = approach_point(centre, memory.traversable, memory.frame, pos)
                if target is None:
                    break
                tol = max(half, self.nav.eps_nav - float(np.linalg.norm(target - centre[:2])))
                if float(np.linalg.norm(target - pos)) <= tol:
                    break  # the agent stands where its map lets it come closest
            start = away()
            yield from nv.goto(target, tol, self.ts)
            seen = yield from self._verify(centre, nv)
            looked = True
            # Navigate(p_g | eps_nav): an agent whose map grows with what it sees (`_map_grew`) plans again from
            # here while each round brings it closer; a map built in advance has nothing new to plan with
            if not self._map_grew(memory) or away() > start - half:
                break
            looked = False
        reached = away() <= self.nav.eps_nav + 1e-6
        if not looked:
            seen = yield from self._verify(centre, nv)
        # where Navigate ended counts when it shows the object and lies within eps_nav of p_g, or within the view radius
        # of the object's points (the furniture under p_g keeps the agent farther than eps_nav), half a step to spare
        near = reached or footprint_distance(self.ts.observation["position"], pts) <= self.nav.fn_viewpoint_radius - half
        tried = 0
        if not (near and seen):
            # "then STOP with the object in view", close by: where Navigate stopped does not show it (the
            # receptacle's edge hides it from close by, the nearest free cell is behind the piece) or is farther
            # than eps_nav (no free cell nearer): other places of the agent's map within the view radius
            # (nav.fn_viewpoint_radius) of p_g, nearest by path first, forward_step apart, each checked by looking
            pos = np.asarray(self.ts.observation["position"], float)[:2]
            cands, _d = infer_view_points(centre[None], memory.traversable, memory.frame, pos,
                                          self.nav.fn_viewpoint_radius, self.nav.forward_step)
            for c in cands:
                if tried >= self.nav.fn_max_checks - 1 or self.env.steps >= self.nav.max_steps - 10:
                    break
                if np.linalg.norm(c - np.asarray(self.ts.observation["position"], float)[:2]) < half:
                    continue
                # a place to look from, not a point to stand on exactly: within half a step (the candidates' spacing)
                if not (yield from nv.goto(c, half, self.ts)):
                    continue
                tried += 1
                seen = yield from self._verify(centre, nv)
                if seen:
                    break
        return {"fn": "paper", "fn_reached": bool(reached), "fn_verified": bool(seen), "fn_checks": tried}

    def _map_grew(self, memory: SceneMemory) -> bool:
        """Add what the agent sees now to its planning map; return whether it did (an A* agent plans on the map of its
        first visit, so its map does not grow during an episode)."""
        return False

    def _final_nav_lattice(self, memory: SceneMemory, nv: Navigator, pts: np.ndarray) -> Generator[int, object, dict]:
        """Our FN variant: walk to the nearest inferred lattice view point of the goal that the detector confirms."""
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
                return {"fn": "lattice", "fn_candidates": int(len(cands)), "fn_checks": tried, "fn_verified": True}
        return {"fn": "lattice", "fn_candidates": int(len(cands)), "fn_checks": tried, "fn_verified": False}

    def _found(self, memory: SceneMemory, nv: Navigator, mask: np.ndarray, entry, visited: int) -> Generator[int, object, None]:
        """The goal is detected: reconstruct it, run FN (when on) and STOP."""
        goal = self._reconstruct(mask)
        self.info = {"detected": True, "goal": object_centre(goal).tolist() if len(goal) else None,
                     "nav_points": visited, "receptacle": entry.plane.label if entry else "",
                     "region": entry.region if entry else "", "opened": self.opened}
        if self.final_nav and len(goal):
            self.info.update((yield from self._final_nav(memory, nv, goal)))
        yield STOP

    def _run(self, env) -> Generator[int, object, None]:
        scene = env.scene
        memory = self.memories.get(scene)
        if memory is None:
            raise InputError(scene, "agent.prepare(bundle, make_env) was not called for this scene")
        rng = np.random.default_rng([self.seed, int(env.episode_index)])
        nv = self._navigator(memory)
        visited = 0
        self.opened = 0
        mask = self._detect()  # the goal may be in view where the episode starts
        if mask is not None:
            yield from self._found(memory, nv, mask, None, visited)
            return
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
                if mask is None and entry.plane.label.lower() in self.open_labels:
                    mask = yield from self._open_and_look()
                if mask is None:
                    mask = yield from self._look_around()
                if mask is not None:
                    yield from self._found(memory, nv, mask, entry, visited)
                    return
                pos = np.asarray(self.ts.observation["position"], float)[:2]
                pts = [p for p in pts if np.linalg.norm(p - pos) >= self.nav.d_next]
        self.info = {"detected": False, "nav_points": visited, "opened": self.opened}
        yield STOP


class RandomAStar(ReceptacleAStar):
    """Random A*: receptacles in a random order each episode (algorithm 3)."""

    name = "random-astar"

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the entries shuffled."""
        return [memory.entries[i] for i in rng.permutation(len(memory.entries))]


class SemanticAStar(ReceptacleAStar):
    """Semantic A*: receptacles by decreasing joint relevance of the goal to their region-receptacle pair (algorithm 4).

    ``ranking`` (keyword, default ``placement``): the paper's joint relevance, the goal's share of the placement
    direction at each pair among the pairs it found (`SceneMemory.ranked`); ``search``: the search direction
    (`Relevance.pair_score`, where people would put the goal, whatever else the home keeps there).
    """

    name = "semantic-astar"

    def __init__(self, *args: Any, ranking: str = "placement", **kwargs: Any) -> None:
        if ranking not in RANKINGS:
            raise ValueError(f"unknown ranking {ranking!r} ({' or '.join(RANKINGS)})")
        super().__init__(*args, **kwargs)
        self.ranking = ranking

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the entries ranked by relevance to the goal (random among ties)."""
        return memory.ranked(category, self.relevance_for(memory, category), rng, self.ranking)



class SemanticFrontierAgent(ReceptacleAStar):
    """No prior knowledge (the paper's VLFM / L3MVN rows): frontier exploration scored by semantics, per episode.

    Each episode starts from nothing (no memory of earlier episodes, GPS+compass only: it works in its
    start frame). It scans, builds an occupancy map from depth, and drives to the frontier with the best
    utility ``(0.1 + s) / (1 + d / 5 m)``, where ``d`` is the path length to it and ``s`` the highest relevance
    P(goal | label), from the semantics backend, of the labels its detector reported within
    ``nav.frontier_radius`` of the frontier (L3MVN-style; `Relevance.pair_score` in the label's best region,
    as the agent does not know the regions). When the detector sees the goal it runs FN and stops; during FN it adds
    the depth of each look at the goal to its map and plans again from it (`_map_grew`).
    """

    name = "semantic-frontier"

    def __init__(self, nav: NavConfig | None = None, seed: int = 0, final_nav: bool | None = None,
                 semantics: SemanticsConfig | None = None, agent: AgentConfig | None = None) -> None:
        """Build the agent (parameters as `ReceptacleAStar`'s of the same names)."""
        super().__init__(nav, seed, final_nav, semantics=semantics, agent=agent)
        self.knowledge = Knowledge(detector="gt", pose="gps+compass", prior="none",
                                   fn=self.nav.fn_mode if self.final_nav else "-")
        self._occ: OccupancyMap | None = None  # the current episode's occupancy map

    def prepare(self, bundle, make_env: Callable[..., object]) -> None:
        """Nothing to learn in advance: keep the detector and the goal categories."""
        self.bundle = bundle
        self.detector = bundle.detector

    def _map_grew(self, memory: SceneMemory) -> bool:
        """Add the depth of the current frame (when rendered) to the episode's occupancy map and plan on it."""
        occ = self._occ
        if occ is None or not self.frame_fresh:
            return False
        occ.integrate(self.ts.observation["depth"], self.env.K, self._camera(), self.nav.depth_max)
        memory.traversable = occ.traversable()
        return True

    def _scores(self, category: str, labels: list[str]) -> dict[str, float]:
        """Return label -> relevance of the goal category to it (the backend's P(goal | label))."""
        from ..semantics import relevance

        labels = sorted(set(labels) - {category})
        if not labels:
            return {}
        key = (category, tuple(labels), tuple(self.bundle.categories))
        if key not in self._relevance:
            objects = sorted(set(self.bundle.categories) | {category})
            self._relevance[key] = relevance(objects, sorted(self.semantics.region_labels), labels, self.backend())
        rel = self._relevance[key]
        return {lab: max(rel.pair_score(category, r, lab) for r in rel.regions) for lab in labels}

    def _run(self, env) -> Generator[int, object, None]:
        from scipy.sparse.csgraph import dijkstra

        from ..gridgraph import cell_graph
        from ..grid import nearest_true

        category = str(self.ts.observation["objectgoal_text"])
        frame = agent_frame(np.zeros(2), self.nav.map_size, self.nav.map_resolution)
        occ = self._occ = OccupancyMap(frame, floor_z=0.0, agent=self.agent_config)
        occ.mark_free_disc(np.zeros(2), self.agent_config.radius + 0.05)
        seen: list[tuple[np.ndarray, str]] = []  # (world XY in the start frame, label) of detections
        nv = Navigator(self.nav, occ.traversable, frame,
                       on_blocked=lambda p, yaw: occ.mark_blocked(blocked_cells(frame, p, yaw, self.nav.forward_step)))
        visits = 0
        budget = self.nav.max_steps - 40  # leave room for FN

        def look() -> np.ndarray | None:
            o = self.ts.observation
            T = self._camera()
            occ.integrate(o["depth"], self.env.K, T, self.nav.depth_max)
            obs = Observation(rgb=o["rgb"], depth=o["depth"][..., 0], K=self.env.K, T_cam=T,
                              segmentation=o.get("semantic"), view_id=self.env.steps)
            for det in self.detector.detect(obs):
                pts = goal_points(o["depth"], det.mask, self.env.K, T, self.nav.depth_min, self.nav.depth_max)
                if len(pts):
                    seen.append((np.median(pts[:, :2], axis=0), det.label))
            return self._detect()

        while self.env.steps < budget:
            mask = look() if self.frame_fresh else None
            for _ in range(scan_actions(self.nav.turn_angle)):
                if mask is not None or self.env.steps >= budget:
                    break
                yield from self._rendered(TURN_LEFT)
                mask = look()
            if mask is not None:
                goal = self._reconstruct(mask)
                self.info = {"detected": True, "goal": object_centre(goal).tolist() if len(goal) else None,
                             "frontiers": visits}
                if self.final_nav and len(goal):
                    mem = SceneMemory(env.scene, frame, occ.traversable())
                    self.info.update((yield from self._final_nav(mem, nv, goal)))
                yield STOP
                return
            pos = np.asarray(self.ts.observation["position"], float)[:2]
            occ.mark_free_disc(pos, self.agent_config.radius + 0.05)
            trav = occ.traversable()
            clusters = occ.frontiers()
            rc = frame.to_cell(pos[None])[0]
            if not trav[rc[0], rc[1]]:
                near = nearest_true(trav, rc)
                rc = near if near is not None else rc
            if not clusters or not trav[rc[0], rc[1]]:
                break
            g, index = cell_graph(trav)
            dist = dijkstra(g, indices=int(index[rc[0], rc[1]]))
            scores = self._scores(category, [lab for _xy, lab in seen])
            best, best_u = None, -1.0
            for cells in clusters:
                d = dist[index[cells[:, 0], cells[:, 1]]] * frame.resolution
                k = int(np.argmin(d))
                if not np.isfinite(d[k]) or d[k] < 0.5:
                    continue
                xy = frame.to_world(cells[k][None])[0]
                near_labels = [lab for q, lab in seen if np.linalg.norm(q - xy) <= self.nav.frontier_radius]
                s = max((scores.get(lab, 0.0) for lab in near_labels), default=0.0)
                u = (0.1 + s) / (1.0 + float(d[k]) / 5.0)
                if u > best_u:
                    best, best_u = xy, u
            if best is None:
                break
            visits += 1
            yield from nv.goto(best, 0.25, self.ts)
        self.info = {"detected": False, "frontiers": visits}
        yield STOP
