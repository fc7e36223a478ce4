"""The data model of a generated home: storeys, rooms, doors, labelled instances, support surfaces, one mesh.

Every preset of the default world (``world/presets.py``) yields an :class:`Apartment` (the name predates the
presets: a house is one too). Coordinates are metres, **Z up**; room polygons run counter-clockwise on the wall
centre lines. The writers (``world/writers/``) and the scan maker read only these records.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .files import num, poly_json

if TYPE_CHECKING:
    import trimesh

MATERIALS: tuple[str, ...] = (
    "plain", "wood", "fabric", "metal", "ceramic", "floor_wood", "floor_tile", "wall", "ceiling", "glass",
)
STRUCTURE_LABELS: tuple[str, ...] = ("floor", "wall", "ceiling", "door frame", "window")


@dataclass(frozen=True)
class ArticulatedInstance:
    """An articulated piece placed in an apartment: instance id, builder kind and seed, world pose, room, storey."""

    id: int
    kind: str
    seed: int
    position: tuple[float, float, float]  # world position of the URDF root frame, m (Z up)
    yaw: int  # degrees about +Z (0, 90, 180, 270)
    room: int
    floor: int


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
    preset: str = "apartment"  # the world preset that drew it (world/presets.py)

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
            "floors": [{"index": f.index, "height": num(f.height)} for f in self.floors],
            "rooms": [{"id": r.id, "type": r.type, "floor": r.floor, "polygon": poly_json(r.polygon)} for r in self.rooms],
            "instances": [
                {
                    "id": i.id, "label": i.label, "room": i.room, "floor": i.floor, "kind": i.kind,
                    "support_surfaces": [{"height": num(s.height), "polygon": poly_json(s.polygon)} for s in i.support_surfaces],
                }
                for i in self.instances
            ],
        }
