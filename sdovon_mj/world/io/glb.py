"""The clean mode's GLB: one node per instance, one primitive per colour, procedural textures (glTF 2.0 binary).

`glb_bytes` also writes the visual meshes of the HM3D, MP3D and Habitat layouts (Z up there, or one instance in
its own frame); `Glb` and `pack_glb` build any single-buffer GLB (the HM3D semantic mesh).
"""

from __future__ import annotations

import struct
from typing import Callable, Collection

import numpy as np

from ..files import dumps_json
from ..model import MATERIALS, Apartment
from ..textures import TEXTURE_SCALE, texture_png, triplanar_uv

TEXTURED = ("wood", "floor_wood", "floor_tile")
FLOAT, UINT, USHORT, UBYTE = 5126, 5125, 5123, 5121  # glTF component types
ARRAY, ELEMENTS = 34962, 34963  # glTF buffer view targets


def zup_to_yup(v: np.ndarray) -> np.ndarray:
    """Rotate Z-up coordinates to glTF's Y-up: (x, y, z) -> (x, z, -y)."""
    return np.stack([v[:, 0], v[:, 2], -v[:, 1]], axis=1)



class Glb:
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
        comp = {np.dtype("<f4"): FLOAT, np.dtype("<u4"): UINT, np.dtype("<u2"): USHORT,
                np.dtype("u1"): UBYTE}[arr.dtype.newbyteorder("<")]
        acc = {"bufferView": self.view(arr.astype(arr.dtype.newbyteorder("<")).tobytes(), target), "componentType": comp,
               "count": int(arr.shape[0]) if kind != "SCALAR" else int(arr.size), "type": kind}
        if comp == UBYTE:
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
    g = Glb()
    if to_file is None:
        def to_file(_iid: int, v: np.ndarray) -> np.ndarray:
            return zup_to_yup(v)
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
                attrs = {"POSITION": g.accessor(pos, "VEC3", ARRAY, True), "TEXCOORD_0": g.accessor(uv, "VEC2", ARRAY)}
                prim = {"attributes": attrs, "material": len(materials), "mode": 4}
            else:
                used, local = np.unique(m.faces[sel], return_inverse=True)
                pos = to_file(inst.id, m.vertices[used]).astype("<f4")
                idx = local.reshape(-1).astype("<u2" if len(used) < 65536 else "<u4")
                prim = {"attributes": {"POSITION": g.accessor(pos, "VEC3", ARRAY, True)},
                        "indices": g.accessor(idx, "SCALAR", ELEMENTS), "material": len(materials), "mode": 4}
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
    return pack_glb(gltf, g)


def pack_glb(gltf: dict, g: Glb) -> bytes:
    """Return the GLB bytes of a glTF document whose single buffer is `g`."""
    while len(g.bin) % 4:
        g.bin.append(0)
    gltf["buffers"][0]["byteLength"] = len(g.bin)
    js = dumps_json(gltf, indent=None).encode("ascii")
    js += b" " * ((4 - len(js) % 4) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(g.bin), 0x004E4942) + bytes(g.bin)
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body

