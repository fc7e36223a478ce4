"""The oracle reference agent (a labelled upper bound): the generator's navigable map and view points, the shortest
path to the nearest view point, STOP."""

from __future__ import annotations

import math
from typing import Generator

import numpy as np

from ..actions import STOP, TURN_LEFT
from ..config import AgentConfig, NavConfig
from ..gridgraph import GeodesicField
from ..knowledge import Knowledge
from .agent import Agent, public_home
from .control import Navigator, lattice_approach, segment_checker


@public_home
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
