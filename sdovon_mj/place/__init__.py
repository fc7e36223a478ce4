"""Semantic object placement and physical settling -> scene variants (paper section 3.4).

Public API:
- `place_variant(scene, planes, relevance, objects, store_root, cfg, seed, index) -> SceneVariant`
- `place_variants(scene, planes, relevance, objects, store_root, cfg, scene_seed) -> list[SceneVariant]`
- `run_variant(...) -> (SceneVariant, VariantStats)` (the same, with wall-time figures)
- `variant_seed(scene_seed, index)`, `planes_from_scene(scene)` (ground-truth planes)
- `check_variant(variant, planes, store_root) -> VariantCheck` (independent resting check)
- `top_down_picture` / `view_picture` (pictures.py)
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen pictures; must be set before mujoco picks a GL backend

from .check import VariantCheck, check_variant, format_report, per_category
from .variants import VariantStats, place_variant, place_variants, planes_from_scene, run_variant, variant_seed

__all__ = ["place_variant", "place_variants", "run_variant", "variant_seed", "planes_from_scene", "VariantStats",
           "check_variant", "VariantCheck", "format_report", "per_category"]
