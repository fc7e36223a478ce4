"""A Habitat scene dataset (HSSD style): stage, object templates, semantic config and scene instance."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..files import dumps_json, num, write_bytes
from ..model import Apartment
from .glb import glb_bytes, zup_to_yup


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
    write_bytes(out / "stages" / f"{name}.glb", glb_bytes(apartment, name, ids=structure))
    write_bytes(out / "stages" / f"{name}.stage_config.json", dumps_json({
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
            return zup_to_yup((w - t) @ rz) * scale

        tname = f"{name}_{inst.id:04d}"
        write_bytes(out / "objects" / f"{tname}.glb", glb_bytes(apartment, tname, ids={inst.id}, to_file=to_file))
        write_bytes(out / "objects" / f"{tname}.object_config.json", dumps_json({
            "render_asset": f"{tname}.glb", "up": up, "front": front, "units_to_meters": 1.0 / scale,
            "semantic_id": class_id[inst.label]}).encode())
        t_hab = zup_to_yup(t[None])[0]
        rot = [float(np.cos(yaw / 2)), 0.0, float(np.sin(yaw / 2)), 0.0]  # wxyz: yaw about Habitat's +Y
        entry = {"template_name": f"objects/{tname}.object_config.json", "motion_type": "STATIC",
                 "translation_origin": "asset_local", "rotation": [num(x) for x in rot]}
        if inst.id % 2:
            # COM = the local bounding-box centre (Habitat's default): translation places it
            local = zup_to_yup((v - t) @ rz)
            com = (local.min(axis=0) + local.max(axis=0)) / 2
            r_hab = np.array([[c, 0.0, sn], [0.0, 1.0, 0.0], [-sn, 0.0, c]])
            t_hab = t_hab + r_hab @ com
            entry["translation_origin"] = "COM"
        entry["translation"] = [num(x) for x in t_hab]
        objects.append(entry)
    regions = []
    heights = {f.index: f.height for f in apartment.floors}
    for r in apartment.rooms:
        h = float(heights.get(r.floor, 0.0))
        loop = [[num(x), num(h), num(-y)] for x, y in np.asarray(r.polygon, dtype=float)]
        regions.append({"name": f"room_{r.id}", "label": r.type, "poly_loop": loop, "floor_height": num(h),
                        "extrusion_height": num(apartment.wall_height)})
    write_bytes(out / "semantics" / f"{name}.semantic_config.json", dumps_json({
        "classes": [{"id": class_id[c], "name": c} for c in classes], "region_annotations": regions}).encode())
    scene_path = out / "scenes" / f"{name}.scene_instance.json"
    write_bytes(scene_path, dumps_json({
        "stage_instance": {"template_name": f"stages/{name}.stage_config.json", "translation": [0.0, 0.0, 0.0],
                           "rotation": [1.0, 0.0, 0.0, 0.0]},
        "translation_origin": "asset_local", "default_lighting": "", "object_instances": objects,
        "semantic_scene_instance": name}).encode())
    write_bytes(out / f"{name}.scene_dataset_config.json", dumps_json({
        "stages": {"default_attributes": {"up": up, "front": front}, "paths": {".json": ["stages"]}},
        "objects": {"default_attributes": {"up": up, "front": front}, "paths": {".json": ["objects"]}},
        "scene_instances": {"paths": {".json": ["scenes"]}},
        "semantic_scene_descriptor_instances": {name: f"semantics/{name}.semantic_config.json"}}).encode())
    return scene_path
