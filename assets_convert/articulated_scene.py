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

A dataset's pieces (a Habitat scene's ``articulated_object_instances``, `habitat.Reading.articulated`) come the same
way with a full pose and a scale and no sidecar: their interior and top surfaces are derived from their collision
geometry (`derive_surfaces`).
"""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import numpy as np

import mujoco
from sdovon_mj.config import ConvertConfig
from sdovon_mj.errors import InputError
from sdovon_mj.geometry import points_in_polygon, quat_to_mat
from sdovon_mj.naming import scene_stem
from sdovon_mj.records import (ArticulatedFixture, ArticulatedPart, InteriorSurface, SceneAsset, SemanticInstance,
                               SupportSurface)
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


def pieces_from_sidecar(sidecar: str | Path) -> list[dict]:
    """Return a sidecar's pieces as `add_articulated` takes them (URDF path resolved, pose as a wxyz quaternion)."""
    sidecar = Path(sidecar)
    out = []
    for p in read_sidecar(sidecar):
        yaw = math.radians(float(p["yaw"]))
        out.append({**p, "urdf": sidecar.parent / p["urdf"], "source": str(p["urdf"]),
                    "quat": [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]})
    return out


def add_articulated(work: Path, scene_path: Path, asset: SceneAsset, pieces: Path | list[dict],
                    config: ConvertConfig | None = None, cache_dir: str | Path | None = None) -> SceneAsset:
    """Convert URDF pieces and build them into the scene written in folder `work`; return the asset.

    Parameters
    ----------
    work : Path
        The scene's output folder (``scene.xml``, ``assets/``, the mesh sidecar), rewritten in place.
    scene_path : Path
        The scene input file (for error messages and the pieces' recorded sources).
    asset : SceneAsset
        The scene as `convert_scene` built it (instances, rooms, mesh sidecar name).
    pieces : Path or list of dict
        A ``<stem>.articulated.json`` sidecar, or pieces as a dataset reader gives them (`habitat.Reading.
        articulated`): ``id``, ``label``, ``urdf`` (path), ``position`` (m) and ``quat`` (wxyz) of the URDF root
        frame in the world, optionally ``scale`` (uniform, on top of the URDF's own), ``room``/``floor``, ``source``
        (recorded in the converted piece), and ``interiors`` (the sidecar's, local to a ``yaw``) -- without them the
        interior and top surfaces are derived from the piece's collision geometry (`derive_surfaces`).
    config : ConvertConfig, optional
        Conversion settings for the URDFs.
    cache_dir : str or Path, optional
        Conversion cache folder of the URDF pieces (default: the user cache).
    """
    from .urdf import convert_urdf_report

    if isinstance(pieces, (str, Path)):
        where = Path(pieces)
        pieces = pieces_from_sidecar(where)
    else:
        where = Path(scene_path)
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
            raise InputError(display_path(where), f"piece {p['urdf']}: instance id {iid} is taken by the scene mesh")
        taken.add(iid)
        name = f"art_{iid}"
        source = p.get("source") or Path(os.path.relpath(p["urdf"], Path(scene_path).parent)).as_posix()
        try:
            obj, info = convert_urdf_report(p["urdf"], work / "articulated", category=str(p["label"]), name=name,
                                            config=config, cache_dir=cache_dir, source=str(source),
                                            scale=float(p.get("scale", 1.0)))
        except InputError as e:
            if "yaw" in p:  # our own generator's piece: its URDF must convert
                raise
            asset.unused.append(f"{display_path(Path(p['urdf']))} (piece {p.get('name', name)}) not imported: {e.cause}")
            continue
        asset.unused += [f"{display_path(Path(p['urdf']))} (piece {p.get('name', name)}): {u}"
                         for u in info.get("unused", [])]
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
        frame = spec.worldbody.add_frame(pos=[float(c) for c in p["position"]], quat=[float(c) for c in p["quat"]])
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
        bounds = np.stack([v.min(axis=0), v.max(axis=0)])
        room, floor = int(p.get("room", -1)), int(p.get("floor", -1))
        if "room" not in p and "yaw" not in p:  # a dataset's piece: the room its box centre lies in
            room, floor = _room_of(asset, (bounds[0] + bounds[1]) / 2)
        pos = np.asarray(p["position"], dtype=np.float64)
        receptacle: bool | None = True
        if "interiors" in p or "yaw" in p:  # our generator's pieces: yaw-only pose, interiors in its local frame
            yaw = math.radians(float(p["yaw"]))
            R = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
            interiors = []
            for s in p.get("interiors", []):
                poly = np.asarray(s["polygon"], dtype=np.float64) @ R.T + pos[:2]
                joint = f"{name}/{s['joint']}" if s.get("joint") else None
                body = f"{name}/{s['link']}" if s.get("link") and s["link"] != "body" else f"{name}/object"
                interiors.append(InteriorSurface(height=float(pos[2] + float(s["height"])), polygon=poly, joint=joint,
                                                 body=body))
            fx = ArticulatedFixture(instance_id=iid, label=str(p["label"]), model=f"articulated/objects/{name}/model.xml",
                                    position=pos, yaw=float(p["yaw"]), parts=parts, interiors=interiors)
        else:
            interiors, tops = derive_surfaces(model, data, name)
            asset.support_surfaces += [SupportSurface(instance_id=iid, height=h, polygon=poly) for h, poly in tops]
            receptacle = True if interiors or tops else None  # a room door holds nothing: its label decides
            Rm = quat_to_mat(np.asarray(p["quat"], float))
            fx = ArticulatedFixture(instance_id=iid, label=str(p["label"]), model=f"articulated/objects/{name}/model.xml",
                                    position=pos, yaw=math.degrees(math.atan2(Rm[1, 0], Rm[0, 0])), parts=parts,
                                    interiors=interiors, quat=np.asarray(p["quat"], dtype=np.float64),
                                    scale=float(p.get("scale", 1.0)))
        out.append(fx)
        instances.append(SemanticInstance(id=iid, label=str(p["label"]), geoms=geoms_of.get(iid, []), room=room,
                                          floor=floor, kind="receptacle", bounds=bounds, receptacle=receptacle))
    save_scene_mesh(work / asset.mesh, np.concatenate(Vs), np.concatenate(Fs), np.concatenate(FIs))
    Vall = np.concatenate(Vs)
    asset.instances = sorted(instances, key=lambda i: i.id)
    asset.bounds = np.stack([Vall.min(axis=0), Vall.max(axis=0)])
    asset.articulated = out
    return asset


def _room_of(asset: SceneAsset, point: np.ndarray) -> tuple[int, int]:
    """Return (room id, floor) of the scene's room whose polygon holds `point` (XY), else (-1, -1)."""
    for r in asset.rooms:
        if points_in_polygon(np.asarray(r.polygon, float), np.asarray(point, float)[None, :2])[0]:
            return int(r.id), int(r.floor)
    return -1, -1


# ----------------------------------------------------------------------------------------------
# interior and top surfaces from a piece's collision geometry

UP_COS = math.cos(math.radians(10.0))  # a face within 10 degrees of horizontal, facing up, can hold an object
MIN_AREA = 0.02  # m^2: smaller upward faces (panel edges, a door's top rim) hold no object
MIN_WIDTH = 0.08  # m: twice area / perimeter (a rectangle's ab / (a + b)); a thinner face (a door's top edge) holds none
MIN_CLEARANCE = 0.06  # m: an upward face with less free height above it (a panel under a panel) holds no object
RAY_EPS = 1e-4  # m: hits nearer than this along a ray are the face the ray starts on
HORIZONTAL_RAYS = 16  # directions around a surface in which an opening is looked for


def _collision_triangles(model: mujoco.MjModel, data: mujoco.MjData, prefix: str) -> list[tuple[int, np.ndarray]]:
    """Return (geom id, (T, 3, 3) world triangles) of the collision geoms (group 3) on bodies named ``prefix...``."""
    out = []
    for g in range(model.ngeom):
        body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g])) or ""
        if int(model.geom_group[g]) != 3 or not body.startswith(prefix):
            continue
        tri = _geom_triangles(model, data, g)
        if tri is not None:
            out.append((g, tri[0][tri[1]]))
    return out


def _first_hit(origin: np.ndarray, direction: np.ndarray, tris: np.ndarray) -> float:
    """Return the distance along a ray to the first triangle it crosses beyond `RAY_EPS` (inf: none; Moller-Trumbore)."""
    a, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    pv = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    sv = origin - a
    u = np.einsum("ij,ij->i", sv, pv) * inv
    qv = np.cross(sv, e1)
    v = (qv @ direction) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > RAY_EPS)
    return float(t[hit].min()) if hit.any() else math.inf


def _escapes(point: np.ndarray, tris: np.ndarray) -> bool:
    """Return whether a ray from `point` straight up or in one of `HORIZONTAL_RAYS` directions leaves the piece."""
    dirs = [np.array([0.0, 0.0, 1.0])] + [np.array([math.cos(a), math.sin(a), 0.0]) for a in
                                          np.linspace(0, 2 * math.pi, HORIZONTAL_RAYS, endpoint=False)]
    return any(math.isinf(_first_hit(point, d, tris)) for d in dirs)


def _upward_caps(g: int, tris: np.ndarray, data: mujoco.MjData) -> tuple[float, np.ndarray] | None:
    """Return (height, CCW XY polygon) of a convex collision geom's upward-facing cap, or None when it has none
    of `MIN_AREA`."""
    from scipy.spatial import ConvexHull, QhullError

    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    norm = np.linalg.norm(n, axis=1)
    keep = norm > 1e-12
    n[keep] /= norm[keep, None]
    out = np.einsum("ij,ij->i", n, tris.mean(axis=1) - data.geom_xpos[g]) < 0  # convex: normals point away from it
    n[out] *= -1
    up = keep & (n[:, 2] >= UP_COS)
    if not up.any():
        return None
    pts = tris[up].reshape(-1, 3)
    try:
        hull = ConvexHull(pts[:, :2])
    except QhullError:
        return None
    if hull.volume < MIN_AREA or 2 * hull.volume / hull.area < MIN_WIDTH:  # 2-D hull: volume = area, area = perimeter
        return None
    return float(pts[:, 2].mean()), pts[hull.vertices, :2]


def derive_surfaces(model: mujoco.MjModel, data: mujoco.MjData,
                    name: str) -> tuple[list[InteriorSurface], list[tuple[float, np.ndarray]]]:
    """Return the interior surfaces and the tops (height, CCW polygon) of piece `name` (bodies ``<name>/...``).

    Every upward cap of a collision geom (at the model's default joint state, every part closed) of at least
    `MIN_AREA` with `MIN_CLEARANCE` free above it is a candidate: nothing of the piece above it makes it a top (a
    counter top); else it is inside (a shelf, a drawer or carcass bottom), reachable as it is when a ray from just
    above its centre leaves the piece (up or sideways: an open shelf), else through the movable joint whose opening
    (to the limit farthest from its default) lets such a ray out -- the surface moving with its own body (a drawer
    bottom slides out with its drawer); joints that move the surface's own body are tried first. An inside surface
    that no single joint opens (behind two doors, under a drawer) is left out.
    """
    prefix = f"{name}/"
    closed = _collision_triangles(model, data, prefix)
    if not closed:
        return [], []
    every = np.concatenate([t for _g, t in closed])
    joints = [j for j in range(model.njnt) if (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or "").startswith(prefix)
              and int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))]
    qpos0 = data.qpos.copy()
    opened = []  # (joint, its body's ancestors-or-self set, triangles, body poses) with that one joint open
    for j in joints:
        a = int(model.jnt_qposadr[j])
        lo, hi = (float(v) for v in model.jnt_range[j]) if model.jnt_limited[j] else (qpos0[a] - 1.5, qpos0[a] + 1.5)
        data.qpos[:] = qpos0
        data.qpos[a] = hi if abs(hi - qpos0[a]) >= abs(lo - qpos0[a]) else lo
        mujoco.mj_kinematics(model, data)
        moved = {int(b) for b in range(model.nbody) if _below(model, b, int(model.jnt_bodyid[j]))}
        opened.append((j, moved, np.concatenate([t for _g, t in _collision_triangles(model, data, prefix)]),
                       data.xpos.copy(), data.xmat.copy()))
    data.qpos[:] = qpos0
    mujoco.mj_kinematics(model, data)
    interiors: list[InteriorSurface] = []
    tops: list[tuple[float, np.ndarray]] = []
    for g, tris in closed:
        cap = _upward_caps(g, tris, data)
        if cap is None:
            continue
        h, poly = cap
        centre = np.append(poly.mean(axis=0), h)
        clearance = _first_hit(centre + [0, 0, 1e-3], np.array([0.0, 0.0, 1.0]), every)
        if math.isinf(clearance):
            tops.append((h, poly))
            continue
        if clearance < MIN_CLEARANCE:
            continue
        b = int(model.geom_bodyid[g])
        probe = centre + [0.0, 0.0, min(clearance / 2, 0.1)]
        body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        if _escapes(probe, every):
            interiors.append(InteriorSurface(height=h, polygon=poly, joint=None, body=body))
            continue
        p0, R0 = data.xpos[b].copy(), data.xmat[b].reshape(3, 3).copy()
        found = None
        for j, moved, tris_j, xpos, xmat in sorted(opened, key=lambda o: b not in o[1]):  # own body's joints first
            q = (probe - p0) @ R0 @ xmat[b].reshape(3, 3).T + xpos[b]  # the probe moves with its body
            if _escapes(q, tris_j):
                found = j
                break
        if found is not None:
            interiors.append(InteriorSurface(height=h, polygon=poly, body=body,
                                             joint=mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, found)))
    return interiors, tops


def _below(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    """Return whether `body` is `ancestor` or one of its descendants."""
    while body > 0:
        if body == ancestor:
            return True
        body = int(model.body_parentid[body])
    return False


__all__ = ["FORMAT", "add_articulated", "derive_surfaces", "input_files", "pieces_from_sidecar", "read_sidecar",
           "sidecar_for"]
