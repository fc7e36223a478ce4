"""Procedural articulated furniture written as URDF + OBJ files: cabinets, dressers, wardrobes, fridges, microwaves.

Same frame as `world.furniture`: metres, Z up, the floor (a microwave: the counter top) at z = 0, the back against
the wall at y = 0, the front facing +y, centred on x = 0. Carcasses, doors, drawers and shelves are URDF box
primitives (collision = visual); handles are OBJ meshes (visual only, so the converter gives them hulls of their
own). Doors are revolute joints at their hinge edge (opening outwards, towards +y, ``0 .. DOOR_OPEN`` rad), drawers
prismatic joints along +y (``0 .. DRAWER_PULL`` x depth), interior shelves fixed links. Each builder returns an
`ArticulatedModel` naming its interior support surfaces and the joint that closes each (None: open to the room).
Builders are seeded by the `rng` they are given: the same draws give the same bytes. With ``world.articulated`` the
homes place them (`world.artplace`: the layout proxies the room programs place, and the URDF writer).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..store import atomic_write_text
from .furniture import APPLIANCES, METALS, WOODS, jitter, pick, u

DOOR_OPEN = 1.75  # rad: how far a door swings open
DRAWER_PULL = 0.8  # a drawer slides out this fraction of its depth
PANEL = 0.018  # m: board thickness
SIZES = {  # kind -> (width, depth, height) ranges, m; a builder's first three draws
    "cabinet": ((0.5, 1.0), (0.55, 0.6), (0.86, 0.9)),
    "dresser": ((0.8, 1.2), (0.45, 0.52), (0.8, 1.0)),
    "wardrobe": ((0.9, 1.3), (0.55, 0.62), (1.9, 2.2)),
    "fridge": ((0.6, 0.72), (0.62, 0.68), (1.75, 1.95)),
    "microwave": ((0.45, 0.55), (0.34, 0.4), (0.26, 0.32)),
}


def draw_size(rng: np.random.Generator, kind: str) -> tuple[float, float, float]:
    """Draw (width, depth, height) of an articulated piece of `kind` (m): the first draws of its builder."""
    (w0, w1), (d0, d1), (h0, h1) = SIZES[kind]
    return u(rng, w0, w1), u(rng, d0, d1), u(rng, h0, h1)


@dataclass
class Interior:
    """A support surface inside an articulated piece: height (m), CCW polygon (local XY) and the closing joint."""

    height: float
    polygon: np.ndarray  # (N, 2)
    joint: str | None  # the joint that must open to reach it (None: reachable as is)
    link: str  # the URDF link it belongs to (moves with a drawer)


@dataclass
class ArticulatedModel:
    """A written articulated piece: its URDF, size, movable joints and interior surfaces."""

    label: str
    urdf: Path
    width: float
    depth: float
    height: float
    joints: list[str] = field(default_factory=list)
    interiors: list[Interior] = field(default_factory=list)


def _f(values: tuple[float, ...] | list[float] | np.ndarray) -> str:
    """Return numbers as URDF attribute text (fixed precision: same input, same bytes)."""
    return " ".join(f"{float(v):.4f}".rstrip("0").rstrip(".") if abs(float(v)) > 5e-5 else "0" for v in values)


def _rgba(rgb: tuple[int, ...]) -> str:
    """Return a 0-255 colour as URDF rgba text."""
    return _f([c / 255.0 for c in rgb[:3]] + [1.0])


class _Builder:
    """Collects links (boxes, OBJ handles) and joints, then writes the URDF and its meshes."""

    def __init__(self, name: str, folder: Path) -> None:
        self.name, self.folder = name, Path(folder)
        self.links: dict[str, list[str]] = {}
        self.joints: list[str] = []
        self.meshes: dict[str, str] = {}
        self.movable: list[str] = []

    def box(self, link: str, lo: tuple[float, float, float], hi: tuple[float, float, float], rgb: tuple[int, ...]) -> None:
        """Add a box (corners lo, hi in the link frame) to a link, as visual and collision."""
        c, s = (np.add(lo, hi) / 2), np.subtract(hi, lo)
        g = f'<origin xyz="{_f(c)}"/><geometry><box size="{_f(s)}"/></geometry>'
        self.links.setdefault(link, []).append(
            f'<visual>{g}<material name="{link}_{len(self.links[link])}"><color rgba="{_rgba(rgb)}"/></material></visual>'
            f'<collision>{g}</collision>')

    def handle(self, link: str, centre: tuple[float, float, float], length: float, vertical: bool, rgb: tuple[int, ...]) -> None:
        """Add a bar handle (an OBJ mesh, visual only) standing 3 cm proud of +y at `centre`."""
        lx, lz = (0.014, length) if vertical else (length, 0.014)
        key = f"handle_{'v' if vertical else 'h'}_{length:.3f}"
        if key not in self.meshes:
            self.meshes[key] = _box_obj((lx, 0.03, lz), (0.0, 0.015, 0.0))
        self.links.setdefault(link, []).append(
            f'<visual><origin xyz="{_f(centre)}"/><geometry><mesh filename="meshes/{key}.obj"/></geometry>'
            f'<material name="{link}_{len(self.links[link])}"><color rgba="{_rgba(rgb)}"/></material></visual>')

    def joint(self, name: str, kind: str, parent: str, child: str, xyz: tuple[float, float, float],
              axis: tuple[float, float, float] = (0, 0, 1), lower: float = 0.0, upper: float = 0.0,
              damping: float = 0.0, friction: float = 0.0) -> str:
        """Add a joint (revolute / prismatic / fixed); return its name.

        Parameters
        ----------
        name : str
            Joint name.
        kind : str
            "revolute", "prismatic" or "fixed".
        parent, child : str
            Link names.
        xyz : tuple of 3 float
            Child frame origin in the parent frame, m.
        axis : tuple of 3 float
            Joint axis in the child frame.
        lower, upper : float
            Limits, rad or m.
        damping, friction : float
            URDF dynamics (N m s/rad or N s/m; N m or N).
        """
        self.links.setdefault(child, [])
        text = f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/><origin xyz="{_f(xyz)}"/>'
        if kind != "fixed":
            effort = 50 if kind == "revolute" else 200
            text += (f'<axis xyz="{_f(axis)}"/><limit lower="{_f([lower])}" upper="{_f([upper])}" effort="{effort}" '
                     f'velocity="1"/><dynamics damping="{_f([damping])}" friction="{_f([friction])}"/>')
            self.movable.append(name)
        self.joints.append(text + "</joint>")
        return name

    def write(self) -> Path:
        """Write ``<folder>/<name>.urdf`` and ``<folder>/meshes/*.obj``; return the URDF path."""
        for key, text in sorted(self.meshes.items()):
            atomic_write_text(self.folder / "meshes" / f"{key}.obj", text)
        links = "\n".join(f'  <link name="{n}">{"".join(body)}</link>' for n, body in self.links.items())
        text = (f'<?xml version="1.0"?>\n<!-- sdovon-mj procedural articulated {self.name} -->\n<robot name="{self.name}">\n'
                f'{links}\n' + "\n".join(f"  {j}" for j in self.joints) + "\n</robot>\n")
        path = self.folder / f"{self.name}.urdf"
        atomic_write_text(path, text)
        return path


def _box_obj(size: tuple[float, float, float], centre: tuple[float, float, float]) -> str:
    """Return OBJ text of an axis-aligned box (outward faces)."""
    c, h = np.asarray(centre), np.asarray(size) / 2
    v = [c + h * np.array([sx, sy, sz]) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    f = [(1, 3, 4), (1, 4, 2), (5, 6, 8), (5, 8, 7), (1, 2, 6), (1, 6, 5), (3, 7, 8), (3, 8, 4), (1, 5, 7), (1, 7, 3),
         (2, 4, 8), (2, 8, 6)]
    return ("# sdovon-mj articulated handle\n" + "".join(f"v {_f(p)}\n" for p in v)
            + "".join(f"f {a} {b} {c}\n" for a, b, c in f))


def _carcass(b: _Builder, w: float, d: float, z0: float, z1: float, rgb: tuple[int, ...], top: bool = True) -> None:
    """Add an open-front box (sides, back, bottom at z0, optional top) to link ``body``, front at y = d."""
    x0, x1 = -w / 2, w / 2
    b.box("body", (x0, 0, z0), (x0 + PANEL, d, z1), rgb)
    b.box("body", (x1 - PANEL, 0, z0), (x1, d, z1), rgb)
    b.box("body", (x0 + PANEL, 0, z0), (x1 - PANEL, PANEL, z1), rgb)
    b.box("body", (x0 + PANEL, PANEL, z0), (x1 - PANEL, d, z0 + PANEL), rgb)
    if top:
        b.box("body", (x0, 0, z1 - PANEL), (x1, d, z1), rgb)


def _door(b: _Builder, name: str, x_hinge: float, width: float, d: float, z0: float, z1: float, left_hinge: bool,
          rgb: tuple[int, ...], metal: tuple[int, ...], thick: float = PANEL) -> str:
    """Add a door link hinged at x_hinge on the front plane y = d (opening outwards); return its joint name.

    Parameters
    ----------
    b : _Builder
        The piece being built.
    name : str
        Door link name (the joint is ``<name>_hinge``).
    x_hinge : float
        Hinge x, m (the door extends +x from it for a left hinge, -x for a right hinge).
    width : float
        Door width, m.
    d : float
        Front plane y, m.
    z0, z1 : float
        Door bottom and top, m.
    left_hinge : bool
        Hinge on the door's left edge.
    rgb, metal : tuple of int
        Door and handle colours (0-255).
    thick : float
        Door thickness, m.
    """
    sign = 1.0 if left_hinge else -1.0
    xa, xb = (0.002, width - 0.002) if left_hinge else (-width + 0.002, -0.002)
    b.box(name, (xa, 0.0, 0.0), (xb, thick, z1 - z0), rgb)
    b.handle(name, (sign * (width - 0.05), thick, 0.5 * (z1 - z0)), min(0.3, 0.5 * (z1 - z0)), True, metal)
    return b.joint(f"{name}_hinge", "revolute", "body", name, (x_hinge, d, z0), (0, 0, sign), 0.0, DOOR_OPEN,
                   damping=0.3, friction=0.05)


def _drawer(b: _Builder, name: str, w: float, d: float, z0: float, z1: float, rgb: tuple[int, ...],
            metal: tuple[int, ...]) -> tuple[str, Interior]:
    """Add a drawer (front panel at y = d, box behind it) sliding along +y; return its joint and its bottom."""
    inner_w, depth, hgt = w - 2 * PANEL - 0.01, d - PANEL - 0.02, (z1 - z0) - 0.03
    x0, x1 = -inner_w / 2, inner_w / 2
    y0 = -depth  # drawer frame: the front plane at y = 0
    t = 0.01
    b.box(name, (x0, y0, 0), (x1, 0, t), rgb)
    b.box(name, (x0, y0, 0), (x1, y0 + t, hgt), rgb)
    b.box(name, (x0, y0, 0), (x0 + t, 0, hgt), rgb)
    b.box(name, (x1 - t, y0, 0), (x1, 0, hgt), rgb)
    b.box(name, (-w / 2 + 0.003, 0, -0.008), (w / 2 - 0.003, PANEL, (z1 - z0) - 0.016), rgb)  # front panel, 8 mm gaps
    b.handle(name, (0.0, PANEL, 0.5 * (z1 - z0)), min(0.25, 0.4 * w), False, metal)
    j = b.joint(f"{name}_slide", "prismatic", "body", name, (0.0, d, z0 + 0.012), (0, 1, 0), 0.0, DRAWER_PULL * depth,
                damping=3.0, friction=0.3)
    poly = np.array([[x0 + t, y0 + t + d], [x1 - t, y0 + t + d], [x1 - t, d], [x0 + t, d]])
    return j, Interior(z0 + 0.012 + t, poly, j, name)


def _shelf(b: _Builder, name: str, w: float, d: float, z: float, rgb: tuple[int, ...], joint: str | None) -> Interior:
    """Add an interior shelf (a fixed link, top at z) between the side panels; return its surface."""
    x0, x1 = -w / 2 + PANEL, w / 2 - PANEL
    b.box(name, (x0, PANEL, -PANEL), (x1, d - 0.01, 0.0), rgb)
    b.joint(f"{name}_mount", "fixed", "body", name, (0.0, 0.0, z))
    return Interior(z, np.array([[x0, PANEL], [x1, PANEL], [x1, d - 0.01], [x0, d - 0.01]]), joint, name)


def kitchen_cabinet(rng: np.random.Generator, folder: str | Path, name: str = "kitchen_cabinet") -> ArticulatedModel:
    """A kitchen base cabinet (0.86-0.9 m tall, on a plinth) with one or two hinged doors and an interior shelf."""
    w, d, h = draw_size(rng, "cabinet")
    wood, metal = pick(rng, WOODS), pick(rng, METALS)
    b = _Builder(name, Path(folder))
    b.box("body", (-w / 2 + 0.02, 0.02, 0), (w / 2 - 0.02, d - 0.06, 0.1), jitter(wood, rng, 10))  # plinth
    _carcass(b, w, d, 0.1, h, wood)
    doors = 2 if w > 0.7 else 1
    dw = w / doors
    joints = [_door(b, f"door_{k}", -w / 2 + k * dw if k == 0 else w / 2, dw, d, 0.1, h - 0.004, k == 0,
                    jitter(wood, rng, 4), metal) for k in range(doors)]
    shelf = _shelf(b, "shelf_0", w, d, round(0.1 + 0.5 * (h - 0.1), 3), wood, joints[0])
    bottom = Interior(0.1 + PANEL, np.array([[-w / 2 + PANEL, PANEL], [w / 2 - PANEL, PANEL], [w / 2 - PANEL, d],
                                             [-w / 2 + PANEL, d]]), joints[0], "body")
    m = ArticulatedModel("cabinet", b.write(), w, d, h, list(b.movable), [bottom, shelf])
    return m


def dresser(rng: np.random.Generator, folder: str | Path, name: str = "dresser") -> ArticulatedModel:
    """A chest of drawers (top 0.8-1.0 m) with three or four drawers on prismatic joints."""
    w, d, h = draw_size(rng, "dresser")
    wood, metal = pick(rng, WOODS), pick(rng, METALS)
    b = _Builder(name, Path(folder))
    base = 0.08
    b.box("body", (-w / 2 + 0.02, 0.02, 0), (w / 2 - 0.02, d - 0.05, base), jitter(wood, rng, 10))
    _carcass(b, w, d, base, h, wood)
    rows = int(rng.integers(3, 5))
    step = (h - PANEL - base - PANEL) / rows
    interiors = []
    for r in range(rows):
        z0 = base + PANEL + r * step
        if r:
            b.box("body", (-w / 2 + PANEL, PANEL, z0 - PANEL / 2), (w / 2 - PANEL, d, z0), wood)  # runner board
        _j, inside = _drawer(b, f"drawer_{r}", w, d, z0, z0 + step, jitter(wood, rng, 4), metal)
        interiors.append(inside)
    return ArticulatedModel("dresser", b.write(), w, d, h, list(b.movable), interiors)


def wardrobe(rng: np.random.Generator, folder: str | Path, name: str = "wardrobe") -> ArticulatedModel:
    """A wardrobe (1.9-2.2 m) with two hinged doors, a hat shelf and a floor."""
    w, d, h = draw_size(rng, "wardrobe")
    wood, metal = pick(rng, WOODS), pick(rng, METALS)
    b = _Builder(name, Path(folder))
    b.box("body", (-w / 2 + 0.02, 0.0, 0), (w / 2 - 0.02, d - 0.05, 0.08), jitter(wood, rng, 10))
    _carcass(b, w, d, 0.08, h, wood)
    j0 = _door(b, "door_0", -w / 2, w / 2, d, 0.08, h - 0.004, True, jitter(wood, rng, 4), metal)
    _door(b, "door_1", w / 2, w / 2, d, 0.08, h - 0.004, False, jitter(wood, rng, 4), metal)
    shelf = _shelf(b, "shelf_0", w, d, round(h - 0.35, 3), wood, j0)
    floor = Interior(0.08 + PANEL, np.array([[-w / 2 + PANEL, PANEL], [w / 2 - PANEL, PANEL], [w / 2 - PANEL, d],
                                             [-w / 2 + PANEL, d]]), j0, "body")
    return ArticulatedModel("wardrobe", b.write(), w, d, h, list(b.movable), [floor, shelf])


def fridge(rng: np.random.Generator, folder: str | Path, name: str = "fridge") -> ArticulatedModel:
    """A fridge-freezer (1.75-1.95 m): fridge door above, freezer door below, both hinged right; two fridge shelves."""
    w, d, h = draw_size(rng, "fridge")
    c = pick(rng, APPLIANCES)
    metal = (150, 150, 155) if c[0] > 100 else (200, 200, 205)
    b = _Builder(name, Path(folder))
    split = round(u(rng, 0.35, 0.42) * h, 3)
    _carcass(b, w, d, 0.0, h, c)
    b.box("body", (-w / 2 + PANEL, PANEL, split - PANEL), (w / 2 - PANEL, d, split + PANEL), c)  # freezer divider
    fz = _door(b, "freezer_door", w / 2, w, d, 0.01, split - 0.003, False, jitter(c, rng, 4), metal, 0.04)
    fd = _door(b, "fridge_door", w / 2, w, d, split + 0.003, h - 0.004, False, jitter(c, rng, 4), metal, 0.04)
    shelves = [_shelf(b, f"shelf_{k}", w, d, round(split + PANEL + (k + 1) * (h - split) / 3, 3), c, fd) for k in range(2)]
    inner = np.array([[-w / 2 + PANEL, PANEL], [w / 2 - PANEL, PANEL], [w / 2 - PANEL, d], [-w / 2 + PANEL, d]])
    interiors = [Interior(split + PANEL, inner, fd, "body"), *shelves, Interior(PANEL, inner, fz, "body")]
    return ArticulatedModel("fridge", b.write(), w, d, h, list(b.movable), interiors)


def microwave(rng: np.random.Generator, folder: str | Path, name: str = "microwave") -> ArticulatedModel:
    """A microwave (0.45-0.55 m wide, standing on its counter at z = 0) with a door hinged on its left."""
    w, d, h = draw_size(rng, "microwave")
    c = pick(rng, APPLIANCES)
    b = _Builder(name, Path(folder))
    _carcass(b, w, d, 0.0, h, c)
    panel = 0.12  # control panel on the right, part of the body
    b.box("body", (w / 2 - panel, PANEL, PANEL), (w / 2 - PANEL, d, h - PANEL), jitter(c, rng, 6))
    j = _door(b, "door", -w / 2, w - panel, d, 0.0, h, True, jitter(c, rng, 4), pick(rng, METALS))
    floor = Interior(PANEL, np.array([[-w / 2 + PANEL, PANEL], [w / 2 - panel, PANEL], [w / 2 - panel, d],
                                      [-w / 2 + PANEL, d]]), j, "body")
    return ArticulatedModel("microwave", b.write(), w, d, h, list(b.movable), [floor])


BUILDERS = {"cabinet": kitchen_cabinet, "dresser": dresser, "wardrobe": wardrobe, "fridge": fridge,
            "microwave": microwave}


__all__ = ["ArticulatedModel", "BUILDERS", "Interior", "SIZES", "draw_size", "dresser", "fridge", "kitchen_cabinet", "microwave", "wardrobe"]
