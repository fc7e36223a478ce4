"""The no-prior Semantic Frontier agent (the paper's VLFM / L3MVN rows): each episode from nothing, frontier
exploration scored by the semantics backend's relevance of what it detected near each frontier."""

from __future__ import annotations

from typing import Generator

import numpy as np

from ..actions import STOP, TURN_LEFT
from ..config import AgentConfig, NavConfig, SemanticsConfig
from ..knowledge import Knowledge
from ..records import Observation
from .agent import public_home
from .control import Navigator, blocked_cells
from .frontier import OccupancyMap, agent_frame, scan_actions
from .goal import goal_points, object_centre
from .memory import SceneMemory
from .receptacle_astar import ReceptacleAStar


def near_seen(points: np.ndarray, xy: np.ndarray, radius: float) -> list[int]:
    """Return the indices (ascending) of the points (N, 2) within `radius` (m) of `xy`, each decided as
    ``np.linalg.norm(point - xy) <= radius`` decides it: the distances are computed at once, and the few within a
    rounding's reach of the radius (where the two sums' last bits could differ) are decided one by one."""
    if len(points) == 0:
        return []
    d = np.linalg.norm(points - xy[None], axis=1)
    near = d <= radius
    close = np.flatnonzero(np.abs(d - radius) <= 1e-9 * max(1.0, abs(radius)))
    for n in close:
        near[n] = np.linalg.norm(points[n] - xy) <= radius
    return np.flatnonzero(near).tolist()


@public_home
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
        """Build the agent.

        Parameters
        ----------
        nav : NavConfig, optional
            Actions, tolerances, FN settings, the occupancy map's size and resolution (default `NavConfig()`).
        seed : int
            The agent's seed (its policy draws nothing at random).
        final_nav : bool, optional
            Final navigation after a detection; default ``nav.final_nav``.
        semantics : SemanticsConfig, optional
            The semantics backend that scores the labels it detected (default `SemanticsConfig()`).
        agent : AgentConfig, optional
            The agent's body, camera and ``eta_gt`` (default `AgentConfig()`).
        """
        super().__init__(nav, seed, final_nav, semantics=semantics, agent=agent)
        self.knowledge = Knowledge(detector="gt", pose="gps+compass", prior="none",
                                   fn=self.nav.fn_mode if self.final_nav else "-",
                                   rgb=False)  # the ground-truth detector reads the category image, not colour
        self._occ: OccupancyMap | None = None  # the current episode's occupancy map

    def _explore(self, env) -> Generator[int, object, None]:
        yield STOP  # no prior: it declares none and the evaluator starts no first visit

    def _map_centre(self) -> np.ndarray:
        """Return where its episode's map is centred: the start (the origin of its GPS+compass frame)."""
        return np.zeros(2)

    def _floor_z(self) -> float:
        """Return the height of the floor in its pose frame (the start frame: 0)."""
        return 0.0

    def _looked(self, category: str, seen: list[tuple[np.ndarray, str]], found: bool) -> None:
        """A look is done: ``seen`` its detections so far (XY, label), ``found`` whether the goal is in view (a hook
        for a memory; none here: every episode from nothing)."""

    def _recalled(self, category: str, xy: np.ndarray) -> float:
        """Return a frontier's score from memory (0 here: no memory; a memory's score competes with relevance)."""
        return 0.0

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
        from ..gridgraph import node_distances
        from ..grid import nearest_true

        category = str(self.ts.observation["objectgoal_text"])
        start = self._map_centre()
        frame = agent_frame(start, self.nav.map_size, self.nav.map_resolution)
        occ = self._occ = OccupancyMap(frame, floor_z=self._floor_z(), agent=self.agent_config)
        occ.mark_free_disc(start, self.agent_config.radius + 0.05)
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
            mask = self._detect()
            self._looked(category, seen, mask is not None)
            return mask

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
            dist, index = node_distances(trav, rc)
            scores = self._scores(category, [lab for _xy, lab in seen])
            seen_xy = np.array([q for q, _lab in seen], dtype=float).reshape(-1, 2)
            best, best_u = None, -1.0
            for cells in clusters:
                d = dist[index[cells[:, 0], cells[:, 1]]] * frame.resolution
                k = int(np.argmin(d))
                if not np.isfinite(d[k]) or d[k] < 0.5:
                    continue
                xy = frame.to_world(cells[k][None])[0]
                near_labels = [seen[n][1] for n in near_seen(seen_xy, xy, self.nav.frontier_radius)]
                s = max([scores.get(lab, 0.0) for lab in near_labels] + [self._recalled(category, xy)])
                u = (0.1 + s) / (1.0 + float(d[k]) / 5.0)
                if u > best_u:
                    best, best_u = xy, u
            if best is None:
                break
            visits += 1
            yield from nv.goto(best, 0.25, self.ts)
        self.info = {"detected": False, "frontiers": visits}
        yield STOP
