"""Seeded procedural apartments: rooms, walls with doorways, furniture with true support surfaces.

``generate_apartment(seed)`` returns an :class:`Apartment`: storeys, rooms (CCW footprints on the
wall centre lines), labelled instances (structure, receptacles, furniture), ground-truth support
surfaces of every receptacle and one triangle mesh (metres, **Z up**) whose faces carry an instance
id, an RGBA colour and a material tag. Everything derives from ``numpy.random.default_rng`` seeded
with the apartment seed: the same seed gives the same apartment bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np
from scipy import ndimage

from ..config import AgentConfig
from . import furniture as FU
from . import layout as LA
from . import shapes as S
from .artplace import ArticulatedInstance, is_proxy, proxy
from .furniture import Model, u

if TYPE_CHECKING:
    import trimesh

MATERIALS: tuple[str, ...] = (
    "plain", "wood", "fabric", "metal", "ceramic", "floor_wood", "floor_tile", "wall", "ceiling", "glass",
)
STRUCTURE_LABELS: tuple[str, ...] = ("floor", "wall", "ceiling", "door frame", "window")
SKIRTING = (0.012, 0.08)  # skirting board depth and height
WALL_T = 0.1  # wall thickness (two 5 cm room-side slabs back to back)
STOREY_HEIGHT = 3.0  # floor-to-floor height of a two-storey apartment
AGENT_RADIUS = AgentConfig().radius  # apartments leave passages for the default agent (config.AgentConfig)
NAV_IGNORE_ABOVE = 0.9  # furniture whose bottom is higher than this does not block walking
FLAT = 0.02  # furniture lower than this (rugs) does not block walking
OBJECT_CLEARANCE = 0.3  # free height kept above receptacle tops when placing furniture
DOOR_KEEPOUT = 0.85  # depth kept free in front of a doorway


@dataclass(frozen=True)
class Storey:
    """A storey: index and floor height (world Z of the walkable surface); exported as a records.Floor."""

    index: int
    height: float


@dataclass(frozen=True)
class RoomSpec:
    """A room: id, type, storey and CCW footprint polygon (world XY, wall centre lines); exported as a records.Room."""

    id: int
    type: str
    floor: int
    polygon: np.ndarray


@dataclass(frozen=True)
class SurfaceSpec:
    """A horizontal support face of a receptacle: world Z height and CCW world XY polygon (records.SupportSurface)."""

    height: float
    polygon: np.ndarray


@dataclass(frozen=True)
class InstanceSpec:
    """A labelled instance: structure (floor, wall, ...), receptacle or plain furniture (records.SemanticInstance)."""

    id: int
    label: str
    room: int
    floor: int
    kind: str  # "structure" | "receptacle" | "furniture"
    support_surfaces: tuple[SurfaceSpec, ...] = ()


@dataclass(frozen=True)
class Door:
    """A doorway between two rooms: opening centre (world XYZ floor level), clear width and height."""

    floor: int
    rooms: tuple[int, int]
    centre: np.ndarray
    normal: np.ndarray  # unit XY vector across the wall
    width: float = 0.9
    height: float = 2.0


@dataclass
class WorldMesh:
    """One triangle mesh: vertices (N, 3) float64 metres Z up; faces (M, 3); per-face attributes."""

    vertices: np.ndarray
    faces: np.ndarray
    face_instance: np.ndarray  # (M,) int32
    face_color: np.ndarray  # (M, 4) uint8 RGBA
    face_material: np.ndarray  # (M,) uint8 index into MATERIALS

    def to_trimesh(self) -> "trimesh.Trimesh":
        """Return a trimesh.Trimesh (unprocessed, face colours attached)."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, face_colors=self.face_color, process=False)


@dataclass
class Apartment:
    """A generated apartment (see the module docstring)."""

    seed: int
    floors: tuple[Storey, ...]
    wall_height: float
    rooms: tuple[RoomSpec, ...]
    instances: tuple[InstanceSpec, ...]
    doors: tuple[Door, ...]
    mesh: WorldMesh
    ceilings: bool = True
    notes: tuple[str, ...] = ()
    articulated: tuple[ArticulatedInstance, ...] = ()  # world.articulated: pieces written as URDF (world/artplace.py)

    def instance(self, instance_id: int) -> InstanceSpec:
        """Return the instance with this id."""
        return self.instances[instance_id]

    def room(self, room_id: int) -> RoomSpec:
        """Return the room with this id."""
        return self.rooms[room_id]

    @property
    def receptacles(self) -> list[InstanceSpec]:
        """Return the receptacle instances."""
        return [i for i in self.instances if i.kind == "receptacle"]

    def semantics(self, name: str, mode: str, mesh_file: str, up: str) -> dict:
        """Return the sidecar dictionary (format sdovon-world/1; world Z-up coordinates)."""
        return {
            "format": "sdovon-world/1",
            "name": name,
            "seed": int(self.seed),
            "mode": mode,
            "units": "m",
            "up": up,
            "mesh": mesh_file,
            "floors": [{"index": f.index, "height": _num(f.height)} for f in self.floors],
            "rooms": [{"id": r.id, "type": r.type, "floor": r.floor, "polygon": _poly(r.polygon)} for r in self.rooms],
            "instances": [
                {
                    "id": i.id, "label": i.label, "room": i.room, "floor": i.floor, "kind": i.kind,
                    "support_surfaces": [{"height": _num(s.height), "polygon": _poly(s.polygon)} for s in i.support_surfaces],
                }
                for i in self.instances
            ],
        }


def _num(x: float) -> float:
    """Round a coordinate for JSON (6 decimals, no negative zero)."""
    return float(round(float(x), 6)) + 0.0


def _poly(p: np.ndarray) -> list[list[float]]:
    """Return a polygon as a JSON list of [x, y]."""
    return [[_num(a), _num(b)] for a, b in np.asarray(p)]


# ------------------------------------------------------------------------------------------------
# furniture groups and placement

_COS = {0: 1, 90: 0, 180: -1, 270: 0}
_SIN = {0: 0, 90: 1, 180: 0, 270: -1}


def _rot(yaw: int) -> np.ndarray:
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
        r = _rot(yaw)
        out = []
        for m, dx, dy, iy in self.items:
            p = r @ np.array([dx, dy])
            out.append((m, float(ox + p[0]), float(oy + p[1]), (yaw + iy) % 360))
        return out

    def footprint(self) -> np.ndarray:
        """Return (x0, y0, x1, y1) of all items in the group frame."""
        boxes = np.array([_item_box(m, dx, dy, iy) for m, dx, dy, iy in self.items])
        return np.array([boxes[:, 0].min(), boxes[:, 1].min(), boxes[:, 2].max(), boxes[:, 3].max()])


def _item_box(m: Model, ox: float, oy: float, yaw: int) -> np.ndarray:
    """Return (x0, y0, x1, y1, z0, z1) of a model placed at (ox, oy) with yaw (z1 = real top)."""
    b = _model_bounds(m)
    corners = np.array([[b[0], b[1]], [b[3], b[1]], [b[3], b[4]], [b[0], b[4]]]) @ _rot(yaw).T
    return np.array([corners[:, 0].min() + ox, corners[:, 1].min() + oy, corners[:, 0].max() + ox,
                     corners[:, 1].max() + oy, b[2], b[5]])


def _overlap2(a: np.ndarray, b: np.ndarray, margin: float = 0.0) -> bool:
    """Whether two (x0, y0, x1, y1, ...) rectangles overlap (closer than `margin` counts)."""
    return bool(a[0] < b[2] + margin and b[0] < a[2] + margin and a[1] < b[3] + margin and b[1] < a[3] + margin)


@dataclass
class _RoomState:
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
            b = _item_box(m, ox, oy, yaw)
            if b[0] < ix[0] - 1e-6 or b[1] < ix[1] - 1e-6 or b[2] > ix[2] + 1e-6 or b[3] > ix[3] + 1e-6:
                return False
            for wz in self.windows if m.label not in ("sink", "bed", "sofa") else ():  # may stand below a window
                if _overlap2(b, wz) and b[4] < wz[5] and wz[4] < b[5]:
                    return False
            if m.kind == "receptacle":
                b[5] += OBJECT_CLEARANCE
            for k in self.keepouts:
                if _overlap2(b, k):
                    return False
            for o in self.bodies:
                if _overlap2(b, o, 0.02) and b[4] < o[5] and o[4] < b[5]:
                    return False
            if b[4] < NAV_IGNORE_ABOVE and b[5] > FLAT:
                for c in self.clear:
                    if _overlap2(b, c):
                        return False
            new.append(b)
        if clear is not None:
            if clear[0] < ix[0] - 1e-6 or clear[1] < ix[1] - 1e-6 or clear[2] > ix[2] + 1e-6 or clear[3] > ix[3] + 1e-6:
                return False
            for o in self.bodies:
                if o[4] < NAV_IGNORE_ABOVE and o[5] > FLAT and _overlap2(clear, o):
                    return False
        return True

    def commit(self, items: list[tuple[Model, float, float, int]], clear: np.ndarray | None) -> None:
        """Record placed items."""
        for m, ox, oy, yaw in items:
            b = _item_box(m, ox, oy, yaw)
            if m.kind == "receptacle":
                b[5] += OBJECT_CLEARANCE
            self.bodies.append(b)
            self.placed.append((m, ox, oy, yaw))
        if clear is not None:
            self.clear.append(clear)


_SIDES = (("S", 0), ("E", 90), ("N", 180), ("W", 270))


def _place_wall(state: _RoomState, g: Group, rng: np.random.Generator, corner: bool) -> bool:
    """Place a group with its back against one of the room's walls."""
    fp = g.footprint()
    ix = state.interior
    cands = []
    for side, yaw in _SIDES:
        r = _rot(yaw)
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
            r = _rot(yaw)
            c = np.array([[fp[0], fp[3]], [fp[2], fp[3]], [fp[2], fp[3] + g.front_clear], [fp[0], fp[3] + g.front_clear]]) @ r.T
            clear = np.array([c[:, 0].min() + ox, c[:, 1].min() + oy, c[:, 0].max() + ox, c[:, 1].max() + oy])
        if state.fits(items, clear):
            state.commit(items, clear)
            return True
    return False


def _place_centre(state: _RoomState, g: Group, rng: np.random.Generator, margin: float = 0.5) -> bool:
    """Place a free-standing group (a dining table with chairs) away from the walls."""
    fp = g.footprint()
    ix = state.interior
    long_x = (ix[2] - ix[0]) >= (ix[3] - ix[1])
    for k in range(16):
        yaw = 0 if (long_x == (k % 4 != 3)) else 90
        r = _rot(yaw)
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
        boxes = [_item_box(*it) for it in items]
        zone = np.array([min(b[0] for b in boxes) - margin, min(b[1] for b in boxes) - margin,
                         max(b[2] for b in boxes) + margin, max(b[3] for b in boxes) + margin])
        if any(o[4] < NAV_IGNORE_ABOVE and o[5] > FLAT and _overlap2(zone, o) for o in state.bodies):
            continue
        if state.fits(items, None):
            state.commit(items, zone)
            return True
    return False


def _nav_ok(state: _RoomState, anchors: list[np.ndarray], openings: list[np.ndarray], res: float = 0.05) -> bool:
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
            b = _item_box(m, ox, oy, yaw)
            if not np.any(main & inside(b, AGENT_RADIUS + 0.27)):
                return False
    return True


# ------------------------------------------------------------------------------------------------
# room programs


Factory = Callable[[np.random.Generator, int], Group]


def _single(make: Callable[[np.random.Generator], Model], clear: float = 0.0) -> Factory:
    """Return a factory for a single-piece group."""
    return lambda rng, level: Group([(make(rng), 0.0, 0.0, 0)], clear)


def _bed_group(rng: np.random.Generator, level: int, min_dim: float) -> Group:
    """A bed with one or two nightstands beside it."""
    double = level == 0 and min_dim >= 3.0 and rng.random() < 0.8
    b = FU.bed(rng, double)
    wood = FU.pick(rng, FU.WOODS)
    n = 2 if (double and level == 0 and rng.random() < 0.8) else 1
    items = [(b, 0.0, 0.0, 0)]
    side = 1.0 if rng.random() < 0.5 else -1.0
    for k in range(n):
        ns = FU.nightstand(rng, wood)
        s = side if k == 0 else -side
        items.append((ns, s * (0.5 * b.width + 0.04 + 0.5 * ns.width), 0.0, 0))
    if rng.random() < 0.4 and level == 0:
        items.append((FU.rug(rng, b.width + 0.4, 0.7), 0.0, b.depth + 0.03, 0))
    return Group(items, 0.5)


def _sofa_group(rng: np.random.Generator, level: int) -> Group:
    """A sofa facing a coffee table."""
    sf = FU.sofa(rng, None if level == 0 else u(rng, 1.6, 1.8))
    ct = FU.coffee_table(rng)
    gap = u(rng, 0.38, 0.45)
    items = [(sf, 0.0, 0.0, 0), (ct, 0.0, sf.depth + gap, 0)]
    if rng.random() < 0.6 and level == 0:
        rw = min(sf.width - 0.1, ct.width + u(rng, 0.4, 0.8))
        items.append((FU.rug(rng, rw, gap + ct.depth + 0.25), 0.0, sf.depth + 0.05, 0))
    return Group(items, 0.3)


def _desk_group(rng: np.random.Generator, level: int) -> Group:
    """A desk with its chair pushed into the knee space."""
    d, knee = FU.desk(rng, None if level == 0 else 1.0)
    c = FU.chair(rng)
    return Group([(d, 0.0, 0.0, 0), (c, knee, d.depth - 0.12 + c.depth, 180)], 0.3)


def _kitchen_run(rng: np.random.Generator, level: int, wall: float, art: bool = False) -> Group:
    """A counter run with a recessed sink and the fridge at one end (`art`: an articulated fridge)."""
    f = proxy("fridge", rng) if art else FU.fridge(rng)
    maxlen = wall - f.width - 0.1
    if level > 0:
        maxlen = min(maxlen, 1.6)
    cw = u(rng, 1.4, max(1.4, min(2.8, maxlen))) if maxlen >= 1.4 else max(0.8, maxlen)
    side = 1 if rng.random() < 0.5 else -1
    c, extras = FU.counter(rng, cw, u(rng, 0.88, 0.92), 0.6, "recessed" if cw >= 1.35 else "none", sink_side=-side,
                           hob=cw >= 2.0)
    items = [(c, 0.0, 0.0, 0)] + [(e, 0.0, 0.0, 0) for e in extras]
    items.append((f, side * (0.5 * cw + 0.02 + 0.5 * f.width), 0.0, 0))
    return Group(items, 0.9)


def _vanity(rng: np.random.Generator, level: int) -> Group:
    """A bathroom vanity (counter) with a vessel sink at one end."""
    w = u(rng, 0.8, 1.2) if level == 0 else 0.8
    c, extras = FU.counter(rng, w, u(rng, 0.82, 0.86), u(rng, 0.46, 0.52), "vessel", sink_side=1 if rng.random() < 0.5 else -1)
    return Group([(c, 0.0, 0.0, 0)] + [(e, 0.0, 0.0, 0) for e in extras], 0.6)


def _tv_group(rng: np.random.Generator, level: int) -> Group:
    """A TV stand with a TV on it."""
    st, tv = FU.tv_stand(rng)
    return Group([(st, 0.0, 0.0, 0), (tv, 0.0, 0.0, 0)], 0.6)


def _dining_group(rng: np.random.Generator, level: int, big: bool, iw: float, idp: float, against_wall: bool = False) -> Group:
    """A table with chairs around it (centred at the group origin), sized to fit the room."""
    wood = FU.pick(rng, FU.WOODS)
    c0 = FU.chair(rng, wood)
    cw, cd = c0.width, c0.depth
    reach = cd - 0.1  # how far a pushed-in chair sticks out from the table edge
    margin = 0.5
    long_, short = max(iw, idp), min(iw, idp)
    if not big and not against_wall and rng.random() < 0.35:
        t = FU.table(rng, u(rng, 0.85, 1.0), round_top=True)
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
    t = FU.table(rng, tw, td)
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


def _program(rtype: str, iw: float, idp: float, rng: np.random.Generator, height_max: float,
             art: bool = False) -> list[tuple[Factory, str, bool, float]]:
    """Return the room's furniture groups: (factory, mode, required, probability if optional).

    `art` (``world.articulated``): dressers, wardrobes and fridges are articulated pieces, kitchens get an
    articulated base cabinet with a microwave and bathrooms often a base cabinet (`artplace.proxy`), and living
    rooms and offices get a dresser more often (homes keep small things in closed storage in every room).
    """
    longest = max(iw, idp)
    shortest = min(iw, idp)
    bs = lambda r: FU.bookshelf(r, height_max)  # noqa: E731
    if art:
        dresser = lambda r, w=None: proxy("dresser", r)  # noqa: E731
    else:
        dresser = FU.dresser
    if rtype == "bedroom":
        return [
            (lambda r, lv: _bed_group(r, lv, shortest), "wall", True, 1.0),
            (lambda r, lv: Group([(dresser(r, None if lv == 0 else 0.8), 0.0, 0.0, 0)], 0.6), "wall", True, 1.0),
            (lambda r, lv: Group([(proxy("wardrobe", r) if art else FU.wardrobe(r, height_max, lv > 0), 0.0, 0.0, 0)],
                                 0.7), "corner", True, 1.0),
            (_single(FU.wall_shelf), "high", False, 0.5),
            (_desk_group, "wall", False, 0.3),
            (_single(FU.floor_lamp), "corner", False, 0.3),
            (_single(bs, 0.5), "corner", False, 0.2),
            (_single(FU.picture), "high", False, 0.6),
        ]
    if rtype == "kitchen":
        return [
            (lambda r, lv: _kitchen_run(r, lv, longest, art), "corner", True, 1.0),
            (lambda r, lv: _dining_group(r, lv, False, iw, idp), "centre", True, 1.0),
            (lambda r, lv: _dining_group(r, lv, False, iw, idp, against_wall=True), "fallback", False, 1.0),
            *([(_cabinet_group, "wall", False, 0.9)] if art else []),
            (_single(lambda r: FU.counter(r, u(r, 0.8, 1.4), u(r, 0.88, 0.92))[0], 0.8), "corner", False, 0.5),
            (_single(FU.wall_shelf), "high", False, 0.5),
        ]
    if rtype == "living room":
        return [
            (_sofa_group, "wall", True, 1.0),
            (_single(bs, 0.5), "corner", True, 1.0),
            (_single(FU.wall_shelf), "high", True, 1.0),
            (_tv_group, "wall", False, 0.7),
            (_single(FU.chair, 0.3), "wall", False, 0.3),
            (_single(dresser, 0.6), "wall", False, 0.5 if art else 0.25),
            (_single(FU.wall_shelf), "high", False, 0.25),
            (_single(FU.floor_lamp), "corner", False, 0.5),
            (_single(FU.picture), "high", False, 0.7),
            (_single(FU.picture), "high", False, 0.4),
        ]
    if rtype == "bathroom":
        return [
            (_single(FU.toilet, 0.5), "wall", True, 1.0),
            (_vanity, "wall", True, 1.0),
            (_single(FU.wall_shelf), "high", True, 1.0),
            (_single(FU.bathtub, 0.5), "corner", False, 0.6),
            *([(_single(lambda r: proxy("cabinet", r), 0.6), "wall", False, 0.6)] if art else []),
        ]
    if rtype == "office":
        return [
            (_desk_group, "wall", True, 1.0),
            (_single(bs, 0.5), "corner", True, 1.0),
            (_single(FU.wall_shelf), "high", False, 0.6),
            (_single(dresser, 0.6), "wall", False, 0.5 if art else 0.3),
            (_single(bs, 0.5), "wall", False, 0.3),
            (_single(FU.floor_lamp), "corner", False, 0.3),
            (_single(FU.picture), "high", False, 0.4),
        ]
    if rtype == "dining room":
        return [
            (lambda r, lv: _dining_group(r, lv, True, iw, idp), "centre", True, 1.0),
            (lambda r, lv: _dining_group(r, lv, True, iw, idp, against_wall=True), "fallback", False, 1.0),
            (_single(dresser, 0.5), "wall", True, 1.0),
            (_single(FU.wall_shelf), "high", False, 0.6),
            (_single(bs, 0.5), "corner", False, 0.3),
            (_single(FU.picture), "high", False, 0.7),
        ]
    raise ValueError(f"unknown room type {rtype!r}")


def _room_doors(room: LA.PlanRoom, doors: list[LA.PlanDoor]) -> list[tuple[LA.PlanDoor, str]]:
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


def _door_zones(room: LA.PlanRoom, doors: list[LA.PlanDoor]) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """Return (keep-out rectangles, walking anchors, opening rectangles) of a room's doors."""
    t = 0.5 * WALL_T
    keep, anchors, openings = [], [], []
    for d, side in _room_doors(room, doors):
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


def _furnish(room: LA.PlanRoom, doors: list[LA.PlanDoor], rng: np.random.Generator, wall_h: float,
             windows: dict[str, list[tuple]], art: bool = False) -> tuple[list[tuple[Model, float, float, int]], list[str]]:
    """Place the room's furniture (`art`: with articulated pieces); retries with fewer optional pieces and smaller sizes.

    Returns the placed items (model, x, y, yaw in degrees; storey-relative metres) and the notes on what
    could not be placed.
    """
    t = 0.5 * WALL_T + SKIRTING[0] + 0.003
    interior = np.array([room.x0 + t, room.y0 + t, room.x1 - t, room.y1 - t])
    wzones = _window_zones(interior, windows)
    keep, anchors, openings = _door_zones(room, doors)
    iw, idp = interior[2] - interior[0], interior[3] - interior[1]
    height_max = wall_h - 0.15
    best: list[tuple[Model, float, float, int]] | None = None
    attempts = 36
    for attempt in range(attempts):
        level = 0 if attempt < 10 else 1
        keep_opt = 1.0 if attempt < 20 else 0.0
        tolerate = attempt >= 28  # late attempts may skip a required piece that does not fit
        prog = _program(room.type, iw, idp, rng, height_max, art)
        state = _RoomState(interior, keep, windows=list(wzones))
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
                placed = _place_centre(state, g, rng)
                if not placed:
                    last_failed = True
                    continue
            else:
                placed = _place_wall(state, g, rng, corner=(mode == "corner" and rng.random() < 0.7))
            last_failed = False
            if not placed and required:
                if not tolerate:
                    ok = False
                    break
                skipped.append(g.items[0][0].label)
        if ok and _nav_ok(state, anchors, openings):
            notes = [f"room {room.id} ({room.type}): no room for {', '.join(skipped)}"] if skipped else []
            return state.placed, notes
        if ok and best is None:
            best = state.placed
    return best or [], [f"room {room.id} ({room.type}): furniture placed without the navigation guarantee"]


# ------------------------------------------------------------------------------------------------
# mesh assembly

_MeshPart = tuple[S.Mesh, tuple[int, ...], str]  # a mesh (world metres, Z up), its RGB(A) colour and material


@dataclass(frozen=True)
class _Piece:
    """An instance before numbering: its labels and coloured mesh parts (ids are given at assembly)."""

    label: str
    room: int
    floor: int
    kind: str
    parts: tuple[_MeshPart, ...]
    supports: tuple[SurfaceSpec, ...] = ()
    art: tuple | None = None  # an articulated piece: (kind, seed, (x, y, z), yaw); no mesh parts


class _MeshBuilder:
    """Accumulates coloured, labelled parts into one mesh."""

    def __init__(self) -> None:
        self.v: list[np.ndarray] = []
        self.f: list[np.ndarray] = []
        self.inst: list[np.ndarray] = []
        self.col: list[np.ndarray] = []
        self.mat: list[np.ndarray] = []
        self.n = 0

    def add(self, mesh: S.Mesh, instance: int, rgba: tuple[int, ...], material: str) -> None:
        """Append a part."""
        v, f = mesh
        m = len(f)
        self.v.append(np.asarray(v, dtype=np.float64))
        self.f.append(np.asarray(f, dtype=np.int64) + self.n)
        self.n += len(v)
        self.inst.append(np.full(m, instance, dtype=np.int32))
        c = tuple(rgba) + ((255,) if len(rgba) == 3 else ())
        self.col.append(np.tile(np.array(c, dtype=np.uint8), (m, 1)))
        self.mat.append(np.full(m, MATERIALS.index(material), dtype=np.uint8))

    def build(self) -> WorldMesh:
        """Return the accumulated mesh."""
        return WorldMesh(np.concatenate(self.v), np.concatenate(self.f), np.concatenate(self.inst),
                         np.concatenate(self.col), np.concatenate(self.mat))


def _assemble(pieces: list[_Piece]) -> tuple[tuple[InstanceSpec, ...], WorldMesh]:
    """Number the pieces in order (instance id = position) and join their parts into one mesh."""
    mb = _MeshBuilder()
    instances = []
    for k, p in enumerate(pieces):
        instances.append(InstanceSpec(k, p.label, p.room, p.floor, p.kind, p.supports))
        for mesh, rgba, material in p.parts:
            mb.add(mesh, k, rgba, material)
    return tuple(instances), mb.build()


WALL_COLOURS = ((236, 233, 226), (222, 226, 230), (232, 222, 206), (214, 222, 212), (242, 242, 240), (226, 214, 214))
FLOOR_WOOD = ((168, 124, 86), (196, 156, 112), (132, 96, 66), (210, 190, 160))
FLOOR_TILE = ((204, 204, 198), (176, 178, 182), (226, 222, 214), (150, 140, 130))
_WALL_SIDES = ("S", "E", "N", "W")  # wall sides of a room: south (y0), east (x1), north (y1), west (x0)


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


def _windows(r: LA.PlanRoom, ext: dict[str, bool], wall_h: float, rng: np.random.Generator) -> dict[str, list[tuple]]:
    """Choose windows on a room's exterior walls: side -> [(centre, half width, sill, top)] (storey-relative)."""
    out: dict[str, list[tuple]] = {}
    t = 0.5 * WALL_T
    for side in _WALL_SIDES:
        if not ext[side]:
            continue
        lo, hi = (r.x0 + t, r.x1 - t) if side in ("S", "N") else (r.y0 + t, r.y1 - t)
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
            c = LA.snap(lo + length * (k + 0.5) / n + rng.uniform(-0.1, 0.1) * length / n)
            c = float(np.clip(c, lo + 0.3 + 0.5 * ww, hi - 0.3 - 0.5 * ww))
            wins.append((c, 0.5 * ww, sill, top))
        out[side] = wins
    return out


# ------------------------------------------------------------------------------------------------
# the apartment, step by step


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


@dataclass(frozen=True)
class _Finish:
    """A room's seeded finish: colours (RGB) of floor, walls, skirting and window frames, and its windows."""

    floor_rgb: tuple[int, ...]
    tiled: bool
    wall_rgb: tuple[int, ...]
    skirting_rgb: tuple[int, ...]
    windows: dict[str, list[tuple]]  # side -> [(centre, half width, sill, top)], storey-relative metres
    frame_rgb: tuple[int, ...]


def _plan_apartment(seed: int, floors: int | None) -> _Plan:
    """Draw the storey count, wall height, room types and floor plan of the apartment `seed`."""
    rng = np.random.default_rng([int(seed), 0])
    two = rng.random() < 0.3
    nfl = int(floors) if floors else (2 if two else 1)
    wall_h = LA.snap(rng.uniform(2.5, 2.8))
    types = LA.choose_room_types(rng, int(seed), nfl)
    width, depth, prooms, pdoors = LA.plan(rng, types)
    return _Plan(nfl, wall_h, width, depth, prooms, pdoors, [0.0, STOREY_HEIGHT][:nfl])


def _exterior(r: LA.PlanRoom, width: float, depth: float) -> dict[str, bool]:
    """Return side -> whether that wall of the room is an outer wall of the apartment."""
    return {"W": r.x0 <= 1e-6, "E": r.x1 >= width - 1e-6, "S": r.y0 <= 1e-6, "N": r.y1 >= depth - 1e-6}


def _room_finish(r: LA.PlanRoom, ext: dict[str, bool], wall_h: float, rng: np.random.Generator) -> _Finish:
    """Draw a room's floor, wall, skirting and window-frame colours and its windows (in this order)."""
    tiled = r.type in ("kitchen", "bathroom")
    fcol = FU.jitter((FLOOR_TILE if tiled else FLOOR_WOOD)[int(rng.integers(4))], rng, 5)
    wcol = FU.jitter(WALL_COLOURS[int(rng.integers(len(WALL_COLOURS)))], rng, 3)
    if r.type == "bathroom":
        wcol = FU.jitter((214, 226, 232), rng, 4)
    skc = (246, 246, 244) if rng.random() < 0.6 else FU.jitter(fcol, rng, 8)
    wins = _windows(r, ext, wall_h, rng)
    frame_c = (244, 244, 242) if rng.random() < 0.7 else FU.pick(rng, FU.WOODS[:4])
    return _Finish(fcol, tiled, wcol, skc, wins, frame_c)


def _floor_slab(r: LA.PlanRoom, ext: dict[str, bool], fl: int, z0: float, wall_h: float, finish: _Finish) -> _Piece:
    """Return the room's floor slab (reaching under the outer walls; upper storeys fill up to the storey below)."""
    t = 0.5 * WALL_T
    fx0, fy0 = r.x0 - (t if ext["W"] else 0.0), r.y0 - (t if ext["S"] else 0.0)
    fx1, fy1 = r.x1 + (t if ext["E"] else 0.0), r.y1 + (t if ext["N"] else 0.0)
    slab = 0.1 if fl == 0 else STOREY_HEIGHT - wall_h - 0.05
    material = "floor_tile" if finish.tiled else "floor_wood"
    return _Piece("floor", r.id, fl, "structure", ((S.box((fx0, fy0, z0 - slab), (fx1, fy1, z0)), finish.floor_rgb, material),))


def _ceiling(r: LA.PlanRoom, fl: int, z0: float, wall_h: float) -> _Piece:
    """Return the room's ceiling slab (2 cm thick, between the walls)."""
    t = 0.5 * WALL_T
    box = S.box((r.x0 + t, r.y0 + t, z0 + wall_h), (r.x1 - t, r.y1 - t, z0 + wall_h + 0.02))
    return _Piece("ceiling", r.id, fl, "structure", ((box, (248, 248, 246), "ceiling"),))


def _wall_openings(side: str, doors: list[tuple[LA.PlanDoor, str]], windows: dict[str, list[tuple]],
                   z0: float) -> list[tuple[float, float, float, float]]:
    """Return the openings of one wall: (centre, half width, bottom Z, top Z) of its doors, then its windows."""
    opens = [(d.centre, 0.5 * d.width, z0, z0 + d.height) for d, s_ in doors if s_ == side]
    opens += [(c, hw, z0 + sill, z0 + top) for c, hw, sill, top in windows.get(side, [])]
    return opens


def _wall(r: LA.PlanRoom, side: str, ext: dict[str, bool], opens: list[tuple[float, float, float, float]],
          fl: int, z0: float, wall_h: float, finish: _Finish) -> _Piece:
    """Return one wall of a room: the room-side slab around its openings, outer walls full thickness, skirting."""
    t = 0.5 * WALL_T
    sd, sh = SKIRTING
    along_x = side in ("S", "N")  # S and N walls run along X, W and E walls along Y
    if along_x:
        lo, hi = r.x0 - (t if ext["W"] else 0.0), r.x1 + (t if ext["E"] else 0.0)
        clip_lo, clip_hi = r.x0 + t, r.x1 - t
        c0, c1 = r.y0, r.y1
    else:
        lo, hi = r.y0 + t, r.y1 - t
        clip_lo, clip_hi = lo + sd, hi - sd
        c0, c1 = r.x0, r.x1
    if side in ("S", "W"):  # across the wall: slab [a0, a1], skirting [k0, k1] on the room side
        a0, a1 = c0 - (t if ext[side] else 0.0), c0 + t
        k0, k1 = a1, a1 + sd
    else:
        a0, a1 = c1 - t, c1 + (t if ext[side] else 0.0)
        k0, k1 = a0 - sd, a0

    def box(u0: float, u1: float, v0: float, v1: float, za: float, zb: float) -> S.Mesh:
        """Return the box spanning [u0, u1] along the wall, [v0, v1] across it and [za, zb] in Z."""
        return S.box((u0, v0, za), (u1, v1, zb)) if along_x else S.box((v0, u0, za), (v1, u1, zb))

    parts: list[_MeshPart] = []
    for a, b, za, zb in _wall_pieces(lo, hi, opens, z0, z0 + wall_h):
        parts.append((box(a, b, a0, a1, za, zb), finish.wall_rgb, "wall"))
        a2, b2 = max(a, clip_lo), min(b, clip_hi)
        if za <= z0 + 1e-9 and b2 - a2 > 1e-6:
            parts.append((box(a2, b2, k0, k1, z0, z0 + sh), finish.skirting_rgb, "wood"))
    return _Piece("wall", r.id, fl, "structure", tuple(parts))


def _window(r: LA.PlanRoom, side: str, window: tuple, fl: int, z0: float, frame_rgb: tuple[int, ...]) -> _Piece:
    """Return one window: frame and sill (in the wall, across its thickness) and the glass pane."""
    c, hw, sill, top = window
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

    def place(lo_: tuple, hi_: tuple) -> S.Mesh:
        """Return a box given as (along the wall, into the room, Z) corners, in world coordinates."""
        (a0, o0, z_0), (a1, o1, z_1) = lo_, hi_
        o0, o1 = sorted((line + inward * o0, line + inward * o1))
        if side in ("S", "N"):
            return S.box((a0, o0, z_0), (a1, o1, z_1))
        return S.box((o0, a0, z_0), (o1, a1, z_1))

    parts: list[_MeshPart] = [(place(lo_, hi_), frame_rgb, "plain") for lo_, hi_ in frame + [sill_box]]
    parts.append((place(*glass), (176, 206, 226, 96), "glass"))
    return _Piece("window", r.id, fl, "structure", tuple(parts))


def _furniture(r: LA.PlanRoom, placed: list[tuple[Model, float, float, int]], fl: int, z0: float) -> list[_Piece]:
    """Return the placed furniture as pieces: parts and support surfaces moved to world coordinates."""
    out = []
    for m, ox, oy, yaw in placed:
        if is_proxy(m):
            kind, seed, lift = m.articulated  # type: ignore[attr-defined]
            out.append(_Piece(m.label, r.id, fl, "receptacle", (), (), (kind, seed, (ox, oy, z0 + lift), yaw)))
            continue
        rot2 = _rot(yaw)
        rot3 = np.eye(3)
        rot3[:2, :2] = rot2
        sup = tuple(
            SurfaceSpec(float(h + z0), np.asarray(poly) @ rot2.T + np.array([ox, oy])) for h, poly in m.supports
        )
        parts = tuple((S.transform((p.vertices, p.faces), rot=rot3, shift=(ox, oy, z0)), p.rgba, p.material) for p in m.parts)
        out.append(_Piece(m.label, r.id, fl, m.kind, parts, sup))
    return out


def _room(seed: int, r: LA.PlanRoom, plan: _Plan, storey_doors: list[LA.PlanDoor],
          ceilings: bool, art: bool = False) -> tuple[list[_Piece], list[str]]:
    """Build one room (its own seeded generator): floor, ceiling, four walls, windows, furniture; and notes."""
    rng = np.random.default_rng([int(seed), 1, r.id])
    fl, z0, wall_h = r.floor, plan.floor_z[r.floor], plan.wall_h
    ext = _exterior(r, plan.width, plan.depth)
    finish = _room_finish(r, ext, wall_h, rng)
    placed, notes = _furnish(r, storey_doors, rng, wall_h, finish.windows, art)
    doors = _room_doors(r, storey_doors)
    pieces = [_floor_slab(r, ext, fl, z0, wall_h, finish)]
    pieces += [_ceiling(r, fl, z0, wall_h)] if ceilings else []
    pieces += [_wall(r, side, ext, _wall_openings(side, doors, finish.windows, z0), fl, z0, wall_h, finish) for side in _WALL_SIDES]
    pieces += [_window(r, side, w, fl, z0, finish.frame_rgb) for side, wl in finish.windows.items() for w in wl]
    pieces += _furniture(r, placed, fl, z0)
    return pieces, notes


def _door_frame_colour(seed: int, fl: int) -> tuple[int, ...]:
    """Draw the door-frame colour of a storey (its own seeded generator)."""
    rng = np.random.default_rng([int(seed), 2, fl])
    return FU.jitter((240, 238, 232), rng, 3) if rng.random() < 0.6 else FU.pick(rng, FU.WOODS[:4])


def _door_frame(d: LA.PlanDoor, z0: float, rgb: tuple[int, ...]) -> _Piece:
    """Return a doorway's frame: two jambs and the head, slightly thicker than the wall."""
    c, half, jt, dt = d.centre, 0.5 * d.width, 0.05, 0.5 * WALL_T + 0.01
    parts: list[_MeshPart] = []
    for a, b, za, zb in ((c - half, c - half + jt, z0, z0 + d.height), (c + half - jt, c + half, z0, z0 + d.height),
                         (c - half, c + half, z0 + d.height - jt, z0 + d.height)):
        if d.vertical:
            parts.append((S.box((d.line - dt, a, za), (d.line + dt, b, zb)), rgb, "wood"))
        else:
            parts.append((S.box((a, d.line - dt, za), (b, d.line + dt, zb)), rgb, "wood"))
    return _Piece("door frame", min(d.room_a, d.room_b), d.floor, "structure", tuple(parts))


def _door(d: LA.PlanDoor, z0: float) -> Door:
    """Return a plan door as a Door record (clear opening inside the frame)."""
    if d.vertical:
        centre, normal = np.array([d.line, d.centre, z0]), np.array([1.0, 0.0])
    else:
        centre, normal = np.array([d.centre, d.line, z0]), np.array([0.0, 1.0])
    return Door(d.floor, (d.room_a, d.room_b), centre, normal, round(d.width - 0.1, 6), round(d.height - 0.05, 6))


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
    pieces: list[_Piece] = []
    notes: list[str] = []
    for fl in range(plan.storeys):
        storey_doors = [d for d in plan.doors if d.floor == fl]
        for r in (r for r in plan.rooms if r.floor == fl):
            room_pieces, room_notes = _room(seed, r, plan, storey_doors, ceilings, articulated)
            pieces += room_pieces
            notes += room_notes
        colour = _door_frame_colour(seed, fl)
        pieces += [_door_frame(d, plan.floor_z[fl], colour) for d in storey_doors]
    instances, mesh = _assemble(pieces)
    return Apartment(
        seed=int(seed),
        floors=tuple(Storey(k, plan.floor_z[k]) for k in range(plan.storeys)),
        wall_height=float(plan.wall_h),
        rooms=tuple(RoomSpec(r.id, r.type, r.floor, FU.rect(r.x0, r.y0, r.x1, r.y1)) for r in plan.rooms),
        instances=instances,
        doors=tuple(_door(d, plan.floor_z[d.floor]) for d in plan.doors),
        mesh=mesh,
        ceilings=ceilings,
        notes=tuple(notes),
        articulated=tuple(ArticulatedInstance(k, p.art[0], p.art[1], tuple(float(c) for c in p.art[2]), int(p.art[3]),
                                              p.room, p.floor) for k, p in enumerate(pieces) if p.art is not None),
    )
