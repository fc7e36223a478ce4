"""The built shell of a room: floor slab, ceiling, walls with door and window openings, windows, door frames.

Rooms stand on the wall centre lines of the floor plan (``world/layout.py``); each room builds the room-side half
of its walls (``WALL_T`` / 2) and, where a wall is an outer wall of the home, the outer half too. A room's finish
(floor, wall, skirting and window-frame colours, and its windows) is drawn from the room's own generator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import furniture
from . import layout
from . import shapes
from .assembly import MeshPart, Piece
from .furniture import u
from .layout import SKIRTING, STOREY_HEIGHT, WALL_T
from .model import Door

WALL_COLOURS = ((236, 233, 226), (222, 226, 230), (232, 222, 206), (214, 222, 212), (242, 242, 240), (226, 214, 214))
FLOOR_WOOD = ((168, 124, 86), (196, 156, 112), (132, 96, 66), (210, 190, 160))
FLOOR_TILE = ((204, 204, 198), (176, 178, 182), (226, 222, 214), (150, 140, 130))
WALL_SIDES = ("S", "E", "N", "W")  # wall sides of a room: south (y0), east (x1), north (y1), west (x0)


def _wall_pieces(lo: float, hi: float, openings: list[tuple[float, float, float, float]], z0: float,
                 z1: float) -> list[tuple[float, float, float, float]]:
    """Split a wall run lo..hi around openings (centre, half width, bottom, top); returns (a, b, za, zb)."""
    pieces = []
    a = lo
    for c, half, zb, zt in sorted(openings):
        pieces.append((a, c - half, z0, z1))
        if zb > z0 + 1e-9:
            pieces.append((c - half, c + half, z0, zb))
        pieces.append((c - half, c + half, zt, z1))
        a = c + half
    pieces.append((a, hi, z0, z1))
    return [p for p in pieces if p[1] - p[0] > 1e-6 and p[3] - p[2] > 1e-6]


def _windows(r: layout.PlanRoom, ext: dict[str, list[tuple[float, float]]], wall_h: float,
             rng: np.random.Generator) -> dict[str, list[tuple]]:
    """Choose windows on a room's outer walls (the longest outer stretch of each side): side -> [(centre, half width,
    sill, top)] (storey-relative)."""
    out: dict[str, list[tuple]] = {}
    t = 0.5 * WALL_T
    for side in WALL_SIDES:
        if not ext[side]:
            continue
        p, q = max(ext[side], key=lambda s_: s_[1] - s_[0])
        lo, hi = p + t, q - t
        length = hi - lo
        if length < 1.6 or rng.random() < 0.25:
            continue
        n = 2 if length > 4.2 and rng.random() < 0.6 else 1
        small = r.type == "bathroom"
        ww = u(rng, 0.6, 0.8) if small else u(rng, 0.9, min(1.6, length / n - 0.6))
        sill = u(rng, 1.2, 1.4) if small else (u(rng, 1.0, 1.1) if r.type == "kitchen" else u(rng, 0.8, 0.95))
        top = min(wall_h - 0.25, u(rng, 2.0, 2.2))
        wins = []
        for k in range(n):
            c = layout.snap(lo + length * (k + 0.5) / n + rng.uniform(-0.1, 0.1) * length / n)
            c = float(np.clip(c, lo + 0.3 + 0.5 * ww, hi - 0.3 - 0.5 * ww))
            wins.append((c, 0.5 * ww, sill, top))
        out[side] = wins
    return out


Stretches = list[tuple[float, float]]  # intervals along one side of a room, plan metres
Rect = tuple[float, float, float, float]  # x0, y0, x1, y1, plan metres


@dataclass(frozen=True)
class Site:
    """Where a room's shell stands: its plan cell, storey index, floor height and wall height (metres), the outer
    stretches of each side ("S", "E", "N", "W": `exterior_sides`) and the openings cut from its floor and ceiling
    (a stairwell's)."""

    room: layout.PlanRoom
    floor: int
    z0: float
    wall_h: float
    ext: dict[str, Stretches]
    floor_holes: tuple[Rect, ...] = ()
    ceiling_holes: tuple[Rect, ...] = ()


@dataclass(frozen=True)
class Finish:
    """A room's seeded finish: colours (RGB) of floor, walls, skirting and window frames, and its windows."""

    floor_rgb: tuple[int, ...]
    tiled: bool
    wall_rgb: tuple[int, ...]
    skirting_rgb: tuple[int, ...]
    windows: dict[str, list[tuple]]  # side -> [(centre, half width, sill, top)], storey-relative metres
    frame_rgb: tuple[int, ...]


EPS = 1e-6


def exterior_sides(r: layout.PlanRoom, rooms: list[layout.PlanRoom]) -> dict[str, Stretches]:
    """Return side -> the stretches of that side of the room that are outer walls (shared with no room of its storey).

    A stretch is (lo, hi) along the side: x for the S and N sides, y for W and E. A side on the outline of an
    apartment's rectangle is one whole stretch, an inner side none; the wings of a house have sides partly outside.
    """
    out: dict[str, Stretches] = {}
    for side in WALL_SIDES:
        along_x = side in ("S", "N")
        line = {"S": r.y0, "N": r.y1, "W": r.x0, "E": r.x1}[side]
        lo, hi = (r.x0, r.x1) if along_x else (r.y0, r.y1)
        cover = []
        for o in rooms:
            if o.id == r.id or o.floor != r.floor:
                continue
            other = {"S": o.y1, "N": o.y0, "W": o.x1, "E": o.x0}[side]
            if abs(other - line) < EPS:
                cover.append((o.x0, o.x1) if along_x else (o.y0, o.y1))
        free, a = [], lo
        for c0, c1 in sorted(cover):
            if c0 > a + EPS:
                free.append((a, min(c0, hi)))
            a = max(a, c1)
        if hi > a + EPS:
            free.append((a, hi))
        out[side] = [(p, q) for p, q in free if q - p > EPS and q > lo + EPS and p < hi - EPS]
    return out


def _side_range(r: layout.PlanRoom, side: str) -> tuple[float, float]:
    """Return (lo, hi) of a room side along it (x for S and N, y for W and E)."""
    return (r.x0, r.x1) if side in ("S", "N") else (r.y0, r.y1)


def _full(r: layout.PlanRoom, side: str, ext: dict[str, Stretches]) -> bool:
    """Whether the whole side is an outer wall."""
    lo, hi = _side_range(r, side)
    return len(ext[side]) == 1 and abs(ext[side][0][0] - lo) < EPS and abs(ext[side][0][1] - hi) < EPS


def _touches(stretches: Stretches, at: float) -> bool:
    """Whether an outer stretch of a side reaches the corner at coordinate `at` (an end of that side)."""
    return any(abs(p - at) < EPS or abs(q - at) < EPS for p, q in stretches)


def _outer_span(r: layout.PlanRoom, side: str, ext: dict[str, Stretches], p: float, q: float) -> tuple[float, float]:
    """Return the extent along the side of the outer half-slab over the outer stretch (p, q) of a partly outer side.

    S and N walls take the corners: at a corner where the next side is outer too they reach out by half a wall; where
    the stretch ends inside the side (a neighbour's wall meets it there) they stop half a wall short, the neighbour's
    wall filling that corner. W and E walls always stop half a wall short of both ends.
    """
    t = 0.5 * WALL_T
    if side not in ("S", "N"):
        return p + t, q - t
    corner = r.y0 if side == "S" else r.y1
    a = p - t if (abs(p - r.x0) < EPS and _touches(ext["W"], corner)) else (p + t if p > r.x0 + EPS else p)
    b = q + t if (abs(q - r.x1) < EPS and _touches(ext["E"], corner)) else (q - t if q < r.x1 - EPS else q)
    return a, b


def _minus(rect: Rect, holes: tuple[Rect, ...]) -> list[Rect]:
    """Return `rect` less the holes as disjoint rectangles (strips below, above, left and right of each hole)."""
    out = [rect]
    for hx0, hy0, hx1, hy1 in holes:
        nxt = []
        for x0, y0, x1, y1 in out:
            if hx0 >= x1 - EPS or hx1 <= x0 + EPS or hy0 >= y1 - EPS or hy1 <= y0 + EPS:
                nxt.append((x0, y0, x1, y1))
                continue
            cx0, cy0, cx1, cy1 = max(x0, hx0), max(y0, hy0), min(x1, hx1), min(y1, hy1)
            nxt += [(x0, y0, x1, cy0), (x0, cy1, x1, y1), (x0, cy0, cx0, cy1), (cx1, cy0, x1, cy1)]
        out = [b for b in nxt if b[2] - b[0] > EPS and b[3] - b[1] > EPS]
    return out


def room_finish(r: layout.PlanRoom, ext: dict[str, Stretches], wall_h: float, rng: np.random.Generator) -> Finish:
    """Draw a room's floor, wall, skirting and window-frame colours and its windows (in this order)."""
    tiled = r.type in ("kitchen", "bathroom")
    fcol = furniture.jitter((FLOOR_TILE if tiled else FLOOR_WOOD)[int(rng.integers(4))], rng, 5)
    wcol = furniture.jitter(WALL_COLOURS[int(rng.integers(len(WALL_COLOURS)))], rng, 3)
    if r.type == "bathroom":
        wcol = furniture.jitter((214, 226, 232), rng, 4)
    skc = (246, 246, 244) if rng.random() < 0.6 else furniture.jitter(fcol, rng, 8)
    wins = _windows(r, ext, wall_h, rng)
    frame_c = (244, 244, 242) if rng.random() < 0.7 else furniture.pick(rng, furniture.WOODS[:4])
    return Finish(fcol, tiled, wcol, skc, wins, frame_c)


def floor_slab(site: Site, finish: Finish) -> Piece:
    """Return the room's floor slab (reaching under the outer walls; upper storeys fill up to the storey below)."""
    r, ext, fl, z0, wall_h = site.room, site.ext, site.floor, site.z0, site.wall_h
    t = 0.5 * WALL_T
    full = {side: _full(r, side, ext) for side in WALL_SIDES}
    fx0, fy0 = r.x0 - (t if full["W"] else 0.0), r.y0 - (t if full["S"] else 0.0)
    fx1, fy1 = r.x1 + (t if full["E"] else 0.0), r.y1 + (t if full["N"] else 0.0)
    slab = 0.1 if fl == 0 else STOREY_HEIGHT - wall_h - 0.05
    material = "floor_tile" if finish.tiled else "floor_wood"
    rects = _minus((fx0, fy0, fx1, fy1), site.floor_holes)
    for side in WALL_SIDES:  # under the outer half of partly outer walls
        if ext[side] and not full[side]:
            for p, q in ext[side]:
                a, b = _outer_span(r, side, ext, p, q)
                rects.append({"S": (a, r.y0 - t, b, r.y0), "N": (a, r.y1, b, r.y1 + t),
                              "W": (r.x0 - t, a, r.x0, b), "E": (r.x1, a, r.x1 + t, b)}[side])
    parts = tuple((shapes.box((x0, y0, z0 - slab), (x1, y1, z0)), finish.floor_rgb, material) for x0, y0, x1, y1 in rects)
    return Piece("floor", r.id, fl, "structure", parts)


def ceiling(site: Site) -> Piece:
    """Return the room's ceiling slab (2 cm thick, between the walls)."""
    r, fl, z0, wall_h = site.room, site.floor, site.z0, site.wall_h
    t = 0.5 * WALL_T
    rects = _minus((r.x0 + t, r.y0 + t, r.x1 - t, r.y1 - t), site.ceiling_holes)
    return Piece("ceiling", r.id, fl, "structure", tuple(
        (shapes.box((x0, y0, z0 + wall_h), (x1, y1, z0 + wall_h + 0.02)), (248, 248, 246), "ceiling") for x0, y0, x1, y1 in rects))


def wall_openings(side: str, doors: list[tuple[layout.PlanDoor, str]], windows: dict[str, list[tuple]],
                   z0: float) -> list[tuple[float, float, float, float]]:
    """Return the openings of one wall: (centre, half width, bottom Z, top Z) of its doors, then its windows."""
    opens = [(d.centre, 0.5 * d.width, z0, z0 + d.height) for d, s_ in doors if s_ == side]
    opens += [(c, hw, z0 + sill, z0 + top) for c, hw, sill, top in windows.get(side, [])]
    return opens


def wall(site: Site, side: str, opens: list[tuple[float, float, float, float]], finish: Finish) -> Piece:
    """Return one wall of a room: the room-side slab around its openings, outer walls full thickness, skirting."""
    r, ext, fl, z0, wall_h = site.room, site.ext, site.floor, site.z0, site.wall_h
    t = 0.5 * WALL_T
    sd, sh = SKIRTING
    along_x = side in ("S", "N")  # S and N walls run along X, W and E walls along Y
    full = _full(r, side, ext)
    if along_x:
        corner = r.y0 if side == "S" else r.y1
        lo, hi = r.x0 - (t if _touches(ext["W"], corner) else 0.0), r.x1 + (t if _touches(ext["E"], corner) else 0.0)
        clip_lo, clip_hi = r.x0 + t, r.x1 - t
        c0, c1 = r.y0, r.y1
    else:
        lo, hi = r.y0 + t, r.y1 - t
        clip_lo, clip_hi = lo + sd, hi - sd
        c0, c1 = r.x0, r.x1
    if side in ("S", "W"):  # across the wall: slab [a0, a1], skirting [k0, k1] on the room side
        a0, a1 = c0 - (t if full else 0.0), c0 + t
        k0, k1 = a1, a1 + sd
        o0, o1 = c0 - t, c0  # the outer half of a partly outer wall
    else:
        a0, a1 = c1 - t, c1 + (t if full else 0.0)
        k0, k1 = a0 - sd, a0
        o0, o1 = c1, c1 + t

    def box(u0: float, u1: float, v0: float, v1: float, za: float, zb: float) -> shapes.Mesh:
        """Return the box spanning [u0, u1] along the wall, [v0, v1] across it and [za, zb] in Z."""
        return shapes.box((u0, v0, za), (u1, v1, zb)) if along_x else shapes.box((v0, u0, za), (v1, u1, zb))

    parts: list[MeshPart] = []
    for a, b, za, zb in _wall_pieces(lo, hi, opens, z0, z0 + wall_h):
        parts.append((box(a, b, a0, a1, za, zb), finish.wall_rgb, "wall"))
        a2, b2 = max(a, clip_lo), min(b, clip_hi)
        if za <= z0 + 1e-9 and b2 - a2 > 1e-6:
            parts.append((box(a2, b2, k0, k1, z0, z0 + sh), finish.skirting_rgb, "wood"))
    if ext[side] and not full:
        for p, q in ext[side]:
            a, b = _outer_span(r, side, ext, p, q)
            for u0, u1, za, zb in _wall_pieces(a, b, [o for o in opens if a < o[0] < b], z0, z0 + wall_h):
                parts.append((box(u0, u1, o0, o1, za, zb), finish.wall_rgb, "wall"))
    return Piece("wall", r.id, fl, "structure", tuple(parts))


def window(site: Site, side: str, win: tuple, frame_rgb: tuple[int, ...]) -> Piece:
    """Return one window: frame and sill (in the wall, across its thickness) and the glass pane."""
    r, fl, z0 = site.room, site.floor, site.z0
    c, hw, sill, top = win
    t = 0.5 * WALL_T
    zs, zt = z0 + sill, z0 + top
    line = {"S": r.y0, "N": r.y1, "W": r.x0, "E": r.x1}[side]
    inward = {"S": 1.0, "N": -1.0, "W": 1.0, "E": -1.0}[side]
    ft = 0.05
    frame = [((c - hw, -t, zs), (c - hw + ft, t, zt)), ((c + hw - ft, -t, zs), (c + hw, t, zt)),
             ((c - hw + ft, -t, zt - ft), (c + hw - ft, t, zt)), ((c - hw + ft, -t, zs), (c + hw - ft, t, zs + ft))]
    if hw > 0.6:
        frame.append(((c - 0.02, -0.02, zs + ft), (c + 0.02, 0.02, zt - ft)))
    sill_box = ((c - hw - 0.03, t, zs - 0.03), (c + hw + 0.03, t + 0.04, zs))
    glass = ((c - hw + ft, -0.004, zs + ft), (c + hw - ft, 0.004, zt - ft))

    def place(lo_: tuple, hi_: tuple) -> shapes.Mesh:
        """Return a box given as (along the wall, into the room, Z) corners, in world coordinates."""
        (a0, o0, z_0), (a1, o1, z_1) = lo_, hi_
        o0, o1 = sorted((line + inward * o0, line + inward * o1))
        if side in ("S", "N"):
            return shapes.box((a0, o0, z_0), (a1, o1, z_1))
        return shapes.box((o0, a0, z_0), (o1, a1, z_1))

    parts: list[MeshPart] = [(place(lo_, hi_), frame_rgb, "plain") for lo_, hi_ in frame + [sill_box]]
    parts.append((place(*glass), (176, 206, 226, 96), "glass"))
    return Piece("window", r.id, fl, "structure", tuple(parts))


def door_frame_colour(seed: int, fl: int) -> tuple[int, ...]:
    """Draw the door-frame colour of a storey (its own seeded generator)."""
    rng = np.random.default_rng([int(seed), 2, fl])
    return furniture.jitter((240, 238, 232), rng, 3) if rng.random() < 0.6 else furniture.pick(rng, furniture.WOODS[:4])


def door_frame(d: layout.PlanDoor, z0: float, rgb: tuple[int, ...]) -> Piece:
    """Return a doorway's frame: two jambs and the head, slightly thicker than the wall."""
    c, half, jt, dt = d.centre, 0.5 * d.width, 0.05, 0.5 * WALL_T + 0.01
    parts: list[MeshPart] = []
    for a, b, za, zb in ((c - half, c - half + jt, z0, z0 + d.height), (c + half - jt, c + half, z0, z0 + d.height),
                         (c - half, c + half, z0 + d.height - jt, z0 + d.height)):
        if d.vertical:
            parts.append((shapes.box((d.line - dt, a, za), (d.line + dt, b, zb)), rgb, "wood"))
        else:
            parts.append((shapes.box((a, d.line - dt, za), (b, d.line + dt, zb)), rgb, "wood"))
    return Piece("door frame", min(d.room_a, d.room_b), d.floor, "structure", tuple(parts))


def door_record(d: layout.PlanDoor, z0: float) -> Door:
    """Return a plan door as a Door record (clear opening inside the frame)."""
    if d.vertical:
        centre, normal = np.array([d.line, d.centre, z0]), np.array([1.0, 0.0])
    else:
        centre, normal = np.array([d.centre, d.line, z0]), np.array([0.0, 1.0])
    return Door(d.floor, (d.room_a, d.room_b), centre, normal, round(d.width - 0.1, 6), round(d.height - 0.05, 6))
