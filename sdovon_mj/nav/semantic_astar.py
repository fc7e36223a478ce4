"""Semantic A* (paper algorithm 4): receptacles by decreasing relevance of the goal to their region-receptacle pair,
or (``per_metre``) by relevance per step it costs from where the agent stands."""

from __future__ import annotations

import math
from typing import Any, Generator

import numpy as np

from .agent import public_home
from .goal import reachable_field
from .memory import RANKINGS, SceneMemory
from .receptacle_astar import ReceptacleAStar


@public_home
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
