"""The embedded default world: seeded procedural apartments and household objects (no downloads).

>>> from sdovon_mj.world import generate_apartment, write_apartment
>>> apt = generate_apartment(0)                      # Z-up metres, labelled instances, support surfaces
>>> write_apartment(apt, "out", mode="clean")        # out/apartment_0000.glb (+Y up) + .semantics.json
>>> write_apartment(apt, "out", mode="scan")         # out/apartment_0000_vh_clean.ply (+Z up) + ScanNet labels
>>> write_object_library(0, "objects", variants=3)   # objects/<category>/<category>_<k>/model.obj + .mtl + meta.json
"""

from .home import generate_apartment, generate_home, generate_house
from .furniture import FURNITURE_LABELS, RECEPTACLE_LABELS
from .io import default_apartment_path, default_name, write_apartment
from .layout import ROOM_TYPES
from .model import MATERIALS, STRUCTURE_LABELS, Apartment, Door, InstanceSpec, RoomSpec, Storey, SurfaceSpec, WorldMesh
from .objects import OBJECT_CATEGORIES, HouseholdObject, ObjectCategory, generate_object, write_object_library

__all__ = [
    "MATERIALS", "STRUCTURE_LABELS", "FURNITURE_LABELS", "RECEPTACLE_LABELS", "ROOM_TYPES",
    "Apartment", "Door", "InstanceSpec", "RoomSpec", "Storey", "SurfaceSpec", "WorldMesh",
    "generate_apartment", "generate_home", "generate_house", "write_apartment", "default_apartment_path", "default_name",
    "OBJECT_CATEGORIES", "HouseholdObject", "ObjectCategory", "generate_object", "write_object_library",
]
