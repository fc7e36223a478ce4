"""Seeded procedural homes: rooms, walls with doorways, furniture with true support surfaces, clutter, stairs.

``generate_home(seed, preset)`` returns an :class:`~sdovon_mj.world.model.Apartment` (the record of any home):
storeys, rooms (CCW footprints on the wall centre lines), labelled instances (structure, receptacles, furniture),
ground-truth support surfaces of every receptacle and one triangle mesh (metres, **Z up**) whose faces carry an
instance id, an RGBA colour and a material tag. Everything derives from ``numpy.random.default_rng`` streams seeded
with the seed: the same seed and preset give the same home bit for bit.

The steps, each in its own module: the floor plan (the preset's: ``layout`` or ``houseplan``), each room's shell
(``structure``; a stairwell's flights and openings: ``stairs``), its furniture (``programs`` say what, ``placement``
where), its clutter (``clutter``, the preset's density), and the numbering of the pieces into one mesh
(``assembly``). Generator streams: ``[seed, 1, room]`` a room's finish and furniture, ``[seed, 2, storey]`` its door
frames' colour, ``[seed, 3, room]`` a room's clutter, ``[seed, 4, storey]`` the stairs' colour; the plans draw from
their own streams.
"""

from __future__ import annotations

import numpy as np

from . import clutter
from . import furniture
from . import layout
from . import placement
from . import programs
from . import stairs
from . import structure
from .assembly import Piece, assemble
from .layout import STOREY_HEIGHT
from .model import Apartment, ArticulatedInstance, RoomSpec, Storey
from .presets import Preset, preset


def _room(seed: int, r: layout.PlanRoom, plan: layout.Plan, pre: Preset, ceilings: bool, art: bool) -> tuple[list[Piece], list[str]]:
    """Build one room (its own seeded generators): floor, ceiling, four walls, windows, furniture, clutter, stairs."""
    rng = np.random.default_rng([int(seed), 1, r.id])
    storey = [o for o in plan.rooms if o.floor == r.floor]
    storey_doors = [d for d in plan.doors if d.floor == r.floor]
    z0 = r.floor * STOREY_HEIGHT
    site = structure.Site(r, r.floor, z0, plan.wall_h, structure.exterior_sides(r, storey),
                   tuple(stairs.opening(f) for f in plan.flights if f.arrives == r.id),
                   tuple(stairs.opening(f) for f in plan.flights if f.room == r.id))
    finish = structure.room_finish(r, site.ext, site.wall_h, rng)

    def program(rtype: str, iw: float, idp: float, rng_: np.random.Generator, height_max: float) -> list:
        return programs.program(rtype, iw, idp, rng_, height_max, art)

    dress = None
    if pre.clutter > 0:
        crng = np.random.default_rng([int(seed), 3, r.id])
        rooms = {o.id: o for o in plan.rooms}

        def dress(state: placement.RoomState, nav: object) -> None:
            clutter.dress(state, r, storey_doors, rooms, finish.windows, site.wall_h, crng, nav, pre.clutter)  # type: ignore[arg-type]

    fixed = tuple(b for f in plan.flights for b in stairs.keep_clear(f, r.id, site.wall_h))
    placed, notes = placement.furnish(r, storey_doors, rng, site.wall_h, finish.windows, program, fixed, dress)
    doors = layout.room_doors(r, storey_doors)
    pieces = [structure.floor_slab(site, finish)]
    pieces += [structure.ceiling(site)] if ceilings else []
    pieces += [structure.wall(site, side, structure.wall_openings(side, doors, finish.windows, site.z0), finish) for side in structure.WALL_SIDES]
    pieces += [structure.window(site, side, w, finish.frame_rgb) for side, wl in finish.windows.items() for w in wl]
    pieces += placement.furniture_pieces(r, placed, site.floor, site.z0)
    for f in plan.flights:
        if r.id in (f.room, f.arrives):
            srng = np.random.default_rng([int(seed), 4, f.floor])
            wood = furniture.pick(srng, furniture.WOODS)
            pieces.append(stairs.flight_piece(f, z0, wood) if r.id == f.room else stairs.railing_piece(f, r, z0, wood))
    return pieces, notes


def generate_home(seed: int, preset_name: str = "apartment", floors: int | None = None, ceilings: bool = True,
                  articulated: bool = False) -> Apartment:
    """Generate the home of `seed` in a preset (``world/presets.py``: "apartment" or "house").

    Steps: draw the plan; per storey, build each room (own generators: finish, furniture, clutter, then its
    structure, furniture and stair pieces) and then the door frames; number the pieces and join one mesh.

    Parameters
    ----------
    seed : int
        The home's seed: the same seed and preset give the same home bit for bit.
    preset_name : str
        "apartment" (3-6 rooms on 1-2 storeys) or "house" (8-16 rooms on 1-3 storeys).
    floors : int, optional
        A storey count the preset allows (apartment 1-2, house 1-3), or None / 0 for the seeded choice.
    ceilings : bool
        Build the rooms' ceilings.
    articulated : bool
        ``world.articulated``: dressers, wardrobes, fridges, kitchen cabinets and microwaves are articulated pieces
        (``Apartment.articulated``, written as URDF by `write_apartment`) instead of static meshes.
    """
    pre = preset(preset_name)
    if floors not in (None, 0) + pre.storeys:
        raise ValueError(f"floors must be one of {', '.join(map(str, pre.storeys))} for the {pre.name} preset "
                         "(or None / 0 for the seeded choice)")
    plan = pre.plan(seed, floors or None)
    pieces: list[Piece] = []
    notes: list[str] = []
    for fl in range(plan.storeys):
        for r in (r for r in plan.rooms if r.floor == fl):
            room_pieces, room_notes = _room(seed, r, plan, pre, ceilings, articulated)
            pieces += room_pieces
            notes += room_notes
        colour = structure.door_frame_colour(seed, fl)
        pieces += [structure.door_frame(d, fl * STOREY_HEIGHT, colour) for d in plan.doors if d.floor == fl]
    instances, mesh = assemble(pieces)
    return Apartment(
        seed=int(seed),
        floors=tuple(Storey(k, k * STOREY_HEIGHT) for k in range(plan.storeys)),
        wall_height=float(plan.wall_h),
        rooms=tuple(RoomSpec(r.id, r.type, r.floor, furniture.rect(r.x0, r.y0, r.x1, r.y1)) for r in plan.rooms),
        instances=instances,
        doors=tuple(structure.door_record(d, d.floor * STOREY_HEIGHT) for d in plan.doors),
        mesh=mesh,
        ceilings=ceilings,
        notes=tuple(notes),
        articulated=tuple(ArticulatedInstance(k, p.art[0], p.art[1], tuple(float(c) for c in p.art[2]), int(p.art[3]),
                                              p.room, p.floor) for k, p in enumerate(pieces) if p.art is not None),
        preset=pre.name,
    )


def generate_apartment(seed: int, floors: int | None = None, ceilings: bool = True, articulated: bool = False) -> Apartment:
    """Generate the apartment of `seed` (floors: 1, 2 or None for the seeded choice, ~30% two storeys); see
    `generate_home`."""
    if floors not in (None, 0, 1, 2):
        raise ValueError("floors must be 1, 2 or None (0 also means the seeded choice)")
    return generate_home(seed, "apartment", floors, ceilings, articulated)


def generate_house(seed: int, floors: int | None = None, ceilings: bool = True, articulated: bool = False) -> Apartment:
    """Generate the house of `seed` (floors: 1, 2, 3 or None for the seeded choice); see `generate_home`."""
    return generate_home(seed, "house", floors, ceilings, articulated)
