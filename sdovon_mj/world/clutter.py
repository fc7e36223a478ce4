"""Clutter: the many small labelled things of a lived-in home, placed after the furniture.

Real scans label far more than furniture: HM3D-Semantics averages about 47 annotated instances per room (ceiling
lights, curtains, pictures, door leaves, plants, bins, boxes, bags, bottles of shampoo...). With a clutter density
above zero (the ``house`` preset, ``world/presets.py``) each room gets a kit of such things (`KITS`, by room type),
placed in this order once its furniture stands (`dress`):

* ``door``: a door leaf in every doorway the room's side of which it opens into (never between two hallways),
  swung 90 degrees into the room along the doorway's keep-out zone;
* fixtures: a light switch beside each doorway, outlets along the walls, a vent, smoke detectors (`_fixtures`);
* ``ceiling``: lights under the ceiling, about one per 12 m^2;
* ``window``: a curtain beside each side of a window, a radiator under it;
* ``high``: things on the walls above the furniture (pictures, mirrors, clocks, wall lights, towel racks);
* ``wall`` / ``corner``: floor-standing things against a wall (plants, bins, baskets, box stacks);
* ``flat``: rugs and mats (walkable);
* ``surface``: small things on the receptacles' support surfaces (a kettle on the counter, shampoo on the vanity,
  boxes and bags on closet shelves), at most a third of a surface's area.

Each item is tried once (a few spots) and left out when it does not fit; a floor item that would cut the room's
walking region (`placement.nav_ok`) is taken back. Labels are those of the semantic priors' table (its fixtures
are structure: no evidence of a region) and never an object-library category, so a goal category names only placed
objects. Everything is drawn from the room's own
clutter generator: the furniture of a room does not depend on its clutter.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import furniture
from . import layout
from . import placement
from . import shapes
from .artplace import is_proxy
from .furniture import METALS, WOODS, Model, jitter, pick, u
from .layout import SKIRTING, WALL_T

PLASTIC = ((230, 230, 228), (60, 60, 64), (70, 110, 170), (190, 60, 50), (90, 150, 90), (230, 190, 70))
CARDBOARD = ((180, 146, 104), (196, 164, 120), (160, 128, 90))
LEAVES = ((64, 120, 60), (84, 140, 70), (50, 100, 56))


# ------------------------------------------------------------------------------------------------
# the props: every model in its own frame (back against y = 0, front +y, centred on x = 0, floor z = 0)


def _boxy(label: str, size: tuple[float, float, float], rgb: tuple[int, ...], material: str = "plain", z0: float = 0.0,
          kind: str = "furniture") -> Model:
    """Return a one-box prop of size (w, d, h) whose bottom is at `z0`."""
    w, d, h = size
    m = Model(label, kind, [], w, d, z0 + h, z_min=z0)
    m.add(shapes.box((-0.5 * w, 0.0, z0), (0.5 * w, d, z0 + h)), rgb, material)
    return m


def _round(label: str, r: float, h: float, rgb: tuple[int, ...], material: str = "plain", z0: float = 0.0) -> Model:
    """Return a cylindrical prop of radius r and height h standing on `z0` (its back touching y = 0)."""
    m = Model(label, "furniture", [], 2 * r, 2 * r, z0 + h, z_min=z0)
    m.add(shapes.cylinder(r, z0, z0 + h, 14, (0.0, r)), rgb, material)
    return m


def ceiling_light(rng: np.random.Generator, wall_h: float) -> Model:
    """A flush ceiling light: a disc hanging 6-25 cm under the ceiling (centred on the origin)."""
    r, drop = u(rng, 0.15, 0.3), u(rng, 0.06, 0.25)
    m = Model("ceiling light", "furniture", [], 2 * r, 2 * r, wall_h, z_min=wall_h - drop)
    m.add(shapes.cylinder(0.02, wall_h - drop + 0.04, wall_h, 8, (0.0, 0.0)), METALS[0], "metal")
    m.add(shapes.cylinder(r, wall_h - drop, wall_h - drop + 0.05, 20, (0.0, 0.0)), (246, 244, 236), "plain")
    return m


def curtain(rng: np.random.Generator, top: float, rgb: tuple[int, ...]) -> Model:
    """A curtain panel (25-35 cm wide, 5 cm deep) from just above the floor to `top`."""
    w = u(rng, 0.25, 0.35)
    return _boxy("curtain", (w, 0.05, top - 0.03), rgb, "fabric", z0=0.03)


def radiator(rng: np.random.Generator, width: float) -> Model:
    """A panel radiator (10 cm deep, 0.5-0.6 m tall, 10 cm above the floor)."""
    m = Model("radiator", "furniture", [], width, 0.1, 0.7, z_min=0.1)
    h = u(rng, 0.5, 0.6)
    m.height = 0.1 + h
    c = (238, 238, 236)
    m.add(shapes.box((-0.5 * width, 0.03, 0.1), (0.5 * width, 0.1, 0.1 + h)), c, "metal")
    for x in (-0.5 * width + 0.05, 0.5 * width - 0.07):
        m.add(shapes.box((x, 0.0, 0.05), (x + 0.02, 0.03, 0.1 + h - 0.05)), c, "metal")
    return m


def door_leaf(width: float, height: float, rgb: tuple[int, ...]) -> Model:
    """A door leaf (4 cm thick) in its own frame: hinge edge at x = 0, the leaf along +y (open), floor at z = 0."""
    m = Model("door", "furniture", [], 0.04, width, height)
    m.add(shapes.box((-0.02, 0.0, 0.01), (0.02, width, height)), rgb, "wood")
    m.add(shapes.box((0.02, width - 0.1, 0.95), (0.05, width - 0.06, 1.0)), METALS[0], "metal")
    m.add(shapes.box((-0.05, width - 0.1, 0.95), (-0.02, width - 0.06, 1.0)), METALS[0], "metal")
    return m


def _wall_prop(label: str, rng: np.random.Generator) -> Model:
    """Return a thing hung on a wall (bottom 1.0-1.7 m)."""
    if label == "picture":
        return furniture.picture(rng)
    if label == "mirror":
        w, h, z0 = u(rng, 0.4, 0.8), u(rng, 0.5, 0.9), u(rng, 1.05, 1.3)
        m = _boxy("mirror", (w, 0.03, h), pick(rng, WOODS + ((230, 230, 230),)), "wood", z0=z0)
        m.add(shapes.box((-0.5 * w + 0.03, 0.03, z0 + 0.03), (0.5 * w - 0.03, 0.035, z0 + h - 0.03)), (200, 212, 220), "metal")
        return m
    if label == "clock":
        r, z0 = u(rng, 0.12, 0.2), u(rng, 1.6, 1.8)
        m = Model("clock", "furniture", [], 2 * r, 0.05, z0 + 2 * r, z_min=z0)
        face = shapes.transform(shapes.cylinder(r, 0.0, 0.05, 20), rot=shapes.rot_x(-0.5 * np.pi), shift=(0.0, 0.0, z0 + r))
        m.add(face, pick(rng, ((240, 240, 236), (30, 30, 32)) + WOODS[:2]), "plain")
        return m
    if label == "light":
        z0 = u(rng, 1.6, 1.8)
        return _boxy("light", (u(rng, 0.12, 0.2), 0.1, u(rng, 0.15, 0.25)), pick(rng, METALS + ((240, 238, 230),)), "metal", z0)
    if label == "towel rack":
        w, z0 = u(rng, 0.45, 0.7), u(rng, 1.0, 1.2)
        m = Model("towel rack", "furniture", [], w, 0.1, z0 + 0.04, z_min=z0)
        m.add(shapes.box((-0.5 * w, 0.07, z0), (0.5 * w, 0.1, z0 + 0.03)), METALS[0], "metal")
        for x in (-0.5 * w, 0.5 * w - 0.03):
            m.add(shapes.box((x, 0.0, z0), (x + 0.03, 0.07, z0 + 0.04)), METALS[0], "metal")
        return m
    if label == "toilet paper":
        z0 = u(rng, 0.65, 0.75)
        return _round("toilet paper", 0.06, 0.11, (246, 246, 244), "fabric", z0)
    if label == "speaker":
        return _boxy("speaker", (u(rng, 0.16, 0.24), 0.16, u(rng, 0.25, 0.35)), (36, 36, 38), "plain", u(rng, 1.7, 1.9))
    raise ValueError(label)


def _floor_prop(label: str, rng: np.random.Generator) -> Model:
    """Return a thing standing on the floor."""
    if label == "plant":
        r, h = u(rng, 0.14, 0.22), u(rng, 0.6, 1.4)
        m = Model("plant", "furniture", [], 2 * r + 0.1, 2 * r + 0.1, h)
        m.add(shapes.cylinder(r, 0.0, 0.35, 14, (0.0, r + 0.05)), pick(rng, ((180, 90, 60), (230, 230, 226), (60, 60, 64))), "ceramic")
        m.add(shapes.icosphere((0.0, r + 0.05, 0.35 + 0.5 * (h - 0.35)), min(r + 0.05, 0.5 * (h - 0.35)), 1),
              pick(rng, LEAVES), "plain")
        m.add(shapes.box((-0.02, r + 0.03, 0.35), (0.02, r + 0.07, h - 0.1)), (90, 70, 40), "wood")
        return m
    if label == "trash can":
        return _round("trash can", u(rng, 0.12, 0.17), u(rng, 0.3, 0.45), pick(rng, PLASTIC + METALS), "plain")
    if label in ("basket", "laundry basket"):
        return _round(label, u(rng, 0.17, 0.24), u(rng, 0.3, 0.5), pick(rng, ((200, 170, 120), (170, 130, 90)) + PLASTIC), "fabric")
    if label == "box":
        return _boxy("box", (u(rng, 0.3, 0.6), u(rng, 0.3, 0.45), u(rng, 0.25, 0.45)), pick(rng, CARDBOARD), "plain")
    if label == "umbrella stand":
        return furniture.umbrella_stand(rng)
    if label == "shoe rack":
        return furniture.shoe_rack(rng)
    if label == "coat rack":
        return furniture.coat_rack(rng)
    if label == "armchair":
        return furniture.armchair(rng)
    if label == "speaker":
        return _boxy("speaker", (u(rng, 0.2, 0.28), 0.24, u(rng, 0.8, 1.0)), (36, 36, 38), "plain")
    if label in SMALL:  # a small thing on the floor (a bag, a box of toys): back against y = 0
        m = small_prop(label, rng, 0.0)
        m.parts = [furniture.Part(p.vertices + np.array([0.0, 0.5 * m.depth, 0.0]), p.faces, p.rgba, p.material) for p in m.parts]
        return m
    if label in ("rug", "bath mat"):
        w, d = (u(rng, 0.5, 0.8), u(rng, 0.4, 0.55)) if label == "bath mat" else (u(rng, 0.8, 1.8), u(rng, 0.6, 1.2))
        m = furniture.rug(rng, w, d)
        m.label = label
        return m
    raise ValueError(label)


# sizes (w, d, h ranges, m) and palettes of small things on support surfaces
SMALL: dict[str, tuple[tuple[float, float], tuple[float, float], tuple[float, float], tuple, str]] = {
    "kettle": ((0.16, 0.2), (0.14, 0.18), (0.2, 0.26), METALS + ((230, 230, 228),), "round"),
    "toaster": ((0.26, 0.32), (0.16, 0.2), (0.18, 0.22), METALS + ((200, 60, 50),), "box"),
    "coffee maker": ((0.2, 0.28), (0.22, 0.28), (0.3, 0.38), ((40, 40, 42),) + METALS[:1], "box"),
    "jar": ((0.08, 0.12), (0.08, 0.12), (0.12, 0.2), ((200, 214, 220), (180, 150, 110)), "round"),
    "cutting board": ((0.3, 0.4), (0.02, 0.03), (0.22, 0.3), WOODS[:3], "box"),
    "soap": ((0.08, 0.1), (0.05, 0.07), (0.03, 0.04), ((240, 230, 200), (200, 220, 240)), "box"),
    "toothpaste": ((0.18, 0.2), (0.04, 0.05), (0.04, 0.05), ((240, 240, 240), (220, 60, 60)), "box"),
    "shampoo": ((0.06, 0.08), (0.06, 0.08), (0.18, 0.24), PLASTIC, "round"),
    "lotion": ((0.05, 0.07), (0.05, 0.07), (0.14, 0.18), PLASTIC, "round"),
    "tissue box": ((0.22, 0.25), (0.11, 0.13), (0.08, 0.1), PLASTIC + ((240, 236, 224),), "box"),
    "box": ((0.25, 0.4), (0.2, 0.3), (0.12, 0.25), CARDBOARD + PLASTIC[:3], "box"),
    "basket": ((0.25, 0.35), (0.2, 0.28), (0.12, 0.2), ((200, 170, 120), (170, 130, 90)), "box"),
    "bag": ((0.25, 0.35), (0.12, 0.18), (0.22, 0.3), ((120, 70, 40), (40, 40, 44), (140, 30, 40)), "box"),
    "hat": ((0.2, 0.26), (0.2, 0.26), (0.1, 0.14), ((40, 40, 44), (180, 160, 120), (90, 30, 30)), "round"),
    "clothes": ((0.28, 0.36), (0.22, 0.3), (0.06, 0.12), ((70, 90, 140), (200, 200, 196), (150, 60, 60)), "box"),
    "picture frame": ((0.12, 0.2), (0.02, 0.03), (0.15, 0.22), WOODS + ((30, 30, 30),), "box"),
    "candle holder": ((0.06, 0.09), (0.06, 0.09), (0.1, 0.16), METALS, "round"),
    "jewelry box": ((0.16, 0.22), (0.1, 0.14), (0.07, 0.1), WOODS[:4], "box"),
    "globe": ((0.2, 0.26), (0.2, 0.26), (0.3, 0.36), ((70, 110, 160),), "round"),
    "printer": ((0.38, 0.45), (0.3, 0.36), (0.16, 0.22), ((40, 40, 42), (230, 230, 228)), "box"),
    "magazine": ((0.21, 0.23), (0.28, 0.3), (0.01, 0.02), PLASTIC, "box"),
    "laundry detergent": ((0.14, 0.2), (0.1, 0.14), (0.24, 0.3), PLASTIC, "box"),
    "spray bottle": ((0.07, 0.09), (0.07, 0.09), (0.22, 0.28), PLASTIC, "round"),
    "power drill": ((0.22, 0.26), (0.07, 0.09), (0.2, 0.24), ((220, 120, 30), (30, 90, 170)), "box"),
    "toy": ((0.1, 0.2), (0.1, 0.2), (0.08, 0.16), PLASTIC, "box"),
    "board game": ((0.26, 0.4), (0.26, 0.3), (0.05, 0.08), PLASTIC, "box"),
    "toilet paper": ((0.1, 0.12), (0.1, 0.12), (0.09, 0.11), ((246, 246, 244),), "round"),
    "hair dryer": ((0.18, 0.24), (0.08, 0.1), (0.2, 0.26), ((40, 40, 44), (230, 230, 228), (200, 80, 120)), "box"),
    "cosmetics": ((0.04, 0.08), (0.03, 0.06), (0.08, 0.14), PLASTIC + ((200, 170, 150),), "box"),
    "comb": ((0.15, 0.2), (0.03, 0.04), (0.01, 0.02), PLASTIC, "box"),
    "pot": ((0.2, 0.26), (0.2, 0.26), (0.12, 0.18), METALS + ((40, 40, 44),), "round"),
    "pan": ((0.24, 0.3), (0.24, 0.3), (0.04, 0.06), ((40, 40, 44),) + METALS[:1], "round"),
    "backpack": ((0.28, 0.34), (0.16, 0.22), (0.38, 0.48), ((40, 60, 110), (120, 40, 40), (50, 50, 54), (70, 110, 70)), "box"),
}


def small_prop(label: str, rng: np.random.Generator, z0: float) -> Model:
    """Return a small thing (`SMALL`) standing on a surface at height z0 (its footprint centred on the origin)."""
    (w0, w1), (d0, d1), (h0, h1), palette, shape = SMALL[label]
    w, d, h = u(rng, w0, w1), u(rng, d0, d1), u(rng, h0, h1)
    rgb = pick(rng, palette)
    m = Model(label, "furniture", [], w, d, z0 + h, z_min=z0)
    if shape == "round":
        m.add(shapes.transform(shapes.cylinder(0.5, 0.0, 1.0, 14), scale=(w, d, h), shift=(0.0, 0.0, z0)), rgb, "plain")
    else:
        m.add(shapes.box((-0.5 * w, -0.5 * d, z0), (0.5 * w, 0.5 * d, z0 + h)), rgb, "plain")
    return m


# ------------------------------------------------------------------------------------------------
# the kits


@dataclass(frozen=True)
class Item:
    """A kit entry: a label, where it goes (`dress`'s modes), how many (drawn uniformly in lo..hi, each one then
    kept with probability `p`), and for ``surface`` the receptacle labels it may stand on."""

    label: str
    mode: str
    lo: int = 1
    hi: int = 1
    p: float = 1.0
    on: tuple[str, ...] = ()


_W, _H, _F, _C, _S = "wall", "high", "flat", "corner", "surface"
_COMMON = (Item("picture", _H, 2, 4), Item("light", _H, 1, 2, 0.7))
KITS: dict[str, tuple[Item, ...]] = {
    "living room": _COMMON + (Item("picture", _H, 1, 2), Item("clock", _H, 0, 1), Item("speaker", _W, 0, 2),
                              Item("plant", _W, 1, 2), Item("armchair", _W, 0, 1, 0.7), Item("rug", _F, 0, 1),
                              Item("basket", _C, 0, 1, 0.5), Item("candle holder", _S, 1, 2, 0.7, ("shelf", "bookshelf", "tv stand")),
                              Item("picture frame", _S, 1, 3, 0.8, ("shelf", "bookshelf", "dresser", "coffee table")),
                              Item("magazine", _S, 0, 2, 0.7, ("coffee table",)), Item("board game", _S, 0, 1, 0.5, ("bookshelf", "shelf"))),
    "kitchen": _COMMON + (Item("clock", _H, 0, 1), Item("trash can", _W, 1, 2), Item("plant", _W, 0, 1, 0.5),
                          Item("kettle", _S, 1, 1, 0.8, ("counter",)), Item("toaster", _S, 0, 1, 0.6, ("counter",)),
                          Item("coffee maker", _S, 0, 1, 0.6, ("counter",)), Item("jar", _S, 1, 3, 0.8, ("counter", "shelf")),
                          Item("cutting board", _S, 0, 1, 0.6, ("counter",)), Item("rug", _F, 0, 1, 0.4),
                          Item("pot", _S, 0, 2, 0.7, ("counter", "shelf")), Item("pan", _S, 0, 1, 0.6, ("counter",))),
    "dining room": _COMMON + (Item("picture", _H, 0, 2), Item("clock", _H, 0, 1), Item("plant", _W, 1, 2),
                              Item("rug", _F, 0, 1, 0.3), Item("candle holder", _S, 1, 2, 0.8, ("table", "dresser", "shelf")),
                              Item("jar", _S, 0, 2, 0.6, ("dresser", "shelf", "bookshelf"))),
    "bedroom": _COMMON + (Item("mirror", _H, 0, 1), Item("light", _H, 0, 2, 0.5), Item("plant", _W, 0, 1, 0.6),
                          Item("basket", _C, 0, 1, 0.6), Item("box", _W, 0, 2, 0.5), Item("rug", _F, 0, 1, 0.5),
                          Item("jewelry box", _S, 0, 1, 0.6, ("dresser", "nightstand")),
                          Item("picture frame", _S, 1, 2, 0.8, ("nightstand", "dresser", "shelf")),
                          Item("tissue box", _S, 0, 1, 0.6, ("nightstand",)), Item("clothes", _S, 0, 2, 0.6, ("bed", "dresser")),
                          Item("toy", _S, 0, 2, 0.4, ("shelf", "bookshelf", "desk")), Item("bag", _C, 0, 1, 0.5),
                          Item("backpack", _C, 0, 1, 0.5)),
    "office": _COMMON + (Item("clock", _H, 0, 1), Item("trash can", _W, 1, 1), Item("plant", _W, 0, 1, 0.7),
                         Item("box", _W, 0, 2, 0.5), Item("printer", _S, 0, 1, 0.6, ("desk", "shelf", "dresser")),
                         Item("globe", _S, 0, 1, 0.4, ("bookshelf", "shelf", "desk")),
                         Item("picture frame", _S, 0, 2, 0.7, ("desk", "bookshelf", "shelf")), Item("rug", _F, 0, 1, 0.4)),
    "bathroom": (Item("mirror", _H, 1, 1), Item("towel rack", _H, 1, 2), Item("toilet paper", _H, 1, 1),
                 Item("light", _H, 0, 1, 0.6), Item("trash can", _W, 1, 1), Item("basket", _C, 0, 1, 0.5),
                 Item("bath mat", _F, 1, 1), Item("soap", _S, 1, 1, 0.9, ("counter", "shelf")),
                 Item("toothpaste", _S, 0, 1, 0.8, ("counter", "shelf")), Item("shampoo", _S, 1, 2, 0.8, ("shelf", "counter")),
                 Item("lotion", _S, 0, 2, 0.7, ("shelf", "counter")), Item("tissue box", _S, 0, 1, 0.5, ("shelf", "counter")),
                 Item("toilet paper", _S, 0, 2, 0.7, ("shelf",)), Item("hair dryer", _S, 0, 1, 0.5, ("shelf", "counter")),
                 Item("cosmetics", _S, 1, 3, 0.8, ("counter", "shelf")), Item("comb", _S, 0, 1, 0.6, ("counter", "shelf"))),
    "hallway": (Item("picture", _H, 3, 6), Item("light", _H, 2, 4), Item("mirror", _H, 0, 1, 0.5),
                Item("plant", _W, 1, 2), Item("rug", _F, 1, 2), Item("coat rack", _C, 0, 1, 0.3), Item("box", _W, 0, 1, 0.3),
                Item("clock", _H, 0, 1, 0.5)),
    "entryway": (Item("picture", _H, 1, 2), Item("mirror", _H, 1, 1), Item("light", _H, 0, 1), Item("plant", _W, 0, 1),
                 Item("rug", _F, 1, 1), Item("umbrella stand", _C, 1, 1, 0.8), Item("bag", _S, 0, 2, 0.7, ("bench",)),
                 Item("hat", _S, 0, 1, 0.6, ("bench", "shelf"))),
    "laundry room": (Item("light", _H, 0, 1), Item("laundry basket", _W, 1, 2), Item("trash can", _W, 0, 1, 0.5),
                     Item("laundry detergent", _S, 1, 2, 0.9, ("shelf", "counter")),
                     Item("spray bottle", _S, 0, 2, 0.7, ("shelf", "counter")), Item("box", _S, 0, 2, 0.6, ("shelf",)),
                     Item("clothes", _S, 0, 1, 0.5, ("shelf", "counter")), Item("bath mat", _F, 0, 1, 0.5)),
    "closet": (Item("box", _S, 2, 4, 1.0, ("shelf",)), Item("bag", _S, 1, 2, 0.8, ("shelf",)),
               Item("hat", _S, 0, 2, 0.7, ("shelf",)), Item("clothes", _S, 1, 3, 0.9, ("shelf",)),
               Item("basket", _W, 0, 1, 0.6), Item("box", _W, 0, 2, 0.7), Item("backpack", _C, 0, 1, 0.5)),
    "garage": (Item("box", _W, 2, 4), Item("trash can", _W, 1, 2), Item("box", _S, 2, 4, 1.0, ("shelf",)),
               Item("power drill", _S, 0, 1, 0.7, ("table", "shelf")), Item("spray bottle", _S, 0, 2, 0.6, ("shelf", "table")),
               Item("basket", _C, 0, 1, 0.5), Item("light", _H, 1, 2)),
    "stairwell": (Item("picture", _H, 2, 4), Item("light", _H, 1, 2), Item("plant", _W, 0, 1, 0.6),
                  Item("clock", _H, 0, 1, 0.5)),
}
WINDOW_CURTAINS = 0.8  # probability that a window has curtains (two panels)
WINDOW_RADIATOR = {"bathroom": 0.5, "kitchen": 0.6, "garage": 0.0, "closet": 0.0}  # else 0.7
CEILING_M2 = 12.0  # one ceiling light per this floor area (at least one)


# ------------------------------------------------------------------------------------------------
# placing a kit


def _blocks(m: Model) -> bool:
    """Whether a model blocks walking (see `placement`: bottom low, top above a rug; a plate flush with the wall,
    3 cm or thinner, does not)."""
    b = placement.item_box(m, 0.0, 0.0, 0)
    return bool(b[4] < placement.NAV_IGNORE_ABOVE and b[5] > placement.FLAT and min(b[2] - b[0], b[3] - b[1]) > 0.03)


def _try(state: placement.RoomState, items: list[placement.Placed], nav: Callable[[], bool], clear: np.ndarray | None = None) -> bool:
    """Commit the items when they fit and (if they block walking) the room stays walkable; else take them back."""
    if not state.fits(items, clear):
        return False
    n_b, n_p, n_c = len(state.bodies), len(state.placed), len(state.clear)
    state.commit(items, clear)
    if any(_blocks(m) for m, *_ in items) and not nav():
        del state.bodies[n_b:], state.placed[n_p:], state.clear[n_c:]
        return False
    return True


def _door_leaves(state: placement.RoomState, room: layout.PlanRoom, doors: list[layout.PlanDoor], rooms: dict[int, layout.PlanRoom],
                 rng: np.random.Generator, nav: Callable[[], bool]) -> None:
    """Hang a leaf in each doorway that opens into this room: doors open into rooms, not into hallways or stairwells;
    between two rooms the one with the higher id takes it. Hinged at one jamb, open 90 degrees along the keep-out."""
    halls = ("hallway", "stairwell")
    rgb = jitter((236, 232, 222), rng, 4) if rng.random() < 0.6 else pick(rng, WOODS[:4])
    t = 0.5 * WALL_T
    for d, side in layout.room_doors(room, doors):
        other = rooms[d.room_b if d.room_a == room.id else d.room_a]
        if room.type in halls and other.type in halls:
            continue
        if room.type in halls or (other.type not in halls and room.id < other.id):
            continue
        clear_w, height = d.width - 0.1, d.height - 0.05
        hinge = 1.0 if rng.random() < 0.5 else -1.0  # which jamb, along the wall
        c = d.centre + hinge * (0.5 * clear_w - 0.03)
        inward = {"S": 1.0, "N": -1.0, "W": 1.0, "E": -1.0}[side]
        leaf = door_leaf(clear_w, height, rgb)
        # the leaf frame: hinge at the origin, leaf along +y; yaw turns +y into the room
        yaw = {"S": 0, "N": 180, "W": 270, "E": 90}[side]
        line = {"S": room.y0, "N": room.y1, "W": room.x0, "E": room.x1}[side] + inward * (t + SKIRTING[0] + 0.004)
        ox, oy = (c, line) if side in ("S", "N") else (line, c)
        keep, state.keepouts = state.keepouts, []  # the leaf stands in its own doorway's keep-out zone
        try:
            _try(state, [(leaf, float(ox), float(oy), yaw)], nav)
        finally:
            state.keepouts = keep


def _ceiling_lights(state: placement.RoomState, room: layout.PlanRoom, wall_h: float, rng: np.random.Generator) -> None:
    """Hang ceiling lights along the room's long axis, about one per `CEILING_M2`."""
    ix = state.interior
    w, d = ix[2] - ix[0], ix[3] - ix[1]
    n = max(1, int(round(w * d / CEILING_M2)))
    for k in range(n):
        f = (k + 0.5) / n
        x, y = (ix[0] + f * w, ix[1] + 0.5 * d) if w >= d else (ix[0] + 0.5 * w, ix[1] + f * d)
        lamp = ceiling_light(rng, wall_h)
        keep, state.keepouts = state.keepouts, []  # under the ceiling, above the doorways
        try:
            if state.fits([(lamp, float(x), float(y), 0)], None):
                state.commit([(lamp, float(x), float(y), 0)], None)
        finally:
            state.keepouts = keep


def _window_things(state: placement.RoomState, room: layout.PlanRoom, windows: dict[str, list[tuple]], rng: np.random.Generator,
                   nav: Callable[[], bool]) -> None:
    """Curtains beside the windows (two panels each) and radiators under them."""
    ix = state.interior
    rgb = pick(rng, furniture.FABRICS + furniture.LINENS)
    p_rad = WINDOW_RADIATOR.get(room.type, 0.7)
    for side in ("S", "E", "N", "W"):
        for c, hw, sill, top in windows.get(side, []):
            yaw = {"S": 0, "E": 90, "N": 180, "W": 270}[side]
            at = {"S": ix[1], "N": ix[3], "W": ix[0], "E": ix[2]}[side]
            if rng.random() < WINDOW_CURTAINS:
                for sgn in (-1.0, 1.0):
                    panel = curtain(rng, top + 0.1, rgb)
                    along = c + sgn * (hw + 0.06 + 0.5 * panel.width)  # beside the window's keep-clear zone
                    ox, oy = (along, at) if side in ("S", "N") else (at, along)
                    _try(state, [(panel, float(ox), float(oy), yaw)], nav)
            if sill > 0.7 and rng.random() < p_rad:
                rad = radiator(rng, float(np.clip(2 * hw, 0.5, 1.4)))  # its top (<= 0.7 m) stays under the sill
                ox, oy = (c, at) if side in ("S", "N") else (at, c)
                _try(state, [(rad, float(ox), float(oy), yaw)], nav)


SMOKE = ("bedroom", "hallway", "living room", "stairwell", "kitchen")  # rooms with a smoke detector
PLATE = (244, 244, 240)


def _fixtures(state: placement.RoomState, room: layout.PlanRoom, doors: list[layout.PlanDoor], wall_h: float,
              rng: np.random.Generator) -> None:
    """The fixtures a scan labels too: a light switch beside each doorway, outlets along the walls (one per 3.6 m of
    wall, the US code's spacing; one per 4 m of hallway, one in a closet or stairwell), a vent and, in living and
    sleeping rooms, kitchens and halls, a smoke detector. Plates flush with the wall (1.2 cm) block nothing."""
    ix = state.interior
    for d, side in layout.room_doors(room, doors):
        sw = _boxy("light switch", (0.08, 0.012, 0.12), PLATE, "plain", z0=u(rng, 1.05, 1.15))
        yaw = {"S": 0, "N": 180, "W": 270, "E": 90}[side]
        at = {"S": ix[1], "N": ix[3], "W": ix[0], "E": ix[2]}[side]
        for sgn in ((1.0, -1.0) if rng.random() < 0.5 else (-1.0, 1.0)):
            along = d.centre + sgn * (0.5 * d.width + 0.16)
            ox, oy = (along, at) if side in ("S", "N") else (at, along)
            if state.fits([(sw, float(ox), float(oy), yaw)], None):
                state.commit([(sw, float(ox), float(oy), yaw)], None)
                break
    perimeter = 2.0 * ((ix[2] - ix[0]) + (ix[3] - ix[1]))
    if room.type in ("closet", "stairwell"):
        n = 1
    elif room.type == "hallway":  # one per 4 m of hallway
        n = max(1, int(round(max(ix[2] - ix[0], ix[3] - ix[1]) / 4.0)))
    else:
        n = max(1, int(round(perimeter / 3.6)))
    for _ in range(n):
        plate = _boxy("outlet", (0.08, 0.012, 0.12), PLATE, "plain", z0=u(rng, 0.25, 0.35))
        placement.place_wall(state, placement.Group([(plate, 0.0, 0.0, 0)]), rng, corner=False)
    things = [Model("vent", "furniture", [], 0.3, 0.2, wall_h, z_min=wall_h - 0.02)]
    things[0].add(shapes.box((-0.15, -0.1, wall_h - 0.02), (0.15, 0.1, wall_h)), PLATE, "metal")
    if room.type in SMOKE:
        det = Model("smoke detector", "furniture", [], 0.12, 0.12, wall_h, z_min=wall_h - 0.04)
        det.add(shapes.cylinder(0.06, wall_h - 0.04, wall_h, 12), PLATE, "plain")
        things.append(det)
    keep, state.keepouts = state.keepouts, []  # on the ceiling, above the doorways
    try:
        for m in things:
            for _ in range(8):
                x = float(np.round(rng.uniform(ix[0] + 0.3, ix[2] - 0.3), 3))
                y = float(np.round(rng.uniform(ix[1] + 0.3, ix[3] - 0.3), 3))
                if state.fits([(m, x, y, 0)], None):
                    state.commit([(m, x, y, 0)], None)
                    break
    finally:
        state.keepouts = keep


def _surfaces(state: placement.RoomState, labels: tuple[str, ...]) -> tuple[list[tuple[float, np.ndarray, float]], list[Model]]:
    """Return (height, world rectangle x0 y0 x1 y1, headroom) of the support surfaces of the placed receptacles
    with these labels (headroom: up to the next surface above on the same piece, or 0.4 m), and each one's piece."""
    out, hosts = [], []
    for m, ox, oy, yaw in state.placed:
        if m.kind != "receptacle" or m.label not in labels or is_proxy(m):
            continue
        hs = sorted(h for h, _ in m.supports)
        for h, poly in m.supports:
            above = [x for x in hs if x > h + 1e-6]
            room_above = (above[0] - h) if above else 0.4
            p = np.asarray(poly) @ placement.rot90(yaw).T + np.array([ox, oy])
            out.append((float(h), np.concatenate([p.min(0), p.max(0)]), float(room_above)))
            hosts.append(m)
    return out, hosts


def _on_surface(state: placement.RoomState, item: Item, rng: np.random.Generator, used: dict[int, list[np.ndarray]]) -> bool:
    """Stand a small thing on one of the surfaces it may go on (clear of the others there, a third of its area)."""
    surfaces, host = _surfaces(state, item.on)
    if not surfaces:
        return False
    for _ in range(6):
        k = int(rng.integers(len(surfaces)))
        h, r, head = surfaces[k]
        m = small_prop(item.label, rng, h)
        if m.height - h > head - 0.03 or r[2] - r[0] < m.width + 0.05 or r[3] - r[1] < m.depth + 0.05:
            continue
        taken = used.setdefault(k, [])
        if sum((b[2] - b[0]) * (b[3] - b[1]) for b in taken) + m.width * m.depth > (r[2] - r[0]) * (r[3] - r[1]) / 3:
            return False
        x = float(np.round(rng.uniform(r[0] + 0.02 + 0.5 * m.width, r[2] - 0.02 - 0.5 * m.width), 3))
        y = float(np.round(rng.uniform(r[1] + 0.02 + 0.5 * m.depth, r[3] - 0.02 - 0.5 * m.depth), 3))
        box = np.array([x - 0.5 * m.width, y - 0.5 * m.depth, x + 0.5 * m.width, y + 0.5 * m.depth, h, m.height])
        if any(placement.overlap2(box, b, 0.02) for b in taken):
            continue
        # nothing else in the way above the surface (a wall shelf over a counter, the shelf board above)
        if any(placement.overlap2(box, o, 0.0) and o[4] < box[5] - 1e-6 and box[4] + 1e-3 < o[5]
               for o in (placement.item_box(*pl) for pl in state.placed if pl[0] is not host[k])):
            continue
        taken.append(box)
        state.placed.append((m, x, y, 0))  # on its receptacle: no new floor body
        return True
    return False


def dress(state: placement.RoomState, room: layout.PlanRoom, doors: list[layout.PlanDoor], rooms: dict[int, layout.PlanRoom],
          windows: dict[str, list[tuple]], wall_h: float, rng: np.random.Generator, nav: Callable[[], bool],
          density: float = 1.0) -> None:
    """Add the room's clutter (`KITS`) to its furnished placement state, in the order of the module docstring.

    Parameters
    ----------
    state : placement.RoomState
        The room after its furniture (bodies, keep-outs, placed pieces); the clutter is committed into it.
    room : layout.PlanRoom
        The room.
    doors : list of layout.PlanDoor
        The doors of its storey.
    rooms : dict
        Room id -> PlanRoom of the home (which side of a doorway takes the leaf).
    windows : dict
        Side -> [(centre, half width, sill, top)] of the room's windows, storey-relative metres.
    wall_h : float
        Wall height, metres.
    rng : numpy.random.Generator
        The room's clutter generator.
    nav : callable
        ``nav()`` -> whether the room is still walkable door to door and to every receptacle.
    density : float
        Scales every item's probability (1: the house level; 0 places nothing).
    """
    if density <= 0:
        return
    _door_leaves(state, room, doors, rooms, rng, nav)
    _fixtures(state, room, doors, wall_h, rng)
    _ceiling_lights(state, room, wall_h, rng)
    _window_things(state, room, windows, rng, nav)
    used: dict[int, list[np.ndarray]] = {}
    kit = KITS.get(room.type, ())
    for mode in (_H, _W, _C, _F, _S):
        for item in (i for i in kit if i.mode == mode):
            n = int(rng.integers(item.lo, item.hi + 1))
            for _ in range(n):
                if rng.random() >= min(1.0, item.p * density):
                    continue
                if mode == _S:
                    _on_surface(state, item, rng, used)
                    continue
                narrow = min(state.interior[2] - state.interior[0], state.interior[3] - state.interior[1]) < 2.0
                if mode == _F and narrow:  # a runner along a hallway
                    m = furniture.rug(rng, u(rng, 1.4, 3.0), u(rng, 0.5, 0.7))
                    m.label = item.label
                else:
                    m = _wall_prop(item.label, rng) if mode == _H else _floor_prop(item.label, rng)
                g = placement.Group([(m, 0.0, 0.0, 0)], 0.3 if mode in (_W, _C) and item.label == "armchair" else 0.0)
                if mode == _F:
                    placement.place_centre(state, g, rng, margin=0.1 if narrow else 0.3)
                    continue
                n_b, n_p, n_c = len(state.bodies), len(state.placed), len(state.clear)
                if placement.place_wall(state, g, rng, corner=(mode == _C)) and _blocks(m) and not nav():
                    del state.bodies[n_b:], state.placed[n_p:], state.clear[n_c:]


__all__ = ["KITS", "SMALL", "Item", "ceiling_light", "curtain", "door_leaf", "dress", "radiator", "small_prop"]
