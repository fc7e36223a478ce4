"""Mesh -> MJCF conversion: objects (CoACD collision hulls), scenes (visual-only, semantic instances), batches.

Public API: `convert_object`, `convert_scene`, `convert_tree`; settling helpers in `collision`.
Rules for units and up axis: `assets_convert.load` (and README.md in this folder).
"""

from .object import convert_object
from .scene import convert_scene
from .tree import convert_tree

__all__ = ["convert_object", "convert_scene", "convert_tree"]
