"""ObjectNav episodes (paper section 3.5): dense goal view points, start poses with Habitat's filters.

Distances are `sdovon_mj.gridgraph.GeodesicField`, the one geodesic the suite and the agents use too.
"""

from .days import label_day
from .generate import (build_goals, episode_report, farthest_starts, generate_episodes, generate_episodes_with_report,
                       n_episodes_formula)

__all__ = ["label_day", "build_goals", "episode_report", "farthest_starts", "generate_episodes",
           "generate_episodes_with_report", "n_episodes_formula"]
