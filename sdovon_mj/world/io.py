"""Writers for generated apartments: the way a user's scene files arrive.

* ``clean``: ``<name>.glb`` (glTF binary, **+Y up** as glTF requires, metres), one node per
  instance named ``instance_<id>`` whose mesh has one primitive per colour, each with its own
  material (wood, floor planks and tiles carry a small procedural PNG texture).
* ``scan``: ``<name>_vh_clean.ply`` (one fused mesh, **+Z up**, metres, vertex colours, noise and
  holes), ``<name>_vh_clean.segs.json`` and ``<name>.aggregation.json`` (ScanNet style labels).
* both: ``<name>.semantics.json``: rooms, instances and support surfaces in the world Z-up frame.

Every writer is byte-deterministic: fixed float formatting, sorted JSON keys, no timestamps.
"""

from __future__ import annotations

import json
import os
import struct
import tempfile
from pathlib import Path
from typing import Callable, Collection

import numpy as np

from ..store import user_cache_dir
from .apartment import MATERIALS, Apartment, generate_apartment
from .scan import ScanMesh, make_scan
from .textures import TEXTURE_SCALE, texture_png, triplanar_uv

TEXTURED = ("wood", "floor_wood", "floor_tile")
MODES = ("clean", "scan", "hm3d", "mp3d", "habitat")
_FLOAT, _UINT, _USHORT, _UBYTE = 5126, 5125, 5123, 5121
_ARRAY, _ELEMENTS = 34962, 34963


def default_name(seed: int) -> str:
    """Return the default file stem of an apartment."""
    return f"apartment_{int(seed):04d}"


def _zup_to_yup(v: np.ndarray) -> np.ndarray:
    """Rotate Z-up coordinates to glTF's Y-up: (x, y, z) -> (x, z, -y)."""
    return np.stack([v[:, 0], v[:, 2], -v[:, 1]], axis=1)


def dumps_json(data: dict, indent: int | None = 1) -> str:
    """Serialise JSON deterministically (sorted keys)."""
    if indent is None:
        return json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return json.dumps(data, sort_keys=True, indent=indent, ensure_ascii=True) + "\n"


def _write_bytes(path: Path, data: bytes) -> None:
    """Write a file atomically (temp file + rename)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


class _Glb:
    """Accumulates buffer views and accessors of a single-buffer glTF."""

    def __init__(self) -> None:
        self.bin = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def view(self, data: bytes, target: int | None = None) -> int:
        """Append a 4-byte aligned buffer view."""
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target is not None:
            v["target"] = target
        self.bin += data
        self.views.append(v)
        return len(self.views) - 1

    def accessor(self, arr: np.ndarray, kind: str, target: int, minmax: bool = False) -> int:
        """Append an accessor for a float32 / uint32 / uint16 array."""
        arr = np.ascontiguousarray(arr)
        comp = {np.dtype("<f4"): _FLOAT, np.dtype("<u4"): _UINT, np.dtype("<u2"): _USHORT,
                np.dtype("u1"): _UBYTE}[arr.dtype.newbyteorder("<")]
        acc = {"bufferView": self.view(arr.astype(arr.dtype.newbyteorder("<")).tobytes(), target), "componentType": comp,
               "count": int(arr.shape[0]) if kind != "SCALAR" else int(arr.size), "type": kind}
        if comp == _UBYTE:
            acc["normalized"] = True
        if minmax:
            acc["min"] = [float(x) for x in arr.reshape(len(arr), -1).min(0)]
            acc["max"] = [float(x) for x in arr.reshape(len(arr), -1).max(0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def glb_bytes(apartment: Apartment, name: str, ids: Collection[int] | None = None,
              to_file: Callable[[int, np.ndarray], np.ndarray] | None = None, anonymous: bool = False,
              up: str = "+Y") -> bytes:
    """Return a GLB of an apartment's instances (default: all, world frame, Y up, one node per instance).

    Parameters
    ----------
    apartment : Apartment
        The generated apartment.
    name : str
        Scene name (in the glTF scene's extras).
    ids : collection of int, optional
        Instance ids to write (default: every instance).
    to_file : callable, optional
        ``to_file(instance_id, vertices_zup) -> file-frame vertices`` (metres); default: Z up -> Y up.
    anonymous : bool
        Name nodes ``mesh_<k>`` without instance extras (a scan's visual mesh carries no semantics).
    up : str
        The up axis recorded in the scene extras ("+Y" or "+Z").
    """
    m = apartment.mesh
    g = _Glb()
    if to_file is None:
        def to_file(_iid: int, v: np.ndarray) -> np.ndarray:
            return _zup_to_yup(v)
    images, textures, tex_index = [], [], {}
    for t in TEXTURED:
        if np.any(m.face_material == MATERIALS.index(t)):
            tex_index[t] = len(textures)
            images.append({"bufferView": g.view(texture_png(t)), "mimeType": "image/png", "name": t})
            textures.append({"sampler": 0, "source": len(images) - 1})
    nodes, meshes, materials = [], [], []
    order = np.argsort(m.face_instance, kind="stable")
    bounds = np.searchsorted(m.face_instance[order], np.arange(len(apartment.instances) + 1))
    for inst in apartment.instances:
        fidx = order[bounds[inst.id]:bounds[inst.id + 1]]
        if len(fidx) == 0 or (ids is not None and inst.id not in ids):
            continue
        keys = np.concatenate([m.face_color[fidx].astype(np.int64), m.face_material[fidx, None].astype(np.int64)], axis=1)
        _, first, inv = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        inv = inv.ravel()
        prims = []
        for k, grp in enumerate(np.argsort(first, kind="stable")):
            sel = fidx[inv == grp]
            rgba = m.face_color[sel[0]]
            mat_name = MATERIALS[int(m.face_material[sel[0]])]
            pbr = {"baseColorFactor": [round(float(c) / 255.0, 6) for c in rgba], "metallicFactor": 0.0,
                   "roughnessFactor": 0.35 if mat_name in ("metal", "ceramic", "glass") else 0.85}
            material = {"name": f"instance_{inst.id}_{k}_{mat_name}", "pbrMetallicRoughness": pbr}
            if rgba[3] < 255:
                material["alphaMode"] = "BLEND"
            tri = m.vertices[m.faces[sel]]  # (k, 3, 3) Z up
            if mat_name in tex_index:
                pbr["baseColorTexture"] = {"index": tex_index[mat_name]}
                pos = to_file(inst.id, tri.reshape(-1, 3)).astype("<f4")
                uv = triplanar_uv(tri, TEXTURE_SCALE[mat_name]).reshape(-1, 2).astype("<f4")
                attrs = {"POSITION": g.accessor(pos, "VEC3", _ARRAY, True), "TEXCOORD_0": g.accessor(uv, "VEC2", _ARRAY)}
                prim = {"attributes": attrs, "material": len(materials), "mode": 4}
            else:
                used, local = np.unique(m.faces[sel], return_inverse=True)
                pos = to_file(inst.id, m.vertices[used]).astype("<f4")
                idx = local.reshape(-1).astype("<u2" if len(used) < 65536 else "<u4")
                prim = {"attributes": {"POSITION": g.accessor(pos, "VEC3", _ARRAY, True)},
                        "indices": g.accessor(idx, "SCALAR", _ELEMENTS), "material": len(materials), "mode": 4}
            materials.append(material)
            prims.append(prim)
        if anonymous:
            meshes.append({"name": f"mesh_{len(meshes)}", "primitives": prims})
            nodes.append({"name": f"mesh_{len(meshes) - 1}", "mesh": len(meshes) - 1})
            continue
        meshes.append({"name": f"instance_{inst.id}", "primitives": prims})
        nodes.append({"name": f"instance_{inst.id}", "mesh": len(meshes) - 1,
                      "extras": {"instance_id": inst.id, "label": inst.label, "room": inst.room, "floor": inst.floor,
                                 "kind": inst.kind}})
    gltf = {
        "asset": {"version": "2.0", "generator": "sdovon-mj world (procedural)"},
        "scene": 0,
        "scenes": [{"name": name, "nodes": list(range(len(nodes))),
                    "extras": {"format": "sdovon-world/1", "seed": apartment.seed, "units": "m", "up": up}}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": g.accessors,
        "bufferViews": g.views,
        "buffers": [{"byteLength": 0}],
    }
    if textures:
        gltf["textures"] = textures
        gltf["images"] = images
        gltf["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}]
    return _pack_glb(gltf, g)


def _pack_glb(gltf: dict, g: _Glb) -> bytes:
    """Return the GLB bytes of a glTF document whose single buffer is `g`."""
    while len(g.bin) % 4:
        g.bin.append(0)
    gltf["buffers"][0]["byteLength"] = len(g.bin)
    js = dumps_json(gltf, indent=None).encode("ascii")
    js += b" " * ((4 - len(js) % 4) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(g.bin), 0x004E4942) + bytes(g.bin)
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


def ply_bytes(scan: ScanMesh, comment: str = "") -> bytes:
    """Return a binary little-endian PLY with float xyz, uchar RGBA and int face indices (ScanNet layout)."""
    header = ["ply", "format binary_little_endian 1.0"]
    if comment:
        header.append(f"comment {comment}")
    header += [f"element vertex {len(scan.vertices)}", "property float x", "property float y", "property float z",
               "property uchar red", "property uchar green", "property uchar blue", "property uchar alpha",
               f"element face {len(scan.faces)}", "property list uchar int vertex_indices", "end_header"]
    vd = np.zeros(len(scan.vertices), dtype=[("p", "<f4", 3), ("c", "u1", 4)])
    vd["p"] = scan.vertices
    vd["c"] = scan.colors
    fd = np.zeros(len(scan.faces), dtype=[("n", "u1"), ("i", "<i4", 3)])
    fd["n"] = 3
    fd["i"] = scan.faces
    return ("\n".join(header) + "\n").encode("ascii") + vd.tobytes() + fd.tobytes()


def write_apartment(apartment: Apartment, out_dir: str | os.PathLike[str], mode: str = "clean", name: str | None = None,
                    noise_sigma: float = 0.003, max_faces: int = 300_000) -> Path:
    """Write an apartment in `mode` "clean" (GLB), "scan" (PLY + ScanNet labels), "hm3d", "mp3d" or "habitat"; return the main file.

    "clean" and "scan" also write the ``<name>.semantics.json`` sidecar; "hm3d" (`write_hm3d`), "mp3d" (`write_mp3d`)
    and "habitat" (`write_habitat`) write only what a dataset of that layout holds, so their readers get no help.

    Parameters
    ----------
    apartment : Apartment
        The generated apartment.
    out_dir : str or os.PathLike
        Output folder.
    mode : str
        "clean" (GLB, +Y up), "scan" (PLY, +Z up, ScanNet labels), "hm3d", "mp3d" or "habitat".
    name : str, optional
        File stem (default: ``apartment_<seed:04d>``).
    noise_sigma : float
        Scan mode: surface noise std along the normals, metres.
    max_faces : int
        Scan mode: about the most faces of the re-meshed scan.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    out = Path(out_dir)
    name = name or default_name(apartment.seed)
    if mode == "hm3d":
        return write_hm3d(apartment, out, name)
    if mode == "habitat":
        return write_habitat(apartment, out, name)
    if mode == "mp3d":
        return write_mp3d(apartment, out, name)
    if mode == "clean":
        mesh_path = out / f"{name}.glb"
        _write_bytes(mesh_path, glb_bytes(apartment, name))
        up = "+Y"
    else:
        scan = make_scan(apartment, noise_sigma=noise_sigma, max_faces=max_faces)
        mesh_path = out / f"{name}_vh_clean.ply"
        _write_bytes(mesh_path, ply_bytes(scan, f"sdovon-mj procedural scan, seed {apartment.seed}"))
        segs_name = f"{name}_vh_clean.segs.json"
        _write_bytes(out / segs_name, dumps_json({"sceneId": name, "segIndices": [int(s) for s in scan.segments]}, None).encode())
        groups = []
        for inst in apartment.instances:
            segs = np.unique(scan.segments[scan.vertex_instance == inst.id])
            if len(segs) == 0:
                continue
            groups.append({"id": inst.id, "objectId": inst.id, "label": inst.label, "segments": [int(s) for s in segs]})
        agg = {"sceneId": name, "segGroups": groups, "segmentsFile": segs_name}
        _write_bytes(out / f"{name}.aggregation.json", dumps_json(agg, None).encode())
        up = "+Z"
    sidecar = apartment.semantics(name, mode, mesh_path.name, up)
    _write_bytes(out / f"{name}.semantics.json", dumps_json(sidecar).encode())
    from .artplace import remove_articulated, write_articulated

    remove_articulated(out, name)  # an earlier write's pieces must not outlive a switch to rigid furniture
    if apartment.articulated:  # world.articulated: URDF pieces + <name>.articulated.json (world/artplace.py)
        write_articulated(apartment.articulated, out, name, {i.id: i.label for i in apartment.instances})
    return mesh_path


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
    _write_bytes(mesh_path, glb_bytes(apartment, name, to_file=lambda _i, v: v, anonymous=True, up="+Z"))
    m = apartment.mesh
    g = _Glb()
    order = np.argsort(m.face_instance, kind="stable")
    tri = m.vertices[m.faces[order]].reshape(-1, 3).astype("<f4")
    colours = np.array([[int(semantic_colour(i)[k:k + 2], 16) for k in (0, 2, 4)] + [255]
                        for i in range(len(apartment.instances))], dtype=np.uint8)
    col = np.repeat(colours[m.face_instance[order]], 3, axis=0).astype("u1")
    prim = {"attributes": {"POSITION": g.accessor(tri, "VEC3", _ARRAY, True), "COLOR_0": g.accessor(col, "VEC4", _ARRAY)},
            "mode": 4}
    gltf = {"asset": {"version": "2.0", "generator": "sdovon-mj world (hm3d layout)"}, "scene": 0,
            "scenes": [{"name": name, "nodes": [0]}], "nodes": [{"name": "semantic", "mesh": 0}],
            "meshes": [{"name": "semantic", "primitives": [prim]}], "accessors": g.accessors, "bufferViews": g.views,
            "buffers": [{"byteLength": 0}]}
    _write_bytes(out / f"{name}.semantic.glb", _pack_glb(gltf, g))
    lines = ["HM3D Semantic Annotations"]
    used = set(np.unique(m.face_instance).tolist())
    for inst in apartment.instances:
        if inst.id in used:
            lines.append(f'{inst.id},{semantic_colour(inst.id)},"{inst.label}",{inst.room}')
    _write_bytes(out / f"{name}.semantic.txt", ("\n".join(lines) + "\n").encode("utf-8"))
    return mesh_path


MP3D_REGION_CODES = {"bathroom": "a", "bedroom": "b", "closet": "c", "dining room": "d", "kitchen": "k",
                     "living room": "l", "office": "o", "hallway": "h", "laundry room": "j", "toilet": "t"}


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
    _write_bytes(mesh_path, glb_bytes(apartment, name, to_file=lambda _i, v: v, anonymous=True, up="+Z"))
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
    _write_bytes(out / f"{name}_semantic.ply", ("\n".join(header) + "\n").encode("ascii") + vd.tobytes() + fd.tobytes())
    z = lambda *xs: " ".join(f"{_num6(x):g}" for x in xs)  # noqa: E731
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
    _write_bytes(out / f"{name}.house", ("\n".join(lines) + "\n").encode("ascii"))
    return mesh_path


def _yaw_deg(instance_id: int) -> float:
    """Return the yaw of an object instance in the habitat layout (varied, so the reader's rotations are exercised)."""
    return float((int(instance_id) * 37) % 360)


def write_habitat(apartment: Apartment, out_dir: str | os.PathLike[str], name: str) -> Path:
    """Write an apartment as a Habitat scene dataset (HSSD style); return the ``scene_instance.json`` path.

    Layout under `out_dir`: ``<name>.scene_dataset_config.json``; ``stages/<name>.stage_config.json`` + ``.glb``
    (structure: floors, walls, ceilings, windows; Y up; nodes ``instance_<id>``); ``objects/<name>_<id>.object_config.json``
    + ``.glb`` (one template per furniture instance, in its own frame: yawed, every odd instance placed by its centre
    of mass (``translation_origin: COM``), every third written in centimetres with ``units_to_meters`` 0.01) with a
    ``semantic_id``; ``semantics/<name>.semantic_config.json`` (``classes`` lexicon and ``region_annotations``
    of the rooms); ``scenes/<name>.scene_instance.json``.
    """
    out = Path(out_dir)
    up, front = [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]
    structure = {i.id for i in apartment.instances if i.kind == "structure"}
    m = apartment.mesh
    present = set(np.unique(m.face_instance).tolist())
    _write_bytes(out / "stages" / f"{name}.glb", glb_bytes(apartment, name, ids=structure))
    _write_bytes(out / "stages" / f"{name}.stage_config.json", dumps_json({
        "render_asset": f"{name}.glb", "up": up, "front": front, "origin": [0.0, 0.0, 0.0], "units_to_meters": 1.0}).encode())
    classes = sorted({i.label for i in apartment.instances if i.id not in structure and i.id in present})
    class_id = {c: k + 1 for k, c in enumerate(classes)}
    objects = []
    for inst in apartment.instances:
        if inst.id in structure or inst.id not in present:
            continue
        v = m.vertices[np.unique(m.faces[m.face_instance == inst.id])]
        lo, hi = v.min(axis=0), v.max(axis=0)
        t = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
        yaw = np.radians(_yaw_deg(inst.id))
        c, sn = np.cos(yaw), np.sin(yaw)
        rz = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
        scale = 100.0 if inst.id % 3 == 0 else 1.0

        def to_file(_iid: int, w: np.ndarray, t: np.ndarray = t, rz: np.ndarray = rz, scale: float = scale) -> np.ndarray:
            return _zup_to_yup((w - t) @ rz) * scale

        tname = f"{name}_{inst.id:04d}"
        _write_bytes(out / "objects" / f"{tname}.glb", glb_bytes(apartment, tname, ids={inst.id}, to_file=to_file))
        _write_bytes(out / "objects" / f"{tname}.object_config.json", dumps_json({
            "render_asset": f"{tname}.glb", "up": up, "front": front, "units_to_meters": 1.0 / scale,
            "semantic_id": class_id[inst.label]}).encode())
        t_hab = _zup_to_yup(t[None])[0]
        rot = [float(np.cos(yaw / 2)), 0.0, float(np.sin(yaw / 2)), 0.0]  # wxyz: yaw about Habitat's +Y
        entry = {"template_name": f"objects/{tname}.object_config.json", "motion_type": "STATIC",
                 "translation_origin": "asset_local", "rotation": [_num6(x) for x in rot]}
        if inst.id % 2:
            # COM = the local bounding-box centre (Habitat's default): translation places it
            local = _zup_to_yup((v - t) @ rz)
            com = (local.min(axis=0) + local.max(axis=0)) / 2
            r_hab = np.array([[c, 0.0, sn], [0.0, 1.0, 0.0], [-sn, 0.0, c]])
            t_hab = t_hab + r_hab @ com
            entry["translation_origin"] = "COM"
        entry["translation"] = [_num6(x) for x in t_hab]
        objects.append(entry)
    regions = []
    heights = {f.index: f.height for f in apartment.floors}
    for r in apartment.rooms:
        h = float(heights.get(r.floor, 0.0))
        loop = [[_num6(x), _num6(h), _num6(-y)] for x, y in np.asarray(r.polygon, dtype=float)]
        regions.append({"name": f"room_{r.id}", "label": r.type, "poly_loop": loop, "floor_height": _num6(h),
                        "extrusion_height": _num6(apartment.wall_height)})
    _write_bytes(out / "semantics" / f"{name}.semantic_config.json", dumps_json({
        "classes": [{"id": class_id[c], "name": c} for c in classes], "region_annotations": regions}).encode())
    scene_path = out / "scenes" / f"{name}.scene_instance.json"
    _write_bytes(scene_path, dumps_json({
        "stage_instance": {"template_name": f"stages/{name}.stage_config.json", "translation": [0.0, 0.0, 0.0],
                           "rotation": [1.0, 0.0, 0.0, 0.0]},
        "translation_origin": "asset_local", "default_lighting": "", "object_instances": objects,
        "semantic_scene_instance": name}).encode())
    _write_bytes(out / f"{name}.scene_dataset_config.json", dumps_json({
        "stages": {"default_attributes": {"up": up, "front": front}, "paths": {".json": ["stages"]}},
        "objects": {"default_attributes": {"up": up, "front": front}, "paths": {".json": ["objects"]}},
        "scene_instances": {"paths": {".json": ["scenes"]}},
        "semantic_scene_descriptor_instances": {name: f"semantics/{name}.semantic_config.json"}}).encode())
    return scene_path


def _num6(x: float) -> float:
    """Round a coordinate for JSON (6 decimals, no negative zero)."""
    return float(round(float(x), 6)) + 0.0


def default_apartment_path(seed: int = 0, out_dir: str | os.PathLike[str] | None = None, mode: str = "clean",
                           floors: int | None = None) -> Path:
    """Return the mesh path of default apartment `seed`, generating it into out_dir (or the cache) if missing."""
    if out_dir is not None:
        base = Path(out_dir)
    else:  # the shared cache; with SDOVON_CACHE=off, a per-user temporary folder
        base = user_cache_dir("world") or Path(tempfile.gettempdir()) / f"sdovon-mj-world-{os.getuid()}"
    name = default_name(seed) + ("" if floors is None else f"_f{floors}")
    path = base / (f"{name}.glb" if mode == "clean" else f"{name}_vh_clean.ply")
    if not path.exists() or not (base / f"{name}.semantics.json").exists():
        write_apartment(generate_apartment(seed, floors), base, mode, name)
    return path
