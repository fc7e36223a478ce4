"""Small synthetic scenes (boxes as mesh assets) for tests and benchmarks of the observe stage.

A scene is a list of named boxes: storey floors, walls with a door gap, a table with thin legs, a
bed, ceilings. It is written the way a converted scene is: a visual-only MJCF whose geoms are named
``inst_<k>`` (one OBJ mesh asset each) and the scene mesh sidecar npz, plus a SceneAsset record.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sdovon_mj.records import SceneAsset, SemanticInstance, save_json
from sdovon_mj.sim import GROUP_CEILING, GROUP_SCENE
from sdovon_mj.sim.model import instance_geom_name, save_scene_mesh
from sdovon_mj.store import atomic_write_text
from sdovon_mj.world.shapes import box
from .mjcf import obj_text


@dataclass
class Box:
    """An axis-aligned box instance: label, min and max corners (world metres, Z up)."""

    label: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    kind: str = "structure"  # structure | furniture | ceiling


def _storey(z: float, size: tuple[float, float], height: float, with_furniture: bool, roof: bool) -> list[Box]:
    """Boxes of one storey whose floor top is at height z."""
    sx, sy = size
    t = 0.1
    out = [Box("floor", (0.0, 0.0, z - 0.2), (sx, sy, z))]
    zt = z + height
    out += [
        Box("wall", (0.0, 0.0, z), (sx, t, zt)),
        Box("wall", (0.0, sy - t, z), (sx, sy, zt)),
        Box("wall", (0.0, 0.0, z), (t, sy, zt)),
        Box("wall", (sx - t, 0.0, z), (sx, sy, zt)),
        # inner wall at x = sx/2 with a 1 m door gap (door frame above 2.0 m)
        Box("wall", (sx / 2 - t / 2, t, z), (sx / 2 + t / 2, sy / 2 - 0.5, zt)),
        Box("wall", (sx / 2 - t / 2, sy / 2 + 0.5, z), (sx / 2 + t / 2, sy - t, zt)),
        Box("wall", (sx / 2 - t / 2, sy / 2 - 0.5, z + 2.0), (sx / 2 + t / 2, sy / 2 + 0.5, zt)),
    ]
    if with_furniture:
        # a table with thin legs (0.05 m) and a 1.2 x 0.8 m top at 0.75 m
        tx, ty = 1.2, 1.2
        out.append(Box("table", (tx, ty, z + 0.71), (tx + 1.2, ty + 0.8, z + 0.75), "furniture"))
        for lx, ly in [(tx, ty), (tx + 1.15, ty), (tx, ty + 0.75), (tx + 1.15, ty + 0.75)]:
            out.append(Box("table", (lx, ly, z), (lx + 0.05, ly + 0.05, z + 0.71), "furniture"))
        # a bed in the other room
        out.append(Box("bed", (sx - 2.2, sy - 1.7, z), (sx - 0.2, sy - 0.2, z + 0.5), "furniture"))
        # a shelf on thin legs, 0.4 m above the floor (a slice at 0.3 m alone would miss it)
        out.append(Box("shelf", (sx / 2 + 0.6, 0.2, z + 0.4), (sx / 2 + 1.6, 0.6, z + 1.2), "furniture"))
    out.append(Box("ceiling" if not roof else "roof", (0.0, 0.0, zt), (sx, sy, zt + 0.2), "ceiling"))
    return out


def apartment_boxes(storeys: int = 2, size: tuple[float, float] = (8.0, 6.0), storey_height: float = 2.6) -> list[Box]:
    """Return the boxes of a synthetic apartment with `storeys` floors (furnished, roofed)."""
    boxes: list[Box] = []
    z = 0.0
    for s in range(storeys):
        top = s == storeys - 1
        st = _storey(z, size, storey_height, with_furniture=True, roof=top)
        if s > 0:  # the ceiling slab below is this storey's floor
            st = [b for b in st if b.label != "floor"]
        boxes += st
        z += storey_height + 0.2
    return boxes


def write_box_scene(boxes: list[Box], out_dir: str | Path, name: str = "synthetic") -> SceneAsset:
    """Write boxes as a converted-style scene (MJCF + OBJ meshes + mesh sidecar + scene.json)."""
    rng = np.random.default_rng(0)
    parts = []
    for b in boxes:
        v, f = box(b.lo, b.hi)
        parts.append((b.label, v, f, (*rng.uniform(0.3, 0.9, 3), 1.0), b.kind == "ceiling"))
    return write_mesh_scene(parts, out_dir, name)


def write_mesh_scene(parts: list[tuple[str, np.ndarray, np.ndarray, tuple[float, ...], bool]], out_dir: str | Path,
                     name: str = "synthetic") -> SceneAsset:
    """Write (label, vertices, faces, rgba, is_ceiling) parts as instances inst_<k> of a scene."""
    out = Path(out_dir)
    (out / "meshes").mkdir(parents=True, exist_ok=True)
    verts, faces, face_inst = [], [], []
    assets, geoms, instances = [], [], []
    offset = 0
    for k, (label, v, f, rgba, ceiling) in enumerate(parts):
        v = np.asarray(v, dtype=np.float64)
        f = np.asarray(f, dtype=np.int64)
        atomic_write_text(out / "meshes" / f"inst_{k}.obj", obj_text(v, f))
        gname = instance_geom_name(k)
        group = GROUP_CEILING if ceiling else GROUP_SCENE
        col = " ".join(f"{c:.3f}" for c in rgba)
        assets.append(f'    <mesh name="m_{k}" file="inst_{k}.obj" inertia="shell"/>')
        geoms.append(f'    <geom name="{gname}" type="mesh" mesh="m_{k}" group="{group}" rgba="{col}" contype="0" conaffinity="0"/>')
        instances.append(SemanticInstance(id=k, label=label, geoms=[gname],
                                          bounds=np.stack([v.min(axis=0), v.max(axis=0)])))
        verts.append(v)
        faces.append(f + offset)
        face_inst.append(np.full(len(f), k))
        offset += len(v)
    xml = "\n".join([
        f'<mujoco model="{name}">',
        '  <compiler meshdir="meshes"/>',
        '  <visual><headlight ambient="0.4 0.4 0.4" diffuse="0.5 0.5 0.5"/></visual>',
        "  <asset>", *assets, "  </asset>",
        "  <worldbody>", *geoms, "  </worldbody>",
        "</mujoco>", ""])
    atomic_write_text(out / f"{name}.xml", xml)
    V, F = np.concatenate(verts), np.concatenate(faces)
    save_scene_mesh(out / f"{name}_mesh.npz", V, F, np.concatenate(face_inst))
    scene = SceneAsset(name=name, mjcf=f"{name}.xml", source="synthetic", instances=instances,
                       bounds=np.stack([V.min(axis=0), V.max(axis=0)]), mesh=f"{name}_mesh.npz")
    save_json(scene, out / "scene.json")
    return scene


def living_room_parts(assets_root: str | Path) -> list[tuple[str, np.ndarray, np.ndarray, tuple[float, ...], bool]]:
    """Return the shared furnished living room (placements.json) as untextured Z-up parts, one per glTF node."""
    import json

    import trimesh
    from trimesh.transformations import euler_matrix, rotation_matrix

    root = Path(assets_root)
    spec = json.loads((root / "scenes" / "furnished_living_room" / "placements.json").read_text(encoding="utf-8"))
    y_to_z = rotation_matrix(np.pi / 2, [1, 0, 0])  # glTF (x, y, z) -> (x, -z, y)
    parts = []
    for inst in spec["instances"]:
        pose = euler_matrix(*np.radians(inst["rpy_deg"]), axes="sxyz")
        pose[:3, 3] = inst["translation"]
        scene = trimesh.load(root / inst["asset"], force="scene")
        for node in sorted(scene.graph.nodes_geometry):
            T, gname = scene.graph[node]
            g = scene.geometry[gname]
            v = trimesh.transform_points(np.asarray(g.vertices), pose @ y_to_z @ T)
            rgba = (0.7, 0.7, 0.7, 1.0)
            try:
                c = np.asarray(g.visual.material.main_color, dtype=np.float64) / 255.0
                rgba = tuple(float(x) for x in c[:3]) + (1.0,)
            except AttributeError:
                pass
            label = inst["name"] if inst["name"] not in ("living_room",) else str(node).split("_")[0]
            parts.append((label, v, np.asarray(g.faces), rgba, False))
    return parts
