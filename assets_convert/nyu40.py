"""NYU40 classes (ScanNet's ``label`` per vertex in ``<scene>_vh_clean_2.labels.ply``) -> our categories: the one table.

The ids and names are NYU Depth v2's 40-class set as ScanNet publishes it (``refridgerator`` spelled as there); 0 is
unannotated. A category is the name as goal text and the receptacle labels (`ReceptacleConfig.labels`) write it:
the spelling fixed, ``night stand`` -> ``nightstand``, ``shelves`` -> ``shelf``, and the three catch-all classes
(``otherstructure``, ``otherfurniture``, ``otherprop``) -> ``structure``, ``furniture``, ``object``.
"""

from __future__ import annotations

NYU40_NAMES: tuple[str, ...] = (
    "wall", "floor", "cabinet", "bed", "chair", "sofa", "table", "door", "window", "bookshelf",
    "picture", "counter", "blinds", "desk", "shelves", "curtain", "dresser", "pillow", "mirror", "floor mat",
    "clothes", "ceiling", "books", "refridgerator", "television", "paper", "towel", "shower curtain", "box",
    "whiteboard", "person", "night stand", "toilet", "sink", "lamp", "bathtub", "bag", "otherstructure",
    "otherfurniture", "otherprop")  # class id k is NYU40_NAMES[k - 1]
UNANNOTATED = 0
RENAMED = {"refridgerator": "refrigerator", "night stand": "nightstand", "shelves": "shelf",
           "otherstructure": "structure", "otherfurniture": "furniture", "otherprop": "object"}


def nyu40_name(class_id: int) -> str:
    """Return the NYU40 name of a class id ('' for 0, unannotated, and for an id outside 1..40)."""
    return NYU40_NAMES[class_id - 1] if 1 <= class_id <= len(NYU40_NAMES) else ""


def category(class_id: int) -> str:
    """Return our category for an NYU40 class id (`RENAMED` applied; 'unlabeled' for 0 and unknown ids)."""
    name = nyu40_name(class_id)
    return RENAMED.get(name, name) if name else "unlabeled"


__all__ = ["NYU40_NAMES", "RENAMED", "UNANNOTATED", "category", "nyu40_name"]
