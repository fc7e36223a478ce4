"""Articulated fixtures in a converted scene: ``<stem>.articulated.json`` beside a scene file (``world.articulated``).

The sidecar (format ``sdovon-articulated/1``, written by ``sdovon_mj.world.artplace``) lists pieces: instance id,
label, room, floor, a URDF (path relative to the sidecar), the world pose of its root frame (``position`` m, ``yaw``
degrees about +Z) and its interior surfaces (local frame: ``height``, ``polygon``, the closing ``joint``, its
``link``). Each URDF is converted by `assets_convert.urdf` into ``<scene>/articulated/objects/art_<id>/`` and
attached to the scene MJCF at its pose: its bodies keep their hinge/slide joints (names ``art_<id>/<joint>``), its
visual geoms are renamed ``inst_<id>_<j>`` so segmentation and the ground-truth detector see scene instance `id`,
and its collision geoms (group 3) stay, so placed objects rest on its shelves and doors push them. The piece's
visual triangles with every part closed join the scene mesh sidecar (ray casts, navigation slices) under its
instance id, and `SceneAsset.articulated` lists each piece (`ArticulatedFixture`).
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np

import mujoco
from sdovon_mj.config import ConvertConfig
from sdovon_mj.errors import InputError
from sdovon_mj.naming import scene_stem
from sdovon_mj.records import ArticulatedFixture, ArticulatedPart, InteriorSurface, SceneAsset, SemanticInstance
from sdovon_mj.sim.model import instance_geom_name, load_scene_mesh, save_scene_mesh
from sdovon_mj.store import atomic_write_text

from .load import display_path

FORMAT = "sdovon-articulated/1"
SUFFIX = ".articulated.json"


def sidecar_for(path: str | Path) -> Path | None:
    """Return ``<stem>.articulated.json`` beside a scene file (`naming.scene_stem`: ScanNet and HM3D suffixes
    dropped), or None."""
    path = Path(path)
    p = path.parent / f"{scene_stem(path)}{SUFFIX}"
    return p if p.is_file() else None


def read_sidecar(path: str | Path) -> list[dict]:
    """Read and check an articulated sidecar; return its pieces (InputError naming the file and the piece)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise InputError(display_path(path), f"articulated sidecar does not read: {e}") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputError(display_path(path), f"not an articulated sidecar (format must be {FORMAT!r})")
    pieces = data.get("pieces")
    if not isinstance(pieces, list):
        raise InputError(display_path(path), "'pieces' must be a list")
    for k, p in enumerate(pieces):
        for key in ("id", "label", "urdf", "position", "yaw"):
            if not isinstance(p, dict) or key not in p:
                raise InputError(display_path(path), f"piece {k} has no {key!r}")
        if len(p["position"]) != 3:
            raise InputError(display_path(path), f"piece {k} ({p['urdf']}): position must have 3 numbers")
        if not (path.parent / p["urdf"]).is_file():
            raise InputError(display_path(path), f"piece {k}: URDF {p['urdf']} not found")
    return pieces


def input_files(path: str | Path) -> list[Path]:
    """Return the articulated sidecar beside a scene file and every file its URDFs read ([] without a sidecar)."""
    from .urdf import read_urdf

    side = sidecar_for(path)
    if side is None:
        return []
    out = [side]
    for p in read_sidecar(side):
        out += read_urdf(side.parent / p["urdf"]).files()
    return out


def _copy_in(src: Path, folder: Path, prefix: str) -> str:
    """Copy a model file into the scene's asset `folder` as ``<prefix>_<name>``; return that name."""
    folder.mkdir(parents=True, exist_ok=True)
    dst = folder / f"{prefix}_{src.name}"
    shutil.copyfile(src, dst)
    return dst.name


def _box_triangles(size: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return (vertices (8, 3), faces (12, 3)) of a box of half-sizes `size` centred at the origin."""
    v = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float) * size
    f = np.array([(0, 2, 3), (0, 3, 1), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4), (2, 6, 7), (2, 7, 3),
                  (0, 4, 6), (0, 6, 2), (1, 3, 7), (1, 7, 5)])
    return v, f


def _geom_triangles(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Return a box or mesh geom's world triangles (vertices, faces) at the current state; None for other types."""
    if int(model.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_BOX):
        v, f = _box_triangles(model.geom_size[g])
    elif int(model.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_MESH):
        m = int(model.geom_dataid[g])
        a, n = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
        fa, fn = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
        v, f = model.mesh_vert[a:a + n].astype(np.float64), model.mesh_face[fa:fa + fn].astype(np.int64)
    else:
        return None
    R = data.geom_xmat[g].reshape(3, 3)
    return v @ R.T + data.geom_xpos[g], f


def add_articulated(work: Path, scene_path: Path, asset: SceneAsset, sidecar: Path,
                    config: ConvertConfig | None = None, cache_dir: str | Path | None = None) -> SceneAsset:
    """Convert the sidecar's URDF pieces and build them into the scene written in folder `work`; return the asset.

    Parameters
    ----------
    work : Path
        The scene's output folder (``scene.xml``, ``assets/``, the mesh sidecar), rewritten in place.
    scene_path : Path
        The scene input file (for error messages).
    asset : SceneAsset
        The scene as `convert_scene` built it (instances, mesh sidecar name).
    sidecar : Path
        The ``<stem>.articulated.json`` file.
    config : ConvertConfig, optional
        Conversion settings for the URDFs.
    cache_dir : str or Path, optional
        Conversion cache folder of the URDF pieces (default: the user cache).
    """
    from .urdf import convert_urdf_report

    pieces = read_sidecar(sidecar)
    if not pieces:
        return asset
    xml = work / asset.mjcf
    spec = mujoco.MjSpec.from_file(str(xml))
    spec.modelfiledir = str(work.resolve())  # attached meshes resolve against the scene folder too
    meshdir = work / (spec.meshdir or "")
    texdir = work / (spec.texturedir or "")
    taken = {i.id for i in asset.instances}
    fixtures: list[tuple[dict, str, list[ArticulatedPart]]] = []
    for p in pieces:
        iid = int(p["id"])
        if iid in taken:
            raise InputError(display_path(sidecar), f"piece {p['urdf']}: instance id {iid} is taken by the scene mesh")
        taken.add(iid)
        name = f"art_{iid}"
        obj, _info = convert_urdf_report(sidecar.parent / p["urdf"], work / "articulated", category=str(p["label"]),
                                         name=name, config=config, cache_dir=cache_dir,
                                         source=str(p["urdf"]))
        model_xml = work / "articulated" / obj.mjcf
        child = mujoco.MjSpec.from_file(str(model_xml))
        cm, ct = model_xml.parent / (child.meshdir or ""), model_xml.parent / (child.texturedir or "")
        for m in child.meshes:  # the piece's files join the scene's asset folder, prefixed with its name
            if m.file:
                m.file = _copy_in(cm / m.file, meshdir, name)
        for t in child.textures:
            if t.file:
                t.file = _copy_in(ct / t.file, texdir, name)
        child.meshdir, child.texturedir = spec.meshdir, spec.texturedir
        child.modelfiledir = spec.modelfiledir
        yaw = math.radians(float(p["yaw"]))
        frame = spec.worldbody.add_frame(pos=[float(c) for c in p["position"]],
                                         quat=[math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
        root = child.worldbody.first_body()
        if root is None:
            raise InputError(display_path(model_xml), "articulated model has no body")
        frame.attach_body(root, f"{name}/", "")
        parts = [ArticulatedPart(joint=f"{name}/{q.joint}", kind=q.kind, range=q.range, body=f"{name}/{q.body}",
                                 axis=q.axis, link=q.link) for q in (obj.parts or [])]
        fixtures.append((p, name, parts))
    # visual geoms of piece k: inst_<id>_<j> (scene instance naming); collision geoms keep their prefixed names
    geoms_of: dict[int, list[str]] = {}
    for p, name, _parts in fixtures:
        iid, j = int(p["id"]), 0
        for g in spec.geoms:
            if g.name.startswith(f"{name}/") and g.group == 2:
                g.name = instance_geom_name(iid, j)
                geoms_of.setdefault(iid, []).append(g.name)
                j += 1
    try:
        model = spec.compile()
    except Exception as e:
        raise InputError(display_path(scene_path), f"scene with articulated pieces does not compile: {e}") from None
    atomic_write_text(xml, spec.to_xml())
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    V, F, FI = load_scene_mesh(work / asset.mesh)
    Vs, Fs, FIs, nv = [V], [F], [FI], len(V)
    instances = list(asset.instances)
    out: list[ArticulatedFixture] = []
    for p, name, parts in fixtures:
        iid = int(p["id"])
        vs = []
        for gname in geoms_of.get(iid, []):
            tri = _geom_triangles(model, data, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, gname))
            if tri is None:
                continue
            Vs.append(tri[0])
            Fs.append(tri[1] + nv)
            FIs.append(np.full(len(tri[1]), iid, dtype=np.int64))
            nv += len(tri[0])
            vs.append(tri[0])
        v = np.concatenate(vs) if vs else np.zeros((1, 3)) + np.asarray(p["position"], float)
        instances.append(SemanticInstance(id=iid, label=str(p["label"]), geoms=geoms_of.get(iid, []),
                                          room=int(p.get("room", -1)), floor=int(p.get("floor", -1)), kind="receptacle",
                                          bounds=np.stack([v.min(axis=0), v.max(axis=0)]), receptacle=True))
        yaw = math.radians(float(p["yaw"]))
        R = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
        pos = np.asarray(p["position"], dtype=np.float64)
        interiors = []
        for s in p.get("interiors", []):
            poly = np.asarray(s["polygon"], dtype=np.float64) @ R.T + pos[:2]
            joint = f"{name}/{s['joint']}" if s.get("joint") else None
            body = f"{name}/{s['link']}" if s.get("link") and s["link"] != "body" else f"{name}/object"
            interiors.append(InteriorSurface(height=float(pos[2] + float(s["height"])), polygon=poly, joint=joint,
                                             body=body))
        out.append(ArticulatedFixture(instance_id=iid, label=str(p["label"]),
                                      model=f"articulated/objects/{name}/model.xml", position=pos,
                                      yaw=float(p["yaw"]), parts=parts, interiors=interiors))
    save_scene_mesh(work / asset.mesh, np.concatenate(Vs), np.concatenate(Fs), np.concatenate(FIs))
    Vall = np.concatenate(Vs)
    asset.instances = sorted(instances, key=lambda i: i.id)
    asset.bounds = np.stack([Vall.min(axis=0), Vall.max(axis=0)])
    asset.articulated = out
    return asset


__all__ = ["FORMAT", "add_articulated", "input_files", "read_sidecar", "sidecar_for"]
