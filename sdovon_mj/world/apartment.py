"""Seeded procedural apartments: rooms, walls with doorways, furniture with true support surfaces.

``generate_apartment(seed)`` returns an :class:`~sdovon_mj.world.model.Apartment`: storeys, rooms (CCW
footprints on the wall centre lines), labelled instances (structure, receptacles, furniture), ground-truth support
surfaces of every receptacle and one triangle mesh (metres, **Z up**) whose faces carry an instance id, an RGBA
colour and a material tag. Everything derives from ``numpy.random.default_rng`` seeded with the apartment seed:
the same seed gives the same apartment bit for bit.

The steps, each in its own module: the floor plan (``layout``), each room's shell (``structure``), its furniture
(``programs`` say what, ``placement`` where), and the numbering of the pieces into one mesh (``assembly``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import furniture as FU
from . import layout as LA
from . import placement as PL
from . import programs as PR
from . import structure as ST
from .assembly import Piece, assemble
from .layout import STOREY_HEIGHT
from .model import Apartment, ArticulatedInstance, RoomSpec, Storey


@dataclass(frozen=True)
class _Plan:
    """The seeded plan of an apartment: storeys, wall height, outer size (metres), rooms and doors."""

    storeys: int
    wall_h: float
    width: float
    depth: float
    rooms: list[LA.PlanRoom]
    doors: list[LA.PlanDoor]
    floor_z: list[float]  # world Z of each storey's walkable surface


def _plan_apartment(seed: int, floors: int | None) -> _Plan:
    """Draw the storey count, wall height, room types and floor plan of the apartment `seed`."""
    rng = np.random.default_rng([int(seed), 0])
    two = rng.random() < 0.3
    nfl = int(floors) if floors else (2 if two else 1)
    wall_h = LA.snap(rng.uniform(2.5, 2.8))
    types = LA.choose_room_types(rng, int(seed), nfl)
    width, depth, prooms, pdoors = LA.plan(rng, types)
    return _Plan(nfl, wall_h, width, depth, prooms, pdoors, [0.0, STOREY_HEIGHT][:nfl])


def _room(seed: int, r: LA.PlanRoom, plan: _Plan, storey_doors: list[LA.PlanDoor],
          ceilings: bool, art: bool = False) -> tuple[list[Piece], list[str]]:
    """Build one room (its own seeded generator): floor, ceiling, four walls, windows, furniture; and notes."""
    rng = np.random.default_rng([int(seed), 1, r.id])
    site = ST.Site(r, r.floor, plan.floor_z[r.floor], plan.wall_h, ST.exterior(r, plan.width, plan.depth))
    finish = ST.room_finish(r, site.ext, site.wall_h, rng)

    def program(rtype: str, iw: float, idp: float, rng_: np.random.Generator, height_max: float) -> list:
        return PR.program(rtype, iw, idp, rng_, height_max, art)

    placed, notes = PL.furnish(r, storey_doors, rng, site.wall_h, finish.windows, program)
    doors = LA.room_doors(r, storey_doors)
    pieces = [ST.floor_slab(site, finish)]
    pieces += [ST.ceiling(site)] if ceilings else []
    pieces += [ST.wall(site, side, ST.wall_openings(side, doors, finish.windows, site.z0), finish) for side in ST.WALL_SIDES]
    pieces += [ST.window(site, side, w, finish.frame_rgb) for side, wl in finish.windows.items() for w in wl]
    pieces += PL.furniture_pieces(r, placed, site.floor, site.z0)
    return pieces, notes


def generate_apartment(seed: int, floors: int | None = None, ceilings: bool = True, articulated: bool = False) -> Apartment:
    """Generate the apartment for `seed` (floors: 1, 2 or None for the seeded choice, ~30% two storeys).

    `articulated` (``world.articulated``): dressers, wardrobes, fridges, kitchen cabinets and microwaves are
    articulated pieces (``Apartment.articulated``, written as URDF by `write_apartment`) instead of static meshes.

    Steps: draw the plan; per storey, build each room (own generator: finish, furniture, then its
    structure and furniture pieces) and then the door frames; number the pieces and join one mesh.
    """
    if floors not in (None, 0, 1, 2):
        raise ValueError("floors must be 1, 2 or None (0 also means the seeded choice)")
    plan = _plan_apartment(seed, floors)
    pieces: list[Piece] = []
    notes: list[str] = []
    for fl in range(plan.storeys):
        storey_doors = [d for d in plan.doors if d.floor == fl]
        for r in (r for r in plan.rooms if r.floor == fl):
            room_pieces, room_notes = _room(seed, r, plan, storey_doors, ceilings, articulated)
            pieces += room_pieces
            notes += room_notes
        colour = ST.door_frame_colour(seed, fl)
        pieces += [ST.door_frame(d, plan.floor_z[fl], colour) for d in storey_doors]
    instances, mesh = assemble(pieces)
    return Apartment(
        seed=int(seed),
        floors=tuple(Storey(k, plan.floor_z[k]) for k in range(plan.storeys)),
        wall_height=float(plan.wall_h),
        rooms=tuple(RoomSpec(r.id, r.type, r.floor, FU.rect(r.x0, r.y0, r.x1, r.y1)) for r in plan.rooms),
        instances=instances,
        doors=tuple(ST.door_record(d, plan.floor_z[d.floor]) for d in plan.doors),
        mesh=mesh,
        ceilings=ceilings,
        notes=tuple(notes),
        articulated=tuple(ArticulatedInstance(k, p.art[0], p.art[1], tuple(float(c) for c in p.art[2]), int(p.art[3]),
                                              p.room, p.floor) for k, p in enumerate(pieces) if p.art is not None),
    )
