"""What the browser viewer shows, as JSON-able payloads built from a run folder (read through `RunView`) and the
per-episode results of `sdovon-mj eval --out` (read by `read_evaluations`).

Three payloads, each one data file of the page (`sdovon_mj.viewer.site`):

- the index: scenes, their variants and floors, the object categories and their colours, the evaluated agents;
- a scene: its static visual geoms (light mesh, `viewer.geometry`), its ceiling apart, region maps and navigable
  maps per floor (grids), receptacle planes (polygons with label, region, height);
- a variant: its placed objects (category, colour, pose, status; one light mesh per object asset), its articulated
  parts posed in the variant's state, its goals (objects, boxes, view points) and episodes (start pose, category,
  goals, distances), and each evaluated agent's result per episode (trajectory and every scalar field it wrote).

Arrays travel as base64 of little-endian typed arrays (`encode`), which the page decodes without a parser.
"""

from __future__ import annotations

import base64
import colorsys
import json
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..store import json_safe
from ..geometry import quat_yaw
from ..records import Episode, ObjectAsset, SceneAsset, SceneVariant
from ..runview import RunLayout, RunView
from ..sim import GROUP_CEILING, GROUP_OBJECT_VISUAL as GROUP_OBJECT, GROUP_SCENE
from .geometry import Triangles, cluster_decimate, model_triangles

FORMAT = 1  # bump when a payload's shape changes (the page checks it)
SCENE_FACES = 400_000  # triangle budget of a scene's static mesh: a laptop's integrated GPU draws this smoothly
OBJECT_FACES = 4_000  # per object asset (a demo run has dozens of objects; a scan-derived one can have 100k+)
CEILING_LABELS = ("ceiling", "roof")
_INST = re.compile(r"^inst_(\d+)(?:_\d+)?$")  # a scene instance's geom names (naming contract, sim/model.py)


def encode(arr: np.ndarray, dtype: str) -> dict[str, Any]:
    """Return an array as {"b64", "dtype", "shape"} (little-endian `dtype`: f4, u4, i4, u2, i2, u1)."""
    a = np.ascontiguousarray(np.asarray(arr).astype("<" + dtype if dtype[0] not in "<>|" else dtype))
    return {"b64": base64.b64encode(a.tobytes()).decode("ascii"), "dtype": dtype.lstrip("<>|"), "shape": list(a.shape)}


def palette(names: list[str], saturation: float = 0.7, value: float = 0.95, offset: float = 0.0) -> dict[str, str]:
    """Return name -> '#rrggbb' for sorted names, hues spread by the golden angle (neighbours in the list differ)."""
    out = {}
    for i, n in enumerate(sorted(set(names))):
        h = (offset + i * 0.381966) % 1.0
        r, g, b = colorsys.hsv_to_rgb(h, saturation, value)
        out[n] = "#%02x%02x%02x" % (round(r * 255), round(g * 255), round(b * 255))
    return out


def to_json(payload: dict[str, Any]) -> str:
    """Return a payload as compact JSON text (ASCII, no NaN)."""
    return json.dumps(json_safe(payload), separators=(",", ":"), ensure_ascii=True, allow_nan=False)


# -- evaluation results ----------------------------------------------------------------------------------------------


@dataclass
class Evaluations:
    """Per-episode results of `sdovon-mj eval --out` runs: agent label -> (variant, episode id) -> result dict."""

    agents: dict[str, dict[tuple[str, str], dict[str, Any]]] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)  # files that were no episode result, with why

    def for_variant(self, variant: str, episode_ids: set[str]) -> dict[str, dict[str, dict[str, Any]]]:
        """Return agent -> episode id -> result for one variant's episodes (results naming another variant left out)."""
        out: dict[str, dict[str, dict[str, Any]]] = {}
        for agent, rows in self.agents.items():
            got = {eid: r for (v, eid), r in rows.items() if v == variant and eid in episode_ids}
            if got:
                out[agent] = got
        return out


def _result_files(root: Path) -> list[Path]:
    """Return the per-episode JSON files of an eval output folder (``episodes/<agent>/*.json``), or of one agent's
    folder, or the file itself."""
    if root.is_file():
        return [root]
    if (root / "episodes").is_dir():
        return sorted((root / "episodes").glob("*/*.json"))
    return sorted(root.glob("*.json")) or sorted(root.glob("*/*.json"))


def read_evaluations(dirs: list[str | Path]) -> Evaluations:
    """Read the per-episode results that `sdovon-mj eval --out DIR` writes (``DIR/episodes/<agent>/<episode>.json``).

    Tolerant of what the format adds later: a result needs ``episode_id`` and ``variant`` and may carry
    ``trajectory`` (a list of [x, y(, z)] world positions, m); every other field is kept as it is. A file that is
    no such result is skipped and named in `Evaluations.skipped`. An agent's label is its ``agent`` field, else its
    folder's name. Raises InputError when a folder does not exist or holds no result at all.
    """
    ev = Evaluations()
    for d in dirs:
        root = Path(d)
        if not root.exists():
            raise InputError(root, "evaluation folder not found")
        found = 0
        for p in _result_files(root):
            try:
                r = json.loads(p.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
                ev.skipped.append(f"{p}: not JSON ({e})")
                continue
            if not isinstance(r, dict) or not isinstance(r.get("episode_id"), str) or not isinstance(r.get("variant"), str):
                ev.skipped.append(f"{p}: no episode_id and variant")
                continue
            traj = r.get("trajectory")
            try:
                r["trajectory"] = [] if traj is None else np.asarray(traj, dtype=float).reshape(len(traj), -1)[:, :3].tolist()
            except (TypeError, ValueError):
                ev.skipped.append(f"{p}: trajectory is not a list of positions")
                continue
            agent = str(r.get("agent") or p.parent.name)
            ev.agents.setdefault(agent, {})[(r["variant"], r["episode_id"])] = r
            found += 1
        if not found:
            raise InputError(root, "holds no per-episode result of `sdovon-mj eval --out` (episodes/<agent>/*.json)")
    return ev


def _scalars(r: dict[str, Any]) -> dict[str, Any]:
    """Return the scalar fields of a result (numbers, strings, booleans), the ones the page lists."""
    return {k: v for k, v in r.items() if isinstance(v, (str, int, float, bool)) or v is None}


# -- payloads --------------------------------------------------------------------------------------------------------


def _mesh_payload(t: Triangles, with_ids: bool = True) -> dict[str, Any]:
    out = {"positions": encode(t.vertices, "f4"), "colors": encode(t.colors, "u1"), "indices": encode(t.faces, "u4")}
    if with_ids:
        out["face_id"] = encode(t.face_id, "i4")
    return out


def _grid(grid: np.ndarray, origin: np.ndarray, resolution: float) -> dict[str, Any]:
    return {"origin": [float(origin[0]), float(origin[1])], "resolution": float(resolution),
            "shape": list(grid.shape), "cells": encode(grid, "u1")}


class SceneModels:
    """The compiled MJCF models of a run's scenes (one compile per scene, kept for its variants)."""

    def __init__(self, view: RunView) -> None:
        self.view = view
        self._models: dict[str, tuple[Any, Any]] = {}

    def get(self, scene: SceneAsset) -> tuple[Any, Any]:
        """Return (MjModel, MjData) of a scene's MJCF (InputError naming the file when it does not compile)."""
        import mujoco

        if scene.name not in self._models:
            path = self.view.path(scene.mjcf)
            try:
                model = mujoco.MjModel.from_xml_path(str(path))
            except (ValueError, OSError) as e:
                raise InputError(path, f"scene MJCF does not load: {e}") from None
            self._models[scene.name] = (model, mujoco.MjData(model))
        return self._models[scene.name]


def _instance_of(model: Any, g: int) -> int:
    """Return the scene instance id a geom belongs to (geoms ``inst_<k>`` / ``inst_<k>_<j>``, sim.model), else -1."""
    import mujoco

    m = _INST.match(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "")
    return int(m.group(1)) if m else -1


def index_payload(view: RunView, evals: Evaluations | None = None, title: str = "") -> dict[str, Any]:
    """Return the index: scenes with floors and variants, categories with colours, agents."""
    scenes, categories, regions = [], set(), set()
    for name in view.scene_names():
        s = view.scene(name)
        variants = []
        for v in view.variants(name):
            eps = view.episodes(v)
            categories.update(p.category for p in v.placements)
            variants.append({"name": v.name, "objects": len(v.placements), "resting": len(v.resting), "episodes": len(eps)})
        for rm in view.region_maps(name):
            regions.update(rm.labels)
        scenes.append({"name": name, "floors": [{"index": f.index, "height": f.height} for f in s.floors],
                       "variants": variants})
    if not title:  # the run's name from its config, and its folder
        name = view.config().name if view.path(RunLayout.CONFIG).is_file() else ""
        title = f"{name} ({view.root.name})" if name and name != view.root.name else view.root.name
    return {"format": FORMAT, "title": title, "run": str(view.root), "scenes": scenes,
            "categories": palette(sorted(categories)), "regions": palette(sorted(regions), 0.45, 0.9, 0.1),
            "agents": sorted(evals.agents) if evals else []}


def scene_payload(view: RunView, name: str, models: SceneModels | None = None, max_faces: int = SCENE_FACES) -> dict[str, Any]:
    """Return a scene's payload: static mesh (ceiling apart), region maps, navigable maps and receptacle planes.

    Geoms on bodies that move (articulated parts) are left to the variant payload, which poses them.
    """
    models = models or SceneModels(view)
    scene = view.scene(name)
    model, data = models.get(scene)
    labels = {int(i.id): i.label for i in scene.instances}
    static = model.body_weldid[model.geom_bodyid] == 0
    ceiling_ids = {i for i, lab in labels.items() if lab.lower() in CEILING_LABELS}

    def fid(g: int) -> int:
        return _instance_of(model, g)

    def is_ceiling(g: int) -> bool:
        return int(model.geom_group[g]) == GROUP_CEILING or fid(g) in ceiling_ids

    main = model_triangles(model, data, lambda g: bool(static[g]) and int(model.geom_group[g]) == GROUP_SCENE
                           and not is_ceiling(g), fid)
    ceiling = model_triangles(model, data, lambda g: bool(static[g]) and is_ceiling(g), fid)
    full = main.face_count
    main = cluster_decimate(main, max_faces)
    ceiling = cluster_decimate(ceiling, max(max_faces // 10, 1000))
    navmaps = view.navmaps(name)
    floors = []
    for nm in navmaps:
        grid = np.where(nm.navigable, 2, np.where(nm.free, 1, 0)).astype(np.uint8)
        floors.append({"floor": nm.floor, "height": nm.height, "navmap": _grid(grid, nm.origin, nm.resolution)})
    free = {nm.floor: nm for nm in navmaps}
    regions = []
    for rm in view.region_maps(name):
        cells = np.asarray(rm.label_map, np.int64) + 1  # 0: unknown
        nm = free.get(rm.floor)
        if nm is not None and nm.free.shape == cells.shape:
            cells = np.where(nm.free, cells, 0)
        height = nm.height if nm is not None else next((f.height for f in scene.floors if f.index == rm.floor), 0.0)
        regions.append({"floor": rm.floor, "height": height, "labels": list(rm.labels),
                        "grid": _grid(cells.astype(np.uint8), rm.origin, rm.resolution), "backend": rm.backend})
    planes = [{"id": p.id, "label": p.label, "region": p.region, "height": p.height, "floor": p.floor,
               "instance": p.instance_id, "part": p.part, "polygon": np.asarray(p.polygon, float).round(4).tolist()}
              for p in view.planes(name)]
    bounds = scene.bounds if scene.bounds is not None else (
        np.stack([main.vertices.min(axis=0), main.vertices.max(axis=0)]) if main.face_count else np.zeros((2, 3)))
    return {"format": FORMAT, "name": name, "bounds": np.asarray(bounds, float).tolist(),
            "floors": floors, "regions": regions, "planes": planes,
            "instances": {str(k): v for k, v in sorted(labels.items())},
            "mesh": _mesh_payload(main), "ceiling": _mesh_payload(ceiling),
            "faces": {"shown": main.face_count, "full": full}}


def _object_mesh(view: RunView, asset: ObjectAsset, max_faces: int) -> Triangles:
    """Return an object asset's visual geoms (group 2; every geom when it has none) in its own frame, decimated."""
    import mujoco

    path = view.path(asset.mjcf)
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except (ValueError, OSError) as e:
        raise InputError(path, f"object MJCF does not load: {e}") from None
    data = mujoco.MjData(model)
    visual = [g for g in range(model.ngeom) if int(model.geom_group[g]) == GROUP_OBJECT]
    keep = set(visual) if visual else set(range(model.ngeom))
    return cluster_decimate(model_triangles(model, data, lambda g: g in keep), max_faces)


def variant_payload(view: RunView, variant: SceneVariant, evals: Evaluations | None = None,
                    models: SceneModels | None = None, object_cache: dict[str, Triangles] | None = None,
                    max_object_faces: int = OBJECT_FACES) -> dict[str, Any]:
    """Return a variant's payload: objects (with their asset meshes), posed articulated parts, goals, episodes and
    the evaluated agents' results on its episodes.

    Parameters
    ----------
    view
        The run.
    variant
        One of its variants.
    evals
        Evaluation results to attach (None: none).
    models
        Compiled scene models to reuse across variants (default: compile here).
    object_cache
        Asset name -> light mesh, shared across variants (filled here).
    max_object_faces
        Triangle budget of one object asset's mesh.
    """
    import mujoco

    models = models or SceneModels(view)
    object_cache = {} if object_cache is None else object_cache
    library = view.objects()
    objects, assets = [], {}
    for p in variant.placements:
        if p.settled_pos is None:
            continue
        if p.asset not in object_cache and p.asset in library:
            object_cache[p.asset] = _object_mesh(view, library[p.asset], max_object_faces)
        if p.asset in object_cache and p.asset not in assets:
            assets[p.asset] = _mesh_payload(object_cache[p.asset], with_ids=False)
        q = p.settled_quat if p.settled_quat is not None else np.array([1.0, 0.0, 0.0, 0.0])
        bbox = library[p.asset].bbox if p.asset in library else None
        objects.append({"id": p.object_id, "category": p.category, "asset": p.asset, "status": p.status,
                        "region": p.region, "position": np.asarray(p.settled_pos, float).round(5).tolist(),
                        "quat": np.asarray(q, float).round(6).tolist(), "part": p.part,
                        "bbox": None if bbox is None else np.asarray(bbox, float).tolist()})
    # articulated parts (bodies with joints) in the variant's state
    scene = view.scene(variant.scene)
    model, data = models.get(scene)
    moving = model.body_weldid[model.geom_bodyid] != 0
    parts = Triangles.empty()
    if np.any(moving & (model.geom_group == GROUP_SCENE)):
        data.qpos[:] = model.qpos0
        for joint, value in (variant.articulation or {}).items():
            j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
            if j >= 0:
                data.qpos[int(model.jnt_qposadr[j])] = float(value)
        parts = model_triangles(model, data, lambda g: bool(moving[g]) and int(model.geom_group[g]) == GROUP_SCENE,
                                lambda g: _instance_of(model, g))
        parts = cluster_decimate(parts, SCENE_FACES // 4)
    episodes = view.episodes(variant)
    goals: dict[str, dict[str, Any]] = {}
    eps = []
    for e in episodes:
        for g in e.goals:
            if g.object_id not in goals:
                vps = np.array([vp.position for vp in g.view_points], float).reshape(-1, 3)
                goals[g.object_id] = {"object_id": g.object_id, "category": g.category,
                                      "position": np.asarray(g.position, float).round(5).tolist(),
                                      "bounds": None if g.bounds is None else np.asarray(g.bounds, float).round(5).tolist(),
                                      "open_part": g.open_part, "view_points": encode(vps, "f4")}
        eps.append(_episode(e))
    results = evals.for_variant(variant.name, {e.episode_id for e in episodes}) if evals else {}
    res = {agent: {eid: {"metrics": _scalars(r), "trajectory": r.get("trajectory") or []} for eid, r in rows.items()}
           for agent, rows in results.items()}
    return {"format": FORMAT, "name": variant.name, "scene": variant.scene, "objects": objects, "assets": assets,
            "parts": _mesh_payload(parts), "goals": goals, "episodes": eps, "results": res}


def _episode(e: Episode) -> dict[str, Any]:
    return {"id": e.episode_id, "category": e.object_category, "floor": e.floor,
            "start": np.asarray(e.start_position, float).round(5).tolist(), "yaw": round(quat_yaw(e.start_rotation), 3),
            "goals": [g.object_id for g in e.goals], "geodesic": e.geodesic_distance, "euclidean": e.euclidean_distance}


def warn(msg: str) -> None:
    """Print a warning line on stderr."""
    print(f"sdovon-mj view: warning: {msg}", file=sys.stderr)
