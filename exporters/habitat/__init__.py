"""Habitat exporter: habitat-sim scene dataset + habitat-lab ObjectNav-v1 episodes (docs/formats/habitat.md;
the rules it keeps: docs/background.md, "Habitat export rules").

Layout under the output folder (``<name>`` = dataset name, ``<split>`` = split)::

    data/scene_datasets/<name>/<name>.scene_dataset_config.json
    data/scene_datasets/<name>/stages/<scene>.stage_config.json + <scene>.glb      (Y-up vertices)
    data/scene_datasets/<name>/objects/<asset>.object_config.json + <asset>.glb    (Y-up, body frame)
    data/scene_datasets/<name>/scenes/<variant>.scene_instance.json                (one per variant)
    data/scene_datasets/<name>/urdf/<scene>_<piece>/<scene>_<piece>.urdf + meshes  (articulated pieces, Z-up)
    data/datasets/objectnav/<name>/<split>/<split>.json.gz                         (category maps, no episodes)
    data/datasets/objectnav/<name>/<split>/content/<variant>.json.gz               (episodes + goals_by_category)

Use with habitat-lab from the output folder (CWD): ``habitat.dataset.data_path=
'data/datasets/objectnav/<name>/{split}/{split}.json.gz'``, ``habitat.dataset.scenes_dir=data/scene_datasets``.
Furniture is baked into the stage (it blocks habitat's rebuilt navmesh); placed objects are STATIC
instances. Variants without episodes (no valid goals) are reported and skipped.

Articulated pieces (``SceneAsset.articulated``, issue 17) stay out of the stage: their URDF (as world:scene wrote
it, with the meshes it names) is copied under ``urdf/`` and each variant's scene instance lists them in
``articulated_object_instances`` (habitat-sim's scene instance format): ``template_name`` (the URDF's stem, found
through the dataset config's ``articulated_objects`` paths), ``translation`` / ``rotation`` of the URDF root
(`frames.urdf_rotation_wxyz`; of its inertial frame when the root link has one, as habitat-sim places it; a
dataset's piece at any orientation and scale: `articulated_instance`), ``fixed_base``, and the variant's joint
state as ``initial_joint_pose`` (one value per movable joint, in the URDF's joint order) and by joint name in
``user_defined.joint_states``.
"""

from __future__ import annotations

import gzip
import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from sdovon_mj.errors import InputError
from sdovon_mj.records import ArticulatedFixture, Episode, Goal, SceneAsset, SceneVariant
from sdovon_mj.runview import RunLayout
from sdovon_mj.sim import GROUP_CEILING, GROUP_OBJECT_VISUAL, GROUP_SCENE
from sdovon_mj.sim.model import pose_settled
from sdovon_mj.store import atomic_write_bytes, dumps
from sdovon_mj.export import ExportOptions, ExportReport, ExportUnit, Exporter, RunView, UnitResult, merge_unit_results

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
    """Return ``json.dumps(_r(data), indent=1, sort_keys=True, ensure_ascii=False)`` + newline (the store's faster
    encoder gives exactly that text for finite data; json itself writes what it alone accepts: NaN, infinities)."""
    r = _r(data)
    try:
        return dumps(r)
    except ValueError:
        return json.dumps(r, indent=1, sort_keys=True, ensure_ascii=False) + "\n"


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


def _articulated_geoms(model: mujoco.MjModel) -> set[int]:
    """Return the geoms of articulated pieces (bodies ``art_<id>/...`` and their children): not part of the stage."""
    out = set()
    for g in range(model.ngeom):
        b = int(model.geom_bodyid[g])
        while b > 0:
            if (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or "").startswith("art_"):
                out.add(g)
                break
            b = int(model.body_parentid[b])
    return out


def _piece_urdf(run: RunView, scene: SceneAsset, fx: ArticulatedFixture) -> Path:
    """Return the source URDF of an articulated piece (its converted asset.json's ``source``)."""
    asset = run.path(fx.model).parent / "asset.json"
    try:
        src = str(json.loads(asset.read_text(encoding="utf-8"))["source"])
    except (OSError, json.JSONDecodeError, KeyError, TypeError) as e:
        raise InputError(asset, f"articulated piece {fx.instance_id}: no readable source URDF ({e})") from None
    for cand in (run.path(scene.source).parent / src, asset.parent / src, run.path(src)):
        if cand.is_file():
            return cand
    raise InputError(asset, f"articulated piece {fx.instance_id}: source URDF {src} not found")


def urdf_template_name(scene: str, urdf: Path) -> str:
    """Return the Habitat template name (and folder / file stem) of a scene's articulated piece URDF."""
    return f"{scene}_{urdf.stem}"


def urdf_files(urdf: Path) -> list[str]:
    """Return the URDF's mesh files (relative paths as written), in document order, each once."""
    try:
        root = ET.parse(urdf).getroot()
    except (OSError, ET.ParseError) as e:
        raise InputError(urdf, f"URDF does not parse ({e})") from None
    out: list[str] = []
    for m in root.iter("mesh"):
        f = m.get("filename", "")
        if f and f not in out:
            if f.startswith(("package://", "/")) or ".." in Path(f).parts:
                raise InputError(urdf, f"mesh {f!r}: only paths relative to the URDF's folder are exported")
            out.append(f)
    return out


def urdf_movable_joints(urdf: Path) -> list[tuple[str, float, float]]:
    """Return (name, lower, upper) of the URDF's movable joints (revolute, prismatic, continuous) in file order."""
    root = ET.parse(urdf).getroot()
    out = []
    for j in root.iter("joint"):
        if j.get("type") in ("revolute", "prismatic", "continuous"):
            lim = j.find("limit")
            lo = float(lim.get("lower", 0.0)) if lim is not None else 0.0
            hi = float(lim.get("upper", 0.0)) if lim is not None else 0.0
            out.append((str(j.get("name")), lo, hi))
    return out


def urdf_root_inertial(urdf: Path) -> np.ndarray:
    """Return the 4x4 inertial frame of a URDF's root link in that link's frame (identity when it has none)."""
    from scipy.spatial.transform import Rotation

    root = ET.parse(urdf).getroot()
    children = {c.get("link") for j in root.iter("joint") for c in j.findall("child")}
    T = np.eye(4)
    for link in root.findall("link"):
        if link.get("name") in children:
            continue
        o = link.find("inertial/origin")
        if o is not None:
            T[:3, :3] = Rotation.from_euler("xyz", [float(v) for v in o.get("rpy", "0 0 0").split()]).as_matrix()
            T[:3, 3] = [float(v) for v in o.get("xyz", "0 0 0").split()]
        break
    return T


def urdf_scale(urdf: Path) -> float:
    """Return the ``uniform_scale`` of the Habitat ``<stem>.ao_config.json`` beside a URDF (1 without one)."""
    cfg = urdf.with_name(urdf.stem + ".ao_config.json")
    if not cfg.is_file():
        return 1.0
    try:
        return float(json.loads(cfg.read_text(encoding="utf-8")).get("uniform_scale", 1.0))
    except (OSError, ValueError, TypeError, AttributeError) as e:
        raise InputError(cfg, f"articulated-object config does not read ({e})") from None


def articulated_instance(scene: str, fx: ArticulatedFixture, urdf: Path, state: dict[str, float]) -> dict[str, Any]:
    """Return a habitat-sim ``articulated_object_instances`` entry for a piece in a variant's joint state.

    habitat-sim puts the instance transform on the multibody's base, the root link's inertial frame: a URDF whose
    root link has an ``<inertial><origin>`` gets that frame's pose (``translation_origin: "COM"``), one without it
    its root frame's (``"asset_local"``). A piece converted at a scale (`ArticulatedFixture.scale`, times the
    ao_config's, which the copy leaves behind) carries it as ``uniform_scale``.

    Parameters
    ----------
    scene : str
        The scene name (prefix of the template name).
    fx : ArticulatedFixture
        The piece: root position (m, MuJoCo world), yaw (degrees) or full rotation (`quat`), scale, its parts'
        scene joint names.
    urdf : Path
        Its source URDF (joint order and names, root inertial frame).
    state : dict of str to float
        Scene joint name (``art_<id>/<joint>``) -> position (rad or m), e.g. ``SceneVariant.articulation``; joints
        missing here are at 0 clamped into their limits.
    """
    prefix = f"art_{fx.instance_id}/"
    joints = urdf_movable_joints(urdf)
    pose = [float(state.get(prefix + n, min(max(0.0, lo), hi) if hi > lo else 0.0)) for n, lo, hi in joints]
    scale = float(fx.scale) * urdf_scale(urdf)
    inertial = urdf_root_inertial(urdf)
    inertial[:3, 3] *= scale
    if np.array_equal(inertial, np.eye(4)):
        origin, translation = "asset_local", frames.position(fx.position)
        rotation = frames.urdf_rotation_wxyz(float(fx.yaw)) if fx.quat is None else \
            frames.urdf_rotation_matrix_wxyz(fx.rotation())
    else:
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = fx.rotation(), fx.position
        base = T @ inertial
        origin, translation = "COM", frames.position(base[:3, 3])
        rotation = frames.urdf_rotation_matrix_wxyz(base[:3, :3])
    return {"template_name": urdf_template_name(scene, urdf), "translation_origin": origin, "fixed_base": True,
            "motion_type": "DYNAMIC", "translation": translation, "rotation": rotation,
            **({"uniform_scale": scale} if scale != 1.0 else {}), "initial_joint_pose": pose,
            "user_defined": {"joint_states": {n: v for (n, _lo, _hi), v in zip(joints, pose)},
                             "instance_id": int(fx.instance_id), "label": fx.label}}


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
                     "start_filters": {k: float(v) for k, v in sorted(ep.start_filters.items())},
                     **_day_info(ep)},
            "goals": [], "start_room": None, "shortest_paths": None, "object_category": ep.object_category}


def _day_info(ep: Episode) -> dict[str, Any]:
    """Return an episode's day info ({} outside a chain of days): the day and each goal's history since the day
    before, keyed by its Habitat object id (habitat-lab's ObjectGoal takes no extra keys, so it lives in info)."""
    if ep.day is None:
        return {}
    return {"day": int(ep.day),
            "goal_history": {habitat_object_id(g.object_id, g.category): g.history or "" for g in ep.goals}}


OBJECTS_UNIT = "_objects"  # the object templates' unit (scene names never start with '_')


def _dataset_paths(out_dir: Path, options: ExportOptions) -> tuple[Path, Path, str]:
    """Return (scene dataset folder, episode dataset folder, dataset config path relative to out_dir)."""
    sd_rel = f"data/scene_datasets/{options.name}"
    ds_rel = f"data/datasets/objectnav/{options.name}/{options.split}"
    return Path(out_dir) / sd_rel, Path(out_dir) / ds_rel, f"{sd_rel}/{options.name}.scene_dataset_config.json"


# An episode's category in an episodes.json as the store writes it (`store.dumps`: a list of records, indent 1, so an
# episode's own keys sit two spaces in); nested records and dicts sit deeper.
_CATEGORY_LINE = re.compile(r'\n  "object_category": ("(?:[^"\\\n]|\\.)*")')


def _episode_categories(text: str) -> list[str] | None:
    """Return the categories of an episodes.json text written by the store, without parsing it whole; None when the
    text is not in that layout (the caller parses it then).

    A file of the store's layout holds one category line per episode record: every ``"object_category"`` key of the
    text is one of them (the key appears nowhere else in an Episode), and the list has that many records.
    """
    if not (text.startswith("[\n {") or text.strip() == "[]"):
        return None
    found = _CATEGORY_LINE.findall(text)
    if len(found) != text.count('"object_category"') or len(found) != text.count('\n {\n  "__record__": "Episode"'):
        return None
    return [str(json.loads(q)) for q in found]


def _category_maps(run: RunView) -> dict[str, dict[str, int]]:
    """Return the category id maps over every variant's episodes (read as raw JSON: only the categories)."""
    cats: set[str] = set()
    for scene in run.scene_names():
        layouts = ((RunLayout.episodes, RunLayout.variant_record), (RunLayout.day_episodes, RunLayout.day_record))
        files = [p for episodes, record in layouts for p in sorted(run.root.glob(episodes(scene)))
                 if run.path(record(scene, p.parent.name)).is_file()]  # a variant's or a day's (RunView.variants, days)
        for p in files:
            text = p.read_text(encoding="utf-8")
            found = _episode_categories(text)
            if found is not None:
                cats.update(found)
                continue
            try:
                rows = json.loads(text)
                cats.update(str(r["object_category"]) for r in rows)
            except (json.JSONDecodeError, KeyError, TypeError) as e:
                raise InputError(p, f"not a valid list of Episode records ({e})") from None
    cat_ids = {c: i for i, c in enumerate(sorted(cats))}
    return {"category_to_task_category_id": cat_ids, "category_to_scene_annotation_category_id": dict(cat_ids)}


class _Writer:
    """Writes files atomically and remembers them."""

    def __init__(self) -> None:
        self.written: list[Path] = []

    def __call__(self, path: Path, data: bytes) -> None:
        atomic_write_bytes(path, data)
        self.written.append(path)


class HabitatExporter(Exporter):
    """Writes a habitat-sim scene dataset and a habitat-lab ObjectNav-v1 dataset.

    Units: one per scene (its stage, scene instances and episode contents) and one for the object templates
    (each asset's template from its first use in variant order, as the serial export always did); every unit
    reads the whole run's categories, so the pipeline starts them when all variants are done.
    """

    name = "habitat"

    def units(self, run: RunView, options: ExportOptions) -> list[ExportUnit]:
        """Return one unit per scene and the object templates' unit."""
        return [ExportUnit(s, None) for s in run.scene_names()] + [ExportUnit(OBJECTS_UNIT, None)]

    def export_unit(self, run: RunView, out_dir: Path, options: ExportOptions, unit: ExportUnit) -> UnitResult:
        """Write one unit: a scene's files or the object templates."""
        out_dir = Path(out_dir)
        res = UnitResult(unit.key)
        write = _Writer()
        if unit.key == OBJECTS_UNIT:
            self._templates(run, out_dir, options, write)
        else:
            self._scene(run, out_dir, options, unit.key, res, write)
        res.files = sorted({p.relative_to(out_dir).as_posix() for p in write.written})
        return res

    def _scene(self, run: RunView, out_dir: Path, options: ExportOptions, scene_name: str, res: UnitResult,
               write: _Writer) -> None:
        """Write a scene's stage and its variants' scene instances and episode contents."""
        sd, ds, dataset_config = _dataset_paths(out_dir, options)
        maps = None
        for variant in run.dataset_variants(scene_name):
            eps = run.episodes(variant)
            if not eps:
                res.skipped[variant.name] = "no valid goals (zero episodes)"
                continue
            if maps is None:  # first variant with episodes: the stage, once
                maps = _category_maps(run)
                scene = run.scene(variant.scene)
                smodel, sdata = _compile(run.path(scene.mjcf))
                mujoco.mj_forward(smodel, sdata)
                moving = _articulated_geoms(smodel)  # articulated pieces are URDF instances, not stage
                geoms = [g for g in range(smodel.ngeom)
                         if int(smodel.geom_group[g]) in (GROUP_SCENE, GROUP_CEILING) and g not in moving]
                mesh = geoms_scene(smodel, sdata, geoms, np.eye(4), frames.C)  # textured where MuJoCo is
                if mesh is None:
                    raise InputError(run.path(scene.mjcf), "scene has no visual geometry to export as a stage")
                write(sd / "stages" / f"{scene.name}.glb", glb_bytes(mesh))
                write(sd / "stages" / f"{scene.name}.stage_config.json", _json({
                    "render_asset": f"{scene.name}.glb", "collision_asset": f"{scene.name}.glb", "up": UP, "front": FRONT,
                    "origin": [0.0, 0.0, 0.0], "units_to_meters": 1.0, "shader_type": "material"}).encode())
                urdfs = {}
                for fx in scene.articulated:  # each piece's URDF and meshes, once per scene
                    src = _piece_urdf(run, scene, fx)
                    name = urdf_template_name(scene.name, src)
                    for f in urdf_files(src):
                        if not (src.parent / f).is_file():
                            raise InputError(src, f"mesh {f} not found")
                        write(sd / "urdf" / name / f, (src.parent / f).read_bytes())
                    write(sd / "urdf" / name / f"{name}.urdf", src.read_bytes())
                    urdfs[fx.instance_id] = src
            model, data = _variant_model(run, variant)
            instances = []
            for p in sorted(variant.placements, key=lambda p: p.object_id):
                b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.object_id)
                if b < 0:
                    continue
                instances.append({"template_name": f"objects/{p.asset}.object_config.json", "motion_type": "STATIC",
                                  "translation_origin": "asset_local", "translation": frames.position(data.xpos[b]),
                                  "rotation": frames.body_rotation_wxyz(data.xquat[b])})
            write(sd / "scenes" / f"{variant.name}.scene_instance.json", _json({
                "stage_instance": {"template_name": f"stages/{variant.scene}.stage_config.json",
                                   "translation": [0.0, 0.0, 0.0], "rotation": [1.0, 0.0, 0.0, 0.0]},
                "translation_origin": "asset_local", "default_lighting": "", "object_instances": instances,
                **({"articulated_object_instances": [
                    articulated_instance(scene.name, fx, urdfs[fx.instance_id], dict(variant.articulation or {}))
                    for fx in scene.articulated]} if scene.articulated else {})}).encode())
            scene_id = f"{options.name}/scenes/{variant.name}.scene_instance.json"
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
            res.variants.append(variant.name)
            res.episodes += len(eps)

    def _templates(self, run: RunView, out_dir: Path, options: ExportOptions, write: _Writer) -> None:
        """Write each placed asset's object template from its first use (variant order, then object id)."""
        sd, _ds, _cfg = _dataset_paths(out_dir, options)
        objects = run.objects()
        done: set[str] = set()
        for variant in run.all_dataset_variants():
            todo = sorted((p for p in variant.placements if p.asset not in done), key=lambda p: p.object_id)
            if not todo or not run.episodes(variant):
                continue
            model, data = _variant_model(run, variant)
            for p in todo:
                b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.object_id)
                if b < 0 or p.asset in done:
                    continue
                T = np.eye(4)
                T[:3, :3] = data.xmat[b].reshape(3, 3)
                T[:3, 3] = data.xpos[b]
                mesh = geoms_scene(model, data, _body_geoms(model, b, (GROUP_OBJECT_VISUAL,)), T, frames.C)
                if mesh is None:
                    raise InputError(run.path(variant.mjcf), f"body {p.object_id} has no visual geoms (group 2)")
                mass = float(objects[p.asset].mass) if p.asset in objects else float(model.body_subtreemass[b])
                write(sd / "objects" / f"{p.asset}.glb", glb_bytes(mesh))
                write(sd / "objects" / f"{p.asset}.object_config.json", _json({
                    "render_asset": f"{p.asset}.glb", "collision_asset": f"{p.asset}.glb", "up": UP, "front": FRONT,
                    "scale": [1.0, 1.0, 1.0], "units_to_meters": 1.0, "mass": mass}).encode())
                done.add(p.asset)

    def finish(self, run: RunView, out_dir: Path, options: ExportOptions, results: list[UnitResult]) -> ExportReport:
        """Write the split file (category maps, no episodes) and the scene dataset config."""
        out_dir = Path(out_dir)
        sd, ds, _cfg = _dataset_paths(out_dir, options)
        report, written = merge_unit_results(self.name, out_dir, options.name, results)
        maps = _category_maps(run)
        articulated = any(run.scene(n).articulated for n in run.scene_names())
        write = _Writer()
        write(ds / f"{options.split}.json.gz", _gz({**maps, "episodes": []}))
        write(sd / f"{options.name}.scene_dataset_config.json", _json({
            "stages": {"default_attributes": {"up": UP, "front": FRONT, "origin": [0.0, 0.0, 0.0], "units_to_meters": 1.0},
                       "paths": {".json": ["stages"]}},
            "objects": {"default_attributes": {"up": UP, "front": FRONT, "units_to_meters": 1.0}, "paths": {".json": ["objects"]}},
            **({"articulated_objects": {"paths": {".urdf": ["urdf/*/"]}}} if articulated else {}),  # ReplicaCAD's form
            "scene_instances": {"paths": {".json": ["scenes"]}}}).encode())
        report.files = sorted({p.relative_to(out_dir).as_posix() for p in written + write.written})
        return report
