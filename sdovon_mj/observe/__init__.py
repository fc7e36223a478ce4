"""Observe stage (paper section 3.1): floors, navigable maps, Gaussian coverage sampling, RGB-D renders."""

from .coverage import CoverageStats, coverage_fraction, coverage_viewpoints, uniform_viewpoints
from .floors import find_floors, floor_below
from .io import load_shards, save_shards
from .navmap import OffFloorError, locate, navigable_map, navmap_image, save_png
from .render_views import load_model, make_renderer, render_observations, view_angles, view_poses
from .stage import observe_scene, scene_floors_and_maps

__all__ = [
    "CoverageStats", "OffFloorError", "coverage_fraction", "coverage_viewpoints", "find_floors", "floor_below", "load_model",
    "load_shards", "locate", "make_renderer", "navigable_map", "navmap_image", "observe_scene", "render_observations",
    "save_png", "save_shards", "scene_floors_and_maps", "uniform_viewpoints", "view_angles", "view_poses",
]
