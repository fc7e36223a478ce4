"""A third-party artist's kitchen, written as a Blender glTF export looks (a test fixture, not shipped data).

`write_artist_kitchen` writes one GLB: Y up (glTF), metres, a node tree whose empties carry their own
translation / rotation / scale (a ``Kitchen`` group holding a ``Counter_Run`` group holding the base
cabinets, the worktop, the sink and the oven), node names as an artist leaves them (``Cabinet_Base.001``,
``Countertop_Marble``, ``Fridge_Body``, ``Upper_Cabinet.003``, ``Kitchen_Island``, ``Bar_Stool_01``,
``Shelf_Wall.002``, ``Sink``, ``Oven``, ``Cube.012`` for a wall, ``Plane`` for the floor), PBR materials
(the worktop, the island top and the floor textured) and no semantic sidecar. Every box is a unit cube
scaled by its node, as modelling tools make them. ``floor=False`` leaves the ``Plane`` out (the add_floor path).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import trimesh
    from PIL.Image import Image

__all__ = ["KITCHEN_NODES", "write_artist_kitchen"]

# the node names of the kitchen's pieces (the floor "Plane" only with floor=True)
KITCHEN_NODES = ("Plane", "Cube.012", "Cube.013", "Cabinet_Base.001", "Cabinet_Base.002", "Countertop_Marble", "Sink",
                 "Oven", "Fridge_Body", "Fridge_Door.001", "Upper_Cabinet.003", "Upper_Cabinet.004", "Kitchen_Island",
                 "Island_Top", "Bar_Stool_01", "Bar_Stool_02", "Shelf_Wall.002", "Dining_Table")


def _texture(kind: str, size: int = 64) -> "Image":
    """Return a deterministic texture image: 'marble' (grey veins), 'wood' (stripes) or 'tiles'."""
    from PIL import Image

    y, x = np.mgrid[0:size, 0:size].astype(float) / size
    if kind == "marble":
        v = 0.5 + 0.5 * np.sin(12 * (x + 0.35 * np.sin(5 * y) + 0.2 * y))
        rgb = np.stack([225 - 60 * v, 225 - 60 * v, 230 - 55 * v], axis=-1)
    elif kind == "wood":
        v = 0.5 + 0.5 * np.sin(40 * x + 3 * np.sin(6 * y))
        rgb = np.stack([150 + 40 * v, 95 + 30 * v, 55 + 15 * v], axis=-1)
    else:
        v = ((np.floor(x * 8) + np.floor(y * 8)) % 2)[..., None]
        rgb = np.where(v > 0, [200.0, 196.0, 186.0], [150.0, 146.0, 140.0])
    return Image.fromarray(np.clip(rgb, 0, 255).astype(np.uint8))


def _cube(material: object | None = None, rgba: tuple[int, int, int, int] | None = None) -> "trimesh.Trimesh":
    """Return a unit cube (side 1, centred) with planar UVs and a texture material, or a flat colour."""
    import trimesh

    m = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    if material is not None:
        v = m.vertices
        uv = np.where(np.abs(v[:, 1:2]) > 0.49, v[:, [0, 2]], v[:, [0, 1]]) + 0.5
        m.visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    else:
        m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile(np.asarray(rgba, np.uint8), (len(m.faces), 1)))
    return m


def _cylinder(radius: float, height: float, rgba: tuple[int, int, int, int]) -> "trimesh.Trimesh":
    """Return a Y-axis cylinder (centred) with a flat colour."""
    import trimesh

    m = trimesh.creation.cylinder(radius=radius, height=height, sections=24)
    m.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))  # Z axis -> Y axis
    m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile(np.asarray(rgba, np.uint8), (len(m.faces), 1)))
    return m


def _trs(t: tuple[float, float, float] = (0, 0, 0), yaw_deg: float = 0.0,
         s: tuple[float, float, float] = (1, 1, 1)) -> np.ndarray:
    """Return a 4x4 node matrix: translation, rotation about +Y (glTF up), scale."""
    import trimesh

    T = trimesh.transformations.rotation_matrix(np.radians(yaw_deg), [0, 1, 0])
    T[:3, :3] = T[:3, :3] @ np.diag(s)
    T[:3, 3] = t
    return T


def write_artist_kitchen(path: str | Path, floor: bool = True) -> Path:
    """Write the artist kitchen GLB at `path` (Y up, metres, nested transformed nodes); return the path.

    The room is 6 m x 5 m: a worktop run with base cabinets, a sink and an oven along the back wall with
    upper cabinets above, a fridge beside it, an island (turned 90 degrees in its node) with a top and two
    bar stools, a wall shelf on the side wall and a small dining table. `floor` False leaves out the floor
    ``Plane`` (the scene then needs ``convert.add_floor``).
    """
    import trimesh
    from trimesh.visual.material import PBRMaterial

    def tex(kind: str) -> PBRMaterial:
        return PBRMaterial(name=kind.title(), baseColorTexture=_texture(kind), metallicFactor=0.0, roughnessFactor=0.6)

    white, grey, steel, dark = (236, 236, 230, 255), (120, 122, 126, 255), (190, 192, 196, 255), (60, 52, 46, 255)
    scene = trimesh.Scene()
    graph = scene.graph

    def empty(name: str, parent: str, T: np.ndarray) -> str:
        graph.update(frame_from=parent, frame_to=name, matrix=T)
        return name

    def add(name: str, parent: str, mesh: "trimesh.Trimesh", T: np.ndarray) -> str:
        scene.add_geometry(mesh, node_name=name, geom_name=name + "_mesh", parent_node_name=parent, transform=T)
        return name

    root = scene.graph.base_frame
    if floor:  # Blender's default plane is 2 m x 2 m: scaled by its node
        plane = trimesh.Trimesh([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], [[0, 2, 1], [0, 3, 2]], process=False)
        plane.visual = trimesh.visual.TextureVisuals(uv=np.array([[0, 0], [4, 0], [4, 4], [0, 4]], float),
                                                     material=tex("tiles"))
        add("Plane", root, plane, _trs(s=(3.0, 1.0, 2.5)))
    add("Cube.012", root, _cube(rgba=white), _trs((0, 1.3, -2.55), s=(6.0, 2.6, 0.1)))  # back wall
    add("Cube.013", root, _cube(rgba=white), _trs((-3.05, 1.3, 0), s=(0.1, 2.6, 5.0)))  # side wall
    kitchen = empty("Kitchen", root, _trs((0.0, 0.0, -2.2)))
    run = empty("Counter_Run", kitchen, _trs((-0.6, 0.0, 0.0)))
    add("Cabinet_Base.001", run, _cube(rgba=white), _trs((-1.2, 0.43, 0), s=(1.2, 0.86, 0.6)))
    add("Cabinet_Base.002", run, _cube(rgba=white), _trs((0.0, 0.43, 0), s=(1.2, 0.86, 0.6)))
    add("Oven", run, _cube(rgba=steel), _trs((0.9, 0.43, 0), s=(0.6, 0.86, 0.6)))
    add("Countertop_Marble", run, _cube(tex("marble")), _trs((-0.15, 0.88, 0.02), s=(3.3, 0.04, 0.64)))
    basin = [((0, 0.005, 0), (0.5, 0.01, 0.4)), ((-0.245, 0.06, 0), (0.01, 0.12, 0.4)), ((0.245, 0.06, 0), (0.01, 0.12, 0.4)),
             ((0, 0.06, -0.195), (0.5, 0.12, 0.01)), ((0, 0.06, 0.195), (0.5, 0.12, 0.01))]
    sink_mesh = trimesh.util.concatenate([_cube(rgba=steel).apply_transform(_trs(t, s=s)) for t, s in basin])
    add("Sink", run, sink_mesh, _trs((-0.2, 0.9, 0.02)))
    for k, x in enumerate((-1.5, -0.3)):  # wall cabinets above the worktop
        add(f"Upper_Cabinet.00{3 + k}", run, _cube(rgba=white), _trs((x, 1.85, -0.12), s=(1.1, 0.7, 0.35)))
    add("Fridge_Body", kitchen, _cube(rgba=steel), _trs((1.6, 0.9, 0.05), s=(0.8, 1.8, 0.7)))
    add("Fridge_Door.001", "Fridge_Body", _cube(rgba=grey), _trs((0, 0, 0.52), s=(0.98, 0.98, 0.04)))
    island = empty("Island", root, _trs((0.4, 0.0, 0.2), yaw_deg=90.0))  # long side along glTF Z
    add("Kitchen_Island", island, _cube(rgba=dark), _trs((0, 0.43, 0), s=(1.8, 0.86, 0.8)))
    add("Island_Top", island, _cube(tex("wood")), _trs((0, 0.88, 0), s=(1.9, 0.04, 0.9)))
    for k, z in enumerate((-0.45, 0.45)):  # stools on one long side (island frame), seat + pole
        stool = trimesh.util.concatenate([_cylinder(0.19, 0.05, dark).apply_transform(_trs((0, 0.65, 0))),
                                          _cylinder(0.03, 0.63, steel).apply_transform(_trs((0, 0.315, 0)))])
        add(f"Bar_Stool_0{k + 1}", island, stool, _trs((z, 0.0, 0.75)))
    boards = trimesh.util.concatenate([_cube(tex("wood")).apply_transform(_trs((0, h, 0), s=(1.2, 0.03, 0.32)))
                                       for h in (1.05, 1.45)])
    add("Shelf_Wall.002", root, boards, _trs((-2.8, 0.0, 0.6), yaw_deg=90.0))
    table = empty("Dining", root, _trs((-1.5, 0.0, 1.4)))
    add("Dining_Table", table, _cube(tex("wood")), _trs((0, 0.74, 0), s=(1.2, 0.04, 0.8)))
    for k, (x, z) in enumerate(((-0.55, -0.35), (0.55, -0.35), (-0.55, 0.35), (0.55, 0.35))):
        add(f"Cube.02{k + 1}", table, _cube(rgba=dark), _trs((x, 0.36, z), s=(0.05, 0.72, 0.05)))  # legs
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(scene.export(file_type="glb"))
    return path
