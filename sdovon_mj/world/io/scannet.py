"""The scan mode's files (ScanNet layout): the fused PLY, its over-segmentation and the instance aggregation."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..files import dumps_json, write_bytes
from ..model import Apartment
from ..scan import ScanMesh, make_scan


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



def write_scannet(apartment: Apartment, out: Path, name: str, noise_sigma: float = 0.003, max_faces: int = 300_000) -> Path:
    """Write ``<name>_vh_clean.ply`` (+Z up), ``<name>_vh_clean.segs.json`` and ``<name>.aggregation.json``; return the PLY.

    Parameters
    ----------
    apartment : Apartment
        The generated home.
    out : Path
        Output folder.
    name : str
        File stem.
    noise_sigma : float
        Surface noise std along the normals, metres.
    max_faces : int
        About the most faces of the re-meshed scan.
    """
    scan = make_scan(apartment, noise_sigma=noise_sigma, max_faces=max_faces)
    mesh_path = out / f"{name}_vh_clean.ply"
    write_bytes(mesh_path, ply_bytes(scan, f"sdovon-mj procedural scan, seed {apartment.seed}"))
    segs_name = f"{name}_vh_clean.segs.json"
    write_bytes(out / segs_name, dumps_json({"sceneId": name, "segIndices": [int(s) for s in scan.segments]}, None).encode())
    groups = []
    for inst in apartment.instances:
        segs = np.unique(scan.segments[scan.vertex_instance == inst.id])
        if len(segs) == 0:
            continue
        groups.append({"id": inst.id, "objectId": inst.id, "label": inst.label, "segments": [int(s) for s in segs]})
    agg = {"sceneId": name, "segGroups": groups, "segmentsFile": segs_name}
    write_bytes(out / f"{name}.aggregation.json", dumps_json(agg, None).encode())
    return mesh_path
