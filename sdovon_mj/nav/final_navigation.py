"""Final navigation (FN) after a detection, for the A* agents (``nav.fn_mode``): the paper's Navigate(p_g | eps_nav)
then STOP, ours with retries (STOP where the object is in view), or our lattice variant (inferred view points)."""

from __future__ import annotations

from typing import Generator

import numpy as np

from ..grid import segment_free
from .control import Navigator
from .goal import approach_point, footprint_distance, infer_view_points, object_centre
from .memory import SceneMemory


class FinalNavigation:
    """How `ReceptacleAStar` ends an episode once it detected the goal (`_final_nav`); what it returns joins the
    episode's ``info``."""

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

    def _reach(self, target: np.ndarray, nv: Navigator) -> Generator[int, object, bool]:
        """Walk onto a point within a few centimetres (exact forward/turn lattice plan); return success."""
        radius = 0.45 * self.nav.success_distance
        ok = yield from nv.goto(target, radius, self.ts)
        pos = np.asarray(self.ts.observation["position"], float)[:2]
        return bool(ok and np.linalg.norm(pos - target) <= radius + 1e-6)
