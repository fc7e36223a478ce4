"""Random A* (paper algorithm 3): receptacles visited in a random order each episode."""

from __future__ import annotations

import numpy as np

from .agent import public_home
from .memory import SceneMemory
from .receptacle_astar import ReceptacleAStar


@public_home
class RandomAStar(ReceptacleAStar):
    """Random A*: receptacles in a random order each episode (algorithm 3)."""

    name = "random-astar"

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the entries shuffled."""
        return [memory.entries[i] for i in rng.permutation(len(memory.entries))]
