"""Room programs: which furniture groups each room type holds, required or optional, and how each is drawn.

`program` returns a room type's groups as (factory, mode, required, probability); a factory draws a
:class:`~sdovon_mj.world.placement.Group` from the room's generator at a size level (0: full size, 1: smaller,
for the placement retries). Modes: ``wall`` (back against a wall), ``corner``, ``centre`` (free-standing),
``high`` (on a wall above the furniture) and ``fallback`` (a wall-side variant tried when the centre group failed).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from . import furniture
from .artplace import proxy
from .furniture import Model, u
from .placement import Group

Factory = Callable[[np.random.Generator, int], Group]


def _single(make: Callable[[np.random.Generator], Model], clear: float = 0.0) -> Factory:
    """Return a factory for a single-piece group."""
    return lambda rng, level: Group([(make(rng), 0.0, 0.0, 0)], clear)


def _bed_group(rng: np.random.Generator, level: int, min_dim: float) -> Group:
    """A bed with one or two nightstands beside it."""
    double = level == 0 and min_dim >= 3.0 and rng.random() < 0.8
    b = furniture.bed(rng, double)
    wood = furniture.pick(rng, furniture.WOODS)
    n = 2 if (double and level == 0 and rng.random() < 0.8) else 1
    items = [(b, 0.0, 0.0, 0)]
    side = 1.0 if rng.random() < 0.5 else -1.0
    for k in range(n):
        ns = furniture.nightstand(rng, wood)
        s = side if k == 0 else -side
        items.append((ns, s * (0.5 * b.width + 0.04 + 0.5 * ns.width), 0.0, 0))
    if rng.random() < 0.4 and level == 0:
        items.append((furniture.rug(rng, b.width + 0.4, 0.7), 0.0, b.depth + 0.03, 0))
    return Group(items, 0.5)


def _sofa_group(rng: np.random.Generator, level: int) -> Group:
    """A sofa facing a coffee table."""
    sf = furniture.sofa(rng, None if level == 0 else u(rng, 1.6, 1.8))
    ct = furniture.coffee_table(rng)
    gap = u(rng, 0.38, 0.45)
    items = [(sf, 0.0, 0.0, 0), (ct, 0.0, sf.depth + gap, 0)]
    if rng.random() < 0.6 and level == 0:
        rw = min(sf.width - 0.1, ct.width + u(rng, 0.4, 0.8))
        items.append((furniture.rug(rng, rw, gap + ct.depth + 0.25), 0.0, sf.depth + 0.05, 0))
    return Group(items, 0.3)


def _desk_group(rng: np.random.Generator, level: int) -> Group:
    """A desk with its chair pushed into the knee space."""
    d, knee = furniture.desk(rng, None if level == 0 else 1.0)
    c = furniture.chair(rng)
    return Group([(d, 0.0, 0.0, 0), (c, knee, d.depth - 0.12 + c.depth, 180)], 0.3)


def _kitchen_run(rng: np.random.Generator, level: int, wall: float, art: bool = False) -> Group:
    """A counter run with a recessed sink and the fridge at one end (`art`: an articulated fridge)."""
    f = proxy("fridge", rng) if art else furniture.fridge(rng)
    maxlen = wall - f.width - 0.1
    if level > 0:
        maxlen = min(maxlen, 1.6)
    cw = u(rng, 1.4, max(1.4, min(2.8, maxlen))) if maxlen >= 1.4 else max(0.8, maxlen)
    side = 1 if rng.random() < 0.5 else -1
    c, extras = furniture.counter(rng, cw, u(rng, 0.88, 0.92), 0.6, "recessed" if cw >= 1.35 else "none", sink_side=-side,
                           hob=cw >= 2.0)
    items = [(c, 0.0, 0.0, 0)] + [(e, 0.0, 0.0, 0) for e in extras]
    items.append((f, side * (0.5 * cw + 0.02 + 0.5 * f.width), 0.0, 0))
    return Group(items, 0.9)


def _vanity(rng: np.random.Generator, level: int) -> Group:
    """A bathroom vanity (counter) with a vessel sink at one end."""
    w = u(rng, 0.8, 1.2) if level == 0 else 0.8
    c, extras = furniture.counter(rng, w, u(rng, 0.82, 0.86), u(rng, 0.46, 0.52), "vessel", sink_side=1 if rng.random() < 0.5 else -1)
    return Group([(c, 0.0, 0.0, 0)] + [(e, 0.0, 0.0, 0) for e in extras], 0.6)


def _tv_group(rng: np.random.Generator, level: int) -> Group:
    """A TV stand with a TV on it."""
    st, tv = furniture.tv_stand(rng)
    return Group([(st, 0.0, 0.0, 0), (tv, 0.0, 0.0, 0)], 0.6)


def _dining_group(rng: np.random.Generator, level: int, big: bool, iw: float, idp: float, against_wall: bool = False) -> Group:
    """A table with chairs around it (centred at the group origin), sized to fit the room."""
    wood = furniture.pick(rng, furniture.WOODS)
    c0 = furniture.chair(rng, wood)
    cw, cd = c0.width, c0.depth
    reach = cd - 0.1  # how far a pushed-in chair sticks out from the table edge
    margin = 0.5
    long_, short = max(iw, idp), min(iw, idp)
    if not big and not against_wall and rng.random() < 0.35:
        t = furniture.table(rng, u(rng, 0.85, 1.0), round_top=True)
        r = 0.5 * t.width
        items = [(t, 0.0, -r, 0)]
        n = 4 if (level == 0 and rng.random() < 0.6) else 2
        for yaw in (180, 0, 90, 270)[:n]:
            off = r - 0.1 + cd
            pos = {180: (0.0, off), 0: (0.0, -off), 90: (off, 0.0), 270: (-off, 0.0)}[yaw]
            items.append((c0, pos[0], pos[1], yaw))
        return Group(items)
    if big:
        tw = u(rng, 1.4, 2.0) if level == 0 else 1.4
        td = u(rng, 0.85, 1.0)
        tw = max(1.2, min(tw, long_ - 2 * margin - 0.6))
    else:
        tw = u(rng, 1.0, 1.3) if level == 0 else 1.0
        td = u(rng, 0.7, 0.8)
    two_sides = (level == 0 or big) and not against_wall and short - 2 * margin - (0.7 if not big else 0.6) >= td + 2 * reach
    t = furniture.table(rng, tw, td)
    items = [(t, 0.0, -0.5 * td, 0)]
    # keep chairs clear of the table legs
    legs = _table_leg_span(t)
    span = 2 * legs - 0.04
    k = int(np.clip(np.floor(span / (cw + 0.12)), 1, 3))
    for yaw in ((180, 0) if two_sides else (180,)):
        for i in range(k):
            x = -0.5 * span + span * (i + 0.5) / k
            off = 0.5 * td - 0.1 + cd
            items.append((c0, x, off if yaw == 180 else -off, yaw))
    ylegs = _table_leg_span(t, axis=1)
    if big and tw >= 1.6 and ylegs > 0.5 * cw + 0.02 and long_ - 2 * margin - 0.6 >= tw + 2 * reach and rng.random() < 0.6:
        off = 0.5 * tw - 0.1 + cd
        items.append((c0, off, 0.0, 90))
        items.append((c0, -off, 0.0, 270))
    return Group(items)


def _table_leg_span(t: Model, axis: int = 0) -> float:
    """Return the half-width between the inner faces of a rectangular table's legs along an axis."""
    top = max(p.vertices[:, 2].max() for p in t.parts)
    legs = [p for p in t.parts if p.vertices[:, 2].min() <= 1e-9 and p.vertices[:, 2].max() < top - 0.02]
    if not legs:
        return 0.5 * (t.width if axis == 0 else t.depth)
    centre = 0.0 if axis == 0 else 0.5 * t.depth
    inner = min(float(np.min(np.abs(p.vertices[:, axis] - centre))) for p in legs)
    return inner


def _cabinet_group(rng: np.random.Generator, level: int) -> Group:
    """An articulated kitchen base cabinet with an articulated microwave on its top (world.articulated)."""
    cab = proxy("cabinet", rng)
    return Group([(cab, 0.0, 0.0, 0), (proxy("microwave", rng, lift=cab.height), 0.0, 0.02, 0)], 0.8)


def program(rtype: str, iw: float, idp: float, rng: np.random.Generator, height_max: float,
            art: bool = False) -> list[tuple[Factory, str, bool, float]]:
    """Return the room's furniture groups: (factory, mode, required, probability if optional).

    Parameters
    ----------
    rtype : str
        Room type (``layout.ROOM_TYPES``).
    iw, idp : float
        Interior width and depth of the room (between the skirting boards), metres.
    rng : numpy.random.Generator
        Not drawn from here: the factories draw from the generator they are called with.
    height_max : float
        Tallest a piece may be, metres.
    art : bool
        ``world.articulated``: dressers, wardrobes and fridges are articulated pieces, kitchens get an
        articulated base cabinet with a microwave and bathrooms often a base cabinet (`artplace.proxy`), and
        living rooms and offices get a dresser more often (homes keep small things in closed storage in every room).
    """
    longest = max(iw, idp)
    shortest = min(iw, idp)
    bs = lambda r: furniture.bookshelf(r, height_max)  # noqa: E731
    if art:
        dresser = lambda r, w=None: proxy("dresser", r)  # noqa: E731
    else:
        dresser = furniture.dresser
    if rtype == "bedroom":
        return [
            (lambda r, lv: _bed_group(r, lv, shortest), "wall", True, 1.0),
            (lambda r, lv: Group([(dresser(r, None if lv == 0 else 0.8), 0.0, 0.0, 0)], 0.6), "wall", True, 1.0),
            (lambda r, lv: Group([(proxy("wardrobe", r) if art else furniture.wardrobe(r, height_max, lv > 0), 0.0, 0.0, 0)],
                                 0.7), "corner", True, 1.0),
            (_single(furniture.wall_shelf), "high", False, 0.5),
            (_desk_group, "wall", False, 0.3),
            (_single(furniture.floor_lamp), "corner", False, 0.3),
            (_single(bs, 0.5), "corner", False, 0.2),
            (_single(furniture.picture), "high", False, 0.6),
        ]
    if rtype == "kitchen":
        return [
            (lambda r, lv: _kitchen_run(r, lv, longest, art), "corner", True, 1.0),
            (lambda r, lv: _dining_group(r, lv, False, iw, idp), "centre", True, 1.0),
            (lambda r, lv: _dining_group(r, lv, False, iw, idp, against_wall=True), "fallback", False, 1.0),
            *([(_cabinet_group, "wall", False, 0.9)] if art else []),
            (_single(lambda r: furniture.counter(r, u(r, 0.8, 1.4), u(r, 0.88, 0.92))[0], 0.8), "corner", False, 0.5),
            (_single(furniture.wall_shelf), "high", False, 0.5),
        ]
    if rtype == "living room":
        return [
            (_sofa_group, "wall", True, 1.0),
            (_single(bs, 0.5), "corner", True, 1.0),
            (_single(furniture.wall_shelf), "high", True, 1.0),
            (_tv_group, "wall", False, 0.7),
            (_single(furniture.chair, 0.3), "wall", False, 0.3),
            (_single(dresser, 0.6), "wall", False, 0.5 if art else 0.25),
            (_single(furniture.wall_shelf), "high", False, 0.25),
            (_single(furniture.floor_lamp), "corner", False, 0.5),
            (_single(furniture.picture), "high", False, 0.7),
            (_single(furniture.picture), "high", False, 0.4),
        ]
    if rtype == "bathroom":
        return [
            (_single(furniture.toilet, 0.5), "wall", True, 1.0),
            (_vanity, "wall", True, 1.0),
            (_single(furniture.wall_shelf), "high", True, 1.0),
            (_single(furniture.bathtub, 0.5), "corner", False, 0.6),
            *([(_single(lambda r: proxy("cabinet", r), 0.6), "wall", False, 0.6)] if art else []),
        ]
    if rtype == "office":
        return [
            (_desk_group, "wall", True, 1.0),
            (_single(bs, 0.5), "corner", True, 1.0),
            (_single(furniture.wall_shelf), "high", False, 0.6),
            (_single(dresser, 0.6), "wall", False, 0.5 if art else 0.3),
            (_single(bs, 0.5), "wall", False, 0.3),
            (_single(furniture.floor_lamp), "corner", False, 0.3),
            (_single(furniture.picture), "high", False, 0.4),
        ]
    if rtype == "dining room":
        return [
            (lambda r, lv: _dining_group(r, lv, True, iw, idp), "centre", True, 1.0),
            (lambda r, lv: _dining_group(r, lv, True, iw, idp, against_wall=True), "fallback", False, 1.0),
            (_single(dresser, 0.5), "wall", True, 1.0),
            (_single(furniture.wall_shelf), "high", False, 0.6),
            (_single(bs, 0.5), "corner", False, 0.3),
            (_single(furniture.picture), "high", False, 0.7),
        ]
    # the rooms of houses (``world/houseplan.py``)
    if rtype == "hallway":
        return [
            (_single(furniture.bench, 0.3), "wall", False, 0.3 if shortest >= 1.4 else 0.0),
            (_single(furniture.shoe_rack, 0.3), "wall", False, 0.3 if shortest >= 1.4 else 0.0),
            (_single(furniture.wall_shelf), "high", False, 0.4),
        ]
    if rtype == "entryway":
        return [
            (_single(furniture.bench, 0.4), "wall", True, 1.0),
            (_single(furniture.shoe_rack, 0.3), "wall", False, 0.9),
            (_single(furniture.coat_rack), "corner", False, 0.8),
            (_single(furniture.wall_shelf), "high", False, 0.5),
        ]
    if rtype == "laundry room":
        return [
            (lambda r, lv: Group([(furniture.washing_machine(r), 0.0, 0.0, 0), (furniture.dryer(r), 0.62, 0.0, 0)], 0.7), "corner", True, 1.0),
            (_single(lambda r: furniture.shelving(r, height_max), 0.5), "wall", False, 0.8),
            (_single(furniture.wall_shelf), "high", False, 0.7),
            (_single(furniture.ironing_board, 0.2), "wall", False, 0.5),
        ]
    if rtype == "closet":
        return [
            (_single(lambda r: furniture.shelving(r, height_max), 0.5), "corner", True, 1.0),
            (_single(lambda r: furniture.shelving(r, height_max), 0.5), "wall", False, 0.8),
            (_single(furniture.shoe_rack, 0.3), "wall", False, 0.5),
        ]
    if rtype == "garage":
        return [
            (_single(lambda r: furniture.shelving(r, height_max), 0.5), "corner", True, 1.0),
            (_single(furniture.workbench, 0.8), "wall", False, 0.8),
            (_single(furniture.tool_cabinet, 0.6), "wall", False, 0.6),
            (_single(lambda r: furniture.shelving(r, height_max), 0.5), "wall", False, 0.7),
            (_single(furniture.wall_shelf), "high", False, 0.5),
        ]
    if rtype == "stairwell":
        return [(_single(furniture.wall_shelf), "high", False, 0.3)]
    raise ValueError(f"unknown room type {rtype!r}")
