"""The HM3D-Semantics layout: visual GLB, semantic GLB (instance colours per vertex) and ``.semantic.txt``."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..files import write_bytes
from ..model import Apartment
from .glb import ARRAY, Glb, glb_bytes, pack_glb


def semantic_colour(instance_id: int) -> str:
    """Return the HM3D-style hex colour (RRGGBB) of an instance: a bijection of the id onto 24-bit colours."""
    return f"{(int(instance_id) * 2654435761 + 0x3A5F1D) % (1 << 24):06X}"


def write_hm3d(apartment: Apartment, out_dir: str | os.PathLike[str], name: str) -> Path:
    """Write an apartment in the HM3D-Semantics layout; return the path of ``<name>.glb``.

    Files: ``<name>.glb`` (the visual mesh, **Z up** as HM3D's raw GLBs, metres, nodes without semantics),
    ``<name>.semantic.glb`` (the same triangles, each carrying its instance's colour as a per-vertex
    COLOR_0) and ``<name>.semantic.txt`` (``HM3D Semantic Annotations`` then one
    ``<id>,<RRGGBB>,"<category>",<region>`` line per instance; region = the room id, -1 outside rooms).
    """
    out = Path(out_dir)
    mesh_path = out / f"{name}.glb"
    write_bytes(mesh_path, glb_bytes(apartment, name, to_file=lambda _i, v: v, anonymous=True, up="+Z"))
    m = apartment.mesh
    g = Glb()
    order = np.argsort(m.face_instance, kind="stable")
    tri = m.vertices[m.faces[order]].reshape(-1, 3).astype("<f4")
    colours = np.array([[int(semantic_colour(i)[k:k + 2], 16) for k in (0, 2, 4)] + [255]
                        for i in range(len(apartment.instances))], dtype=np.uint8)
    col = np.repeat(colours[m.face_instance[order]], 3, axis=0).astype("u1")
    prim = {"attributes": {"POSITION": g.accessor(tri, "VEC3", ARRAY, True), "COLOR_0": g.accessor(col, "VEC4", ARRAY)},
            "mode": 4}
    gltf = {"asset": {"version": "2.0", "generator": "sdovon-mj world (hm3d layout)"}, "scene": 0,
            "scenes": [{"name": name, "nodes": [0]}], "nodes": [{"name": "semantic", "mesh": 0}],
            "meshes": [{"name": "semantic", "primitives": [prim]}], "accessors": g.accessors, "bufferViews": g.views,
            "buffers": [{"byteLength": 0}]}
    write_bytes(out / f"{name}.semantic.glb", pack_glb(gltf, g))
    lines = ["HM3D Semantic Annotations"]
    used = set(np.unique(m.face_instance).tolist())
    for inst in apartment.instances:
        if inst.id in used:
            lines.append(f'{inst.id},{semantic_colour(inst.id)},"{inst.label}",{inst.room}')
    write_bytes(out / f"{name}.semantic.txt", ("\n".join(lines) + "\n").encode("utf-8"))
    return mesh_path
