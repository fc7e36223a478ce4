"""Looking, for the A* agents: detecting the goal in the current frame, Observe at a navigation point (two pitches,
the look around, OPEN at furniture with doors or drawers), facing a point, verifying a goal is in view, and
reconstructing the goal's points from depth."""

from __future__ import annotations

import math
from typing import Generator

import numpy as np

from ..actions import LOOK_DOWN, LOOK_UP, OPEN, TURN_LEFT
from ..sim.camera import pose_cv
from .control import Navigator
from .goal import goal_points


class Looking:
    """How `ReceptacleAStar` looks: every look renders its frame (``wants_frame``) and asks the detector."""

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
