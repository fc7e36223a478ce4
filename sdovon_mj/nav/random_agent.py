"""The random reference agent: uniformly random moves, STOP with a given probability per step."""

from __future__ import annotations

import hashlib
from typing import Generator

import numpy as np

from ..actions import STOP
from ..config import AgentConfig, NavConfig
from .agent import Agent, public_home


@public_home
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
