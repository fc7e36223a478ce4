"""Receptacle search with A* (paper algorithms 3/4): the episode of the A* agents, which visit the receptacles of
their memory in their search order, look at each, open furniture with doors or drawers, and run FN on a detection."""

from __future__ import annotations

from typing import Generator

import numpy as np

from ..actions import STOP
from ..config import AgentConfig, NavConfig, PerceiveConfig, ReceptacleConfig, SemanticsConfig
from ..errors import InputError
from ..knowledge import Knowledge
from ..records import Relevance
from .agent import Agent, public_home
from .control import Navigator
from .final_navigation import FinalNavigation
from .first_visit import FirstVisitMemory
from .goal import object_centre
from .looking import Looking
from .memory import SceneMemory
from .planning import Planning
from .search_order import SearchOrder

# Receptacles the A* agents try to open (OPEN) when they do not see the goal at them: furniture with doors or
# drawers, named by the labels their detector gives (what a robot that knows such furniture opens would try).
OPENABLE_LABELS = ("cabinet", "kitchen cabinet", "wall cabinet", "cupboard", "dresser", "chest of drawers", "drawer",
                   "wardrobe", "closet", "fridge", "refrigerator", "microwave", "nightstand", "oven", "dishwasher")


@public_home
class ReceptacleAStar(FirstVisitMemory, SearchOrder, Looking, Planning, FinalNavigation, Agent):
    """Receptacle search with A* (paper algorithms 3/4); subclasses choose the receptacle order.

    Knowledge: the ground-truth detector, its pose in the scene frame (localized, as the paper's agents), and
    what it built itself on its first visit of the scene (appendix D; ``explore_steps``, the evaluator's exploration
    phase): receptacles, planes and regions from its own frames with the pipeline's stages, relevance from the
    semantics backend. Optional privileges (``oracle_parts``) make it a labelled oracle variant, for the ablation
    of what each was worth.

    What it does is split by concept: its memory of each floor's first visit (`first_visit.FirstVisitMemory`), the
    receptacles' search order (`search_order.SearchOrder`), looking (`looking.Looking`), planning on its map
    (`planning.Planning`) and final navigation (`final_navigation.FinalNavigation`); here the episode itself.
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
                                   fn=self.nav.fn_mode if self.final_nav else "-", explore_steps=int(explore_steps),
                                   rgb=False)  # the ground-truth detector reads the category image, not colour
        self.memories: dict[tuple[str, float], SceneMemory] = {}  # (scene, floor height in m) -> its first visit's
        self._explore_key: tuple[str, float] | None = None  # the first visit under way
        self._memory_key: tuple[str, float] | None = None  # the memory the current episode plans on
        self._relevance: dict[tuple[str, str], Relevance] = {}
        self._backend = None
        self.wants_frame = False

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
