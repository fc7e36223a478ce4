"""Multi-scene Habitat scene datasets written from the default world (test and bench fixtures, not shipped data).

`write_scene_dataset` writes one default-world apartment in the Habitat layout (`sdovon_mj.world.write_apartment`,
mode "habitat": a ``*.scene_dataset_config.json``, one stage, one object template per furniture piece, a semantic
config with the rooms) and then several scene instances over that one stage and those templates, as HSSD ships a
cluttered and an uncluttered instance of one house: scene ``house_a`` places every object, ``house_b`` leaves out
every second one, ``house_c`` every third one, and so on. ``broken=True`` adds ``house_broken``: every object of
``house_a`` plus one whose template's render asset is a well-formed GLB holding points and no triangle, so it
passes an input check (its files exist and parse) and fails its conversion.
"""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ["SCENE_NAMES", "write_scene_dataset"]

SCENE_NAMES = ("house_a", "house_b", "house_c", "house_d", "house_e", "house_f")


def write_scene_dataset(out: str | Path, scenes: int = 3, seed: int = 0, broken: bool = False) -> Path:
    """Write a Habitat scene dataset of `scenes` scene instances sharing one stage and its object templates.

    Returns the ``*.scene_dataset_config.json`` path. Scene k (``SCENE_NAMES[k]``) places the apartment's object
    instances except every (k+1)-th one (k = 0: all of them); ``broken`` adds ``house_broken`` (see the module
    docstring). The apartment is default-world apartment `seed` with one floor.
    """
    import numpy as np
    import trimesh

    from sdovon_mj.world import generate_apartment, write_apartment

    if not 1 <= scenes <= len(SCENE_NAMES):
        raise ValueError(f"scenes must be 1..{len(SCENE_NAMES)}, got {scenes}")
    out = Path(out)
    first = write_apartment(generate_apartment(seed, floors=1), out, mode="habitat", name="apt")
    doc = json.loads(first.read_text(encoding="utf-8"))
    first.unlink()
    objects = doc["object_instances"]
    for k in range(scenes):
        keep = [o for i, o in enumerate(objects) if k == 0 or i % (k + 1) != 0]
        _write(first.parent / f"{SCENE_NAMES[k]}.scene_instance.json", {**doc, "object_instances": keep})
    if broken:
        glb = out / "objects" / "broken_points.glb"
        points = trimesh.PointCloud(np.random.default_rng(seed).random((64, 3)))
        glb.write_bytes(trimesh.Scene(points).export(file_type="glb"))
        _write(out / "objects" / "broken_points.object_config.json",
               {"render_asset": glb.name, "up": [0.0, 1.0, 0.0], "front": [0.0, 0.0, -1.0]})
        extra = {"template_name": "objects/broken_points.object_config.json", "motion_type": "STATIC",
                 "translation": [0.0, 0.5, 0.0], "rotation": [1.0, 0.0, 0.0, 0.0]}
        _write(first.parent / "house_broken.scene_instance.json", {**doc, "object_instances": objects + [extra]})
    return out / "apt.scene_dataset_config.json"


def _write(path: Path, doc: dict) -> None:
    """Write a JSON file (indented, sorted keys as the world writers do)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n", encoding="utf-8")
