"""The Matterport3D layout as habitat-sim reads it: visual GLB, ``_semantic.ply`` and the ``.house`` file."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..files import num, write_bytes
from ..model import Apartment
from .glb import glb_bytes


MP3D_REGION_CODES = {"bathroom": "a", "bedroom": "b", "closet": "c", "dining room": "d", "kitchen": "k",
                     "living room": "l", "office": "o", "hallway": "h", "laundry room": "j", "toilet": "t",
                     "entryway": "e", "garage": "g", "stairwell": "s"}


def write_mp3d(apartment: Apartment, out_dir: str | os.PathLike[str], name: str) -> Path:
    """Write an apartment in the Matterport3D layout (as habitat-sim reads it); return the path of ``<name>.glb``.

    Files: ``<name>.glb`` (visual mesh, **Z up**, no semantics in its nodes), ``<name>_semantic.ply`` (the same
    triangles; per-face ``object_id``, ``category_id`` and ``segment_id``) and ``<name>.house`` (ASCII: ``H`` header,
    ``L`` levels, ``R`` regions with their one-letter label code and bounding box, ``S``/``V`` region surfaces,
    ``C`` categories, ``O`` objects
    with their region and category). Category names are written with underscores for spaces (the file is
    whitespace-separated); region codes follow Matterport's table (``MP3D_REGION_CODES``; others ``z``, other room).
    Each region has one floor surface (``S``) whose ``V`` vertices are the room's counter-clockwise polygon, as
    Matterport's data_organization.md defines a region's extent; the ``H`` line's counts match the lines written.
    """
    out = Path(out_dir)
    mesh_path = out / f"{name}.glb"
    write_bytes(mesh_path, glb_bytes(apartment, name, to_file=lambda _i, v: v, anonymous=True, up="+Z"))
    m = apartment.mesh
    present = set(np.unique(m.face_instance).tolist())
    insts = [i for i in apartment.instances if i.id in present]
    cats = sorted({i.label for i in insts})
    cat_of = {i.id: cats.index(i.label) for i in insts}
    used, local = np.unique(m.faces, return_inverse=True)
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(used)}", "property float x",
              "property float y", "property float z", f"element face {len(m.faces)}",
              "property list uchar int vertex_indices", "property int object_id", "property int category_id",
              "property int segment_id", "end_header"]
    vd = np.ascontiguousarray(m.vertices[used], dtype="<f4")
    fd = np.zeros(len(m.faces), dtype=[("n", "u1"), ("i", "<i4", 3), ("o", "<i4"), ("c", "<i4"), ("s", "<i4")])
    fd["n"] = 3
    fd["i"] = local.reshape(-1, 3)
    fd["o"] = m.face_instance
    fd["c"] = [cat_of[int(k)] for k in m.face_instance]
    fd["s"] = m.face_instance
    write_bytes(out / f"{name}_semantic.ply", ("\n".join(header) + "\n").encode("ascii") + vd.tobytes() + fd.tobytes())
    z = lambda *xs: " ".join(f"{num(x):g}" for x in xs)  # noqa: E731
    lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
    n_vertices = sum(len(r.polygon) for r in apartment.rooms)
    lines = ["ASCII 1.1", f"H {name} house 0 0 {n_vertices} {len(apartment.rooms)} 0 {len(insts)} {len(cats)} "
                          f"{len(apartment.rooms)} 0 {len(apartment.floors)} 0 0 0 0 0 {z(*lo, *hi)} 0 0 0 0 0"]
    heights = {f.index: f.height for f in apartment.floors}
    for f in apartment.floors:
        lines.append(f"L {f.index} {sum(r.floor == f.index for r in apartment.rooms)} - 0 0 {z(heights[f.index])} "
                     f"{z(*lo[:2], heights[f.index], *hi[:2], heights[f.index] + apartment.wall_height)} 0 0 0 0 0")
    for r in apartment.rooms:
        poly = np.asarray(r.polygon, dtype=float)
        h0 = float(heights.get(r.floor, 0.0))
        (x0, y0), (x1, y1) = poly.min(axis=0), poly.max(axis=0)
        code = MP3D_REGION_CODES.get(r.type, "z")
        lines.append(f"R {r.id} {r.floor} 0 0 {code} {z((x0 + x1) / 2, (y0 + y1) / 2, h0)} "
                     f"{z(x0, y0, h0, x1, y1, h0 + apartment.wall_height)} {z(apartment.wall_height)} 0 0 0 0")
    vk = 0
    for r in apartment.rooms:  # one floor surface per region: its counter-clockwise polygon as V lines
        poly = np.asarray(r.polygon, dtype=float)
        h0 = float(heights.get(r.floor, 0.0))
        (x0, y0), (x1, y1) = poly.min(axis=0), poly.max(axis=0)
        code = MP3D_REGION_CODES.get(r.type, "z")
        lines.append(f"S {r.id} {r.id} 0 {code} {z((x0 + x1) / 2, (y0 + y1) / 2, h0)} 0 0 1 "
                     f"{z(x0, y0, h0, x1, y1, h0)} 0 0 0 0 0")
        for x, y in poly:
            lines.append(f"V {vk} {r.id} {code} {z(x, y, h0)} 0 0 1 0 0 0")
            vk += 1
    for k, c in enumerate(cats):
        token = c.replace(" ", "_")
        lines.append(f"C {k} {k} {token} {k} {token} 0 0 0 0 0")
    for i in insts:
        v = m.vertices[np.unique(m.faces[m.face_instance == i.id])]
        c, r = (v.min(axis=0) + v.max(axis=0)) / 2, (v.max(axis=0) - v.min(axis=0)) / 2
        lines.append(f"O {i.id} {i.room} {cat_of[i.id]} {z(*c)} 1 0 0 0 1 0 {z(*r)} 0 0 0 0 0 0 0 0")
    write_bytes(out / f"{name}.house", ("\n".join(lines) + "\n").encode("ascii"))
    return mesh_path
