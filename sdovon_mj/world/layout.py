"""Seeded floor plans: the plan records, and the apartments' plans (a rectangular footprint cut into rooms).

Rooms are axis-aligned cells whose edges are wall centre lines. Each storey of an apartment is a
partition of the same rectangular footprint (origin at its south-west corner). Doors join rooms
of one storey along a spanning tree of the room adjacency graph (the living room is the hub).
Houses (wings, hallways, stairwells) are planned in ``world/houseplan.py`` into the same records.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

ROOM_TYPES: tuple[str, ...] = ("kitchen", "living room", "bedroom", "bathroom", "office", "dining room")

# target floor areas (m^2) and minimum cell dimensions (m) per room type
AREA: dict[str, tuple[float, float]] = {
    "living room": (19.0, 28.0),
    "kitchen": (10.0, 14.0),
    "dining room": (11.0, 15.0),
    "bedroom": (12.0, 17.0),
    "bathroom": (4.8, 7.0),
    "office": (8.5, 12.0),
}
MIN_DIM: dict[str, float] = {
    "living room": 3.5, "kitchen": 2.8, "dining room": 3.0, "bedroom": 3.2, "bathroom": 2.0, "office": 2.6,
}
MAX_ASPECT = 2.2
DOOR_OPENING = 1.0  # wall opening incl. 5 cm jambs -> 0.9 m clear
DOOR_HEIGHT = 2.05  # opening incl. 5 cm head -> 2.0 m clear
DOOR_MARGIN = 0.3  # minimum distance of an opening from the end of the shared wall
GRID = 0.05
WALL_T = 0.1  # wall thickness (two 5 cm room-side slabs back to back)
SKIRTING = (0.012, 0.08)  # skirting board depth and height
STOREY_HEIGHT = 3.0  # floor-to-floor height of a home of several storeys


@dataclass
class PlanRoom:
    """A room cell of one storey (edges on wall centre lines)."""

    id: int
    type: str
    floor: int
    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def size(self) -> tuple[float, float]:
        """Return the cell's (width, depth)."""
        return self.x1 - self.x0, self.y1 - self.y0


@dataclass
class PlanDoor:
    """A doorway between two rooms: the wall line, the opening centre along it, the orientation."""

    floor: int
    room_a: int
    room_b: int
    vertical: bool  # True: wall along y at x = line; False: wall along x at y = line
    line: float
    centre: float
    width: float = DOOR_OPENING
    height: float = DOOR_HEIGHT


@dataclass(frozen=True)
class Flight:
    """A straight flight of stairs from storey `floor` up to `floor` + 1 (plan metres, storey-relative)."""

    floor: int
    lane: tuple[float, float, float, float]  # x0, y0, x1, y1 of its footprint
    rises: str  # the side it climbs towards: "E", "W", "N" or "S"
    risers: int = 17
    room: int = -1  # the stairwell room it stands in (storey `floor`)
    arrives: int = -1  # the stairwell room it arrives in (storey `floor` + 1)


@dataclass(frozen=True)
class Plan:
    """A seeded floor plan: storeys, wall height (m), rooms, doors, stair flights and the footprint's shape."""

    storeys: int
    wall_h: float
    rooms: list[PlanRoom]
    doors: list[PlanDoor]
    flights: list[Flight]
    shape: str = "rectangle"


def snap(v: float, step: float = GRID) -> float:
    """Round `v` to the plan grid."""
    return float(round(float(np.round(v / step)) * step, 6))


def choose_room_types(rng: np.random.Generator, seed: int, floors: int) -> list[list[str]]:
    """Return the room types of each storey (3-6 rooms in all; seed % 6 picks a type that must appear)."""
    featured = ROOM_TYPES[seed % len(ROOM_TYPES)]

    def fill(types: list[str], n: int, pool: dict[str, float]) -> list[str]:
        while len(types) < n:
            names = sorted(pool)
            w = np.array([pool[k] for k in names], dtype=np.float64)
            for i, k in enumerate(names):
                limit = 2 if k == "bedroom" else 1
                if types.count(k) >= limit:
                    w[i] = 0.0
            if w.sum() <= 0:
                break
            k = names[int(rng.choice(len(names), p=w / w.sum()))]
            types.append(k)
        return types

    if floors == 1:
        n = int(rng.integers(3, 7))
        types = ["living room"]
        if featured not in types:
            types.append(featured)
        pool = {"kitchen": 5.0, "bathroom": 3.0, "bedroom": 3.0, "office": 1.2, "dining room": 1.2}
        return [fill(types, n, pool)]
    n = int(rng.integers(4, 7))
    n0 = n // 2 + (1 if (n % 2 and rng.random() < 0.5) else 0)
    n1 = n - n0
    down = ["living room", "kitchen"]
    up = ["bedroom"]
    if featured in ("dining room",) and featured not in down:
        down.append(featured)
    if featured in ("office", "bathroom") and featured not in up:
        up.append(featured)
    down = fill(down[:max(n0, 2)], n0, {"dining room": 2.0, "bathroom": 2.0, "office": 1.0})
    up = fill(up[:max(n1, 1)], n1, {"bathroom": 3.0, "bedroom": 3.0, "office": 1.5})
    return [down, up]


def _layouts(rect: tuple[float, float, float, float], items: list[tuple[int, float, str]],
             budget: list[int]) -> list[dict[int, tuple]]:
    """Enumerate valid guillotine cuts of `rect` for the ordered items (areas ~proportional)."""
    budget[0] -= 1
    if budget[0] < 0:
        return []
    x0, y0, x1, y1 = rect
    w, d = x1 - x0, y1 - y0
    if len(items) == 1:
        t = items[0][2]
        if min(w, d) < MIN_DIM[t] - 1e-9 or max(w, d) / min(w, d) > MAX_ASPECT:
            return []
        return [{items[0][0]: rect}]
    total = sum(it[1] for it in items)
    out: list[dict[int, tuple]] = []
    for k in range(1, len(items)):
        frac0 = sum(it[1] for it in items[:k]) / total
        for vertical, stretch in itertools.product((True, False), (1.0, 0.85, 1.15)):
            frac = float(np.clip(frac0 * stretch, 0.05, 0.95))
            if vertical:
                xs = snap(x0 + frac * w)
                a, b = (x0, y0, xs, y1), (xs, y0, x1, y1)
            else:
                ys = snap(y0 + frac * d)
                a, b = (x0, y0, x1, ys), (x0, ys, x1, y1)
            left = _layouts(a, items[:k], budget)
            if not left:
                continue
            right = _layouts(b, items[k:], budget)
            for la in left:
                for rb in right:
                    out.append({**la, **rb})
                    if len(out) >= 16:
                        return out
    return out


def partition(rng: np.random.Generator, width: float, depth: float, types: list[str], areas: list[float],
              tries: int = 12) -> list[tuple[float, float, float, float]] | None:
    """Cut the footprint width x depth into len(types) valid cells (None if no valid cut was found).

    Parameters
    ----------
    rng : numpy.random.Generator
        Random draws of the room order and the layout chosen.
    width, depth : float
        Footprint size, metres.
    types : list of str
        Room types, one per cell.
    areas : list of float
        Target floor area per room, m^2.
    tries : int
        Room orders tried.
    """
    for _ in range(tries):
        order = [int(i) for i in rng.permutation(len(types))]
        found = _layouts((0.0, 0.0, width, depth), [(i, areas[i], types[i]) for i in order], [400])
        if not found:
            continue

        def badness(layout: dict[int, tuple]) -> float:
            r = [max(c[2] - c[0], c[3] - c[1]) / min(c[2] - c[0], c[3] - c[1]) for c in layout.values()]
            return float(max(r))

        scores = np.array([badness(lay) for lay in found])
        good = np.flatnonzero(scores <= scores.min() + 0.3)
        pick = found[int(good[int(rng.integers(len(good)))])]
        return [pick[i] for i in range(len(types))]
    return None


def shared_wall(a: PlanRoom, b: PlanRoom) -> tuple[bool, float, float, float] | None:
    """Return (vertical, line, lo, hi) of the wall two rooms share, or None."""
    eps = 1e-6
    for vertical, (ax1, ax0, bx0, bx1, lo_a, hi_a, lo_b, hi_b) in (
        (True, (a.x1, a.x0, b.x0, b.x1, a.y0, a.y1, b.y0, b.y1)),
        (False, (a.y1, a.y0, b.y0, b.y1, a.x0, a.x1, b.x0, b.x1)),
    ):
        for line in ((ax1 if abs(ax1 - bx0) < eps else None), (ax0 if abs(ax0 - bx1) < eps else None)):
            if line is None:
                continue
            lo, hi = max(lo_a, lo_b), min(hi_a, hi_b)
            if hi - lo > eps:
                return vertical, float(line), float(lo), float(hi)
    return None


def place_doors(rng: np.random.Generator, rooms: list[PlanRoom]) -> list[PlanDoor] | None:
    """Join the rooms of one storey by doors along a random spanning tree (None if impossible)."""
    need = DOOR_OPENING + 2 * DOOR_MARGIN
    cand = []
    for i, a in enumerate(rooms):
        for b in rooms[i + 1:]:
            sw = shared_wall(a, b)
            if sw is None or sw[3] - sw[2] < need:
                continue
            w = rng.uniform(0.0, 1.0)
            types = {a.type, b.type}
            if "living room" not in types:
                w += 1.5
            if types == {"bathroom", "kitchen"} or types == {"bathroom", "dining room"}:
                w += 3.0
            if "bathroom" in types and types & {"bedroom", "living room"}:
                w -= 0.5
            cand.append((w, a.id, b.id, sw))
    cand.sort(key=lambda c: (c[0], c[1], c[2]))
    parent = {r.id: r.id for r in rooms}

    def find(x: int) -> int:
        while parent[x] != x:
            x = parent[x]
        return x

    chosen = []
    rest = []
    for c in cand:
        ra, rb = find(c[1]), find(c[2])
        if ra != rb:
            parent[ra] = rb
            chosen.append(c)
        else:
            rest.append(c)
    if len({find(r.id) for r in rooms}) != 1:
        return None
    # sometimes one extra door makes a loop (never into a bathroom)
    extra = [c for c in rest if "bathroom" not in (rooms_by_id(rooms)[c[1]].type, rooms_by_id(rooms)[c[2]].type)]
    if extra and rng.random() < 0.3:
        chosen.append(extra[int(rng.integers(len(extra)))])
    doors = []
    for _, ia, ib, (vertical, line, lo, hi) in sorted(chosen, key=lambda c: (c[1], c[2])):
        a0 = lo + DOOR_MARGIN + 0.5 * DOOR_OPENING
        a1 = hi - DOOR_MARGIN - 0.5 * DOOR_OPENING
        if rng.random() < 0.6:
            centre = a0 if rng.random() < 0.5 else a1
        else:
            centre = rng.uniform(a0, a1)
        centre = float(np.clip(snap(centre), a0, a1))
        doors.append(PlanDoor(rooms[0].floor, ia, ib, vertical, line, centre))
    return doors


def rooms_by_id(rooms: list[PlanRoom]) -> dict[int, PlanRoom]:
    """Return the rooms keyed by id."""
    return {r.id: r for r in rooms}


def plan(rng: np.random.Generator, types_per_floor: list[list[str]]) -> tuple[float, float, list[PlanRoom], list[PlanDoor]]:
    """Return (width, depth, rooms, doors) of a footprint shared by all storeys."""
    for _attempt in range(200):
        areas = [[float(rng.uniform(*AREA[t])) for t in types] for types in types_per_floor]
        total = max(sum(a) for a in areas)
        aspect = rng.uniform(1.0, 1.6)
        width = snap(np.sqrt(total * aspect))
        depth = snap(total / width)
        if rng.random() < 0.5:
            width, depth = depth, width
        rooms: list[PlanRoom] = []
        doors: list[PlanDoor] = []
        ok = True
        for f, (types, ar) in enumerate(zip(types_per_floor, areas)):
            cells = partition(rng, width, depth, types, ar)
            if cells is None:
                ok = False
                break
            storey = [PlanRoom(len(rooms) + i, t, f, *c) for i, (t, c) in enumerate(zip(types, cells))]
            ds = place_doors(rng, storey)
            if ds is None:
                ok = False
                break
            rooms += storey
            doors += ds
        if ok:
            return width, depth, rooms, doors
    raise RuntimeError("no valid floor plan found")


def room_doors(room: PlanRoom, doors: list[PlanDoor]) -> list[tuple[PlanDoor, str]]:
    """Return the doors of a room with the side of the room they are on (S, E, N, W)."""
    out = []
    for d in doors:
        if room.id not in (d.room_a, d.room_b):
            continue
        if d.vertical:
            side = "W" if abs(d.line - room.x0) < 1e-6 else "E"
        else:
            side = "S" if abs(d.line - room.y0) < 1e-6 else "N"
        out.append((d, side))
    return out


def plan_apartment(seed: int, floors: int | None = None) -> Plan:
    """Draw the storey count (1, 2 or None for the seeded choice, ~30% two), wall height, room types and floor
    plan of the apartment `seed`."""
    rng = np.random.default_rng([int(seed), 0])
    two = rng.random() < 0.3
    nfl = int(floors) if floors else (2 if two else 1)
    wall_h = snap(rng.uniform(2.5, 2.8))
    types = choose_room_types(rng, int(seed), nfl)
    _width, _depth, rooms, doors = plan(rng, types)
    return Plan(nfl, wall_h, rooms, doors, [])
