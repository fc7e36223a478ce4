"""A variant's rigid-body content read from its compiled MJCF, for exporters to other simulators (USD, URDF).

One home for what every simulator format needs from a variant: the settled pose of each placed object
(`obj_<n>` bodies), its inertial (mass, centre of mass, principal axes and moments, as MuJoCo computed them
from the hulls), its visual meshes (group 2, with colour, texture and UVs) and its collision hulls
(group 3) in the body frame; the static scene's visual meshes (groups 0 and 1, world frame), which of
them collide (group 0), and the support geometry the objects were settled on (group 4).

Primitive geoms become triangle meshes and textures are read (`exporters.habitat.glb`: `geom_trimesh`,
`geom_texture`, texrepeat baked into the UVs) from the compiled model, i.e. what MuJoCo renders. UVs are
given with v pointing up (OBJ/USD convention; MuJoCo stores ``1 - v``); images are written as PNG.
"""

from __future__ import annotations

import hashlib
import io
from dataclasses import dataclass, field

import numpy as np

from sdovon_mj.errors import InputError
from sdovon_mj.records import SceneVariant
from sdovon_mj.sim import GROUP_CEILING, GROUP_OBJECT_COLLISION, GROUP_OBJECT_VISUAL, GROUP_SCENE, GROUP_SUPPORT
from sdovon_mj.sim.articulation import part_joints
from sdovon_mj.export import RunView

import mujoco  # after sdovon_mj, whose package entry sets MUJOCO_GL

from exporters.habitat import _variant_model
from exporters.habitat.glb import geom_rgba, geom_texture, geom_trimesh

_T = mujoco.mjtGeom


@dataclass
class MeshPart:
    """One geom as a triangle mesh in its owner's frame (world for the scene, body frame for an object).

    ``uv`` (K, 2, v up) and ``face_uv`` (M, 3) are set when the geom is a textured mesh, with ``image``
    (H, W, C) uint8 (first row = top) and ``texture`` its compiled texture id (-1 = none); ``rgba`` (4,)
    floats in [0, 1].
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    rgba: np.ndarray
    texture: int = -1
    uv: np.ndarray | None = None
    face_uv: np.ndarray | None = None
    collides: bool = False
    image: np.ndarray | None = None

    def digest(self) -> str:
        """Return a content digest (geometry, UVs, colour, texture id): equal parts share exported files."""
        h = hashlib.sha256()
        for a in (self.vertices.astype("<f8"), self.faces.astype("<i8"), self.rgba.astype("<f8")):
            h.update(a.tobytes())
        h.update(str(self.texture).encode())
        if self.uv is not None and self.face_uv is not None:
            h.update(self.uv.astype("<f8").tobytes())
            h.update(self.face_uv.astype("<i8").tobytes())
        return h.hexdigest()[:16]


@dataclass
class RigidBody:
    """A placed object: settled world pose (wxyz), inertial in the body frame, visual and collision parts."""

    object_id: str
    asset: str
    category: str
    pos: np.ndarray
    quat: np.ndarray
    mass: float
    com: np.ndarray
    inertia: np.ndarray
    principal_quat: np.ndarray
    visuals: list[MeshPart] = field(default_factory=list)
    collisions: list[MeshPart] = field(default_factory=list)


@dataclass
class VariantParts:
    """Everything a simulator export needs from one variant (see the module docstring)."""

    variant: SceneVariant
    model: mujoco.MjModel
    scene: list[MeshPart]
    support: list[MeshPart]
    bodies: list[RigidBody]
    gravity: np.ndarray


def geom_part(model: mujoco.MjModel, g: int) -> MeshPart | None:
    """Return geom g as a MeshPart in its body's frame (the world frame for world geoms); None for surface-less types.

    The compiled local pose (geom_pos, geom_quat) is used, not world poses, so every placement of an
    object yields the same bytes."""
    t = int(model.geom_type[g])
    uv = face_uv = image = None
    tex = -1
    if t == _T.mjGEOM_MESH:
        mid = int(model.geom_dataid[g])
        va, vn = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
        fa, fn = int(model.mesh_faceadr[mid]), int(model.mesh_facenum[mid])
        verts = model.mesh_vert[va:va + vn].astype(float)
        faces = model.mesh_face[fa:fa + fn].astype(np.int64)
        textured = geom_texture(model, g)
        if textured is not None:
            image, corners = textured  # per-corner UVs, MuJoCo convention (v stored as 1 - v), texrepeat applied
            tex = int(model.mat_texid[int(model.geom_matid[g]), int(mujoco.mjtTextureRole.mjTEXROLE_RGB)])
            uv = np.stack([corners[..., 0], 1.0 - corners[..., 1]], axis=-1).reshape(-1, 2)
            face_uv = np.arange(len(uv), dtype=np.int64).reshape(-1, 3)
    else:
        tm = geom_trimesh(model, g)
        if tm is None:
            return None
        verts, faces = np.asarray(tm.vertices, dtype=float), np.asarray(tm.faces, dtype=np.int64)
    if len(faces) == 0:
        return None
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, model.geom_quat[g])
    verts = verts @ R.reshape(3, 3).T + model.geom_pos[g]
    rgba = geom_rgba(model, g).astype(float) / 255.0
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom_{g}"
    return MeshPart(name=name, vertices=verts, faces=faces, rgba=rgba, texture=tex, uv=uv, face_uv=face_uv, image=image)


def texture_png(image: np.ndarray) -> bytes:
    """Return a texture image (H, W, 1|3|4) uint8, first row = top, as PNG bytes."""
    from PIL import Image

    c = int(image.shape[2])
    mode = {1: "L", 3: "RGB", 4: "RGBA"}.get(c)
    if mode is None:
        raise ValueError(f"texture image has {c} channels (expected 1, 3 or 4)")
    buf = io.BytesIO()
    Image.fromarray(image[:, :, 0] if c == 1 else image, mode).save(buf, format="PNG", optimize=False)
    return buf.getvalue()


def _group_parts(model: mujoco.MjModel, geoms: np.ndarray, groups: tuple[int, ...]) -> list[tuple[int, MeshPart]]:
    """Return (group, part) for the geoms of the given groups that have a surface."""
    out = []
    for g in geoms:
        grp = int(model.geom_group[g])
        part = geom_part(model, int(g)) if grp in groups else None
        if part is not None:
            out.append((grp, part))
    return out


def variant_parts(run: RunView, variant: SceneVariant) -> VariantParts:
    """Compile a variant's MJCF with its settled qpos and return its scene, support and rigid bodies.

    A variant with articulated scene pieces (issue 17: ``art_<id>`` bodies with hinge or slide joints) or an object
    with child bodies is refused with an `InputError` naming the file: these formats hold neither.
    """
    path = run.path(variant.mjcf)
    model, data = _variant_model(run, variant)
    pieces = sorted({(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or "").split("/")[0]
                     for j in part_joints(model)})
    if pieces:  # their hinges and slides have no place in a static scene plus free rigid bodies: refused, not dropped
        raise InputError(path, f"{len(pieces)} articulated scene piece(s) with hinge/slide joints ({', '.join(pieces[:8])}"
                               f"{', ...' if len(pieces) > 8 else ''}): this format holds a static scene and single "
                               f"rigid objects only; export the run as mjcf or habitat, which keep the joints and the "
                               f"variant's joint state")
    scene: list[MeshPart] = []
    support: list[MeshPart] = []
    for grp, part in _group_parts(model, np.flatnonzero(model.geom_bodyid == 0), (GROUP_SCENE, GROUP_CEILING, GROUP_SUPPORT)):
        part.collides = grp in (GROUP_SCENE, GROUP_SUPPORT)
        (support if grp == GROUP_SUPPORT else scene).append(part)
    bodies: list[RigidBody] = []
    for p in sorted(variant.placements, key=lambda p: p.object_id):
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.object_id)
        if b < 0:
            continue  # not in the model (dropped placement)
        if any(int(model.body_parentid[c]) == b for c in range(model.nbody) if c != b):
            raise InputError(path, f"body {p.object_id} has child bodies; only single rigid bodies can be exported")
        vis, col = [], []
        for grp, part in _group_parts(model, np.flatnonzero(model.geom_bodyid == b), (GROUP_OBJECT_VISUAL, GROUP_OBJECT_COLLISION)):
            part.collides = grp == GROUP_OBJECT_COLLISION
            (col if part.collides else vis).append(part)
        if not col:
            raise InputError(path, f"body {p.object_id} has no collision geoms (group 3)")
        bodies.append(RigidBody(object_id=p.object_id, asset=p.asset, category=p.category,
                                pos=data.xpos[b].copy(), quat=data.xquat[b].copy(), mass=float(model.body_mass[b]),
                                com=model.body_ipos[b].copy(), inertia=model.body_inertia[b].copy(),
                                principal_quat=model.body_iquat[b].copy(), visuals=vis, collisions=col))
    return VariantParts(variant=variant, model=model, scene=scene, support=support, bodies=bodies,
                        gravity=model.opt.gravity.copy())


def obj_text(part: MeshPart, mtl: str = "", material: str = "") -> str:
    """Return a MeshPart as Wavefront OBJ text (with ``vt`` and a material reference when textured/coloured)."""
    lines = ["# sdovon-mj export: metres, Z up"]
    if mtl:
        lines.append(f"mtllib {mtl}")
    lines += [f"v {x:.7g} {y:.7g} {z:.7g}" for x, y, z in part.vertices]
    if material:
        lines.append(f"usemtl {material}")
    if part.uv is not None and part.face_uv is not None:
        lines += [f"vt {u:.7g} {v:.7g}" for u, v in part.uv]
        lines += [f"f {a + 1}/{ta + 1} {b + 1}/{tb + 1} {c + 1}/{tc + 1}"
                  for (a, b, c), (ta, tb, tc) in zip(part.faces, part.face_uv)]
    else:
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in part.faces]
    return "\n".join(lines) + "\n"


__all__ = ["MeshPart", "RigidBody", "VariantParts", "geom_part", "texture_png", "variant_parts", "obj_text"]
