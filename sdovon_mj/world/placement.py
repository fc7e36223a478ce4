"""Furniture placement in a room: groups against walls or free-standing, collision and walking checks, retries.

A room's furniture comes as :class:`Group` s (pieces placed together in a group frame, e.g. a bed with its
nightstands) from a room program (``world/programs.py``). `furnish` places a program's groups one by one (against a
wall, in a corner, free-standing or high on a wall), keeping doorways, window fronts and walking passages clear,
and retries with fewer optional pieces and smaller sizes until every door joins one walkable region that reaches
every receptacle (`_nav_ok`). `furniture_pieces` turns the placed models into world-frame pieces.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy import ndimage

from ..config import AgentConfig
from . import layout
from . import shapes
from .artplace import is_proxy
from .assembly import Piece
from .furniture import Model
from .layout import SKIRTING, WALL_T
from .model import SurfaceSpec

AGENT_RADIUS = AgentConfig().radius  # apartments leave passages for the default agent (config.AgentConfig)
NAV_IGNORE_ABOVE = 0.9  # furniture whose bottom is higher than this does not block walking
FLAT = 0.02  # furniture lower than this (rugs) does not block walking
OBJECT_CLEARANCE = 0.3  # free height kept above receptacle tops when placing furniture
DOOR_KEEPOUT = 0.85  # depth kept free in front of a doorway
Placed = tuple[Model, float, float, int]  # a model at storey-relative (x, y) metres with a yaw in degrees
# a room program: (room type, interior width, interior depth, generator, tallest height) -> its groups
Program = Callable[[str, float, float, np.random.Generator, float], list[tuple[Callable, str, bool, float]]]

_COS = {0: 1, 90: 0, 180: -1, 270: 0}
_SIN = {0: 0, 90: 1, 180: 0, 270: -1}


def rot90(yaw: int) -> np.ndarray:
    """Return the exact 2x2 rotation for a multiple of 90 degrees."""
    y = yaw % 360
    return np.array([[_COS[y], -_SIN[y]], [_SIN[y], _COS[y]]], dtype=np.float64)


def _model_bounds(m: Model) -> np.ndarray:
    """Return (x0, y0, z0, x1, y1, z1) of a model's parts in its local frame (cached)."""
    b = getattr(m, "_bounds", None)
    if b is None:
        v = np.concatenate([p.vertices for p in m.parts])
        b = np.concatenate([v.min(0), v.max(0)])
        m._bounds = b
    return b


@dataclass
class Group:
    """Furniture placed together: (model, dx, dy, yaw) in the group frame (back at y = 0, front +y)."""

    items: list[tuple[Model, float, float, int]]
    front_clear: float = 0.0

    def placed(self, ox: float, oy: float, yaw: int) -> list[tuple[Model, float, float, int]]:
        """Return the items with world (ox, oy, yaw) for a group origin and yaw."""
        r = rot90(yaw)
        out = []
        for m, dx, dy, iy in self.items:
            p = r @ np.array([dx, dy])
            out.append((m, float(ox + p[0]), float(oy + p[1]), (yaw + iy) % 360))
        return out

    def footprint(self) -> np.ndarray:
        """Return (x0, y0, x1, y1) of all items in the group frame."""
        boxes = np.array([item_box(m, dx, dy, iy) for m, dx, dy, iy in self.items])
        return np.array([boxes[:, 0].min(), boxes[:, 1].min(), boxes[:, 2].max(), boxes[:, 3].max()])


def item_box(m: Model, ox: float, oy: float, yaw: int) -> np.ndarray:
    """Return (x0, y0, x1, y1, z0, z1) of a model placed at (ox, oy) with yaw (z1 = real top)."""
    b = _model_bounds(m)
    corners = np.array([[b[0], b[1]], [b[3], b[1]], [b[3], b[4]], [b[0], b[4]]]) @ rot90(yaw).T
    return np.array([corners[:, 0].min() + ox, corners[:, 1].min() + oy, corners[:, 0].max() + ox,
                     corners[:, 1].max() + oy, b[2], b[5]])


def overlap2(a: np.ndarray, b: np.ndarray, margin: float = 0.0) -> bool:
    """Whether two (x0, y0, x1, y1, ...) rectangles overlap (closer than `margin` counts)."""
    return bool(a[0] < b[2] + margin and b[0] < a[2] + margin and a[1] < b[3] + margin and b[1] < a[3] + margin)


@dataclass
class RoomState:
    """Placement state of one room."""

    interior: np.ndarray  # x0, y0, x1, y1
    keepouts: list[np.ndarray]
    bodies: list[np.ndarray] = field(default_factory=list)  # x0 y0 x1 y1 z0 z1eff
    clear: list[np.ndarray] = field(default_factory=list)
    placed: list[tuple[Model, float, float, int]] = field(default_factory=list)
    windows: list[np.ndarray] = field(default_factory=list)  # x0 y0 x1 y1 z0 z1: keep tall pieces away

    def fits(self, items: list[tuple[Model, float, float, int]], clear: np.ndarray | None) -> bool:
        """Whether the placed items (and their front clearance) fit without collisions."""
        ix = self.interior
        new = []
        for m, ox, oy, yaw in items:
            b = item_box(m, ox, oy, yaw)
            if b[0] < ix[0] - 1e-6 or b[1] < ix[1] - 1e-6 or b[2] > ix[2] + 1e-6 or b[3] > ix[3] + 1e-6:
                return False
            for wz in self.windows if m.label not in ("sink", "bed", "sofa") else ():  # may stand below a window
                if overlap2(b, wz) and b[4] < wz[5] and wz[4] < b[5]:
                    return False
            if m.kind == "receptacle":
                b[5] += OBJECT_CLEARANCE
            for k in self.keepouts:
                if overlap2(b, k):
                    return False
            for o in self.bodies:
                if overlap2(b, o, 0.02) and b[4] < o[5] and o[4] < b[5]:
                    return False
            if b[4] < NAV_IGNORE_ABOVE and b[5] > FLAT:
                for c in self.clear:
                    if overlap2(b, c):
                        return False
            new.append(b)
        if clear is not None:
            if clear[0] < ix[0] - 1e-6 or clear[1] < ix[1] - 1e-6 or clear[2] > ix[2] + 1e-6 or clear[3] > ix[3] + 1e-6:
                return False
            for o in self.bodies:
                if o[4] < NAV_IGNORE_ABOVE and o[5] > FLAT and overlap2(clear, o):
                    return False
        return True

    def commit(self, items: list[tuple[Model, float, float, int]], clear: np.ndarray | None) -> None:
        """Record placed items."""
        for m, ox, oy, yaw in items:
            b = item_box(m, ox, oy, yaw)
            if m.kind == "receptacle":
                b[5] += OBJECT_CLEARANCE
            self.bodies.append(b)
            self.placed.append((m, ox, oy, yaw))
        if clear is not None:
            self.clear.append(clear)


_SIDES = (("S", 0), ("E", 90), ("N", 180), ("W", 270))


def place_wall(state: RoomState, g: Group, rng: np.random.Generator, corner: bool) -> bool:
    """Place a group with its back against one of the room's walls."""
    fp = g.footprint()
    ix = state.interior
    cands = []
    for side, yaw in _SIDES:
        r = rot90(yaw)
        c = np.array([[fp[0], fp[1]], [fp[2], fp[1]], [fp[2], fp[3]], [fp[0], fp[3]]]) @ r.T
        rx0, ry0, rx1, ry1 = c[:, 0].min(), c[:, 1].min(), c[:, 0].max(), c[:, 1].max()
        if side in ("S", "N"):
            oy = ix[1] - ry0 if side == "S" else ix[3] - ry1
            lo, hi = ix[0] - rx0, ix[2] - rx1
        else:
            ox = ix[0] - rx0 if side == "W" else ix[2] - rx1
            lo, hi = ix[1] - ry0, ix[3] - ry1
        if hi < lo - 1e-9:
            continue
        hi = max(hi, lo)
        ts = [lo, hi] if corner else [lo, hi] + list(rng.uniform(lo, hi, 6))
        for t in ts:
            t = float(np.clip(np.round(t, 3), lo, hi))
            cands.append((side, yaw, (t, oy) if side in ("S", "N") else (ox, t)))
    for i in rng.permutation(len(cands)):
        side, yaw, (ox, oy) = cands[int(i)]
        items = g.placed(float(ox), float(oy), yaw)
        clear = None
        if g.front_clear > 0:
            r = rot90(yaw)
            c = np.array([[fp[0], fp[3]], [fp[2], fp[3]], [fp[2], fp[3] + g.front_clear], [fp[0], fp[3] + g.front_clear]]) @ r.T
            clear = np.array([c[:, 0].min() + ox, c[:, 1].min() + oy, c[:, 0].max() + ox, c[:, 1].max() + oy])
        if state.fits(items, clear):
            state.commit(items, clear)
            return True
    return False


def place_centre(state: RoomState, g: Group, rng: np.random.Generator, margin: float = 0.5) -> bool:
    """Place a free-standing group (a dining table with chairs) away from the walls."""
    fp = g.footprint()
    ix = state.interior
    long_x = (ix[2] - ix[0]) >= (ix[3] - ix[1])
    for k in range(16):
        yaw = 0 if (long_x == (k % 4 != 3)) else 90
        r = rot90(yaw)
        c = np.array([[fp[0], fp[1]], [fp[2], fp[1]], [fp[2], fp[3]], [fp[0], fp[3]]]) @ r.T
        rx0, ry0, rx1, ry1 = c[:, 0].min(), c[:, 1].min(), c[:, 0].max(), c[:, 1].max()
        lox, hix = ix[0] + margin - rx0, ix[2] - margin - rx1
        loy, hiy = ix[1] + margin - ry0, ix[3] - margin - ry1
        if hix < lox or hiy < loy:
            continue
        if k < 4:
            ox, oy = 0.5 * (lox + hix), 0.5 * (loy + hiy)
        else:
            ox, oy = rng.uniform(lox, hix), rng.uniform(loy, hiy)
        ox, oy = float(np.round(ox, 3)), float(np.round(oy, 3))
        items = g.placed(ox, oy, yaw)
        boxes = [item_box(*it) for it in items]
        zone = np.array([min(b[0] for b in boxes) - margin, min(b[1] for b in boxes) - margin,
                         max(b[2] for b in boxes) + margin, max(b[3] for b in boxes) + margin])
        if any(o[4] < NAV_IGNORE_ABOVE and o[5] > FLAT and overlap2(zone, o) for o in state.bodies):
            continue
        if state.fits(items, None):
            state.commit(items, zone)
            return True
    return False


def nav_ok(state: RoomState, anchors: list[np.ndarray], openings: list[np.ndarray], res: float = 0.05) -> bool:
    """Whether all doors of the room join one walkable region that reaches every receptacle."""
    ix = state.interior
    pad = 0.3
    x0, y0 = ix[0] - pad, ix[1] - pad
    nx = int(np.ceil((ix[2] - ix[0] + 2 * pad) / res))
    ny = int(np.ceil((ix[3] - ix[1] + 2 * pad) / res))
    xs = x0 + (np.arange(nx) + 0.5) * res
    ys = y0 + (np.arange(ny) + 0.5) * res
    gx, gy = np.meshgrid(xs, ys, indexing="xy")

    def inside(b: np.ndarray, grow: float = 0.0) -> np.ndarray:
        return (gx >= b[0] - grow) & (gx <= b[2] + grow) & (gy >= b[1] - grow) & (gy <= b[3] + grow)

    free = inside(ix)
    for o in openings:
        free |= inside(o)
    for b in state.bodies:
        if b[4] < NAV_IGNORE_ABOVE and b[5] > FLAT:
            free &= ~inside(b)
    dist = ndimage.distance_transform_edt(free) * res
    nav = dist > AGENT_RADIUS + 0.04  # a little stricter than the agent radius
    lab, _ = ndimage.label(nav)
    labels = set()
    for a in anchors:
        i = int((a[1] - y0) / res)
        j = int((a[0] - x0) / res)
        if not (0 <= i < ny and 0 <= j < nx) or lab[i, j] == 0:
            return False
        labels.add(int(lab[i, j]))
    if len(labels) != 1:
        return False
    # receptacles must be reachable from roomy cells (not only from a squeeze beside the bed)
    main = (lab == labels.pop()) & (dist > AGENT_RADIUS + 0.08)
    for m, ox, oy, yaw in state.placed:
        if m.kind == "receptacle":
            b = item_box(m, ox, oy, yaw)
            if not np.any(main & inside(b, AGENT_RADIUS + 0.27)):
                return False
    return True


def _door_zones(room: layout.PlanRoom, doors: list[layout.PlanDoor]) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """Return (keep-out rectangles, walking anchors, opening rectangles) of a room's doors."""
    t = 0.5 * WALL_T
    keep, anchors, openings = [], [], []
    for d, side in layout.room_doors(room, doors):
        c, half = d.centre, 0.5 * d.width + 0.1
        clear = 0.45
        if side == "S":
            y = room.y0 + t
            keep.append(np.array([c - half, y, c + half, y + DOOR_KEEPOUT]))
            anchors.append(np.array([c, y + 0.35]))
            openings.append(np.array([c - clear, y - 0.4, c + clear, y + 0.01]))
        elif side == "N":
            y = room.y1 - t
            keep.append(np.array([c - half, y - DOOR_KEEPOUT, c + half, y]))
            anchors.append(np.array([c, y - 0.35]))
            openings.append(np.array([c - clear, y - 0.01, c + clear, y + 0.4]))
        elif side == "W":
            x = room.x0 + t
            keep.append(np.array([x, c - half, x + DOOR_KEEPOUT, c + half]))
            anchors.append(np.array([x + 0.35, c]))
            openings.append(np.array([x - 0.4, c - clear, x + 0.01, c + clear]))
        else:
            x = room.x1 - t
            keep.append(np.array([x - DOOR_KEEPOUT, c - half, x, c + half]))
            anchors.append(np.array([x - 0.35, c]))
            openings.append(np.array([x - 0.01, c - clear, x + 0.4, c + clear]))
    return keep, anchors, openings


def _window_zones(interior: np.ndarray, windows: dict[str, list[tuple]]) -> list[np.ndarray]:
    """Return the boxes (x0, y0, x1, y1, z0, z1) in front of a room's windows that tall pieces keep clear of."""
    wzones = []
    for side, wl in windows.items():
        for c, hw, sill, top in wl:
            a, b = c - hw - 0.05, c + hw + 0.05
            z = (sill - 0.05, top)
            if side == "S":
                wzones.append(np.array([a, interior[1], b, interior[1] + 0.35, *z]))
            elif side == "N":
                wzones.append(np.array([a, interior[3] - 0.35, b, interior[3], *z]))
            elif side == "W":
                wzones.append(np.array([interior[0], a, interior[0] + 0.35, b, *z]))
            else:
                wzones.append(np.array([interior[2] - 0.35, a, interior[2], b, *z]))
    return wzones


def furnish(room: layout.PlanRoom, doors: list[layout.PlanDoor], rng: np.random.Generator, wall_h: float,
            windows: dict[str, list[tuple]], program: Program, fixed: tuple[np.ndarray, ...] = (),
            dress: Callable[[RoomState, Callable[[], bool]], None] | None = None) -> tuple[list[Placed], list[str]]:
    """Place the room's furniture; retries with fewer optional pieces and smaller sizes.

    Returns the placed items (model, x, y, yaw in degrees; storey-relative metres) and the notes on what
    could not be placed.

    Parameters
    ----------
    room : layout.PlanRoom
        The room (its cell on the wall centre lines, storey-relative metres).
    doors : list of layout.PlanDoor
        The doors of the room's storey (those of this room keep their fronts clear).
    rng : numpy.random.Generator
        The room's generator: every draw of the program's factories and of the placement.
    wall_h : float
        Wall height, metres (the tallest piece stays 0.15 m below it).
    windows : dict
        Side ("S", "E", "N", "W") -> [(centre, half width, sill, top)] of the room's windows, metres.
    program : callable
        ``program(room_type, interior_width, interior_depth, rng, height_max)`` -> the room's groups as
        (factory, mode, required, probability) (``world/programs.py``); called once per attempt.
    fixed : tuple of numpy.ndarray
        Boxes (x0, y0, x1, y1, z0, z1; storey-relative metres) that stand in the room before its furniture: a
        stairwell's flights, the opening of the flight from below and its railing.
    dress : callable, optional
        ``dress(state, nav)``: adds the room's clutter to the furnished state (``world/clutter.py``); ``nav()``
        tells whether the room is still walkable. Not drawn from `rng`.
    """
    t = 0.5 * WALL_T + SKIRTING[0] + 0.003
    interior = np.array([room.x0 + t, room.y0 + t, room.x1 - t, room.y1 - t])
    wzones = _window_zones(interior, windows)
    keep, anchors, openings = _door_zones(room, doors)
    iw, idp = interior[2] - interior[0], interior[3] - interior[1]
    height_max = wall_h - 0.15
    best: RoomState | None = None
    attempts = 36
    for attempt in range(attempts):
        level = 0 if attempt < 10 else 1
        keep_opt = 1.0 if attempt < 20 else 0.0
        tolerate = attempt >= 28  # late attempts may skip a required piece that does not fit
        prog = program(room.type, iw, idp, rng, height_max)
        state = RoomState(interior, keep, windows=list(wzones))
        state.bodies += [np.asarray(b, dtype=np.float64) for b in fixed]
        ok = True
        skipped: list[str] = []
        last_failed = False
        for factory, mode, required, prob in prog:
            if mode == "fallback":
                # a wall-side variant of the previous (centre) group, tried only when that failed
                if not last_failed:
                    continue
                required, mode = True, "wall"
            if not rng.random() < prob * (1.0 if required else keep_opt):
                continue
            g = factory(rng, level)
            if mode == "centre":
                placed = place_centre(state, g, rng)
                if not placed:
                    last_failed = True
                    continue
            else:
                placed = place_wall(state, g, rng, corner=(mode == "corner" and rng.random() < 0.7))
            last_failed = False
            if not placed and required:
                if not tolerate:
                    ok = False
                    break
                skipped.append(g.items[0][0].label)
        if ok and nav_ok(state, anchors, openings):
            notes = [f"room {room.id} ({room.type}): no room for {', '.join(skipped)}"] if skipped else []
            if dress is not None:
                dress(state, lambda st=state: nav_ok(st, anchors, openings))
            return state.placed, notes
        if ok and best is None:
            best = state
    if best is not None and dress is not None:  # only clutter that keeps out of the way (nav_ok is already false)
        dress(best, lambda st=best: nav_ok(st, anchors, openings))
    return (best.placed if best else []), [f"room {room.id} ({room.type}): furniture placed without the navigation guarantee"]


def furniture_pieces(r: layout.PlanRoom, placed: list[tuple[Model, float, float, int]], fl: int, z0: float) -> list[Piece]:
    """Return the placed furniture as pieces: parts and support surfaces moved to world coordinates."""
    out = []
    for m, ox, oy, yaw in placed:
        if is_proxy(m):
            kind, seed, lift = m.articulated  # type: ignore[attr-defined]
            out.append(Piece(m.label, r.id, fl, "receptacle", (), (), (kind, seed, (ox, oy, z0 + lift), yaw)))
            continue
        rot2 = rot90(yaw)
        rot3 = np.eye(3)
        rot3[:2, :2] = rot2
        sup = tuple(
            SurfaceSpec(float(h + z0), np.asarray(poly) @ rot2.T + np.array([ox, oy])) for h, poly in m.supports
        )
        parts = tuple((shapes.transform((p.vertices, p.faces), rot=rot3, shift=(ox, oy, z0)), p.rgba, p.material) for p in m.parts)
        out.append(Piece(m.label, r.id, fl, m.kind, parts, sup))
    return out
