"""Seeded procedural household objects: 29 categories, any number of shape variants each.

Objects are built from closed parts (revolved profiles, rounded boxes, swept tubes, ellipsoids),
so every part is watertight and the whole mesh is watertight in the edge sense (CoACD decomposes
it later). Units are metres, Z up, the object rests on z = 0 and is centred in XY on its bounding
box. ``write_object_library`` writes ``<out>/<category>/<category>_<k>/model.obj`` + ``model.mtl``
(per-part Kd colours) + ``meta.json``, byte-deterministically.
"""

from __future__ import annotations

import json
import os
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np

from . import shapes

if TYPE_CHECKING:
    import trimesh

LICENSE = "CC0-1.0 (procedural, sdovon-mj)"

Part = tuple[shapes.Mesh, tuple[int, int, int], str]  # mesh, RGB colour, part name


@dataclass(frozen=True)
class ObjectCategory:
    """A category: its name and plausible bounding-box size (long side, short side, height) in metres."""

    name: str
    size_min: tuple[float, float, float]
    size_max: tuple[float, float, float]
    builder: Callable[[np.random.Generator], list[Part]]


@dataclass
class HouseholdObject:
    """A generated object: closed coloured parts, Z up, base at z = 0, centred on its XY box."""

    category: str
    name: str
    seed: int
    parts: list[Part]

    @property
    def vertices(self) -> np.ndarray:
        """Return all vertices (N, 3)."""
        return np.concatenate([p[0][0] for p in self.parts])

    @property
    def faces(self) -> np.ndarray:
        """Return all faces (M, 3) indexing `vertices`."""
        return shapes.concat([p[0] for p in self.parts])[1]

    @property
    def dims(self) -> np.ndarray:
        """Return the bounding-box extents (x, y, z)."""
        v = self.vertices
        return v.max(0) - v.min(0)

    def to_trimesh(self) -> "trimesh.Trimesh":
        """Return the object as one trimesh.Trimesh with face colours."""
        import trimesh

        v, f = shapes.concat([p[0] for p in self.parts])
        colors = np.concatenate([np.tile(np.array(p[1] + (255,), dtype=np.uint8), (len(p[0][1]), 1)) for p in self.parts])
        return trimesh.Trimesh(v, f, face_colors=colors, process=False)


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Uniform draw rounded to 0.1 mm."""
    return float(np.round(rng.uniform(lo, hi), 4))


def _c(rng: np.random.Generator, palette: tuple, amount: float = 8.0) -> tuple[int, int, int]:
    """A palette colour with a small random tint."""
    base = np.asarray(palette[int(rng.integers(len(palette)))], dtype=np.float64)
    return tuple(int(x) for x in np.clip(np.round(base + rng.normal(0.0, amount, 3)), 0, 255))


CERAMICS = ((240, 240, 236), (200, 40, 40), (40, 80, 160), (230, 190, 60), (30, 30, 32), (70, 140, 90), (220, 140, 150))
PLASTICS = ((220, 50, 50), (40, 110, 200), (250, 210, 40), (60, 170, 80), (245, 245, 245), (30, 30, 30), (240, 130, 40))
GLASS = ((150, 190, 170), (110, 70, 40), (190, 210, 220), (60, 110, 70))
FABRIC = ((190, 60, 60), (70, 90, 150), (200, 190, 160), (110, 140, 100), (230, 230, 225), (150, 110, 160), (240, 180, 90))
METAL = ((200, 200, 205), (175, 175, 180), (210, 190, 140))
DARK = ((35, 35, 38), (60, 60, 64), (90, 90, 96), (180, 180, 185))
WOOD = ((150, 110, 70), (110, 75, 45), (190, 150, 105))


def _shell(outer: list[tuple[float, float]], wall: float, bottom: float, seg: int = 32) -> shapes.Mesh:
    """Revolve a thin-walled open vessel: `outer` (r, z) from the base rim up to the lip; base closed."""
    outer = [(float(r), float(z)) for r, z in outer]
    inner = [(max(r - wall, 0.002), max(z, bottom)) for r, z in outer[::-1]]
    lip = outer[-1]
    prof = [(0.0, 0.0)] + outer + [(lip[0] - 0.5 * wall, lip[1] + 0.002)] + inner[:-1] + [(inner[-1][0], bottom), (0.0, bottom)]
    return shapes.revolve(prof, seg)


# ------------------------------------------------------------------------------------------------
# builders (each returns parts; the caller centres the result)


def _mug(rng: np.random.Generator) -> list[Part]:
    r, h = _u(rng, 0.038, 0.045), _u(rng, 0.085, 0.1)
    style = int(rng.integers(3))
    rb = r * (0.82 if style == 1 else 1.0)
    mid = r * (1.06 if style == 2 else 1.0)
    body = _shell([(rb - 0.003, 0.0), (rb, 0.004), (mid, 0.5 * h), (r, h)], 0.004, 0.007)
    major, minor = _u(rng, 0.024, 0.03), _u(rng, 0.0045, 0.006)
    handle = shapes.torus_arc((r - 0.002, 0.0, 0.5 * h), major, minor, -np.radians(95), np.radians(95), "xz", 14, 10)
    col = _c(rng, CERAMICS)
    return [(body, col, "body"), (handle, col, "handle")]


def _cup(rng: np.random.Generator) -> list[Part]:
    rt, h = _u(rng, 0.035, 0.045), _u(rng, 0.08, 0.13)
    rb = rt * _u(rng, 0.7, 0.95)
    col = _c(rng, GLASS + PLASTICS[:4] if rng.random() < 0.5 else CERAMICS)
    body = _shell([(rb - 0.002, 0.0), (rb, 0.003), (rt, h)], 0.003, 0.008, 36)
    return [(body, col, "body")]


def _bowl(rng: np.random.Generator) -> list[Part]:
    r, h = _u(rng, 0.06, 0.1), _u(rng, 0.05, 0.085)
    foot = 0.45 * r
    t = np.linspace(0.0, 0.5 * np.pi, 7)
    wall = [(foot + (r - foot) * np.sin(a), 0.008 + (h - 0.008) * (1 - np.cos(a))) for a in t]
    body = _shell([(foot - 0.003, 0.0), (foot, 0.008)] + wall[1:], 0.004, 0.011, 40)
    return [(body, _c(rng, CERAMICS), "body")]


def _plate(rng: np.random.Generator) -> list[Part]:
    r, h = _u(rng, 0.09, 0.14), _u(rng, 0.016, 0.025)
    prof = [(0.0, 0.0), (0.55 * r, 0.0), (0.6 * r, 0.006), (r, h), (r - 0.004, h + 0.001), (0.62 * r, 0.009), (0.0, 0.009)]
    return [(shapes.revolve(prof, 48), _c(rng, CERAMICS), "body")]


def _book(rng: np.random.Generator) -> list[Part]:
    w, l, t = _u(rng, 0.12, 0.21), _u(rng, 0.17, 0.28), _u(rng, 0.015, 0.055)
    if w > 0.8 * l:
        w = round(0.7 * l, 4)
    c = 0.002
    cover = _c(rng, FABRIC + PLASTICS + DARK, 14)
    parts = [
        (shapes.rounded_box((0, 0, 0), (l, w, c), 0.0008, 2), cover, "back"),
        (shapes.rounded_box((0, 0, t - c), (l, w, t), 0.0008, 2), cover, "front"),
        (shapes.rounded_box((0.0003, 0, 0.5 * c), (l - 0.0003, c, t - 0.5 * c), 0.0007, 2), cover, "spine"),
        (shapes.rounded_box((0.004, 0.7 * c, 0.7 * c), (l - 0.004, w - 0.004, t - 0.7 * c), 0.001, 2), (236, 230, 210), "pages"),
    ]
    return parts


def _bottle(rng: np.random.Generator) -> list[Part]:
    r, h = _u(rng, 0.03, 0.045), _u(rng, 0.2, 0.31)
    neck = _u(rng, 0.011, 0.015)
    sh = h * _u(rng, 0.55, 0.7)
    prof = [(0.0, 0.0), (r - 0.004, 0.0), (r, 0.005), (r, sh), (0.55 * r + 0.45 * neck, sh + 0.35 * (h - sh) * 0.5),
            (neck, sh + 0.55 * (h - sh)), (neck, h - 0.02), (0.0, h - 0.02)]
    body = shapes.revolve(prof, 32)
    cap = shapes.cylinder(neck + 0.002, h - 0.022, h, 20)
    label = shapes.cylinder(r + 0.0008, 0.3 * sh, 0.8 * sh, 32)
    return [(body, _c(rng, GLASS + PLASTICS), "body"), (cap, _c(rng, PLASTICS + METAL), "cap"),
            (label, _c(rng, FABRIC), "label")]


def _can(rng: np.random.Generator) -> list[Part]:
    r, h = _u(rng, 0.026, 0.033), _u(rng, 0.1, 0.123)
    prof = [(0.0, 0.003), (r - 0.006, 0.0), (r - 0.003, 0.0), (r, 0.008), (r, h - 0.01), (r - 0.004, h - 0.002),
            (r - 0.003, h), (r - 0.005, h), (r - 0.006, h - 0.004), (0.0, h - 0.004)]
    return [(shapes.revolve(prof, 36), _c(rng, PLASTICS + METAL, 12), "body")]


def _cereal_box(rng: np.random.Generator) -> list[Part]:
    w, d, h = _u(rng, 0.19, 0.3), _u(rng, 0.05, 0.09), _u(rng, 0.25, 0.35)
    return [(shapes.rounded_box((0, 0, 0), (w, d, h), 0.003, 4), _c(rng, PLASTICS + FABRIC, 15), "box")]


def _laptop(rng: np.random.Generator) -> list[Part]:
    w, d = _u(rng, 0.3, 0.38), _u(rng, 0.21, 0.26)
    tb, tl = _u(rng, 0.012, 0.018), _u(rng, 0.005, 0.008)
    shell = _c(rng, DARK + METAL)
    parts: list[Part] = [(shapes.rounded_box((0, 0, 0), (w, d, tb), 0.004, 3), shell, "base"),
                         (shapes.box((0.02, 0.06, tb - 0.0005), (w - 0.02, d - 0.02, tb + 0.001)), (20, 20, 22), "keys")]
    if rng.random() < 0.34:  # closed
        parts.append((shapes.rounded_box((0, 0, tb + 0.0015), (w, d, tb + 0.0015 + tl), 0.003, 3), shell, "lid"))
        return parts
    ang = np.radians(_u(rng, 100.0, 115.0))
    lid = shapes.rounded_box((0, 0, 0), (w, tl, d), 0.003, 3)
    screen = shapes.box((0.015, tl - 0.0005, 0.015), (w - 0.015, tl + 0.001, d - 0.015))
    rot = shapes.rot_x(-(ang - 0.5 * np.pi))
    hinge = (0.0, d - tl, tb)
    parts.append((shapes.transform(lid, rot=rot, shift=hinge), shell, "lid"))
    parts.append((shapes.transform(shapes.transform(screen, shift=(0, -tl, 0)), rot=rot, shift=hinge), (15, 20, 30), "screen"))
    return parts


def _remote(rng: np.random.Generator) -> list[Part]:
    l, w, t = _u(rng, 0.14, 0.22), _u(rng, 0.038, 0.055), _u(rng, 0.016, 0.026)
    body = _c(rng, DARK)
    parts: list[Part] = [(shapes.rounded_box((0, 0, 0), (l, w, t), 0.006, 3), body, "body")]
    rows = int(rng.integers(3, 6))
    for i in range(rows):
        for j in range(3):
            x = l * (0.25 + 0.6 * i / max(rows - 1, 1))
            y = w * (0.25 + 0.25 * j)
            parts.append((shapes.cylinder(0.0035, t - 0.001, t + 0.002, 8, (x, y)), (200, 200, 200) if (i + j) % 3 else (200, 40, 40),
                          "button"))
    return parts


def _pillow(rng: np.random.Generator) -> list[Part]:
    if rng.random() < 0.4:
        a = _u(rng, 0.4, 0.5)
        l, w = a, a
    else:
        l, w = _u(rng, 0.45, 0.6), _u(rng, 0.3, 0.42)
    h = _u(rng, 0.1, 0.16)
    return [(shapes.superellipsoid((0, 0, 0), (l, w, h), 0.35, 0.22, 12, 28), _c(rng, FABRIC), "cover")]


def _stuffed_toy(rng: np.random.Generator) -> list[Part]:
    s = _u(rng, 0.7, 1.25)
    fur = _c(rng, ((150, 100, 60), (230, 220, 200), (200, 160, 110), (120, 120, 125), (230, 170, 190)))
    kind = int(rng.integers(3))
    ell = lambda c, r: shapes.ellipsoid(tuple(np.array(c) * s), tuple(np.array(r) * s), 8, 14)  # noqa: E731
    parts: list[Part] = [
        (ell((0, 0, 0.07), (0.06, 0.05, 0.07)), fur, "body"),
        (ell((0, 0, 0.165), (0.048, 0.045, 0.045)), fur, "head"),
        (ell((-0.035, 0.045, 0.025), (0.025, 0.035, 0.022)), fur, "leg_l"),
        (ell((0.035, 0.045, 0.025), (0.025, 0.035, 0.022)), fur, "leg_r"),
        (ell((-0.06, 0.015, 0.09), (0.018, 0.018, 0.04)), fur, "arm_l"),
        (ell((0.06, 0.015, 0.09), (0.018, 0.018, 0.04)), fur, "arm_r"),
        (ell((0, 0.04, 0.158), (0.02, 0.015, 0.015)), (60, 40, 30), "snout"),
    ]
    if kind == 1:  # bunny: long ears
        parts += [(ell((-0.02, 0, 0.24), (0.013, 0.008, 0.05)), fur, "ear_l"), (ell((0.02, 0, 0.24), (0.013, 0.008, 0.05)), fur, "ear_r")]
    else:  # bear / cat: round ears
        parts += [(ell((-0.033, 0, 0.2), (0.016, 0.01, 0.016)), fur, "ear_l"), (ell((0.033, 0, 0.2), (0.016, 0.01, 0.016)), fur, "ear_r")]
    if kind == 2:
        parts.append((ell((0, -0.055, 0.03), (0.012, 0.03, 0.012)), fur, "tail"))
    return parts


def _vase(rng: np.random.Generator) -> list[Part]:
    r, h = _u(rng, 0.04, 0.085), _u(rng, 0.15, 0.35)
    style = int(rng.integers(3))
    if style == 0:
        outer = [(0.8 * r, 0.0), (r, 0.3 * h), (r, 0.9 * h), (0.9 * r, h)]
    elif style == 1:
        outer = [(0.6 * r, 0.0), (r, 0.25 * h), (0.95 * r, 0.5 * h), (0.45 * r, 0.8 * h), (0.4 * r, 0.92 * h), (0.55 * r, h)]
    else:
        outer = [(0.5 * r, 0.0), (0.7 * r, 0.3 * h), (0.85 * r, 0.7 * h), (r, h)]
    return [(_shell(outer, 0.004, 0.01, 36), _c(rng, CERAMICS + GLASS), "body")]


def _potted_plant(rng: np.random.Generator) -> list[Part]:
    pr, ph = _u(rng, 0.055, 0.1), _u(rng, 0.08, 0.16)
    pot = _shell([(0.75 * pr, 0.0), (pr, ph)], 0.006, 0.012, 28)
    soil = shapes.cylinder(pr - 0.008, ph - 0.025, ph - 0.012, 24)
    green = _c(rng, ((60, 130, 60), (40, 100, 50), (90, 150, 70)), 12)
    parts: list[Part] = [(pot, _c(rng, ((180, 90, 60), (230, 230, 225), (60, 60, 64), (200, 170, 130))), "pot"),
                         (soil, (70, 50, 35), "soil")]
    kind = int(rng.integers(3))
    if kind == 0:  # leafy: flattened ellipsoid leaves on a fan
        n = int(rng.integers(6, 10))
        for k in range(n):
            a = 2 * np.pi * k / n + rng.uniform(-0.2, 0.2)
            tilt = rng.uniform(0.5, 1.1)
            ln = _u(rng, 0.1, 0.2)
            leaf = shapes.ellipsoid((0, 0, 0), (0.5 * ln, 0.018, 0.004), 6, 10)
            leaf = shapes.transform(leaf, rot=shapes.rot_z(a) @ shapes.rot_y(-tilt), shift=(0.0, 0.0, 0.0))
            tip = shapes.rot_z(a) @ shapes.rot_y(-tilt) @ np.array([0.5 * ln, 0, 0])
            parts.append((shapes.transform(leaf, shift=(tip[0], tip[1], ph - 0.015 + tip[2])), green, f"leaf{k}"))
    elif kind == 1:  # bush of spheres
        for k in range(int(rng.integers(4, 7))):
            rr = _u(rng, 0.04, 0.07)
            off = rng.uniform(-0.5, 0.5, 2) * pr
            parts.append((shapes.icosphere((off[0], off[1], ph + rr * rng.uniform(0.3, 1.4)), rr, 1), green, f"bush{k}"))
    else:  # cactus
        hh = _u(rng, 0.12, 0.3)
        parts.append((shapes.revolve([(0, ph - 0.02), (0.025, ph - 0.02), (0.03, ph + 0.5 * hh), (0.02, ph + hh), (0, ph + hh + 0.01)], 14),
                      green, "cactus"))
        arm = np.array([[0.02, 0, ph + 0.4 * hh], [0.05, 0, ph + 0.42 * hh], [0.06, 0, ph + 0.55 * hh], [0.06, 0, ph + 0.7 * hh]])
        parts.append((shapes.sweep(arm, 0.012, 10), green, "arm"))
    return parts


def _lamp(rng: np.random.Generator) -> list[Part]:
    h = _u(rng, 0.3, 0.55)
    sr = _u(rng, 0.09, 0.17)
    br = _u(rng, 0.05, 0.08)
    base_c = _c(rng, CERAMICS + METAL + WOOD)
    parts: list[Part] = []
    if rng.random() < 0.5:
        parts.append((shapes.revolve([(0, 0), (br, 0), (br, 0.02), (0.5 * br, 0.03), (0, 0.03)], 28), base_c, "base"))
    else:  # ceramic body base
        parts.append((shapes.revolve([(0, 0), (0.7 * br, 0), (br * 1.2, 0.35 * (h - 0.2)), (0.4 * br, h - 0.25), (0, h - 0.25)], 28),
                      base_c, "base"))
    parts.append((shapes.cylinder(0.006, 0.02, h - 0.14, 10), (180, 180, 185), "stem"))
    sh = 0.18 if h > 0.4 else 0.14
    shade = shapes.revolve([(0.6 * sr, h - sh), (sr, h - sh), (0.62 * sr, h), (0.6 * sr, h), (0.98 * sr, h - sh + 0.003),
                       (0.585 * sr, h - sh + 0.003)], 32, closed=True)
    parts.append((shade, _c(rng, ((240, 235, 220), (220, 200, 170), (200, 200, 200), (120, 150, 170))), "shade"))
    return parts


def _shoe(rng: np.random.Generator) -> list[Part]:
    l, w = _u(rng, 0.24, 0.31), _u(rng, 0.085, 0.11)
    h = _u(rng, 0.07, 0.13)
    sole_t = 0.02
    sole = shapes.rounded_box((0, 0, 0), (l, w, sole_t), 0.008, 3)
    a = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    ring = lambda cx, cy, rx, ry, z: np.stack([cx + rx * np.cos(a), cy + ry * np.sin(a), np.full_like(a, z)], 1)  # noqa: E731
    pts = np.concatenate([ring(0.5 * l, 0.5 * w, 0.48 * l, 0.46 * w, sole_t - 0.002),
                          ring(0.58 * l, 0.5 * w, 0.3 * l, 0.38 * w, 0.55 * h),
                          ring(0.28 * l, 0.5 * w, 0.16 * l, 0.35 * w, h)])
    upper = shapes.hull(pts)
    return [(sole, _c(rng, ((240, 240, 240), (40, 40, 40), (150, 110, 70))), "sole"),
            (upper, _c(rng, FABRIC + DARK), "upper")]


def _toothbrush(rng: np.random.Generator) -> list[Part]:
    l = _u(rng, 0.17, 0.195)
    t = np.linspace(0, 1, 12)
    path = np.stack([t * (l - 0.03), np.zeros_like(t), 0.007 + 0.004 * np.sin(np.pi * t)], 1)
    radii = 0.0055 + 0.0015 * np.sin(np.pi * t)
    handle = shapes.sweep(path, radii, 10, aspect=0.75)
    head = shapes.rounded_box((l - 0.035, -0.0055, 0.003), (l, 0.0055, 0.011), 0.003, 3)
    bristle = shapes.rounded_box((l - 0.03, -0.005, 0.011), (l - 0.004, 0.005, 0.022), 0.001, 2)
    col = _c(rng, PLASTICS)
    return [(handle, col, "handle"), (head, col, "head"), (bristle, (240, 240, 245), "bristles")]


def _soap_dispenser(rng: np.random.Generator) -> list[Part]:
    r, h = _u(rng, 0.03, 0.042), _u(rng, 0.11, 0.15)
    body = shapes.revolve([(0, 0), (r - 0.004, 0), (r, 0.006), (r, 0.8 * h), (0.45 * r, h), (0, h)], 32)
    collar = shapes.cylinder(0.013, h - 0.002, h + 0.015, 16)
    stem = shapes.cylinder(0.005, h + 0.015, h + 0.04, 10)
    head = shapes.rounded_box((-0.012, -0.01, h + 0.04), (0.012, 0.01, h + 0.055), 0.003, 2)
    nozzle = shapes.sweep(np.array([[0.0, 0, h + 0.048], [0.02, 0, h + 0.048], [0.035, 0, h + 0.045], [0.045, 0, h + 0.038]]),
                     0.0035, 8)
    pump = _c(rng, METAL + DARK + ((245, 245, 245),))
    return [(body, _c(rng, GLASS + PLASTICS + CERAMICS), "bottle"), (collar, pump, "collar"), (stem, pump, "stem"),
            (head, pump, "head"), (nozzle, pump, "nozzle")]


def _towel(rng: np.random.Generator) -> list[Part]:
    l, w = _u(rng, 0.25, 0.38), _u(rng, 0.18, 0.28)
    layers = int(rng.integers(2, 5))
    lt = _u(rng, 0.012, 0.022)
    col = _c(rng, FABRIC + ((245, 245, 245),))
    parts: list[Part] = []
    for k in range(layers):
        dx = rng.uniform(-0.004, 0.004)
        parts.append((shapes.rounded_box((dx, 0, k * lt), (l + dx, w, (k + 1) * lt + 0.001), 0.5 * lt, 3), col, f"fold{k}"))
    return parts


def _spoon(rng: np.random.Generator) -> list[Part]:
    l = _u(rng, 0.14, 0.2)
    bw = _u(rng, 0.03, 0.045)
    bowl = shapes.ellipsoid((0.5 * bw * 1.4, 0, 0.0045), (0.7 * bw, 0.5 * bw, 0.0045), 6, 16)
    t = np.linspace(0, 1, 10)
    path = np.stack([1.2 * bw + t * (l - 1.3 * bw), np.zeros_like(t), 0.004 + 0.012 * t ** 2], 1)
    handle = shapes.sweep(path, 0.0035 + 0.002 * t, 8, aspect=0.4)
    col = _c(rng, METAL + PLASTICS[:2] + WOOD)
    return [(bowl, col, "bowl"), (handle, col, "handle")]


def _knife(rng: np.random.Generator) -> list[Part]:
    bl, bw = _u(rng, 0.1, 0.18), _u(rng, 0.016, 0.028)
    hl = _u(rng, 0.09, 0.12)
    th = 0.0025
    hw = min(0.018, bw)
    blade = shapes.hull(np.array([[0, 0, 0.0045], [0, bw, 0.0045], [bl, 0.2 * bw, 0.0045], [bl - 0.03, bw, 0.0045],
                             [0, 0, 0.0045 + th], [0, bw, 0.0045 + th], [bl, 0.2 * bw, 0.0045 + th], [bl - 0.03, bw, 0.0045 + th]]))
    blade = shapes.transform(blade, shift=(hl - 0.005, 0.5 * hw - 0.5 * bw + 0.0, 0.0))
    handle = shapes.rounded_box((0, 0, 0), (hl, hw, 0.012), 0.004, 4)
    return [(blade, (205, 205, 210), "blade"), (handle, _c(rng, DARK + WOOD), "handle")]


def _apple(rng: np.random.Generator) -> list[Part]:
    r = _u(rng, 0.035, 0.045)
    h = r * _u(rng, 1.7, 2.0)
    a = np.linspace(0.15, np.pi - 0.12, 11)
    prof = [(0.0, 0.06 * h)] + [(r * np.sin(t) * (1.0 + 0.08 * np.sin(2 * t)), 0.5 * h * (1 - np.cos(t))) for t in a] + [(0.0, 0.9 * h)]
    body = shapes.revolve(prof, 28)
    stem = shapes.sweep(np.array([[0, 0, 0.86 * h], [0.001, 0, 0.95 * h], [0.004, 0, 1.05 * h]]), 0.0018, 6)
    col = _c(rng, ((190, 30, 30), (120, 180, 60), (220, 180, 50), (170, 40, 50)), 12)
    return [(body, col, "body"), (stem, (90, 60, 30), "stem")]


def _banana(rng: np.random.Generator) -> list[Part]:
    l = _u(rng, 0.16, 0.22)
    bend = _u(rng, 0.5, 0.9)
    rad = l / bend
    t = np.linspace(-0.5 * bend, 0.5 * bend, 16)
    path = np.stack([rad * np.sin(t), rad * (1 - np.cos(t)), np.zeros_like(t)], 1)
    s = np.linspace(0, 1, 16)
    radii = _u(rng, 0.016, 0.02) * np.clip(np.sin(np.pi * s) ** 0.5, 0.25, 1.0)
    body = shapes.sweep(path, radii, 6)
    stem = shapes.sweep(np.array([path[-1], path[-1] + np.array([0.012, 0.004, 0.0]), path[-1] + np.array([0.022, 0.01, 0.0])]),
                   0.004, 6)
    col = _c(rng, ((235, 205, 60), (200, 210, 70), (230, 190, 50)))
    return [(body, col, "peel"), (stem, (90, 80, 40), "stem")]


def _keyboard(rng: np.random.Generator) -> list[Part]:
    l, w, t = _u(rng, 0.36, 0.45), _u(rng, 0.12, 0.155), _u(rng, 0.014, 0.02)
    body = _c(rng, DARK + ((235, 235, 235),))
    key = (30, 30, 32) if body[0] > 128 else (225, 225, 225)
    parts: list[Part] = [(shapes.rounded_box((0, 0, 0), (l, w, t), 0.005, 3), body, "base")]
    rows, cols = 5, int(rng.integers(13, 16))
    kx = (l - 0.02) / cols
    ky = (w - 0.02) / rows
    for i in range(rows):
        for j in range(cols):
            if i == 0 and 3 <= j < cols - 4:
                continue
            x0, y0 = 0.01 + j * kx, 0.01 + i * ky
            parts.append((shapes.box((x0 + 0.001, y0 + 0.001, t - 0.001), (x0 + kx - 0.001, y0 + ky - 0.001, t + 0.006)), key, "key"))
    x0 = 0.01 + 3 * kx
    parts.append((shapes.box((x0 + 0.001, 0.011, t - 0.001), (0.01 + (cols - 4) * kx - 0.001, 0.01 + ky - 0.001, t + 0.006)), key, "space"))
    return parts


def _phone(rng: np.random.Generator) -> list[Part]:
    l, w, t = _u(rng, 0.135, 0.165), _u(rng, 0.066, 0.078), _u(rng, 0.007, 0.0095)
    body = _c(rng, DARK + METAL + ((200, 60, 60),))
    return [(shapes.rounded_box((0, 0, 0), (l, w, t), 0.0032, 4), body, "body"),
            (shapes.box((0.006, 0.004, t - 0.0003), (l - 0.006, w - 0.004, t + 0.0004)), (12, 14, 20), "screen")]


def _alarm_clock(rng: np.random.Generator) -> list[Part]:
    col = _c(rng, PLASTICS + METAL)
    if rng.random() < 0.5:  # twin-bell: a drum standing on its rim
        r, d = _u(rng, 0.045, 0.06), _u(rng, 0.04, 0.055)
        drum = shapes.transform(shapes.cylinder(r, -0.5 * d, 0.5 * d, 32), rot=shapes.rot_x(0.5 * np.pi), shift=(0, 0, r + 0.012))
        face = shapes.transform(shapes.cylinder(0.85 * r, 0.0, 0.002, 32), rot=shapes.rot_x(-0.5 * np.pi), shift=(0, 0.5 * d, r + 0.012))
        bells = [shapes.revolve([(0, 0), (0.022, 0), (0.02, 0.012), (0.01, 0.02), (0, 0.021)], 16) for _ in range(2)]
        parts: list[Part] = [(drum, col, "body"), (face, (245, 245, 240), "face")]
        for k, sgn in enumerate((-1, 1)):
            b = shapes.transform(bells[k], rot=shapes.rot_y(sgn * 0.6), shift=(sgn * 0.6 * r, 0, 2 * r + 0.004))
            parts.append((b, col, f"bell{k}"))
            parts.append((shapes.cylinder(0.004, 0.0, r * 0.4 + 0.012, 8, (sgn * 0.55 * r, 0)), col, f"foot{k}"))
        return parts
    w, d, h = _u(rng, 0.09, 0.14), _u(rng, 0.05, 0.075), _u(rng, 0.07, 0.1)
    return [(shapes.rounded_box((0, 0, 0), (w, d, h), 0.01, 4), col, "body"),
            (shapes.box((0.1 * w, d - 0.0005, 0.25 * h), (0.9 * w, d + 0.002, 0.8 * h)), (20, 20, 24), "display")]


def _candle(rng: np.random.Generator) -> list[Part]:
    r, h = _u(rng, 0.02, 0.04), _u(rng, 0.06, 0.2)
    wax = _c(rng, ((245, 240, 225), (220, 60, 60), (240, 200, 120), (180, 200, 230)))
    parts: list[Part] = []
    if rng.random() < 0.35:  # in a glass
        parts.append((_shell([(r + 0.004, 0.0), (r + 0.006, h)], 0.003, 0.006, 32), (200, 215, 220), "glass"))
        parts.append((shapes.cylinder(r, 0.006, 0.75 * h, 32), wax, "wax"))
        parts.append((shapes.cylinder(0.0012, 0.75 * h, 0.75 * h + 0.012, 6), (30, 30, 30), "wick"))
    else:
        parts.append((shapes.revolve([(0, 0), (r, 0), (r, h - 0.004), (r - 0.004, h), (0, h - 0.002)], 32), wax, "wax"))
        parts.append((shapes.cylinder(0.0012, h - 0.003, h + 0.01, 6), (30, 30, 30), "wick"))
    return parts


def _wine_glass(rng: np.random.Generator) -> list[Part]:
    fr, br = _u(rng, 0.03, 0.04), _u(rng, 0.036, 0.045)
    stem_h, bowl_h = _u(rng, 0.06, 0.1), _u(rng, 0.08, 0.11)
    z1 = stem_h + 0.004
    a = np.linspace(0.0, 1.0, 7)
    outer = [(0.004 + (br - 0.004) * np.sin(0.5 * np.pi * t) ** 0.7 * (1 - 0.12 * t ** 3), z1 + bowl_h * t) for t in a[1:]]
    inner = [(max(r - 0.0025, 0.002), z + 0.0025) for r, z in outer[::-1]]
    prof = [(0.0, 0.0), (fr, 0.0), (fr, 0.002), (0.006, 0.005), (0.0035, 0.012), (0.0035, stem_h), (0.006, z1)] + outer + inner[1:] \
        + [(0.0, z1 + 0.006)]
    return [(shapes.revolve(prof, 32), _c(rng, ((215, 225, 230), (230, 230, 230), (200, 220, 205)), 4), "glass")]


def _teapot(rng: np.random.Generator) -> list[Part]:
    r, h = _u(rng, 0.065, 0.09), _u(rng, 0.09, 0.13)
    t = np.linspace(0.1, np.pi - 0.5, 10)
    prof = [(0.0, 0.0), (0.55 * r, 0.0)] + [(r * np.sin(s), 0.5 * h * (1 - np.cos(s)) / (0.5 * (1 - np.cos(np.pi - 0.5)))) for s in t]
    prof += [(0.35 * r, h), (0.0, h)]
    body = shapes.revolve([(max(p[0], 0.0), min(p[1], h)) for p in prof], 32)
    lid = shapes.revolve([(0, h), (0.36 * r, h), (0.3 * r, h + 0.012), (0.08 * r, h + 0.018), (0.0, h + 0.018)], 24)
    knob = shapes.icosphere((0, 0, h + 0.025), 0.009, 1)
    spout_path = np.array([[0.6 * r, 0, 0.3 * h], [r + 0.01, 0, 0.4 * h], [r + 0.04, 0, 0.65 * h], [r + 0.06, 0, 0.85 * h]])
    spout = shapes.sweep(spout_path, np.array([0.016, 0.012, 0.009, 0.007]), 12)
    handle = shapes.torus_arc((-0.8 * r, 0.0, 0.5 * h), _u(rng, 0.035, 0.045), 0.007, np.radians(80), np.radians(280), "xz", 14, 10)
    col = _c(rng, CERAMICS + METAL)
    return [(body, col, "body"), (lid, col, "lid"), (knob, col, "knob"), (spout, col, "spout"), (handle, col, "handle")]


OBJECT_CATEGORIES: dict[str, ObjectCategory] = {
    c.name: c
    for c in (
        ObjectCategory("mug", (0.1, 0.072, 0.08), (0.135, 0.095, 0.106), _mug),
        ObjectCategory("cup", (0.065, 0.065, 0.075), (0.095, 0.095, 0.135), _cup),
        ObjectCategory("bowl", (0.115, 0.115, 0.045), (0.205, 0.205, 0.09), _bowl),
        ObjectCategory("plate", (0.175, 0.175, 0.015), (0.285, 0.285, 0.03), _plate),
        ObjectCategory("book", (0.165, 0.11, 0.014), (0.285, 0.215, 0.06), _book),
        ObjectCategory("bottle", (0.055, 0.055, 0.19), (0.095, 0.095, 0.32), _bottle),
        ObjectCategory("can", (0.05, 0.05, 0.095), (0.07, 0.07, 0.13), _can),
        ObjectCategory("cereal_box", (0.185, 0.045, 0.245), (0.305, 0.095, 0.355), _cereal_box),
        ObjectCategory("laptop", (0.295, 0.205, 0.015), (0.385, 0.36, 0.27), _laptop),
        ObjectCategory("remote", (0.135, 0.035, 0.015), (0.225, 0.06, 0.032), _remote),
        ObjectCategory("pillow", (0.395, 0.295, 0.095), (0.605, 0.505, 0.165), _pillow),
        ObjectCategory("stuffed_toy", (0.1, 0.09, 0.15), (0.2, 0.2, 0.38), _stuffed_toy),
        ObjectCategory("vase", (0.075, 0.075, 0.145), (0.185, 0.185, 0.355), _vase),
        ObjectCategory("potted_plant", (0.1, 0.1, 0.15), (0.5, 0.5, 0.56), _potted_plant),
        ObjectCategory("lamp", (0.17, 0.17, 0.29), (0.35, 0.35, 0.56), _lamp),
        ObjectCategory("shoe", (0.235, 0.08, 0.065), (0.315, 0.115, 0.135), _shoe),
        ObjectCategory("toothbrush", (0.165, 0.01, 0.015), (0.2, 0.03, 0.03), _toothbrush),
        ObjectCategory("soap_dispenser", (0.06, 0.055, 0.14), (0.12, 0.09, 0.22), _soap_dispenser),
        ObjectCategory("towel", (0.245, 0.175, 0.02), (0.395, 0.29, 0.1), _towel),
        ObjectCategory("spoon", (0.135, 0.025, 0.008), (0.205, 0.05, 0.025), _spoon),
        ObjectCategory("knife", (0.18, 0.014, 0.01), (0.31, 0.03, 0.025), _knife),
        ObjectCategory("apple", (0.065, 0.065, 0.06), (0.095, 0.095, 0.095), _apple),
        ObjectCategory("banana", (0.14, 0.03, 0.025), (0.245, 0.08, 0.045), _banana),
        ObjectCategory("keyboard", (0.355, 0.115, 0.018), (0.455, 0.16, 0.03), _keyboard),
        ObjectCategory("phone", (0.13, 0.064, 0.006), (0.17, 0.08, 0.011), _phone),
        ObjectCategory("alarm_clock", (0.08, 0.04, 0.065), (0.16, 0.09, 0.16), _alarm_clock),
        ObjectCategory("candle", (0.038, 0.038, 0.055), (0.1, 0.1, 0.215), _candle),
        ObjectCategory("wine_glass", (0.06, 0.06, 0.14), (0.095, 0.095, 0.23), _wine_glass),
        ObjectCategory("teapot", (0.17, 0.12, 0.1), (0.3, 0.2, 0.2), _teapot),
    )
}


def sorted_dims(dims: np.ndarray) -> np.ndarray:
    """Return (long side, short side, height) of XYZ extents."""
    return np.array([max(dims[0], dims[1]), min(dims[0], dims[1]), dims[2]])


def _category_seed(category: str) -> int:
    """A stable per-category integer (independent of the catalogue order)."""
    return zlib.crc32(category.encode("utf-8"))


def generate_object(category: str, variant: int, seed: int = 0) -> HouseholdObject:
    """Generate variant `variant` of a category: Z up, metres, resting on z = 0, centred in XY."""
    if category not in OBJECT_CATEGORIES:
        raise KeyError(f"unknown object category {category!r}; known: {', '.join(OBJECT_CATEGORIES)}")
    rng = np.random.default_rng([int(seed), _category_seed(category), int(variant)])
    parts = OBJECT_CATEGORIES[category].builder(rng)
    v = np.concatenate([p[0][0] for p in parts])
    lo, hi = v.min(0), v.max(0)
    shift = np.array([-0.5 * (lo[0] + hi[0]), -0.5 * (lo[1] + hi[1]), -lo[2]])
    parts = [((np.asarray(m[0]) + shift, np.asarray(m[1], dtype=np.int64)), col, nm) for m, col, nm in parts]
    return HouseholdObject(category, f"{category}_{variant}", int(seed), parts)


def _fmt(x: float) -> str:
    """Fixed 6-decimal float text without negative zero."""
    s = f"{x:.6f}"
    return "0.000000" if s == "-0.000000" else s


def obj_text(obj: HouseholdObject, mtl_name: str = "model.mtl") -> tuple[str, str]:
    """Return (OBJ text, MTL text): one group and one Kd material per colour."""
    colours: list[tuple[int, int, int]] = []
    for _, col, _ in obj.parts:
        if col not in colours:
            colours.append(col)
    mats = [f"mat{k}" for k in range(len(colours))]
    lines = ["# sdovon-mj procedural household object (CC0-1.0); metres, +Z up", f"mtllib {mtl_name}", f"o {obj.name}"]
    for m, _, _ in obj.parts:
        for x, y, z in np.round(m[0], 6):
            lines.append(f"v {_fmt(x)} {_fmt(y)} {_fmt(z)}")
    offset = 1
    for (m, col, pname) in obj.parts:
        lines.append(f"g {pname}")
        lines.append(f"usemtl {mats[colours.index(col)]}")
        for a, b, c in m[1] + offset:
            lines.append(f"f {a} {b} {c}")
        offset += len(m[0])
    mtl = ["# sdovon-mj procedural household object materials"]
    for name, col in zip(mats, colours):
        r, g, b = (c / 255.0 for c in col)
        mtl += [f"newmtl {name}", "Ka 0.0000 0.0000 0.0000", f"Kd {r:.4f} {g:.4f} {b:.4f}", "Ks 0.1000 0.1000 0.1000",
                "Ns 20.0000", "d 1.0000", "illum 2", ""]
    return "\n".join(lines) + "\n", "\n".join(mtl)


def write_object(obj: HouseholdObject, folder: str | os.PathLike[str]) -> Path:
    """Write model.obj, model.mtl and meta.json of one object into `folder`; returns the OBJ path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    obj_s, mtl_s = obj_text(obj)
    (folder / "model.mtl").write_text(mtl_s, encoding="ascii")
    (folder / "model.obj").write_text(obj_s, encoding="ascii")
    meta = {"category": obj.category, "name": obj.name, "dims_m": [float(round(float(x), 4)) for x in obj.dims],
            "seed": obj.seed, "license": LICENSE, "units": "m", "up": "+Z"}
    (folder / "meta.json").write_text(json.dumps(meta, sort_keys=True, indent=1) + "\n", encoding="ascii")
    return folder / "model.obj"


def write_object_library(seed: int, out_dir: str | os.PathLike[str], variants: int = 3,
                         categories: list[str] | tuple[str, ...] | None = None) -> list[Path]:
    """Write `variants` objects of every (or the given) category; returns the OBJ paths in order."""
    cats = list(OBJECT_CATEGORIES) if not categories else list(categories)
    out = Path(out_dir)
    paths = []
    for cat in cats:
        for k in range(variants):
            obj = generate_object(cat, k, seed)
            paths.append(write_object(obj, out / cat / obj.name))
    return paths
