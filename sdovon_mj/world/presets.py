"""The presets of the default world: what kind of home a seed gives, by size and density, not by code path.

* ``apartment`` (the default; the demo and the fast tests): 3-6 rooms on one or two storeys of one rectangle
  (``layout.plan_apartment``), furniture only.
* ``house``: 8-16 rooms over 1-3 storeys with stairs, hallways, an entryway, bedrooms, bathrooms, a laundry room,
  closets and a garage, on L, T, U and courtyard footprints (``houseplan.plan_house``), with clutter towards
  HM3D-Semantics' density (``clutter.KITS``).

Both go through the same steps (``world/home.py``): plan, each room's shell, furniture, clutter, assembly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from .houseplan import plan_house
from .layout import Plan, plan_apartment


@dataclass(frozen=True)
class Preset:
    """A preset: its name, the stem of its written files (``<stem>_<seed:04d>``) and of its scenes in a run
    (``<scene>_<seed:04d>``), the storey counts it allows, its clutter density (0: none) and its floor plans."""

    name: str
    stem: str
    scene: str
    storeys: tuple[int, ...]
    clutter: float
    plan: Callable[[int, int | None], Plan]


PRESETS: dict[str, Preset] = {
    "apartment": Preset("apartment", "apartment", "apt", (1, 2), 0.0, plan_apartment),
    "house": Preset("house", "house", "house", (1, 2, 3), 1.0, plan_house),
}


def preset(name: str) -> Preset:
    """Return the preset `name` (ValueError naming the known ones otherwise)."""
    if name not in PRESETS:
        raise ValueError(f"unknown world preset {name!r} (known: {', '.join(PRESETS)})")
    return PRESETS[name]
