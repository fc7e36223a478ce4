"""Habitat exporter: habitat-sim scene dataset + habitat-lab ObjectNav-v1 episodes (research/habitat_format.md section 6).

Layout under the output folder (``<name>`` = dataset name, ``<split>`` = split)::

    data/scene_datasets/<name>/<name>.scene_dataset_config.json
    data/scene_datasets/<name>/stages/<scene>.stage_config.json + <scene>.glb      (Y-up vertices)
    data/scene_datasets/<name>/objects/<asset>.object_config.json + <asset>.glb    (Y-up, body frame)
    data/scene_datasets/<name>/scenes/<variant>.scene_instance.json                (one per variant)
    data/datasets/objectnav/<name>/<split>/<split>.json.gz                         (category maps, no episodes)
    data/datasets/objectnav/<name>/<split>/content/<variant>.json.gz               (episodes + goals_by_category)

Use with habitat-lab from the output folder (CWD): ``habitat.dataset.data_path=
'data/datasets/objectnav/<name>/{split}/{split}.json.gz'``, ``habitat.dataset.scenes_dir=data/scene_datasets``.
Furniture is baked into the stage (it blocks habitat's rebuilt navmesh); placed objects are STATIC
instances. Variants without episodes (no valid goals) are reported and skipped.
"""

from __future__ import annotations

import gzip
import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from sdovon_mj.errors import InputError
from sdovon_mj.records import Episode, Goal, SceneVariant
from sdovon_mj.sim import GROUP_CEILING, GROUP_OBJECT_VISUAL, GROUP_SCENE
from sdovon_mj.sim.model import pose_settled
from sdovon_mj.store import atomic_write_bytes
from sdovon_mj.export import ExportOptions, ExportReport, Exporter, RunView, exportable_variants

import mujoco  # after sdovon_mj, whose package entry sets MUJOCO_GL

from . import frames
from .glb import geoms_scene, glb_bytes

UP, FRONT = [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]
_OBJ_NUM = re.compile(r"^obj_(\d+)$")


def _r(v: Any, nd: int = 6) -> Any:
    """Round floats (recursively) for stable, readable JSON."""
    if isinstance(v, float):
        return round(v, nd) + 0.0
    if isinstance(v, (list, tuple)):
        return [_r(x, nd) for x in v]
    if isinstance(v, dict):
        return {k: _r(x, nd) for k, x in v.items()}
    return v


def _json(data: Any) -> str:
    return json.dumps(_r(data), indent=1, sort_keys=True, ensure_ascii=False) + "\n"


def _gz(data: Any) -> bytes:
    return gzip.compress(_json(data).encode("utf-8"), mtime=0)


def habitat_object_id(object_id: str, category: str) -> str:
    """Return the Habitat goal object id '<category>_<n>' of a placed object 'obj_<n>'."""
    m = _OBJ_NUM.match(object_id)
    return f"{category}_{int(m.group(1)) if m else object_id}"


def _compile(path: Path) -> tuple[mujoco.MjModel, mujoco.MjData]:
    if not path.exists():
        raise InputError(path, "MJCF not found")
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as e:
        raise InputError(path, f"MJCF does not compile: {e}") from None
    return model, mujoco.MjData(model)


def _variant_model(run: RunView, variant: SceneVariant) -> tuple[mujoco.MjModel, mujoco.MjData]:
    path = run.path(variant.mjcf)
    model, data = _compile(path)
    pose_settled(model, data, variant.qpos, path)
    return model, data


def _body_geoms(model: mujoco.MjModel, body: int, groups: tuple[int, ...]) -> list[int]:
    out = []
    for g in range(model.ngeom):
        b = int(model.geom_bodyid[g])
        while b > 0 and b != body:
            b = int(model.body_parentid[b])
        if b == body and int(model.geom_group[g]) in groups:
            out.append(g)
    return out


def view_point_json(vp) -> dict[str, Any]:
    """Return a ViewPoint as a Habitat ObjectViewLocation."""
    return {"agent_state": {"position": frames.position(vp.position), "rotation": frames.agent_rotation_xyzw(vp.rotation)},
            "iou": float(vp.visible_fraction)}


def goal_json(goal: Goal) -> dict[str, Any]:
    """Return a Goal as a Habitat ObjectGoal (exactly the ObjectGoal keys)."""
    oid = habitat_object_id(goal.object_id, goal.category)
    return {"object_id": oid, "object_name": oid, "object_name_id": None, "object_category": goal.category,
            "room_id": None, "room_name": None, "position": frames.position(goal.position), "radius": None,
            "view_points": [view_point_json(vp) for vp in goal.view_points]}


def episode_json(ep: Episode, index: int, scene_id: str, dataset_config: str) -> dict[str, Any]:
    """Return an Episode as a Habitat ObjectGoalNavEpisode (extras in info)."""
    closest = next((g for g in ep.goals if g.object_id == ep.closest_goal_object_id), None)
    return {"episode_id": str(index), "scene_id": scene_id, "scene_dataset_config": dataset_config,
            "additional_obj_config_paths": [], "start_position": frames.position(ep.start_position),
            "start_rotation": frames.agent_rotation_xyzw(ep.start_rotation),
            "info": {"geodesic_distance": float(ep.geodesic_distance), "euclidean_distance": float(ep.euclidean_distance),
                     "closest_goal_object_id": habitat_object_id(ep.closest_goal_object_id, closest.category) if closest else "",
                     "sdovon_episode_id": ep.episode_id, "variant": ep.variant, "scene": ep.scene, "floor": int(ep.floor),
                     "start_filters": {k: float(v) for k, v in sorted(ep.start_filters.items())}},
            "goals": [], "start_room": None, "shortest_paths": None, "object_category": ep.object_category}


class HabitatExporter(Exporter):
    """Writes a habitat-sim scene dataset and a habitat-lab ObjectNav-v1 dataset."""

    name = "habitat"

    def export(self, run: RunView, out_dir: Path, options: ExportOptions) -> ExportReport:
        """Write the run as a Habitat dataset under out_dir/data."""
        name, split = options.name, options.split
        out_dir = Path(out_dir)
        sd_rel = f"data/scene_datasets/{name}"
        ds_rel = f"data/datasets/objectnav/{name}/{split}"
        sd, ds = out_dir / sd_rel, out_dir / ds_rel
        dataset_config = f"{sd_rel}/{name}.scene_dataset_config.json"
        report = ExportReport(format=self.name, out_dir=str(out_dir), name=name)
        objects = run.objects()
        # Pass 1: which variants have episodes.
        todo = list(exportable_variants(run, report))
        categories = sorted({ep.object_category for _v, eps in todo for ep in eps})
        cat_ids = {c: i for i, c in enumerate(categories)}
        maps = {"category_to_task_category_id": cat_ids, "category_to_scene_annotation_category_id": dict(cat_ids)}
        written: list[Path] = []

        def write(rel_path: Path, data: bytes) -> None:
            atomic_write_bytes(rel_path, data)
            written.append(rel_path)

        stages_done: set[str] = set()
        templates_done: set[str] = set()
        for variant, eps in todo:
            if variant.scene not in stages_done:
                scene = run.scene(variant.scene)
                smodel, sdata = _compile(run.path(scene.mjcf))
                mujoco.mj_forward(smodel, sdata)
                geoms = [g for g in range(smodel.ngeom) if int(smodel.geom_group[g]) in (GROUP_SCENE, GROUP_CEILING)]
                mesh = geoms_scene(smodel, sdata, geoms, np.eye(4), frames.C)  # textured where MuJoCo is
                if mesh is None:
                    raise InputError(run.path(scene.mjcf), "scene has no visual geometry to export as a stage")
                write(sd / "stages" / f"{scene.name}.glb", glb_bytes(mesh))
                write(sd / "stages" / f"{scene.name}.stage_config.json", _json({
                    "render_asset": f"{scene.name}.glb", "collision_asset": f"{scene.name}.glb", "up": UP, "front": FRONT,
                    "origin": [0.0, 0.0, 0.0], "units_to_meters": 1.0, "shader_type": "material"}).encode())
                stages_done.add(variant.scene)
            model, data = _variant_model(run, variant)
            instances = []
            for p in sorted(variant.placements, key=lambda p: p.object_id):
                b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.object_id)
                if b < 0:
                    continue
                T = np.eye(4)
                T[:3, :3] = data.xmat[b].reshape(3, 3)
                T[:3, 3] = data.xpos[b]
                if p.asset not in templates_done:
                    mesh = geoms_scene(model, data, _body_geoms(model, b, (GROUP_OBJECT_VISUAL,)), T, frames.C)
                    if mesh is None:
                        raise InputError(run.path(variant.mjcf), f"body {p.object_id} has no visual geoms (group 2)")
                    mass = float(objects[p.asset].mass) if p.asset in objects else float(model.body_subtreemass[b])
                    write(sd / "objects" / f"{p.asset}.glb", glb_bytes(mesh))
                    write(sd / "objects" / f"{p.asset}.object_config.json", _json({
                        "render_asset": f"{p.asset}.glb", "collision_asset": f"{p.asset}.glb", "up": UP, "front": FRONT,
                        "scale": [1.0, 1.0, 1.0], "units_to_meters": 1.0, "mass": mass}).encode())
                    templates_done.add(p.asset)
                instances.append({"template_name": f"objects/{p.asset}.object_config.json", "motion_type": "STATIC",
                                  "translation_origin": "asset_local", "translation": frames.position(data.xpos[b]),
                                  "rotation": frames.body_rotation_wxyz(data.xquat[b])})
            write(sd / "scenes" / f"{variant.name}.scene_instance.json", _json({
                "stage_instance": {"template_name": f"stages/{variant.scene}.stage_config.json",
                                   "translation": [0.0, 0.0, 0.0], "rotation": [1.0, 0.0, 0.0, 0.0]},
                "translation_origin": "asset_local", "default_lighting": "", "object_instances": instances}).encode())
            scene_id = f"{name}/scenes/{variant.name}.scene_instance.json"
            basename = f"{variant.name}.scene_instance.json"
            goals_by_cat: dict[str, dict[str, Goal]] = {}
            for ep in eps:
                for g in ep.goals:
                    goals_by_cat.setdefault(ep.object_category, {})[g.object_id] = g
            content = dict(maps)
            content["goals_by_category"] = {f"{basename}_{c}": [goal_json(g) for _k, g in sorted(gs.items())]
                                            for c, gs in sorted(goals_by_cat.items())}
            content["episodes"] = [episode_json(ep, i, scene_id, dataset_config) for i, ep in enumerate(eps)]
            write(ds / "content" / f"{variant.name}.json.gz", _gz(content))
            report.variants.append(variant.name)
            report.episodes += len(eps)
        write(ds / f"{split}.json.gz", _gz({**maps, "episodes": []}))
        write(sd / f"{name}.scene_dataset_config.json", _json({
            "stages": {"default_attributes": {"up": UP, "front": FRONT, "origin": [0.0, 0.0, 0.0], "units_to_meters": 1.0},
                       "paths": {".json": ["stages"]}},
            "objects": {"default_attributes": {"up": UP, "front": FRONT, "units_to_meters": 1.0}, "paths": {".json": ["objects"]}},
            "scene_instances": {"paths": {".json": ["scenes"]}}}).encode())
        report.files = sorted(p.relative_to(out_dir).as_posix() for p in written)
        return report
