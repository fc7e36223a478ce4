"""ObjectNav episodes (paper section 3.5): goal view points, grid geodesics, start poses."""

from .generate import build_goals, episode_report, generate_episodes, generate_episodes_with_report, n_episodes_formula
from .geodesic import GeodesicField, distance_field, geodesic_distance

__all__ = ["build_goals", "episode_report", "generate_episodes", "generate_episodes_with_report",
           "n_episodes_formula", "GeodesicField", "distance_field", "geodesic_distance"]
