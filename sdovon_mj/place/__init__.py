"""Semantic object placement and physical settling -> scene variants (paper section 3.4).

Public API:
- `place_variant(scene, planes, relevance, objects, store_root, cfg, seed, index) -> SceneVariant`
- `place_variants(scene, planes, relevance, objects, store_root, cfg, scene_seed) -> list[SceneVariant]`
- `run_variant(...) -> (SceneVariant, VariantStats)` (the same, with wall-time figures)
- `planes_from_scene(scene)` (ground-truth planes); variant seeds: `sdovon_mj.seeds.variant_seed`
- `check_variant(variant, planes, store_root) -> VariantCheck` (independent resting check)
- `first_day` / `next_day` (days.py): a scene's chain of days by the habit model
- `top_down_picture` / `view_picture` (pictures.py)
"""



from .check import VariantCheck, check_variant, format_report, per_category
from .days import first_day, next_day
from .variants import VariantStats, place_variant, place_variants, planes_from_scene, run_variant

__all__ = ["place_variant", "place_variants", "run_variant", "planes_from_scene", "VariantStats",
           "check_variant", "first_day", "next_day", "VariantCheck", "format_report", "per_category"]
