"""Procedural furniture models: legs, frames, cushions and boards, with true support surfaces.

Every builder returns a :class:`Model` in its own local frame: metres, Z up, the floor at z = 0,
the back of the piece against the wall at y = 0, its front facing +y, centred on x = 0. Support
surfaces are the real horizontal top faces where small objects can rest (every bookshelf level,
the table top, the mattress or duvet top beside the pillows, each sofa seat cushion), given as
CCW polygons in the local XY frame at a height above the floor.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import shapes

RECEPTACLE_LABELS: tuple[str, ...] = (
    "table", "desk", "dresser", "bookshelf", "shelf", "bed", "sofa", "counter", "nightstand", "coffee table",
)
FURNITURE_LABELS: tuple[str, ...] = (
    "chair", "wardrobe", "toilet", "fridge", "sink", "stove", "bathtub", "tv stand", "tv", "floor lamp", "picture", "rug",
)

WOODS = ((176, 134, 92), (122, 84, 56), (205, 175, 135), (96, 66, 44), (232, 228, 220), (64, 62, 60))
FABRICS = ((122, 126, 134), (72, 92, 128), (192, 176, 150), (92, 118, 92), (150, 76, 62), (66, 66, 72), (160, 120, 140))
LINENS = ((236, 236, 230), (200, 214, 230), (226, 214, 190), (210, 200, 212))
METALS = ((190, 192, 196), (60, 60, 64), (214, 200, 160))
APPLIANCES = ((236, 236, 236), (188, 190, 194), (52, 52, 56))
CERAMIC = (242, 242, 240)


@dataclass
class Part:
    """One coloured piece of a model (closed triangle mesh)."""

    vertices: np.ndarray
    faces: np.ndarray
    rgba: tuple[int, int, int, int]
    material: str = "plain"


@dataclass
class Model:
    """A furniture piece in its local frame (see the module docstring)."""

    label: str
    kind: str  # "receptacle" | "furniture"
    parts: list[Part]
    width: float
    depth: float
    height: float
    z_min: float = 0.0
    supports: list[tuple[float, np.ndarray]] = field(default_factory=list)

    def add(self, mesh: shapes.Mesh, rgba: tuple[int, ...], material: str = "plain") -> None:
        """Append a part with colour `rgba` (RGB or RGBA, 0-255)."""
        c = tuple(int(x) for x in rgba)
        if len(c) == 3:
            c = c + (255,)
        self.parts.append(Part(np.asarray(mesh[0], dtype=np.float64), np.asarray(mesh[1], dtype=np.int64), c, material))


def rect(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """Return the CCW rectangle polygon x0..x1, y0..y1."""
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)


def jitter(rgb: tuple[int, ...], rng: np.random.Generator, amount: float = 10.0) -> tuple[int, int, int]:
    """Return `rgb` with a small random offset (a per-instance tint)."""
    c = np.asarray(rgb[:3], dtype=np.float64) + rng.normal(0.0, amount, 3)
    return tuple(int(v) for v in np.clip(np.round(c), 0, 255))


def pick(rng: np.random.Generator, palette: tuple) -> tuple[int, int, int]:
    """Return a jittered colour drawn from a palette."""
    return jitter(palette[int(rng.integers(len(palette)))], rng, 6.0)


def u(rng: np.random.Generator, lo: float, hi: float, step: float = 0.01) -> float:
    """Return a uniform draw in [lo, hi] snapped to `step`."""
    return float(np.round(rng.uniform(lo, hi) / step) * step)


def _legs(m: Model, x0: float, y0: float, x1: float, y1: float, z1: float, size: float, rgba: tuple, material: str = "wood",
          round_: bool = False) -> None:
    """Add four legs in the corners of rectangle x0..x1, y0..y1 from the floor to z1."""
    for x in (x0, x1 - size):
        for y in (y0, y1 - size):
            if round_:
                m.add(shapes.cylinder(0.5 * size, 0.0, z1, 10, (x + 0.5 * size, y + 0.5 * size)), rgba, material)
            else:
                m.add(shapes.box((x, y, 0.0), (x + size, y + size, z1)), rgba, material)


def _drawer_fronts(m: Model, x0: float, x1: float, z0: float, z1: float, y_front: float, rows: int, cols: int,
                   rgba: tuple, knob: tuple, material: str = "wood", round_knobs: bool = False) -> None:
    """Add a grid of drawer fronts (1.5 cm proud of y_front) with knobs just inside the footprint."""
    gap = 0.004
    w = (x1 - x0) / cols
    h = (z1 - z0) / rows
    for r in range(rows):
        for c in range(cols):
            a, b = x0 + c * w + gap, x0 + (c + 1) * w - gap
            lo, hi = z0 + r * h + gap, z0 + (r + 1) * h - gap
            m.add(shapes.box((a, y_front, lo), (b, y_front + 0.015, hi)), rgba, material)
            mx, mz = 0.5 * (a + b), 0.5 * (lo + hi)
            if round_knobs:
                kn = shapes.transform(shapes.cylinder(0.012, 0.0, 0.013, 10), rot=shapes.rot_x(-0.5 * np.pi), shift=(mx, y_front + 0.015, mz))
                m.add(kn, knob, "metal")
            else:
                kw = min(0.06, 0.25 * (b - a))
                m.add(shapes.box((mx - kw, y_front + 0.015, mz - 0.008), (mx + kw, y_front + 0.028, mz + 0.008)), knob, "metal")


# ------------------------------------------------------------------------------------------------
# receptacles


def table(rng: np.random.Generator, width: float | None = None, depth: float | None = None, round_top: bool = False) -> Model:
    """A table: top on four legs with an apron (or a round top on a pedestal); top ~0.75 m."""
    h = u(rng, 0.73, 0.77)
    t = u(rng, 0.028, 0.04, 0.002)
    wood = pick(rng, WOODS)
    legc = wood if rng.random() < 0.7 else pick(rng, METALS)
    if round_top:
        dia = width if width is not None else u(rng, 0.85, 1.1)
        r = 0.5 * dia
        m = Model("table", "receptacle", [], dia, dia, h)
        seg = 32
        m.add(shapes.cylinder(r, h - t, h, seg, (0.0, r)), wood, "wood")
        m.add(shapes.cylinder(0.045, 0.03, h - t, 12, (0.0, r)), legc, "wood")
        m.add(shapes.cylinder(0.26, 0.0, 0.03, 24, (0.0, r)), legc, "wood")
        ang = 2.0 * np.pi * np.arange(seg) / seg
        m.supports.append((h, np.stack([r * np.cos(ang), r + r * np.sin(ang)], 1)))
        return m
    w = width if width is not None else u(rng, 1.0, 1.4)
    d = depth if depth is not None else u(rng, 0.7, 0.9)
    m = Model("table", "receptacle", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.box((x0, 0.0, h - t), (x1, d, h)), wood, "wood")
    ls = u(rng, 0.045, 0.06, 0.005)
    ins = u(rng, 0.03, 0.06)
    _legs(m, x0 + ins, ins, x1 - ins, d - ins, h - t, ls, legc, round_=rng.random() < 0.3)
    ah = 0.08
    a = 0.01
    m.add(shapes.box((x0 + ins + ls, ins + a, h - t - ah), (x1 - ins - ls, ins + a + 0.02, h - t)), wood, "wood")
    m.add(shapes.box((x0 + ins + ls, d - ins - a - 0.02, h - t - ah), (x1 - ins - ls, d - ins - a, h - t)), wood, "wood")
    m.add(shapes.box((x0 + ins + a, ins + ls, h - t - ah), (x0 + ins + a + 0.02, d - ins - ls, h - t)), wood, "wood")
    m.add(shapes.box((x1 - ins - a - 0.02, ins + ls, h - t - ah), (x1 - ins - a, d - ins - ls, h - t)), wood, "wood")
    m.supports.append((h, rect(x0, 0.0, x1, d)))
    return m


def desk(rng: np.random.Generator, width: float | None = None) -> tuple[Model, float]:
    """A desk (top ~0.75 m) with a drawer pedestal or legs; returns the model and its knee-space centre x."""
    w = width if width is not None else u(rng, 1.0, 1.4)
    d = u(rng, 0.55, 0.7)
    h = u(rng, 0.73, 0.76)
    t = 0.03
    wood = pick(rng, WOODS)
    m = Model("desk", "receptacle", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.box((x0, 0.0, h - t), (x1, d, h)), wood, "wood")
    knee = 0.0
    if rng.random() < 0.6:
        pw = 0.4
        left = rng.random() < 0.5
        px0, px1 = (x0, x0 + pw) if left else (x1 - pw, x1)
        m.add(shapes.box((px0 + 0.01, 0.01, 0.0), (px1 - 0.01, d - 0.03, h - t)), wood, "wood")
        _drawer_fronts(m, px0 + 0.01, px1 - 0.01, 0.04, h - t - 0.01, d - 0.03, 3, 1, jitter(wood, rng, 8), pick(rng, METALS))
        # the other end: a full-depth side panel
        sx0, sx1 = (x1 - 0.03, x1) if left else (x0, x0 + 0.03)
        m.add(shapes.box((sx0, 0.02, 0.0), (sx1, d - 0.02, h - t)), wood, "wood")
        knee = 0.5 * ((px1 if left else sx1) + (sx0 if left else px0))
    else:
        legc = pick(rng, METALS)
        _legs(m, x0 + 0.03, 0.03, x1 - 0.03, d - 0.03, h - t, 0.045, legc, "metal")
    m.add(shapes.box((x0 + 0.06, 0.02, 0.38), (x1 - 0.06, 0.035, h - t)), jitter(wood, rng, 6), "wood")
    m.supports.append((h, rect(x0, 0.0, x1, d)))
    return m, knee


def coffee_table(rng: np.random.Generator) -> Model:
    """A coffee table: top ~0.42-0.46 m on legs, sometimes with a lower shelf."""
    w = u(rng, 0.9, 1.25)
    d = u(rng, 0.5, 0.65)
    h = u(rng, 0.4, 0.46)
    t = 0.035
    wood = pick(rng, WOODS)
    m = Model("coffee table", "receptacle", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.box((x0, 0.0, h - t), (x1, d, h)), wood, "wood")
    ls = 0.05
    _legs(m, x0 + 0.03, 0.03, x1 - 0.03, d - 0.03, h - t, ls, jitter(wood, rng, 12))
    if rng.random() < 0.5:
        zs = u(rng, 0.1, 0.13)
        m.add(shapes.box((x0 + 0.03 + ls, 0.03, zs - 0.02), (x1 - 0.03 - ls, d - 0.03, zs)), wood, "wood")
        m.supports.append((zs, rect(x0 + 0.03 + ls, 0.03, x1 - 0.03 - ls, d - 0.03)))
    m.supports.insert(0, (h, rect(x0, 0.0, x1, d)))
    return m


def nightstand(rng: np.random.Generator, wood: tuple | None = None) -> Model:
    """A nightstand (top ~0.55 m) on short legs with one or two drawers."""
    w = u(rng, 0.4, 0.5)
    d = u(rng, 0.36, 0.42)
    h = u(rng, 0.5, 0.6)
    wood = wood if wood is not None else pick(rng, WOODS)
    m = Model("nightstand", "receptacle", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    legh = 0.08
    _legs(m, x0 + 0.02, 0.02, x1 - 0.02, d - 0.05, legh, 0.035, jitter(wood, rng, 10))
    m.add(shapes.box((x0 + 0.01, 0.0, legh), (x1 - 0.01, d - 0.045, h - 0.025)), wood, "wood")
    m.add(shapes.box((x0, 0.0, h - 0.025), (x1, d, h)), wood, "wood")
    _drawer_fronts(m, x0 + 0.015, x1 - 0.015, legh + 0.01, h - 0.03, d - 0.045, int(rng.integers(1, 3)), 1,
                   jitter(wood, rng, 8), pick(rng, METALS), round_knobs=rng.random() < 0.5)
    m.supports.append((h, rect(x0, 0.0, x1, d)))
    return m


def dresser(rng: np.random.Generator, width: float | None = None) -> Model:
    """A chest of drawers / sideboard, top 0.8-1.0 m, on legs or a plinth."""
    w = width if width is not None else u(rng, 0.8, 1.4)
    d = u(rng, 0.45, 0.52)
    h = u(rng, 0.8, 1.0)
    wood = pick(rng, WOODS)
    m = Model("dresser", "receptacle", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    if rng.random() < 0.5:
        base = 0.1
        _legs(m, x0 + 0.03, 0.03, x1 - 0.03, d - 0.06, base, 0.04, jitter(wood, rng, 10))
    else:
        base = 0.07
        m.add(shapes.box((x0 + 0.02, 0.02, 0.0), (x1 - 0.02, d - 0.08, base)), jitter(wood, rng, 10), "wood")
    m.add(shapes.box((x0 + 0.01, 0.0, base), (x1 - 0.01, d - 0.045, h - 0.03)), wood, "wood")
    m.add(shapes.box((x0, 0.0, h - 0.03), (x1, d, h)), wood, "wood")
    rows = int(rng.integers(3, 5))
    cols = 2 if w > 1.0 else 1
    _drawer_fronts(m, x0 + 0.015, x1 - 0.015, base + 0.01, h - 0.035, d - 0.045, rows, cols, jitter(wood, rng, 8),
                   pick(rng, METALS), round_knobs=rng.random() < 0.5)
    m.supports.append((h, rect(x0, 0.0, x1, d)))
    return m


def bookshelf(rng: np.random.Generator, height_max: float = 2.0) -> Model:
    """An open-front bookshelf 1.6-2.0 m tall with 4-5 levels between two side panels."""
    w = u(rng, 0.6, 1.0)
    d = u(rng, 0.28, 0.36)
    h = u(rng, 1.6, min(2.0, height_max))
    levels = int(rng.integers(4, 6))
    t, bt, back = 0.02, 0.02, 0.01
    wood = pick(rng, WOODS)
    m = Model("bookshelf", "receptacle", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.box((x0, 0.0, 0.0), (x0 + t, d, h)), wood, "wood")
    m.add(shapes.box((x1 - t, 0.0, 0.0), (x1, d, h)), wood, "wood")
    m.add(shapes.box((x0 + t, 0.0, 0.0), (x1 - t, back, h - bt)), jitter(wood, rng, 12), "wood")
    m.add(shapes.box((x0 + t, d - 0.03, 0.0), (x1 - t, d - 0.01, 0.06)), wood, "wood")
    m.add(shapes.box((x0 + t, back, h - bt), (x1 - t, d, h)), wood, "wood")
    b0 = 0.08
    step = (h - bt - b0) / levels
    for i in range(levels):
        top = b0 + i * step
        m.add(shapes.box((x0 + t, back, top - bt), (x1 - t, d, top)), wood, "wood")
        m.supports.append((float(top), rect(x0 + t, back, x1 - t, d)))
    return m


def wall_shelf(rng: np.random.Generator) -> Model:
    """A wall-mounted shelf: 1-3 boards between 1.0 and 1.6 m, on brackets or between side panels."""
    w = u(rng, 0.6, 1.2)
    d = u(rng, 0.2, 0.3)
    nb = int(rng.integers(1, 4))
    if nb == 1:
        tops = [u(rng, 1.1, 1.5)]
    elif nb == 2:
        b = u(rng, 1.0, 1.2)
        tops = [b, b + u(rng, 0.35, 0.4)]
    else:
        b = u(rng, 1.0, 1.04)
        tops = [b, b + 0.28, b + 0.56]
    t = 0.025
    wood = pick(rng, WOODS)
    panels = nb == 3 or (nb == 2 and rng.random() < 0.5)
    x0, x1 = -0.5 * w, 0.5 * w
    zmin = tops[0] - t - (0.02 if panels else 0.14)
    zmax = tops[-1] + (0.02 if panels else 0.0)
    m = Model("shelf", "receptacle", [], w, d, zmax, z_min=zmin)
    if panels:
        pt = 0.018
        m.add(shapes.box((x0, 0.0, zmin), (x0 + pt, d, zmax)), wood, "wood")
        m.add(shapes.box((x1 - pt, 0.0, zmin), (x1 - 0.0, d, zmax)), wood, "wood")
        for top in tops:
            m.add(shapes.box((x0 + pt, 0.0, top - t), (x1 - pt, d, top)), wood, "wood")
            m.supports.append((top, rect(x0 + pt, 0.0, x1 - pt, d)))
    else:
        metal = pick(rng, METALS)
        for top in tops:
            m.add(shapes.box((x0, 0.0, top - t), (x1, d, top)), wood, "wood")
            m.supports.append((top, rect(x0, 0.0, x1, d)))
            for bx in (x0 + 0.1, x1 - 0.12):
                m.add(shapes.box((bx, 0.0, top - t - 0.12), (bx + 0.02, d - 0.04, top - t)), metal, "metal")
                m.add(shapes.box((bx, 0.0, top - t - 0.14), (bx + 0.02, 0.02, top - t - 0.12)), metal, "metal")
    return m


def bed(rng: np.random.Generator, double: bool = True) -> Model:
    """A bed: legs, rails and headboard, a mattress (top ~0.55 m), pillows and sometimes a duvet."""
    mw = u(rng, 1.4, 1.8, 0.1) if double else u(rng, 0.9, 1.0, 0.1)
    ml = u(rng, 1.95, 2.05, 0.05)
    rail = 0.04
    head = 0.06
    w = mw + 2 * rail
    d = head + ml + rail
    mtop = u(rng, 0.52, 0.58)
    mz0 = 0.3
    wood = pick(rng, WOODS)
    hb_h = u(rng, 0.9, 1.2)
    m = Model("bed", "receptacle", [], w, d, max(hb_h, mtop + 0.16))
    x0, x1 = -0.5 * w, 0.5 * w
    if rng.random() < 0.5:
        m.add(shapes.chamfer_box((x0, 0.0, 0.0), (x1, head, hb_h), 0.02), pick(rng, FABRICS), "fabric")
    else:
        m.add(shapes.box((x0, 0.0, 0.0), (x1, head, hb_h)), wood, "wood")
    _legs(m, x0, head, x1, d, 0.12, 0.06, jitter(wood, rng, 8))
    m.add(shapes.box((x0, head, 0.12), (x0 + rail, d, mz0 + 0.04)), wood, "wood")
    m.add(shapes.box((x1 - rail, head, 0.12), (x1, d, mz0 + 0.04)), wood, "wood")
    m.add(shapes.box((x0 + rail, d - rail, 0.12), (x1 - rail, d, mz0 + 0.04 if rng.random() < 0.5 else mtop - 0.1)), wood, "wood")
    m.add(shapes.box((x0 + rail, head, mz0 - 0.03), (x1 - rail, d - rail, mz0)), jitter(wood, rng, 15), "wood")
    bev = 0.03
    mx0, mx1, my0, my1 = x0 + rail + 0.005, x1 - rail - 0.005, head + 0.005, d - rail - 0.005
    m.add(shapes.rounded_box((mx0, my0, mz0), (mx1, my1, mtop), bev, 3), (238, 238, 234), "fabric")
    linen = pick(rng, LINENS)
    npil = 2 if double else 1
    pw = min(0.6, (mx1 - mx0 - 0.06) / npil)
    pd = u(rng, 0.33, 0.38)
    ph = u(rng, 0.12, 0.16)
    py0 = my0 + 0.04
    for k in range(npil):
        cx = mx0 + 0.03 + (k + 0.5) * (mx1 - mx0 - 0.06) / npil
        m.add(shapes.superellipsoid((cx - 0.5 * pw, py0, mtop - 0.015), (cx + 0.5 * pw, py0 + pd, mtop - 0.015 + ph), 0.35, 0.25,
                               10, 24), linen, "fabric")
    free_y0 = py0 + pd + 0.03
    if rng.random() < 0.5:
        dz = mtop + 0.04
        dy0 = free_y0 + 0.08
        dx0, dx1 = mx0 - 0.01, mx1 + 0.01
        m.add(shapes.rounded_box((dx0, dy0, mtop - 0.14), (dx1, my1, dz), bev, 3), pick(rng, LINENS + FABRICS), "fabric")
        m.supports.append((dz, rect(dx0 + bev + 0.005, dy0 + bev + 0.005, dx1 - bev - 0.005, my1 - bev - 0.005)))
    else:
        m.supports.append((mtop, rect(mx0 + bev + 0.005, free_y0, mx1 - bev - 0.005, my1 - bev - 0.005)))
    return m


def sofa(rng: np.random.Generator, width: float | None = None) -> Model:
    """A sofa: legs, base, arms, back frame, seat cushions (top ~0.45 m) and back cushions."""
    w = width if width is not None else u(rng, 1.7, 2.3)
    d = u(rng, 0.85, 0.95)
    seat = u(rng, 0.43, 0.47)
    base = 0.3
    arm_w = u(rng, 0.12, 0.2)
    arm_h = u(rng, 0.58, 0.66)
    back_d = u(rng, 0.16, 0.22)
    back_h = u(rng, 0.8, 0.9)
    fab = pick(rng, FABRICS)
    m = Model("sofa", "receptacle", [], w, d, back_h)
    x0, x1 = -0.5 * w, 0.5 * w
    _legs(m, x0 + 0.03, 0.03, x1 - 0.03, d - 0.03, 0.1, 0.04, pick(rng, WOODS[:4] + METALS[:2]))
    m.add(shapes.box((x0 + arm_w, 0.0, 0.1), (x1 - arm_w, d, base)), jitter(fab, rng, 6), "fabric")
    m.add(shapes.chamfer_box((x0, 0.0, 0.1), (x0 + arm_w, d, arm_h), 0.03), fab, "fabric")
    m.add(shapes.chamfer_box((x1 - arm_w, 0.0, 0.1), (x1, d, arm_h), 0.03), fab, "fabric")
    m.add(shapes.chamfer_box((x0 + arm_w, 0.0, base), (x1 - arm_w, back_d, back_h), 0.03), fab, "fabric")
    inner = (x1 - arm_w) - (x0 + arm_w)
    n = 2 if inner < 1.5 else 3
    cw = inner / n
    bev = 0.03
    cush = jitter(fab, rng, 8)
    bcd = 0.15
    for k in range(n):
        cx0 = x0 + arm_w + k * cw + 0.003
        cx1 = cx0 + cw - 0.006
        m.add(shapes.rounded_box((cx0, back_d, base), (cx1, d - 0.01, seat), bev, 3), cush, "fabric")
        m.add(shapes.rounded_box((cx0, back_d, seat), (cx1, back_d + bcd, back_h - 0.04), 0.05, 3), cush, "fabric")
        m.supports.append((seat, rect(cx0 + bev + 0.005, back_d + bcd + 0.02, cx1 - bev - 0.005, d - 0.01 - bev - 0.005)))
    return m


def _free_intervals(x0: float, x1: float, blocked: list[tuple[float, float]], min_len: float = 0.25) -> list[tuple[float, float]]:
    """Return the parts of x0..x1 not covered by `blocked` intervals, at least `min_len` long."""
    out, a = [], x0
    for b0, b1 in sorted(blocked):
        if b0 - a >= min_len:
            out.append((a, b0))
        a = max(a, b1)
    if x1 - a >= min_len:
        out.append((a, x1))
    return out


def counter(rng: np.random.Generator, width: float, height: float = 0.9, depth: float = 0.6, sink: str = "none",
            sink_side: int = 1, hob: bool = False) -> tuple[Model, list[Model]]:
    """A kitchen counter / bathroom vanity: plinth, cabinets with doors, top slab; optional sink and hob.

    `sink`: "none", "recessed" (a basin let into the top) or "vessel" (a bowl standing on the top
    at one end). The counter's support surfaces are the parts of its top that stay free. Returns
    (counter, [sink, stove] as present).

    Parameters
    ----------
    rng : numpy.random.Generator
        Random draws of colours and details.
    width : float
        Length along the wall, metres.
    height : float
        Height to the top of the worktop, metres.
    depth : float
        Depth from the wall, metres.
    sink : str
        "none", "recessed" or "vessel".
    sink_side : int
        End with the sink: +1 (+x) or -1 (-x).
    hob : bool
        Add a stove with a hob.
    """
    w, d, h = width, depth, height
    tt = 0.04
    body = pick(rng, WOODS + ((238, 238, 238), (70, 90, 110), (150, 160, 140)))
    topc = pick(rng, ((60, 60, 62), (226, 222, 214), (150, 140, 130), (200, 200, 205), (120, 90, 60)))
    m = Model("counter", "receptacle", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    plinth = 0.1
    m.add(shapes.box((x0 + 0.01, 0.0, 0.0), (x1 - 0.01, d - 0.08, plinth)), (40, 40, 40), "plain")
    pt = 0.018
    m.add(shapes.box((x0, 0.0, plinth), (x0 + pt, d - 0.04, h - tt)), body, "wood")
    m.add(shapes.box((x1 - pt, 0.0, plinth), (x1, d - 0.04, h - tt)), body, "wood")
    m.add(shapes.box((x0 + pt, 0.0, plinth), (x1 - pt, 0.01, h - tt)), body, "wood")
    m.add(shapes.box((x0 + pt, 0.01, plinth), (x1 - pt, d - 0.04, plinth + pt)), body, "wood")
    ndoor = max(1, int(round(w / 0.5)))
    _drawer_fronts(m, x0, x1, plinth, h - tt - 0.003, d - 0.04, 1, ndoor, jitter(body, rng, 5), pick(rng, METALS))
    extras: list[Model] = []
    metal = METALS[0]
    blocked: list[tuple[float, float]] = []
    side = float(sink_side)
    if sink == "recessed":
        sw = u(rng, 0.45, min(0.6, w - 0.9))
        if hob:
            lo, hi = 0.3 + 0.5 * sw, 0.5 * w - 0.3 - 0.5 * sw
            c = side * rng.uniform(min(lo, hi), hi)
        else:
            lim = 0.5 * w - 0.4 - 0.5 * sw
            c = side * rng.uniform(0.0, lim)
        sx0, sx1 = c - 0.5 * sw, c + 0.5 * sw
        hy0, hy1 = 0.09, d - 0.08
        # the top with a hole for the basin
        m.add(shapes.box((x0, 0.0, h - tt), (sx0, d, h)), topc, "plain")
        m.add(shapes.box((sx1, 0.0, h - tt), (x1, d, h)), topc, "plain")
        m.add(shapes.box((sx0, 0.0, h - tt), (sx1, hy0, h)), topc, "plain")
        m.add(shapes.box((sx0, hy1, h - tt), (sx1, d, h)), topc, "plain")
        blocked.append((sx0, sx1))
        sm = Model("sink", "furniture", [], sw, d, h + 0.3)
        bz = h - 0.2
        sm.add(shapes.box((sx0, hy0, bz), (sx1, hy1, bz + 0.01)), metal, "metal")
        sm.add(shapes.box((sx0, hy0, bz), (sx0 + 0.008, hy1, h - 0.001)), metal, "metal")
        sm.add(shapes.box((sx1 - 0.008, hy0, bz), (sx1, hy1, h - 0.001)), metal, "metal")
        sm.add(shapes.box((sx0 + 0.008, hy0, bz), (sx1 - 0.008, hy0 + 0.008, h - 0.001)), metal, "metal")
        sm.add(shapes.box((sx0 + 0.008, hy1 - 0.008, bz), (sx1 - 0.008, hy1, h - 0.001)), metal, "metal")
        sm.add(shapes.cylinder(0.018, h, h + 0.3, 16, (c, 0.045)), metal, "metal")
        sm.add(shapes.sweep(np.array([[c, 0.045, h + 0.29], [c, 0.06, h + 0.31], [c, 0.12, h + 0.32], [c, 0.2, h + 0.3],
                                 [c, 0.23, h + 0.25]]), 0.011, 10), metal, "metal")
        extras.append(sm)
    elif sink == "vessel":
        m.add(shapes.box((x0, 0.0, h - tt), (x1, d, h)), topc, "plain")
        r = u(rng, 0.17, 0.2)
        c = side * (0.5 * w - r - 0.05)
        cy = 0.5 * d + 0.03
        sm = Model("sink", "furniture", [], 2 * r, d, h + 0.3)
        prof = [(0.0, h), (0.6 * r, h), (r, h + 0.12), (r - 0.01, h + 0.125), (r - 0.012, h + 0.12),
                (0.58 * r, h + 0.02), (0.0, h + 0.02)]
        sm.add(shapes.transform(shapes.revolve(prof, 32), shift=(c, cy, 0.0)), CERAMIC, "ceramic")
        sm.add(shapes.cylinder(0.016, h, h + 0.28, 16, (c, 0.04)), metal, "metal")
        sm.add(shapes.sweep(np.array([[c, 0.04, h + 0.27], [c, 0.06, h + 0.29], [c, cy - 0.08, h + 0.29], [c, cy - 0.05, h + 0.26]]),
                       0.01, 10), metal, "metal")
        extras.append(sm)
        blocked.append((c - r - 0.03, c + r + 0.03))
    else:
        m.add(shapes.box((x0, 0.0, h - tt), (x1, d, h)), topc, "plain")
    if hob:
        hw, hd = 0.58, 0.5
        lo, hi = 0.05 + 0.5 * hw, 0.5 * w - 0.3 - 0.5 * hw
        hc = -side * rng.uniform(min(lo, hi), hi)
        st = Model("stove", "furniture", [], hw, hd, h + 0.01)
        y0h = 0.5 * (d - hd)
        st.add(shapes.box((hc - 0.5 * hw, y0h, h), (hc + 0.5 * hw, y0h + hd, h + 0.006)), (24, 24, 26), "metal")
        for bx, by, br in ((-0.14, 0.13, 0.09), (0.14, 0.13, 0.07), (-0.14, -0.11, 0.07), (0.14, -0.11, 0.09)):
            ring = shapes.revolve([(br - 0.012, h + 0.006), (br, h + 0.006), (br, h + 0.008), (br - 0.012, h + 0.008)], 24, closed=True)
            st.add(shapes.transform(ring, shift=(hc + bx, y0h + 0.5 * hd + by, 0.0)), (90, 90, 94), "metal")
        extras.append(st)
        blocked.append((hc - 0.5 * hw - 0.02, hc + 0.5 * hw + 0.02))
    for a, b in _free_intervals(x0, x1, blocked):
        m.supports.append((h, rect(a, 0.0, b, d)))
    return m, extras


def floor_lamp(rng: np.random.Generator) -> Model:
    """A standing lamp: weighted base, pole and a fabric shade (1.4-1.7 m)."""
    h = u(rng, 1.4, 1.7)
    r = u(rng, 0.17, 0.23)
    m = Model("floor lamp", "furniture", [], 2 * r, 2 * r, h)
    metal = pick(rng, METALS)
    m.add(shapes.cylinder(0.14, 0.0, 0.03, 24, (0.0, r)), metal, "metal")
    m.add(shapes.cylinder(0.012, 0.03, h - 0.2, 10, (0.0, r)), metal, "metal")
    shade = shapes.revolve([(0.7 * r, h - 0.28), (r, h - 0.28), (0.62 * r, h), (0.6 * r, h), (0.98 * r, h - 0.27),
                       (0.69 * r, h - 0.27)], 28, closed=True)
    m.add(shapes.transform(shade, shift=(0.0, r, 0.0)), pick(rng, LINENS), "fabric")
    return m


# ------------------------------------------------------------------------------------------------
# plain furniture


def chair(rng: np.random.Generator, wood: tuple | None = None) -> Model:
    """A chair: four legs, seat at ~0.45 m, back posts and a back rest; front faces +y."""
    w = u(rng, 0.42, 0.48)
    d = u(rng, 0.44, 0.5)
    seat = u(rng, 0.44, 0.47)
    bh = u(rng, 0.82, 0.92)
    wood = wood if wood is not None else pick(rng, WOODS)
    m = Model("chair", "furniture", [], w, d, bh)
    x0, x1 = -0.5 * w, 0.5 * w
    ls = 0.035
    _legs(m, x0, 0.0, x1, d, seat - 0.03, ls, jitter(wood, rng, 6))
    if rng.random() < 0.4:
        m.add(shapes.chamfer_box((x0, 0.0, seat - 0.05), (x1, d, seat), 0.012), pick(rng, FABRICS), "fabric")
    else:
        m.add(shapes.box((x0, 0.0, seat - 0.03), (x1, d, seat)), wood, "wood")
    m.add(shapes.box((x0, 0.0, seat), (x0 + ls, ls, bh)), wood, "wood")
    m.add(shapes.box((x1 - ls, 0.0, seat), (x1, ls, bh)), wood, "wood")
    m.add(shapes.box((x0 + ls, 0.005, bh - 0.22), (x1 - ls, 0.03, bh - 0.02)), wood, "wood")
    return m


def wardrobe(rng: np.random.Generator, height_max: float = 2.2, small: bool = False) -> Model:
    """A wardrobe: plinth, tall carcass, two or three doors with handles, a crown."""
    w = u(rng, 0.8, 1.0) if small else u(rng, 0.9, 1.5)
    d = u(rng, 0.55, 0.62)
    h = u(rng, 1.9, min(2.2, height_max))
    wood = pick(rng, WOODS)
    m = Model("wardrobe", "furniture", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.box((x0 + 0.02, 0.0, 0.0), (x1 - 0.02, d - 0.06, 0.08)), jitter(wood, rng, 10), "wood")
    m.add(shapes.box((x0, 0.0, 0.08), (x1, d - 0.035, h - 0.03)), wood, "wood")
    m.add(shapes.box((x0, 0.0, h - 0.03), (x1, d - 0.02, h)), jitter(wood, rng, 6), "wood")
    n = 2 if w < 1.2 else 3
    dw = w / n
    metal = pick(rng, METALS)
    for k in range(n):
        a, b = x0 + k * dw + 0.003, x0 + (k + 1) * dw - 0.003
        m.add(shapes.box((a, d - 0.035, 0.085), (b, d - 0.018, h - 0.035)), jitter(wood, rng, 4), "wood")
        hx = b - 0.05 if k % 2 == 0 else a + 0.03
        m.add(shapes.box((hx, d - 0.018, 0.9), (hx + 0.02, d, 1.2)), metal, "metal")
    return m


def fridge(rng: np.random.Generator) -> Model:
    """A fridge-freezer: body, two doors and long handles."""
    w = u(rng, 0.6, 0.75)
    d = u(rng, 0.62, 0.7)
    h = u(rng, 1.75, 1.95)
    c = pick(rng, APPLIANCES)
    m = Model("fridge", "furniture", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.chamfer_box((x0, 0.0, 0.0), (x1, d - 0.06, h), 0.01), c, "metal")
    split = u(rng, 0.55, 0.7) * h
    m.add(shapes.chamfer_box((x0, d - 0.06, 0.02), (x1, d - 0.02, split - 0.005), 0.008), jitter(c, rng, 4), "metal")
    m.add(shapes.chamfer_box((x0, d - 0.06, split + 0.005), (x1, d - 0.02, h - 0.01), 0.008), jitter(c, rng, 4), "metal")
    hc = (150, 150, 155) if c[0] > 100 else (200, 200, 205)
    hx = x1 - 0.07
    m.add(shapes.box((hx, d - 0.02, split - 0.45), (hx + 0.025, d, split - 0.05)), hc, "metal")
    m.add(shapes.box((hx, d - 0.02, split + 0.05), (hx + 0.025, d, min(h - 0.05, split + 0.4))), hc, "metal")
    return m


def toilet(rng: np.random.Generator) -> Model:
    """A toilet: pedestal, bowl, seat ring, lid and a cistern against the wall."""
    m = Model("toilet", "furniture", [], 0.42, 0.72, 0.8)
    tank_h = u(rng, 0.74, 0.82)
    m.height = tank_h
    m.add(shapes.chamfer_box((-0.2, 0.0, 0.42), (0.2, 0.18, tank_h), 0.02), CERAMIC, "ceramic")
    ped = shapes.transform(shapes.revolve([(0.0, 0.0), (1.0, 0.0), (0.8, 0.3), (0.0, 0.3)], 20), scale=(0.12, 0.17, 1.0),
                      shift=(0.0, 0.36, 0.0))
    m.add(ped, CERAMIC, "ceramic")
    m.add(shapes.superellipsoid((-0.18, 0.15, 0.22), (0.18, 0.7, 0.4), 0.6, 0.8, 8, 20), CERAMIC, "ceramic")
    ring = shapes.revolve([(0.7, 0.0), (1.0, 0.0), (1.0, 1.0), (0.7, 1.0)], 24, closed=True)
    seatc = CERAMIC if rng.random() < 0.7 else pick(rng, WOODS)
    m.add(shapes.transform(ring, scale=(0.18, 0.26, 0.02), shift=(0.0, 0.44, 0.4)), seatc, "plain")
    lid = shapes.cylinder(1.0, 0.0, 1.0, 24)
    m.add(shapes.transform(lid, scale=(0.175, 0.255, 0.015), shift=(0.0, 0.44, 0.42)), seatc, "plain")
    return m


def bathtub(rng: np.random.Generator) -> Model:
    """A built-in bathtub: outer walls, a hollow basin and a tap."""
    w = u(rng, 1.5, 1.7)
    d = u(rng, 0.7, 0.78)
    h = u(rng, 0.5, 0.58)
    m = Model("bathtub", "furniture", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    t = 0.07
    m.add(shapes.box((x0, 0.0, 0.0), (x1, d, 0.12)), CERAMIC, "ceramic")
    m.add(shapes.box((x0, 0.0, 0.12), (x1, t, h)), CERAMIC, "ceramic")
    m.add(shapes.box((x0, d - t, 0.12), (x1, d, h)), CERAMIC, "ceramic")
    m.add(shapes.box((x0, t, 0.12), (x0 + 0.12, d - t, h)), CERAMIC, "ceramic")
    m.add(shapes.box((x1 - 0.12, t, 0.12), (x1, d - t, h)), CERAMIC, "ceramic")
    metal = METALS[0]
    m.add(shapes.cylinder(0.02, h, h + 0.15, 12, (x1 - 0.06, 0.5 * d)), metal, "metal")
    m.add(shapes.box((x1 - 0.2, 0.5 * d - 0.012, h + 0.13), (x1 - 0.06, 0.5 * d + 0.012, h + 0.15)), metal, "metal")
    m.height = h + 0.15
    return m


def tv_stand(rng: np.random.Generator) -> tuple[Model, Model]:
    """A low TV cabinet and a flat-screen TV on its foot; returns (tv stand, tv)."""
    w = u(rng, 1.2, 1.8)
    d = u(rng, 0.38, 0.45)
    h = u(rng, 0.42, 0.55)
    wood = pick(rng, WOODS)
    m = Model("tv stand", "furniture", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    _legs(m, x0 + 0.03, 0.03, x1 - 0.03, d - 0.06, 0.08, 0.04, jitter(wood, rng, 10))
    m.add(shapes.box((x0, 0.0, 0.08), (x1, d - 0.02, h)), wood, "wood")
    _drawer_fronts(m, x0 + 0.01, x1 - 0.01, 0.09, h - 0.01, d - 0.035, 1, 3 if w > 1.5 else 2, jitter(wood, rng, 8),
                   pick(rng, METALS))
    tw = min(u(rng, 0.9, 1.3), w - 0.1)
    th = tw * 9.0 / 16.0 + 0.02
    tv = Model("tv", "furniture", [], tw, 0.25, h + 0.08 + th)
    black = (28, 28, 30)
    cy = 0.5 * d - 0.05
    tv.add(shapes.box((-0.18, cy - 0.1, h), (0.18, cy + 0.1, h + 0.015)), black, "metal")
    tv.add(shapes.box((-0.03, cy - 0.015, h + 0.015), (0.03, cy + 0.015, h + 0.1)), black, "metal")
    tv.add(shapes.box((-0.5 * tw, cy - 0.045, h + 0.08), (0.5 * tw, cy - 0.015, h + 0.08 + th)), black, "metal")
    return m, tv


def picture(rng: np.random.Generator) -> Model:
    """A framed picture hanging on the wall (bottom edge 1.2-1.5 m)."""
    w, h = u(rng, 0.4, 1.0), u(rng, 0.3, 0.7)
    z0 = u(rng, 1.2, 1.5)
    d, f = 0.03, u(rng, 0.02, 0.045)
    m = Model("picture", "furniture", [], w, d, z0 + h, z_min=z0)
    frame = pick(rng, WOODS + ((240, 240, 240), (30, 30, 30), (200, 170, 90)))
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.box((x0, 0.0, z0), (x1, d, z0 + f)), frame, "wood")
    m.add(shapes.box((x0, 0.0, z0 + h - f), (x1, d, z0 + h)), frame, "wood")
    m.add(shapes.box((x0, 0.0, z0 + f), (x0 + f, d, z0 + h - f)), frame, "wood")
    m.add(shapes.box((x1 - f, 0.0, z0 + f), (x1, d, z0 + h - f)), frame, "wood")
    # the canvas: a few colour fields, slightly recessed
    n = int(rng.integers(1, 4))
    cuts = np.sort(rng.uniform(0.2, 0.8, n - 1)) if n > 1 else np.array([])
    edges = np.concatenate([[x0 + f], x0 + f + cuts * (w - 2 * f), [x1 - f]])
    for a, b in zip(edges[:-1], edges[1:]):
        m.add(shapes.box((a, 0.0, z0 + f), (b, d - 0.008, z0 + h - f)), pick(rng, FABRICS + LINENS + WOODS[:3]), "plain")
    return m


def rug(rng: np.random.Generator, width: float, depth: float) -> Model:
    """A flat rug (8 mm) with a border; walkable, never a receptacle."""
    m = Model("rug", "furniture", [], width, depth, 0.008)
    base = pick(rng, FABRICS + LINENS)
    m.add(shapes.rounded_box((-0.5 * width, 0.0, 0.0), (0.5 * width, depth, 0.006), 0.003, 3), jitter(base, rng, 25), "fabric")
    m.add(shapes.rounded_box((-0.5 * width + 0.08, 0.08, 0.0), (0.5 * width - 0.08, depth - 0.08, 0.008), 0.003, 3), base, "fabric")
    return m


# ------------------------------------------------------------------------------------------------
# furniture of the rooms only houses have (entryways, hallways, laundry rooms, closets, garages)


def bench(rng: np.random.Generator) -> Model:
    """A hall bench: a seat board (~0.46 m) on two side panels, a shelf for shoes below."""
    w, d, h = u(rng, 0.8, 1.2), u(rng, 0.32, 0.4), u(rng, 0.44, 0.48)
    wood = pick(rng, WOODS)
    m = Model("bench", "receptacle", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.box((x0, 0.0, 0.0), (x0 + 0.03, d, h - 0.03)), wood, "wood")
    m.add(shapes.box((x1 - 0.03, 0.0, 0.0), (x1, d, h - 0.03)), wood, "wood")
    m.add(shapes.box((x0 + 0.03, 0.02, 0.1), (x1 - 0.03, d - 0.02, 0.12)), jitter(wood, rng, 8), "wood")
    m.add(shapes.box((x0, 0.0, h - 0.03), (x1, d, h)), wood, "wood")
    m.supports.append((h, rect(x0, 0.0, x1, d)))
    return m


def coat_rack(rng: np.random.Generator) -> Model:
    """A standing coat rack: a round base, a pole (1.7-1.85 m) and four hooks."""
    h, r = u(rng, 1.7, 1.85), 0.2
    m = Model("coat rack", "furniture", [], 2 * r, 2 * r, h)
    c = pick(rng, WOODS + METALS)
    m.add(shapes.cylinder(0.18, 0.0, 0.03, 16, (0.0, r)), c, "wood")
    m.add(shapes.cylinder(0.018, 0.03, h, 10, (0.0, r)), c, "wood")
    for dx, dy in ((0.12, 0.0), (-0.12, 0.0), (0.0, 0.12), (0.0, -0.12)):
        m.add(shapes.box((min(0.0, dx) - 0.01, r + min(0.0, dy) - 0.01, h - 0.12), (max(0.0, dx) + 0.01, r + max(0.0, dy) + 0.01,
                                                                               h - 0.1)), c, "wood")
    return m


def shoe_rack(rng: np.random.Generator) -> Model:
    """A low open shoe rack with two or three slatted levels (~0.5 m)."""
    w, d, h = u(rng, 0.6, 1.0), u(rng, 0.28, 0.34), u(rng, 0.45, 0.6)
    c = pick(rng, WOODS + METALS)
    m = Model("shoe rack", "furniture", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.box((x0, 0.0, 0.0), (x0 + 0.02, d, h)), c, "wood")
    m.add(shapes.box((x1 - 0.02, 0.0, 0.0), (x1, d, h)), c, "wood")
    levels = 3 if h > 0.52 else 2
    for k in range(levels):
        z = 0.05 + k * (h - 0.07) / (levels - 1)
        m.add(shapes.box((x0 + 0.02, 0.0, z), (x1 - 0.02, d, z + 0.02)), jitter(c, rng, 6), "wood")
    return m


def umbrella_stand(rng: np.random.Generator) -> Model:
    """A cylindrical umbrella stand (~0.5 m)."""
    r, h = u(rng, 0.1, 0.14), u(rng, 0.45, 0.55)
    m = Model("umbrella stand", "furniture", [], 2 * r, 2 * r, h)
    m.add(shapes.cylinder(r, 0.0, h, 16, (0.0, r)), pick(rng, METALS + ((140, 40, 40), (40, 60, 90))), "metal")
    return m


def _appliance(rng: np.random.Generator, label: str) -> Model:
    """A front-loading washing machine or dryer: a 0.6 m cube, its round door and a control strip."""
    h = u(rng, 0.84, 0.88)
    c = pick(rng, APPLIANCES[:2])
    m = Model(label, "furniture", [], 0.6, 0.6, h)
    m.add(shapes.chamfer_box((-0.3, 0.0, 0.0), (0.3, 0.58, h), 0.01), c, "metal")
    door = shapes.transform(shapes.cylinder(0.2, 0.0, 0.02, 24), rot=shapes.rot_x(-0.5 * np.pi), shift=(0.0, 0.58, 0.4))
    m.add(door, (90, 96, 104) if label == "washing machine" else jitter(c, rng, 8), "plain")
    m.add(shapes.box((-0.28, 0.58, h - 0.12), (0.28, 0.6, h - 0.02)), jitter(c, rng, 6), "metal")
    return m


def washing_machine(rng: np.random.Generator) -> Model:
    """A front-loading washing machine (see `_appliance`)."""
    return _appliance(rng, "washing machine")


def dryer(rng: np.random.Generator) -> Model:
    """A tumble dryer (see `_appliance`)."""
    return _appliance(rng, "dryer")


def ironing_board(rng: np.random.Generator) -> Model:
    """A folded ironing board standing against the wall (1.2-1.4 m, 4 cm thick)."""
    h, w = u(rng, 1.2, 1.4), u(rng, 0.34, 0.4)
    m = Model("ironing board", "furniture", [], w, 0.06, h)
    m.add(shapes.box((-0.5 * w, 0.0, 0.0), (0.5 * w, 0.04, h)), pick(rng, FABRICS + LINENS), "fabric")
    m.add(shapes.box((-0.04, 0.04, 0.05), (0.04, 0.06, h - 0.1)), METALS[0], "metal")
    return m


def shelving(rng: np.random.Generator, height_max: float = 2.0) -> Model:
    """A storage shelving unit (closets, garages): a bookshelf's carcass, labelled shelf."""
    m = bookshelf(rng, height_max)
    m.label = "shelf"
    return m


def workbench(rng: np.random.Generator) -> Model:
    """A garage workbench: a thick top (~0.9 m) on four legs with a low shelf."""
    w, d, h = u(rng, 1.4, 2.0), u(rng, 0.6, 0.7), u(rng, 0.88, 0.94)
    wood = pick(rng, WOODS[:4])
    m = Model("table", "receptacle", [], w, d, h)
    x0, x1 = -0.5 * w, 0.5 * w
    _legs(m, x0, 0.0, x1, d, h - 0.05, 0.07, jitter(wood, rng, 10))
    m.add(shapes.box((x0 + 0.07, 0.05, 0.15), (x1 - 0.07, d - 0.05, 0.17)), jitter(wood, rng, 10), "wood")
    m.add(shapes.box((x0, 0.0, h - 0.05), (x1, d, h)), wood, "wood")
    m.supports.append((h, rect(x0, 0.0, x1, d)))
    return m


def tool_cabinet(rng: np.random.Generator) -> Model:
    """A metal tool cabinet with drawers (~1 m), not a receptacle."""
    w, d, h = u(rng, 0.6, 0.9), u(rng, 0.45, 0.5), u(rng, 0.9, 1.1)
    c = pick(rng, ((170, 40, 40), (60, 60, 64), (40, 70, 120)))
    m = Model("cabinet", "furniture", [], w, d, h)
    m.add(shapes.box((-0.5 * w, 0.0, 0.0), (0.5 * w, d - 0.015, h)), c, "metal")
    _drawer_fronts(m, -0.5 * w + 0.02, 0.5 * w - 0.02, 0.05, h - 0.03, d - 0.015, 5, 1, jitter(c, rng, 10), METALS[0], "metal")
    return m


def armchair(rng: np.random.Generator) -> Model:
    """An upholstered armchair: a base, a seat cushion (~0.45 m), arms and a back."""
    w, d = u(rng, 0.75, 0.9), u(rng, 0.75, 0.85)
    fab = pick(rng, FABRICS)
    m = Model("armchair", "furniture", [], w, d, 0.85)
    x0, x1 = -0.5 * w, 0.5 * w
    m.add(shapes.rounded_box((x0, 0.0, 0.08), (x1, d, 0.4), 0.02, 2), fab, "fabric")
    m.add(shapes.rounded_box((x0 + 0.12, 0.2, 0.4), (x1 - 0.12, d - 0.02, 0.48), 0.02, 2), jitter(fab, rng, 8), "fabric")
    m.add(shapes.rounded_box((x0, 0.0, 0.4), (x1, 0.2, 0.85), 0.03, 2), fab, "fabric")
    for a in (x0, x1 - 0.12):
        m.add(shapes.rounded_box((a, 0.2, 0.4), (a + 0.12, d, 0.62), 0.02, 2), fab, "fabric")
    _legs(m, x0 + 0.04, 0.04, x1 - 0.04, d - 0.04, 0.08, 0.04, pick(rng, WOODS))
    return m
