"""Stairs between storeys: a flight of solid steps, the opening it needs, and the railing round the opening.

A flight (``layout.Flight``) climbs one storey height in ``risers`` steps along its lane. On the storey it starts
from it is a stack of solid blocks (labelled ``stairs``; the agent cannot climb it: a step is higher than the
navigable map's obstacle band starts), and the ceiling above its lane is open. On the storey it arrives on, the
floor over its lane is open and a railing (labelled ``stairs`` too, as its banister) guards the opening on every
side that is neither a wall nor the end the flight arrives at. Episodes stay on one storey, as in Habitat's ObjectNav
datasets; the stairs are geometry the agent sees.
"""

from __future__ import annotations

import numpy as np

from . import shapes
from .assembly import MeshPart, Piece
from .layout import STOREY_HEIGHT, WALL_T, Flight, PlanRoom

RAIL_H = 0.95  # railing height above the floor, m
POST = 0.045  # post and rail section, m


def opening(f: Flight) -> tuple[float, float, float, float]:
    """Return the opening (x0, y0, x1, y1; plan metres) a flight needs in the ceiling below and the floor above."""
    return f.lane


def flight_piece(f: Flight, z0: float, rgb: tuple[int, ...]) -> Piece:
    """Return the flight's steps (solid blocks from the floor at `z0` up to each tread) as a piece of its stairwell."""
    x0, y0, x1, y1 = f.lane
    rise = STOREY_HEIGHT / f.risers
    treads = f.risers - 1
    along_x = f.rises in ("E", "W")
    lo, hi = (x0, x1) if along_x else (y0, y1)
    going = (hi - lo) / treads
    parts: list[MeshPart] = []
    for i in range(treads):
        a = lo + i * going if f.rises in ("E", "N") else hi - (i + 1) * going
        b = a + going
        top = z0 + (i + 1) * rise
        box = shapes.box((a, y0, z0), (b, y1, top)) if along_x else shapes.box((x0, a, z0), (x1, b, top))
        parts.append((box, rgb, "wood"))
    return Piece("stairs", f.room, f.floor, "furniture", tuple(parts))


def railing_sides(f: Flight, well: PlanRoom) -> list[tuple[float, float, float, float]]:
    """Return the segments (x0, y0, x1, y1; a line along x or y, plan metres) of the railing round a flight's opening
    on the storey it arrives on: every side of the opening but the walls and the end the flight arrives at."""
    x0, y0, x1, y1 = f.lane
    t = 0.5 * WALL_T
    ix = (well.x0 + t, well.y0 + t, well.x1 - t, well.y1 - t)
    sides = {"S": (x0, y0, x1, y0), "N": (x0, y1, x1, y1), "W": (x0, y0, x0, y1), "E": (x1, y0, x1, y1)}
    against = {"S": abs(y0 - ix[1]) < 1e-6, "N": abs(y1 - ix[3]) < 1e-6, "W": abs(x0 - ix[0]) < 1e-6,
               "E": abs(x1 - ix[2]) < 1e-6}
    return [seg for side, seg in sides.items() if side != f.rises and not against[side]]


def railing_piece(f: Flight, well: PlanRoom, z1: float, rgb: tuple[int, ...]) -> Piece:
    """Return the railing round a flight's opening on its arrival storey (floor at `z1`): posts about every 0.9 m
    just outside the opening and a hand rail on top."""
    parts: list[MeshPart] = []
    x0, y0, x1, y1 = f.lane
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    t = 0.5 * WALL_T
    ix = np.array([well.x0 + t, well.y0 + t, well.x1 - t, well.y1 - t])

    def box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> shapes.Mesh:
        """Return a box clipped to the stairwell's inside (a rail meeting a wall stops at its face)."""
        a = np.maximum(np.asarray(lo[:2]), ix[:2])
        b = np.minimum(np.asarray(hi[:2]), ix[2:])
        return shapes.box((a[0], a[1], lo[2]), (b[0], b[1], hi[2]))

    for a0, b0, a1, b1 in railing_sides(f, well):
        along_x = abs(b1 - b0) < 1e-9
        # just outside the opening: push the line away from the lane's centre
        off = (np.sign(b0 - cy) if along_x else np.sign(a0 - cx)) * 0.5 * POST
        n = max(1, int(np.ceil((abs(a1 - a0) if along_x else abs(b1 - b0)) / 0.9)))
        for k in range(n + 1):
            if along_x:
                px, py = a0 + (a1 - a0) * k / n, b0 + off
            else:
                px, py = a0 + off, b0 + (b1 - b0) * k / n
            parts.append((box((px - 0.5 * POST, py - 0.5 * POST, z1), (px + 0.5 * POST, py + 0.5 * POST, z1 + RAIL_H)),
                          rgb, "wood"))
        if along_x:
            lo, hi = (min(a0, a1) - 0.5 * POST, b0 + off - 0.5 * POST), (max(a0, a1) + 0.5 * POST, b0 + off + 0.5 * POST)
        else:
            lo, hi = (a0 + off - 0.5 * POST, min(b0, b1) - 0.5 * POST), (a0 + off + 0.5 * POST, max(b0, b1) + 0.5 * POST)
        parts.append((box((lo[0], lo[1], z1 + RAIL_H - POST), (hi[0], hi[1], z1 + RAIL_H + 0.01)), rgb, "wood"))
    return Piece("stairs", f.arrives, f.floor + 1, "furniture", tuple(parts))


def keep_clear(f: Flight, room: int, wall_h: float) -> list[np.ndarray]:
    """Return the boxes (x0, y0, x1, y1, z0, z1; storey-relative) the flight takes in a room: its lane, full height,
    on both the storey it starts from and the one it arrives on (the opening and its railing)."""
    if room not in (f.room, f.arrives):
        return []
    x0, y0, x1, y1 = f.lane
    pad = POST + 0.01 if room == f.arrives else 0.0
    return [np.array([x0 - pad, y0 - pad, x1 + pad, y1 + pad, 0.0, wall_h])]
