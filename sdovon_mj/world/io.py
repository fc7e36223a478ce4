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

import numpy as np

from ..store import user_cache_dir
from .apartment import MATERIALS, Apartment, generate_apartment
from .scan import ScanMesh, make_scan
from .textures import TEXTURE_SCALE, texture_png, triplanar_uv

TEXTURED = ("wood", "floor_wood", "floor_tile")
_FLOAT, _UINT, _USHORT = 5126, 5125, 5123
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
        comp = {np.dtype("<f4"): _FLOAT, np.dtype("<u4"): _UINT, np.dtype("<u2"): _USHORT}[arr.dtype.newbyteorder("<")]
        acc = {"bufferView": self.view(arr.astype(arr.dtype.newbyteorder("<")).tobytes(), target), "componentType": comp,
               "count": int(arr.shape[0]) if kind != "SCALAR" else int(arr.size), "type": kind}
        if minmax:
            acc["min"] = [float(x) for x in arr.reshape(len(arr), -1).min(0)]
            acc["max"] = [float(x) for x in arr.reshape(len(arr), -1).max(0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def glb_bytes(apartment: Apartment, name: str) -> bytes:
    """Return the clean-mode GLB of an apartment (Y up, one node per instance)."""
    m = apartment.mesh
    g = _Glb()
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
        if len(fidx) == 0:
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
                pos = _zup_to_yup(tri.reshape(-1, 3)).astype("<f4")
                uv = triplanar_uv(tri, TEXTURE_SCALE[mat_name]).reshape(-1, 2).astype("<f4")
                attrs = {"POSITION": g.accessor(pos, "VEC3", _ARRAY, True), "TEXCOORD_0": g.accessor(uv, "VEC2", _ARRAY)}
                prim = {"attributes": attrs, "material": len(materials), "mode": 4}
            else:
                used, local = np.unique(m.faces[sel], return_inverse=True)
                pos = _zup_to_yup(m.vertices[used]).astype("<f4")
                idx = local.reshape(-1).astype("<u2" if len(used) < 65536 else "<u4")
                prim = {"attributes": {"POSITION": g.accessor(pos, "VEC3", _ARRAY, True)},
                        "indices": g.accessor(idx, "SCALAR", _ELEMENTS), "material": len(materials), "mode": 4}
            materials.append(material)
            prims.append(prim)
        meshes.append({"name": f"instance_{inst.id}", "primitives": prims})
        nodes.append({"name": f"instance_{inst.id}", "mesh": len(meshes) - 1,
                      "extras": {"instance_id": inst.id, "label": inst.label, "room": inst.room, "floor": inst.floor,
                                 "kind": inst.kind}})
    gltf = {
        "asset": {"version": "2.0", "generator": "sdovon-mj world (procedural)"},
        "scene": 0,
        "scenes": [{"name": name, "nodes": list(range(len(nodes))),
                    "extras": {"format": "sdovon-world/1", "seed": apartment.seed, "units": "m", "up": "+Y"}}],
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
    """Write an apartment in `mode` "clean" (GLB) or "scan" (PLY + ScanNet labels) plus its sidecar; returns the mesh path.

    Parameters
    ----------
    apartment : Apartment
        The generated apartment.
    out_dir : str or os.PathLike
        Output folder.
    mode : str
        "clean" (GLB, +Y up) or "scan" (PLY, +Z up, ScanNet labels).
    name : str, optional
        File stem (default: ``apartment_<seed:04d>``).
    noise_sigma : float
        Scan mode: surface noise std along the normals, metres.
    max_faces : int
        Scan mode: about the most faces of the re-meshed scan.
    """
    if mode not in ("clean", "scan"):
        raise ValueError(f"mode must be 'clean' or 'scan', got {mode!r}")
    out = Path(out_dir)
    name = name or default_name(apartment.seed)
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
    return mesh_path


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
