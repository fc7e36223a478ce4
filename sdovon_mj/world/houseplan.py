"""Seeded floor plans of houses: wings with hallways, footprints that are not one rectangle, stairwells.

A house storey is built from wings. A wing is a rectangle with a hallway along its length and a strip of rooms on
each side; every strip room opens onto the hallway. The main wing runs along x; arms leave its north side: ``L``
(one arm at an end), ``T`` (one arm in the middle), ``U`` (an arm at each end) and ``courtyard`` (a U closed by a
second main wing, the hallways making a ring round the court). An arm's hallway crosses the main wing's north strip
to meet the main hallway, and a garage may close an arm's far end across its whole width. Upper storeys cover part
of the main wing (`PROGRAMME`). With several storeys a stairwell (the same cell on every storey, in the main wing's
north strip) holds the flights: lanes along its back wall, one flight per pair of storeys, switching back.

The plan is drawn in this canonical orientation, then transposed and mirrored (seeded) and moved to positive
coordinates. Everything is drawn from one generator; a plan whose room count falls outside ``ROOMS`` or that lacks
a room type of ``REQUIRED`` is drawn again, so every house has 8-16 rooms (hallways, closets and stairwells count as
rooms, as in HM3D's regions), a living room, a kitchen, a bedroom, a bathroom, a hallway and an entryway.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .layout import DOOR_MARGIN, DOOR_OPENING, WALL_T, Flight, Plan, PlanDoor, PlanRoom, snap

ROOMS = (8, 16)  # rooms per house, every storey together
REQUIRED = ("living room", "kitchen", "bedroom", "bathroom", "hallway", "entryway")  # in every house
HOUSE_ROOM_TYPES: tuple[str, ...] = ("living room", "kitchen", "dining room", "bedroom", "bathroom", "office", "hallway",
                                     "entryway", "laundry room", "closet", "garage", "stairwell")
STOREYS = ((1, 0.35), (2, 0.45), (3, 0.2))  # storey count and its probability when not given
SHAPES = (("L", 0.3), ("T", 0.25), ("U", 0.25), ("courtyard", 0.2))
# width along the strip (m) of each room type: drawn uniformly in this range, then stretched to fill the strip
WIDTH: dict[str, tuple[float, float]] = {
    "living room": (4.6, 6.0), "kitchen": (3.4, 4.4), "dining room": (3.2, 4.2), "bedroom": (3.3, 4.3),
    "bathroom": (2.2, 2.8), "closet": (1.7, 2.2), "laundry room": (2.2, 2.8), "office": (2.8, 3.6),
    "entryway": (2.4, 3.2),
}
RISERS = Flight.risers  # risers per flight (3 m / 17 = 0.176 m rise)
GOING = 0.25  # tread depth, m: a flight runs (RISERS - 1) * GOING = 4.0 m
LANE = 1.0  # flight width, m
LANDING = 1.1  # free floor at each end of the flights, m
STAIR_CELL = 2 * LANDING + (RISERS - 1) * GOING + WALL_T  # stairwell length along the wing, wall centre lines
GARAGE = (5.2, 6.2)  # garage depth along its arm, m


# ------------------------------------------------------------------------------------------------
# strips of rooms


def _widths(rng: np.random.Generator, types: list[str]) -> list[float]:
    """Draw each room type's width along its strip (m)."""
    return [float(rng.uniform(*WIDTH[t])) for t in types]


def _cut(x0: float, widths: list[float], length: float) -> list[tuple[float, float]]:
    """Return the (x0, x1) of rooms of these widths stretched to fill [x0, x0 + length], cuts snapped to the grid."""
    total = sum(widths)
    edges, acc = [x0], 0.0
    for w in widths[:-1]:
        acc += w
        edges.append(snap(x0 + acc * length / total))
    edges.append(snap(x0 + length))
    return list(zip(edges[:-1], edges[1:]))


def _fill(rng: np.random.Generator, length: float, wishes: list[str], extra: list[str]) -> list[str]:
    """Choose room types for a strip segment of `length` m: the wishes in order while they fit, then `extra` types
    (in order, repeated) while the rooms would be too wide; at least one room. The widths are drawn by `_widths`."""
    out: list[str] = []
    used = 0.0
    for t in wishes:
        if used + WIDTH[t][0] <= length + 1e-9:
            out.append(t)
            used += WIDTH[t][0]
    k = 0
    while extra and (not out or length > 1.35 * sum(WIDTH[t][1] for t in out)):
        t = extra[k % len(extra)]
        if used + WIDTH[t][0] > length + 1e-9:
            break
        out.append(t)
        used += WIDTH[t][0]
        k += 1
    if not out:
        out = ["closet"]
    order = rng.permutation(len(out))
    return [out[int(i)] for i in order]


# ------------------------------------------------------------------------------------------------
# the canonical plan


@dataclass
class _Cell:
    """A room cell while planning (ids and orientation come at the end)."""

    type: str
    floor: int
    x0: float
    y0: float
    x1: float
    y1: float
    hall: str = ""  # the hallway cell key it opens onto ("" for none)
    key: str = ""  # name of a hallway cell


class _Redraw(Exception):
    """The drawn plan does not work out; draw again."""


# The programme of a house by storey count: shapes and the room types wished for each strip. Ground floor: the
# main wing's south strip (the living rooms), its north strip (beside the stairwell and the arm stubs) and each arm
# (its west strip, its east strip; a courtyard's arms and closing wing have rooms on their outer side only). Upper
# storeys cover part of the main wing: two rooms south of the hallway, the stairwell and one room north of it; the
# third storey of a three-storey house is the stairwell with one room beside it (an attic). Longer strips get
# closets and offices (`_fill`), and a plan with more than 16 or fewer than 8 rooms is drawn again.
PROGRAMME = {
    1: {"shapes": (("L", 0.3), ("T", 0.25), ("U", 0.25), ("courtyard", 0.2)),
        "south": ["living room", "dining room", "kitchen"], "north": ["entryway", "bathroom", "laundry room"],
        "arms": {"L": [(["bedroom", "bathroom"], ["bedroom", "closet"])], "T": [(["bedroom", "bathroom"], ["bedroom", "closet"])],
                 "U": [(["bedroom"], ["office"]), (["bedroom"], ["bedroom"])],
                 "courtyard": [(["bedroom"], []), ([], ["bedroom"])]},
        "arm_length": {"L": (6.6, 8.4), "T": (6.6, 8.4), "U": (4.4, 5.6), "courtyard": (4.4, 5.6)},
        "court": ["bedroom", "office", "bathroom"], "garage": 0.7},
    2: {"shapes": (("L", 0.6), ("T", 0.4)), "south": ["living room", "dining room", "kitchen"],
        "north": ["entryway", "bathroom", "laundry room"], "arms": {"L": [([], [])], "T": [([], [])]},
        "arm_length": {"L": (0.0, 0.0), "T": (0.0, 0.0)}, "garage": 1.0},
    3: {"shapes": (("L", 1.0),), "south": ["living room", "kitchen"], "north": ["entryway", "bathroom"],
        "arms": {"L": [([], [])]}, "arm_length": {"L": (0.0, 0.0)}, "garage": 1.0},
}


def _pick(rng: np.random.Generator, options: tuple) -> str:
    """Draw one of (value, probability) options."""
    return options[int(rng.choice(len(options), p=[p for _, p in options]))][0]


def _stair_cell(rng: np.random.Generator, length: float, stubs: list[float], hw: float,
                upper: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """Draw the stairwell's x-range in the main wing's north strip, clear of the arm stubs and leaving no strip
    segment under 2 m, and the upper storeys' x-range (the stairwell and a room of width `upper` beside it)."""
    ends = sorted([0.0, length] + [v for s in stubs for v in (s, s + hw)])
    xs = {snap(x) for x in np.arange(0.0, length - STAIR_CELL + 1e-9, 0.25)}
    xs |= {snap(e) for e in ends} | {snap(e - STAIR_CELL) for e in ends}  # flush against an end or a stub
    cands = []
    for x in sorted(xs):
        x0, x1 = x, x + STAIR_CELL
        if x0 < -1e-9 or x1 > length + 1e-9 or any(x0 < s + hw - 1e-9 and x1 > s + 1e-9 for s in stubs):
            continue
        left = max([e for e in ends if e <= x0 + 1e-9], default=0.0)
        right = min([e for e in ends if e >= x1 - 1e-9], default=length)
        if 1e-9 < x0 - left < 2.0 or 1e-9 < right - x1 < 2.0:
            continue
        for side in (-1, 1):
            lo, hi = (x0 - upper, x1) if side < 0 else (x0, x1 + upper)
            if lo > -1e-9 and hi < length + 1e-9:
                cands.append((x, side))
    if not cands:
        raise _Redraw()
    sx, side = cands[int(rng.integers(len(cands)))]
    stair = (sx, snap(sx + STAIR_CELL))
    return stair, ((snap(sx - upper), stair[1]) if side < 0 else (sx, snap(stair[1] + upper)))


def _canonical(rng: np.random.Generator, storeys: int) -> tuple[list[_Cell], list[tuple[str, str, float]], list[Flight], str]:
    """Draw the canonical plan (`PROGRAMME`): cells, wide openings between hallways (key a, key b, width), flights."""
    prog = PROGRAMME[storeys]
    shape = _pick(rng, prog["shapes"])
    arms = prog["arms"][shape]
    hw = snap(rng.uniform(1.25, 1.5))
    d_s, d_n = snap(rng.uniform(4.2, 5.0)), snap(rng.uniform(3.4, 4.0))
    south = list(prog["south"]) if rng.random() < 0.5 else list(prog["south"])[::-1]
    north = list(prog["north"])
    y_hall0, y_hall1, depth = d_s, d_s + hw, d_s + hw + d_n
    court = shape == "courtyard"
    arm_w = [(snap(rng.uniform(3.0, 3.8)) if (w or not court) else 0.0,
              snap(rng.uniform(3.0, 3.8)) if (e or not court) else 0.0) for w, e in arms]
    upper = snap(rng.uniform(*WIDTH["bathroom"]))  # the upper storeys' room beside the stairwell
    north_min = sum(WIDTH[t][0] for t in north) + (STAIR_CELL if storeys > 1 else 0.0) + len(arms) * (hw + 2.2)
    arms_min = sum(ww + hw + we for ww, we in arm_w) + (2.5 if len(arms) == 2 else 0.0)  # two arms: a court between
    length = snap(max(sum(_widths(rng, south)), north_min, arms_min, 12.0 if len(arms) == 2 else 9.0) + rng.uniform(0.0, 2.0))
    cells: list[_Cell] = []
    links: list[tuple[str, str, float]] = []
    # arm stubs along the north strip: at an end (L), the middle (T) or both ends (U, courtyard)
    if shape == "L":
        stubs = [snap(length - hw - arm_w[0][1])] if rng.random() < 0.5 else [arm_w[0][0]]
    elif shape == "T":
        stubs = [snap(0.5 * (length - hw) + rng.uniform(-1.0, 1.0))]
    else:
        stubs = [arm_w[0][0], snap(length - hw - arm_w[1][1])]
    stair, span = _stair_cell(rng, length, stubs, hw, upper) if storeys > 1 else (None, (0.0, length))
    for fl in range(storeys):
        lo, hi = (0.0, length) if fl == 0 else span
        if fl < 2:
            cells.append(_Cell("hallway", fl, lo, y_hall0, hi, y_hall1, key=f"main{fl}"))
            _strip_cells(rng, cells, fl, lo, hi, 0.0, d_s, south if fl == 0 else ["bedroom", "bedroom"],
                         ["office"] if fl == 0 else [], f"main{fl}", [])
        if fl == 0:
            cuts = ([stair] if stair else []) + [(s, s + hw) for s in stubs]
            _strip_cells(rng, cells, fl, lo, hi, y_hall1, depth, north, ["closet", "office"], f"main{fl}", sorted(cuts))
        else:  # beside the stairwell: a bathroom, or on the attic storey a bedroom opening onto the stairwell
            a, b = (span[0], stair[0]) if span[0] < stair[0] - 1e-9 else (stair[1], span[1])
            cells.append(_Cell("bathroom" if fl == 1 else "bedroom", fl, a, y_hall1, b, depth,
                               hall=f"main{fl}" if fl < 2 else "well2"))
        if stair:
            cells.append(_Cell("stairwell", fl, stair[0], y_hall1, stair[1], depth, hall=f"main{fl}" if fl < 2 else "",
                               key="well2" if fl == 2 else ""))
    # arms (ground floor): stub + hallway, rooms on their sides, maybe a garage across the far end
    far = snap(depth + rng.uniform(*prog["arm_length"][shape]))
    garage_arm = int(rng.integers(len(arms))) if not court and rng.random() < prog["garage"] else -1
    for k, (sx, (ww, we), (w_rooms, e_rooms)) in enumerate(zip(stubs, arm_w, arms)):
        key = f"arm{k}"
        if k == garage_arm:
            g = snap(rng.uniform(*GARAGE))
            cells.append(_Cell("garage", 0, sx - ww, far, sx + hw + we, snap(far + g), hall=key))
        elif far <= depth + 1e-9:
            raise _Redraw()  # an arm without rooms or garage
        cells.append(_Cell("hallway", 0, sx, y_hall1, sx + hw, far, key=key))
        links.append(("main0", key, hw))
        for x0, x1, rooms in ((sx - ww, sx, w_rooms), (sx + hw, sx + hw + we, e_rooms)):
            if x1 - x0 > 1e-9 and far > depth + 1e-9:
                _strip_cells(rng, cells, 0, depth, far, x0, x1, rooms or ["closet"], ["closet"], key, [], across=True)
    if court:  # the closing wing: its hallway along the court, rooms on the outer side
        c_n = snap(rng.uniform(3.4, 4.0))
        x0, x1 = stubs[0] - arm_w[0][0], stubs[1] + hw + arm_w[1][1]
        cells.append(_Cell("hallway", 0, x0, far, x1, far + hw, key="court"))
        links += [("arm0", "court", hw), ("arm1", "court", hw)]
        _strip_cells(rng, cells, 0, x0, x1, far + hw, far + hw + c_n, prog["court"], [], "court", [])
    flights = []
    if stair:  # lanes along the stairwell's back (north) wall, switching back: flight k in lane k % 2
        t = 0.5 * WALL_T
        xa, xb = stair[0] + t + LANDING, stair[0] + t + LANDING + (RISERS - 1) * GOING
        for fl in range(storeys - 1):
            y1 = depth - t - (fl % 2) * LANE
            flights.append(Flight(fl, (snap(xa), snap(y1 - LANE), snap(xb), snap(y1)), "E" if fl % 2 == 0 else "W"))
    return cells, links, flights, shape


def _strip_cells(rng: np.random.Generator, cells: list[_Cell], floor: int, lo: float, hi: float, y0: float, y1: float,
                 wishes: list[str], extra: list[str], hall: str, cuts: list[tuple[float, float]], across: bool = False) -> None:
    """Fill a strip with rooms around `cuts` (stairwell, arm stubs), segment by segment; the wishes go to the longest
    segment first. `across`: the strip runs along y (an arm) between lo and hi, and x between y0 and y1.

    Parameters
    ----------
    rng : numpy.random.Generator
        The plan's generator.
    cells : list of _Cell
        Cells so far; the new rooms are appended.
    floor : int
        Storey index.
    lo, hi : float
        The strip's extent along its length, metres.
    y0, y1 : float
        The strip's extent across, metres.
    wishes, extra : list of str
        Room types wanted, and those added while rooms would be too wide (`_fill`).
    hall : str
        Key of the hallway the rooms open onto.
    cuts : list of (float, float)
        Intervals along the strip taken by other cells.
    across : bool
        Whether the strip runs along y.
    """
    segs, a = [], lo
    for c0, c1 in cuts:
        if c0 > a + 1e-9:
            segs.append((a, c0))
        a = max(a, c1)
    if hi > a + 1e-9:
        segs.append((a, hi))
    order = sorted(range(len(segs)), key=lambda i: -(segs[i][1] - segs[i][0]))
    left = list(wishes)
    for i in order:
        s0, s1 = segs[i]
        if s1 - s0 < WIDTH["closet"][0] - 1e-9:
            if s1 - s0 > 1e-9:
                raise _Redraw()
            continue
        types = _fill(rng, s1 - s0, left, extra)
        for t in types:
            if t in left:
                left.remove(t)
        for t, (p, q) in zip(types, _cut(s0, _widths(rng, types), s1 - s0)):
            if across:
                cells.append(_Cell(t, floor, y0, p, y1, q, hall=hall))
            else:
                cells.append(_Cell(t, floor, p, y0, q, y1, hall=hall))


# ------------------------------------------------------------------------------------------------
# doors


def _shared(a: _Cell, b: _Cell) -> tuple[bool, float, float, float] | None:
    """Return (vertical, line, lo, hi) of the wall two cells of one storey share, or None."""
    eps = 1e-6
    if a.floor != b.floor:
        return None
    for line, other in ((a.x1, b.x0), (a.x0, b.x1)):
        if abs(line - other) < eps:
            lo, hi = max(a.y0, b.y0), min(a.y1, b.y1)
            if hi - lo > eps:
                return True, line, lo, hi
    for line, other in ((a.y1, b.y0), (a.y0, b.y1)):
        if abs(line - other) < eps:
            lo, hi = max(a.x0, b.x0), min(a.x1, b.x1)
            if hi - lo > eps:
                return False, line, lo, hi
    return None


def _door(rng: np.random.Generator, ia: int, ib: int, floor: int, wall: tuple[bool, float, float, float],
          width: float = DOOR_OPENING, margin: float = DOOR_MARGIN) -> PlanDoor | None:
    """Return a door of `width` on a shared wall (near an end or anywhere along it), or None when it does not fit.

    Parameters
    ----------
    rng : numpy.random.Generator
        The plan's generator.
    ia, ib : int
        The two rooms (indices into the cell list).
    floor : int
        Storey index.
    wall : (bool, float, float, float)
        The shared wall: vertical, line, lo, hi (`_shared`).
    width : float
        Opening width, frame included, metres.
    margin : float
        Least wall left at each end of the shared stretch, metres.
    """
    vertical, line, lo, hi = wall
    a0, a1 = lo + margin + 0.5 * width, hi - margin - 0.5 * width
    if a1 < a0 - 1e-9:
        return None
    r = rng.random()
    centre = a0 if r < 0.3 else (a1 if r < 0.6 else rng.uniform(a0, a1))
    centre = float(np.clip(snap(centre), a0, a1))
    return PlanDoor(floor, min(ia, ib), max(ia, ib), vertical, line, centre, width)


def _doors(rng: np.random.Generator, cells: list[_Cell], links: list[tuple[str, str, float]]) -> list[PlanDoor]:
    """Join the cells: each room opens onto its hallway (a closet or bathroom beside a bedroom sometimes onto the
    bedroom instead), hallways meet in wide openings, kitchens and dining and living rooms side by side often share a
    door. Raises `_Redraw` when a room ends up without a door."""
    key = {c.key: i for i, c in enumerate(cells) if c.key}
    doors: list[PlanDoor] = []
    pairs: set[tuple[int, int]] = set()

    def add(i: int, j: int, width: float = DOOR_OPENING, margin: float = DOOR_MARGIN) -> bool:
        if (min(i, j), max(i, j)) in pairs:
            return True
        wall = _shared(cells[i], cells[j])
        well = [c for c in (cells[i], cells[j]) if c.type == "stairwell"]
        if wall and well and wall[0]:  # a side wall of the stairwell: the door stays in front of the flights
            wall = (wall[0], wall[1], wall[2], min(wall[3], well[0].y1 - 0.5 * WALL_T - 2 * LANE - 0.1))
        d = _door(rng, i, j, cells[i].floor, wall, width, margin) if wall else None
        if d is None:
            return False
        doors.append(d)
        pairs.add((d.room_a, d.room_b))
        return True

    for a, b, w in links:
        ia, ib = key[a], key[b]
        if not add(ia, ib, width=snap(w - 0.1), margin=0.0):
            raise _Redraw()
    for i, c in enumerate(cells):
        if not c.hall or c.key:
            continue
        if c.type in ("closet", "bathroom") and rng.random() < 0.5:
            beds = [j for j, o in enumerate(cells) if o.type == "bedroom" and o.floor == c.floor and _shared(c, o)]
            if beds and add(i, beds[int(rng.integers(len(beds)))]):
                continue
        hall = key[c.hall]
        margin = 0.1 if c.type == "garage" else DOOR_MARGIN
        if not add(i, hall, margin=margin):
            others = [j for j, o in enumerate(cells) if o.key and j != hall and _shared(c, o)]
            if not any(add(i, j, margin=0.1) for j in others):
                raise _Redraw()
    social = ("kitchen", "dining room", "living room")
    for i, c in enumerate(cells):
        for j in range(i + 1, len(cells)):
            o = cells[j]
            if c.type in social and o.type in social and c.type != o.type and _shared(c, o) and rng.random() < 0.7:
                add(i, j)
    return doors


# ------------------------------------------------------------------------------------------------
# orientation and the whole plan


def _orient(cells: list[_Cell], doors: list[PlanDoor], flights: list[Flight], transpose: bool, flip_x: bool,
            flip_y: bool) -> tuple[list[_Cell], list[PlanDoor], list[Flight]]:
    """Transpose and mirror a plan, then move it to positive coordinates.

    Parameters
    ----------
    cells, doors, flights : lists
        The canonical plan.
    transpose : bool
        Swap x and y.
    flip_x, flip_y : bool
        Mirror along x / along y (after the transpose).
    """
    sides = {"E": "E", "W": "W", "N": "N", "S": "S"}
    if transpose:
        cells = [replace(c, x0=c.y0, y0=c.x0, x1=c.y1, y1=c.x1) for c in cells]
        doors = [replace(d, vertical=not d.vertical) for d in doors]
        flights = [replace(f, lane=(f.lane[1], f.lane[0], f.lane[3], f.lane[2])) for f in flights]
        sides = {"E": "N", "W": "S", "N": "E", "S": "W"}
    flights = [replace(f, rises=sides[f.rises]) for f in flights]
    mx = max(c.x1 for c in cells) + min(c.x0 for c in cells)
    my = max(c.y1 for c in cells) + min(c.y0 for c in cells)
    if flip_x:
        cells = [replace(c, x0=snap(mx - c.x1), x1=snap(mx - c.x0)) for c in cells]
        doors = [replace(d, line=snap(mx - d.line)) if d.vertical else replace(d, centre=snap(mx - d.centre)) for d in doors]
        flights = [replace(f, lane=(snap(mx - f.lane[2]), f.lane[1], snap(mx - f.lane[0]), f.lane[3]),
                           rises={"E": "W", "W": "E"}.get(f.rises, f.rises)) for f in flights]
    if flip_y:
        cells = [replace(c, y0=snap(my - c.y1), y1=snap(my - c.y0)) for c in cells]
        doors = [replace(d, centre=snap(my - d.centre)) if d.vertical else replace(d, line=snap(my - d.line)) for d in doors]
        flights = [replace(f, lane=(f.lane[0], snap(my - f.lane[3]), f.lane[2], snap(my - f.lane[1])),
                           rises={"N": "S", "S": "N"}.get(f.rises, f.rises)) for f in flights]
    ox, oy = min(c.x0 for c in cells), min(c.y0 for c in cells)
    cells = [replace(c, x0=snap(c.x0 - ox), y0=snap(c.y0 - oy), x1=snap(c.x1 - ox), y1=snap(c.y1 - oy)) for c in cells]
    doors = [replace(d, line=snap(d.line - (ox if d.vertical else oy)), centre=snap(d.centre - (oy if d.vertical else ox)))
             for d in doors]
    flights = [replace(f, lane=(snap(f.lane[0] - ox), snap(f.lane[1] - oy), snap(f.lane[2] - ox), snap(f.lane[3] - oy)))
               for f in flights]
    return cells, doors, flights


def plan_house(seed: int, storeys: int | None = None) -> Plan:
    """Draw the plan of house `seed` (`storeys`: 1-3, or None for the seeded choice; see the module docstring)."""
    rng = np.random.default_rng([int(seed), 10])
    n = int(storeys) if storeys else [s for s, _ in STOREYS][int(rng.choice(len(STOREYS), p=[p for _, p in STOREYS]))]
    wall_h = snap(rng.uniform(2.5, 2.8))
    for _attempt in range(200):
        try:
            cells, links, flights, shape = _canonical(rng, n)
            if not ROOMS[0] <= len(cells) <= ROOMS[1] or not set(REQUIRED) <= {c.type for c in cells}:
                continue
            if any(a.floor == b.floor and min(a.x1, b.x1) - max(a.x0, b.x0) > 1e-6 and min(a.y1, b.y1) - max(a.y0, b.y0) > 1e-6
                   for i, a in enumerate(cells) for b in cells[i + 1:]):
                continue  # wings that would overlap
            doors = _doors(rng, cells, links)
        except _Redraw:
            continue
        cells, doors, flights = _orient(cells, doors, flights, bool(rng.random() < 0.5), bool(rng.random() < 0.5),
                                        bool(rng.random() < 0.5))
        # room ids: storey by storey, in the order drawn; doors keep their (lower, higher) pair
        order = sorted(range(len(cells)), key=lambda i: (cells[i].floor, i))
        new = {old: k for k, old in enumerate(order)}
        rooms = [PlanRoom(new[i], cells[i].type, cells[i].floor, cells[i].x0, cells[i].y0, cells[i].x1, cells[i].y1)
                 for i in order]
        doors = sorted((replace(d, room_a=min(new[d.room_a], new[d.room_b]), room_b=max(new[d.room_a], new[d.room_b]))
                        for d in doors), key=lambda d: (d.floor, d.room_a, d.room_b))
        well = {r.floor: r.id for r in rooms if r.type == "stairwell"}
        flights = [replace(f, room=well[f.floor], arrives=well[f.floor + 1]) for f in flights]
        return Plan(n, wall_h, rooms, doors, flights, shape)
    raise RuntimeError(f"no valid house plan found for seed {seed}")
