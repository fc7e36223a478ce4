"""Agents for the ObjectNav suite: Random A*, Semantic A* (paper appendix D) and its distance-aware variant, the
no-prior Semantic Frontier agent, and the labelled oracle and random references.

Agents are plugins (`plugins.load("agent", name)`, entry point group ``sdovon_mj.agents``); the evaluation builds
them as ``factory(nav=NavConfig, agent=AgentConfig, seed=int)`` in their own process (``nav.final_nav`` switches
final point-goal navigation, ``nav.fn_mode`` picks the paper's FN, our FN with retries, or our lattice variant).
This package never imports the suite: what the agent gets comes in through the protocol's calls.

Every agent declares its `Knowledge` (detector, pose sensor, prior exploration and its step budget, oracle parts,
FN); the evaluation grants exactly that (`sdovon_mj.suite.protocol`): the A* agents build receptacles, planes,
regions and relevance from the frames of their own first visit with the pipeline's stages
(`memory.extract_planes`); only agents that declare oracle parts get generator artefacts, and the tables label them.

Protocol (what `suite.protocol.AgentRunner` calls, in the agent's process; docs/evaluation.md):
    agent.knowledge               what it uses (`sdovon_mj.knowledge.Knowledge`)
    agent.setup(sensors)          once: `suite.observation.Sensors` (camera, intrinsics K, actions, step limit,
                                  the dataset's vocabulary)
    agent.explore(view, ts)       prior="scene" only: the first visit of ``view.scene`` begins (no goal, a step
                                  budget of ``view.max_steps``); then act() until it returns STOP
    agent.reset(view, ts)         an episode begins (``view``: scene, episode id and index, steps, step limit)
    action = agent.act(ts)        one discrete action per time step (dm_env TimeStep, reward None)
    agent.end(view, ts)           the phase is over (STOP or its step limit); ``agent.info`` is read after it
    agent.wants_frame             whether the next observation needs rendered images (blank frames otherwise)
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from typing import Any, Generator

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
from .frontier import Explorer, OccupancyMap, agent_frame, scan_actions
from .goal import (approach_point, footprint_distance, goal_points, infer_view_points, mask_bearing, object_centre,
                   reachable_field)
from .memory import RANKINGS, SceneMemory, build_memory, container_planes, extract_planes
from .sensing import CategoryDetector

# Receptacles the A* agents try to open (OPEN) when they do not see the goal at them: furniture with doors or
# drawers, named by the labels their detector gives (what a robot that knows such furniture opens would try).
OPENABLE_LABELS = ("cabinet", "kitchen cabinet", "wall cabinet", "cupboard", "dresser", "chest of drawers", "drawer",
                   "wardrobe", "closet", "fridge", "refrigerator", "microwave", "nightstand", "oven", "dishwasher")

# A goal seen only beyond the depth range: walks along its bearing to look again, at most this many.
FAR_APPROACHES = 3

# Two poses stand on the same floor when their heights differ by less than this (m): a storey is more than twice it
# (the default world's are 3 m; HM3D / MP3D storeys 2.5-3.5 m), steps of a split level less.
FLOOR_TOLERANCE = 1.0


class Agent:
    """Base agent: generator-driven policies; `_run` (an episode) and `_explore` (a first visit) yield actions and
    read `self.ts`; ``self.env`` is the protocol's view of the current phase (`suite.protocol.AgentView`)."""

    name = "agent"
    knowledge = Knowledge()

    def __init__(self, nav: NavConfig | None = None, seed: int = 0, agent: AgentConfig | None = None) -> None:
        self.nav = nav or NavConfig()
        self.agent_config = agent or AgentConfig()  # body, camera and eta_gt the agent assumes
        self.seed = seed
        self.wants_frame = True
        self._gen: Generator[int, object, None] | None = None
        self.ts = None
        self.info: dict = {}
        self.sensors: Any = None
        self.detector: CategoryDetector | None = None
        self.object_categories: tuple[str, ...] = ()  # the dataset's object categories (`Vocabulary.object_categories`)

    def setup(self, sensors: Any) -> None:
        """Keep the sensors; with the ground-truth detector declared, detect instances in the category image."""
        self.sensors = sensors
        self.object_categories = tuple(sensors.vocabulary.object_categories)  # relevance is normalised over them
        if sensors.knowledge.detector == "gt":
            self.detector = CategoryDetector(sensors.vocabulary.labels, sensors.eta)

    def _start(self, view: Any, ts: Any, gen: Generator[int, object, None]) -> None:
        self.env, self.ts = view, ts
        self.info = {}
        self._gen = gen
        self._started = False
        self.frame_fresh = True  # whether the current observation's images were rendered (a phase's first one is)
        self._render_next = False

    def explore(self, view: Any, ts: Any) -> None:
        """Start the first visit of a scene (agents that declare ``prior="scene"``)."""
        self._start(view, ts, self._explore(view))

    def reset(self, view: Any, ts: Any) -> None:
        """Start an episode."""
        self._start(view, ts, self._run(view))

    def end(self, view: Any, ts: Any) -> None:
        """The phase is over (default: nothing to do)."""

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

    def _explore(self, env) -> Generator[int, object, None]:
        yield STOP

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

    def _run(self, env) -> Generator[int, object, None]:
        oracle = env.oracle
        vps3 = oracle.view_points()
        nm = oracle.navmap(oracle.episode_floor())
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
    what it built itself on its first visit of the scene (appendix D; ``explore_steps``, the evaluator's exploration
    phase): receptacles, planes and regions from its own frames with the pipeline's stages, relevance from the
    semantics backend. Optional privileges (``oracle_parts``) make it a labelled oracle variant, for the ablation
    of what each was worth.
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
            Step budget of its first visit of each scene (declared: `Knowledge.explore_steps`).
        explore_size
            (width, height) in pixels at which it keeps the first visit's frames (and integrates their depth):
            every n-th pixel of the sensor's images, n = sensor width // width.
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
        self.far = 0  # walks towards a goal seen beyond the depth range (info['far_approaches'])
        self.explored: dict = {}  # what the first visit built (the exploration phase's info)
        self.final_nav = self.nav.final_nav if final_nav is None else bool(final_nav)
        self.receptacle_labels = ReceptacleConfig().labels if receptacle_labels is None else tuple(receptacle_labels)
        self.explore_steps = explore_steps
        self.explore_size = explore_size
        self.semantics = semantics or SemanticsConfig()
        self.perceive = perceive or PerceiveConfig()
        self.oracle_parts = tuple(oracle_parts)
        self.knowledge = Knowledge(detector="gt", pose="absolute", prior="scene", oracle=self.oracle_parts,
                                   fn=self.nav.fn_mode if self.final_nav else "-", explore_steps=int(explore_steps))
        self.memories: dict[tuple[str, float], SceneMemory] = {}  # (scene, floor height in m) -> its first visit's
        self._explore_key: tuple[str, float] | None = None  # the first visit under way
        self._memory_key: tuple[str, float] | None = None  # the memory the current episode plans on
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

    def _height(self) -> float:
        """Return the height of the floor the agent stands on (its localized pose's z, m)."""
        return round(float(np.asarray(self.ts.observation["position"], float)[2]), 2)

    def memory_key(self, scene: str, z: float) -> tuple[str, float] | None:
        """Return the key of the memory of `scene`'s first visit of the floor at height `z` (m), None without one.

        A multi-storey home gets one first visit per floor with episodes (the evaluator starts each on its floor,
        as a robot carried there); an episode plans on its own floor's memory.
        """
        near = [(abs(h - z), h) for (sc, h) in self.memories if sc == scene and abs(h - z) < FLOOR_TOLERANCE]
        return (scene, min(near)[1]) if near else None

    def _explore(self, env) -> Generator[int, object, None]:
        """The first visit of a floor: frontier exploration (`frontier.Explorer`), then ExtractPlanes on its frames;
        STOP."""
        self._explore_key = (env.scene, self._height())
        if self.memory_key(*self._explore_key) is not None:  # visited before: nothing to learn
            yield STOP
            return
        s = max(1, int(round(self.sensors.width / max(1, int(self.explore_size[0])))))
        self._explorer = Explorer(self.nav, self.agent_config, self.sensors.K, max_steps=env.max_steps - 1, downsample=s)
        gen = self._explorer.run(self.ts)
        try:
            a, render = next(gen)
            while True:
                self.wants_frame = render
                ts = yield a
                a, render = gen.send(ts)
        except StopIteration:
            pass
        self.wants_frame = False
        self._build_memory(env)
        yield STOP

    def end(self, view: Any, ts: Any) -> None:
        """After a first visit the evaluator ended (its step budget): build the memory from what was seen."""
        if view.phase == "explore" and getattr(self, "_explorer", None) is not None:
            self._build_memory(view)
        if view.phase == "explore":
            self.info = dict(self.explored)
        elif self._memory_key is not None:  # the floor whose memory the episode planned on
            self.info["memory_floor_z"] = self._memory_key[1]

    def _build_memory(self, env) -> None:
        """ExtractPlanes on the first visit's frames: instances, receptacle planes, regions -> the scene's memory."""
        ex, self._explorer = self._explorer, None
        frames, occ = ex.frames, ex.occ
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
        key = self._explore_key
        floor = env.oracle.floor_at(key[1]) if {"navmap", "region_map"} & set(self.oracle_parts) else 0
        if "navmap" in self.oracle_parts:  # ORACLE: plan on the generator's map
            nm = env.oracle.navmap(floor)
            trav, frame = nm.navigable, nm.frame
        if "region_map" in self.oracle_parts:  # ORACLE: the generator's regions
            true_rm = env.oracle.region_map(floor)
            if true_rm is not None:
                planes = [dataclasses.replace(pl, region=true_rm.region_at(np.asarray(pl.polygon, float).mean(axis=0))
                                              or pl.region) for pl in planes]
        self.memories[key] = build_memory(env.scene, [], {}, trav, frame, labels, planes)
        self.memories[key].instances = instances
        self.explored = {"floor_z": key[1], "frames": len(frames), "free_cells": int((occ.state == 1).sum()),
                         "steps": int(ex.steps), "instances": len(instances), "planes": len(planes), "stop_reason": occ.stop_reason,
                         "regions": sorted({pl.region for pl in planes if pl.region})}

    def relevance_for(self, memory: SceneMemory, category: str) -> Relevance | None:
        """Return the relevance of a goal category to the memory's (region, receptacle) pairs.

        From the semantics backend (cached per scene and category); the generator's table only for the
        ``relevance`` oracle variant.
        """
        if "relevance" in self.oracle_parts:
            return self.env.oracle.relevance
        key = (memory.scene, category)
        if key not in self._relevance:
            from ..semantics import relevance

            regions = sorted({e.region for e in memory.entries if e.region} | set(self.semantics.region_labels))
            recs = sorted({e.plane.label for e in memory.entries})
            # over the dataset's object categories (one vocabulary for every variant): P(o|rec) and P(o|rgn) are
            # normalised over the object list
            objects = sorted(set(self.object_categories) | {category})
            self._relevance[key] = relevance(objects, regions, recs, self.backend()) if recs else None
        return self._relevance[key]

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the memory entries in visiting order."""
        raise NotImplementedError

    def _entries(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> Generator[Any, None, None]:
        """Yield the entries to visit, one at a time (default: `order`, fixed at the episode start)."""
        yield from self.order(memory, category, rng)

    # -- one episode ---------------------------------------------------------------------------------

    def _detect(self) -> np.ndarray | None:
        """Return the goal mask in the current observation (None when not detected or not rendered)."""
        if not self.frame_fresh:
            return None
        category = str(self.ts.observation["objectgoal_text"])
        return self.detector.category_mask(self.ts.observation.get("category"), category)

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
        """FN after a detection (``nav.fn_mode``): the paper's (default), ours with retries, or our lattice variant."""
        if self.nav.fn_mode == "lattice":
            return (yield from self._final_nav_lattice(memory, nv, pts))
        if self.nav.fn_mode == "retry":
            return (yield from self._final_nav_retry(memory, nv, pts))
        return (yield from self._final_nav_paper(memory, nv, pts))

    def _navigate(self, memory: SceneMemory, nv: Navigator, centre: np.ndarray,
                  verify: bool) -> Generator[int, object, tuple[bool, bool, bool]]:
        """Navigate(p_g | eps_nav): drive towards the object's centre p_g until within eps_nav of it, or to the
        reachable cell of the agent's map nearest to it; return (reached, seen, looked).

        With ``verify`` it looks at the object after each drive (`_verify`: ``seen``). An agent whose map grows with
        what it sees (`_map_grew`: the no-prior one) turns to face p_g (rendering, so the look joins its map) and
        plans again from there while each round brings it closer; a map built in advance has nothing new to plan with.
        """
        half = self.nav.forward_step / 2.0

        def away() -> float:
            return float(np.linalg.norm(np.asarray(self.ts.observation["position"], float)[:2] - centre[:2]))

        seen = looked = False
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
            if verify:
                seen = yield from self._verify(centre, nv)
                looked = True
            elif self._can_grow():
                self.frame_fresh = False
                yield from self._face(nv, centre)
            if not self._map_grew(memory) or away() > start - half:
                break
            looked = False
        return away() <= self.nav.eps_nav + 1e-6, seen, looked

    def _final_nav_paper(self, memory: SceneMemory, nv: Navigator, pts: np.ndarray) -> Generator[int, object, dict]:
        """The paper's FN (algorithms 3-4): Navigate(p_g | eps_nav) to the detected object's centre p_g, then STOP.

        p_g usually stands on furniture: the agent drives towards it on its own map until within eps_nav, or to the
        reachable cell nearest to it (`_navigate`), and stops there. ``fn_reached``: it came within eps_nav of p_g.
        """
        reached, _seen, _looked = yield from self._navigate(memory, nv, object_centre(pts), verify=False)
        return {"fn": "paper", "fn_reached": bool(reached)}

    def _final_nav_retry(self, memory: SceneMemory, nv: Navigator, pts: np.ndarray) -> Generator[int, object, dict]:
        """Our FN with retries: Navigate(p_g | eps_nav) to the detected object's centre, then STOP with it in view.

        As the paper's (`_navigate`), looking at the object after each drive. Where Navigate ended counts when the
        agent sees the object from there and stands within eps_nav of p_g or within the view radius
        ``nav.fn_viewpoint_radius`` (less half a step) of the object's seen points (`footprint_distance`: the
        furniture under it can keep every free cell farther than eps_nav). Otherwise it tries other places of its map
        within the view radius of p_g (at most ``nav.fn_max_checks`` places in all, nearest by path first) and stops
        at the first that shows the object. The view radius is the task's published one (view points lie within it),
        not a generator record. ``fn_reached`` in the result: it came within eps_nav of p_g.
        """
        centre = object_centre(pts)
        half = self.nav.forward_step / 2.0

        def away() -> float:
            return float(np.linalg.norm(np.asarray(self.ts.observation["position"], float)[:2] - centre[:2]))

        reached, seen, looked = yield from self._navigate(memory, nv, centre, verify=True)
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
        return {"fn": "retry", "fn_reached": bool(reached), "fn_verified": bool(seen), "fn_checks": tried}

    def _map_grew(self, memory: SceneMemory) -> bool:
        """Add what the agent sees now to its planning map; return whether it did (an A* agent plans on the map of its
        first visit, so its map does not grow during an episode)."""
        return False

    def _can_grow(self) -> bool:
        """Return whether the agent's map grows with what it sees during an episode (`_map_grew`)."""
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

    def _approach_far(self, memory: SceneMemory, nv: Navigator, mask: np.ndarray) -> Generator[int, object, np.ndarray | None]:
        """The goal is in view only beyond the depth range: walk along its bearing and look again.

        Each round drives towards the point ``depth_max - 1`` m along the bearing of the mask (the reachable cell of
        the agent's map nearest to it, no detour), faces the bearing and looks (`_observe`); it returns the first
        mask with range, or None when the goal is lost or nothing brings it closer (``FAR_APPROACHES`` rounds).
        """
        for _ in range(FAR_APPROACHES):
            self.far += 1
            T = self._camera()
            ray = mask_bearing(mask, self.env.K, T)
            flat = np.linalg.norm(ray[:2])
            pos = np.asarray(self.ts.observation["position"], float)[:2]
            if flat < 1e-6 or self.env.steps >= self.nav.max_steps - 20:
                return None
            target = T[:3, 3][:2] + ray[:2] / flat * max(1.0, self.nav.depth_max - 1.0)
            dest = approach_point(target, memory.traversable, memory.frame, pos)
            if dest is None or float(np.linalg.norm(dest - pos)) < self.nav.forward_step:
                return None
            yield from nv.goto(dest, self.nav.forward_step, self.ts)
            self.frame_fresh = False
            yield from self._face(nv, T[:3, 3] + ray * (self.nav.depth_max + 2.0))
            self._map_grew(memory)
            mask = yield from self._observe()
            if mask is None:
                return None
            if len(self._reconstruct(mask)):
                return mask
        return None

    def _found(self, memory: SceneMemory, nv: Navigator, mask: np.ndarray, entry,
               visited: int) -> Generator[int, object, bool]:
        """The goal is detected: reconstruct it (approaching a goal seen beyond the depth range first), run FN (when
        on) and STOP; return False when a far goal was lost on the way (the search goes on)."""
        self.far = 0
        goal = self._reconstruct(mask)
        if not len(goal):
            mask = yield from self._approach_far(memory, nv, mask)
            if mask is None:
                return False
            goal = self._reconstruct(mask)
        self.info = {"detected": True, "goal": object_centre(goal).tolist(), "nav_points": visited,
                     "receptacle": entry.plane.label if entry else "", "region": entry.region if entry else "",
                     "opened": self.opened, "far_approaches": self.far}
        if self.final_nav:
            self.info.update((yield from self._final_nav(memory, nv, goal)))
        yield STOP
        return True

    def _run(self, env) -> Generator[int, object, None]:
        scene, z = env.scene, self._height()
        self._memory_key = self.memory_key(scene, z)
        memory = self.memories.get(self._memory_key) if self._memory_key else None
        if memory is None:
            raise InputError(scene, f"no first visit of this scene's floor at z = {z:.2f} m: the A* agents declare "
                                    "prior='scene' and need the evaluator's exploration phase on each floor before "
                                    "its episodes")
        rng = np.random.default_rng([self.seed, int(env.episode_index)])
        nv = self._navigator(memory)
        visited = 0
        self.opened = 0
        mask = self._detect()  # the goal may be in view where the episode starts
        if mask is not None and (yield from self._found(memory, nv, mask, None, visited)):
            return
        for entry in self._entries(memory, str(self.ts.observation["objectgoal_text"]), rng):
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
                if mask is not None and (yield from self._found(memory, nv, mask, entry, visited)):
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
    ``per_metre`` (keyword, default False): the distance-aware order, the classic index of optimal search (the object
    is in one of several places with probabilities p_i, looking in place i costs c_i: visiting by decreasing p_i / c_i
    minimises the expected cost): from wherever the agent stands, the next receptacle is the one with the most
    relevance per step it costs, ``score / (d / forward_step + look)``, where ``d`` is the path length on its map to
    the receptacle's nearest navigation point and ``look`` the steps of one observation there (`look_steps`: facing,
    the look around at two pitches); unreachable ones last. Without ``look`` (relevance per metre of path alone) the
    nearest receptacles win whatever their relevance.
    """

    name = "semantic-astar"

    def __init__(self, *args: Any, ranking: str = "placement", per_metre: bool = False, **kwargs: Any) -> None:
        if ranking not in RANKINGS:
            raise ValueError(f"unknown ranking {ranking!r} ({' or '.join(RANKINGS)})")
        super().__init__(*args, **kwargs)
        self.ranking = ranking
        self.per_metre = bool(per_metre)

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the entries ranked by relevance to the goal (random among ties)."""
        return memory.ranked(category, self.relevance_for(memory, category), rng, self.ranking)

    def look_steps(self) -> int:
        """Return the steps of one observation at a navigation point: facing the receptacle (half a turn on average,
        in turn steps), then ``look_yaws`` views, each a turn of 360 / look_yaws degrees and one tilt."""
        half_turn = int(round(90.0 / self.nav.turn_angle))
        per_view = max(1, int(round(360.0 / max(1, self.nav.look_yaws) / self.nav.turn_angle))) + 1
        return half_turn + max(1, int(self.nav.look_yaws)) * per_view

    def _entries(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> Generator[Any, None, None]:
        """Yield the entries in the paper's order, or (``per_metre``) by relevance per metre from where it stands."""
        if not self.per_metre:
            yield from self.order(memory, category, rng)
            return
        scores = memory.scores(category, self.relevance_for(memory, category), self.ranking)
        tiebreak = rng.permutation(len(memory.entries))
        if scores is None:
            yield from (memory.entries[i] for i in tiebreak)
            return
        left = list(range(len(memory.entries)))
        look = self.look_steps()
        while left:
            reach = reachable_field(memory.traversable, memory.frame, np.asarray(self.ts.observation["position"], float))
            util = {}
            for i in left:
                d = min((reach[0].distance(p) for p in memory.entries[i].nav_points), default=math.inf) if reach else math.inf
                util[i] = float(scores[i]) / (d / self.nav.forward_step + look) if math.isfinite(d) else -1.0
            best = min(left, key=lambda i: (-util[i], tiebreak[i]))
            left.remove(best)
            yield memory.entries[best]



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

    def _explore(self, env) -> Generator[int, object, None]:
        yield STOP  # no prior: it declares none and the evaluator starts no first visit

    def _can_grow(self) -> bool:
        """Its map grows with every look (`_map_grew`)."""
        return True

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
        key = (category, tuple(labels))
        if key not in self._relevance:
            objects = sorted(set(self.object_categories) | {category})
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
                              segmentation=o.get("category"), view_id=self.env.steps)
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
                mem = SceneMemory(env.scene, frame, occ.traversable())
                self.far = 0
                goal = self._reconstruct(mask)
                if not len(goal):  # seen only beyond the depth range: along its bearing, look again
                    mask = yield from self._approach_far(mem, nv, mask)
                    goal = self._reconstruct(mask) if mask is not None else np.zeros((0, 3))
                if len(goal):
                    self.info = {"detected": True, "goal": object_centre(goal).tolist(), "frontiers": visits,
                                 "far_approaches": self.far}
                    if self.final_nav:
                        mem.traversable = occ.traversable()
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
