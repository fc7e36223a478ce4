"""Planning for the A* agents: a navigator on the memory's map that learns cells the world refuses, whether the map
grows with what the agent sees, and walking towards a goal seen only beyond the depth range."""

from __future__ import annotations

from typing import Generator

import numpy as np

from .control import Navigator, blocked_cells
from .goal import approach_point, mask_bearing
from .memory import SceneMemory

# A goal seen only beyond the depth range: walks along its bearing to look again, at most this many.
FAR_APPROACHES = 3


class Planning:
    """How `ReceptacleAStar` moves on its map (A* on the memory's traversable cells)."""

    def _navigator(self, memory: SceneMemory) -> Navigator:
        """Return a navigator on the memory's planning map that learns cells the world refuses."""
        def blocked(pos: np.ndarray, yaw: float) -> None:
            cells = blocked_cells(memory.frame, pos, yaw, self.nav.forward_step)
            trav = memory.traversable.copy()  # a new array: planners cache graphs per mask object
            trav[cells[:, 0], cells[:, 1]] = False
            memory.traversable = trav

        return Navigator(self.nav, lambda: memory.traversable, memory.frame, on_blocked=blocked)

    def _map_grew(self, memory: SceneMemory) -> bool:
        """Add what the agent sees now to its planning map; return whether it did (an A* agent plans on the map of its
        first visit, so its map does not grow during an episode)."""
        return False

    def _can_grow(self) -> bool:
        """Return whether the agent's map grows with what it sees during an episode (`_map_grew`)."""
        return False

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
