"""Triangle meshes of compiled MuJoCo geoms (mesh and primitive types) written as GLB."""

from __future__ import annotations

import numpy as np
import trimesh

import mujoco

_T = mujoco.mjtGeom


def geom_trimesh(model: mujoco.MjModel, g: int) -> trimesh.Trimesh | None:
    """Return geom g's surface in its own frame (None for types without a surface)."""
    t = int(model.geom_type[g])
    s = model.geom_size[g]
    if t == _T.mjGEOM_MESH:
        mid = int(model.geom_dataid[g])
        va, vn = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
        fa, fn = int(model.mesh_faceadr[mid]), int(model.mesh_facenum[mid])
        return trimesh.Trimesh(model.mesh_vert[va:va + vn].astype(float), model.mesh_face[fa:fa + fn].astype(np.int64), process=False)
    if t == _T.mjGEOM_BOX:
        return trimesh.creation.box(extents=2.0 * s[:3])
    if t == _T.mjGEOM_SPHERE:
        return trimesh.creation.icosphere(subdivisions=2, radius=float(s[0]))
    if t == _T.mjGEOM_ELLIPSOID:
        m = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        m.apply_scale(s[:3])
        return m
    if t == _T.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=float(s[0]), height=2.0 * float(s[1]), sections=24)
    if t == _T.mjGEOM_CAPSULE:
        return trimesh.creation.capsule(height=2.0 * float(s[1]), radius=float(s[0]), count=[12, 12])
    if t == _T.mjGEOM_PLANE:
        hx = float(s[0]) if s[0] > 0 else 50.0
        hy = float(s[1]) if s[1] > 0 else 50.0
        v = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], dtype=float)
        return trimesh.Trimesh(v, np.array([[0, 1, 2], [0, 2, 3]]), process=False)
    return None


def geom_rgba(model: mujoco.MjModel, g: int) -> np.ndarray:
    """Return a geom's display colour (its material's when it has one)."""
    mat = int(model.geom_matid[g])
    rgba = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g]
    return np.clip(np.asarray(rgba, dtype=float) * 255.0, 0, 255).astype(np.uint8)


def geoms_mesh(model: mujoco.MjModel, data: mujoco.MjData, geoms: list[int], T_frame: np.ndarray,
               out_rotation: np.ndarray) -> trimesh.Trimesh | None:
    """Return geoms merged into one coloured mesh in a frame (T_frame: world <- frame), then rotated by out_rotation."""
    inv = np.linalg.inv(T_frame)
    parts = []
    for g in geoms:
        m = geom_trimesh(model, g)
        if m is None or len(m.faces) == 0:
            continue
        T = np.eye(4)
        T[:3, :3] = data.geom_xmat[g].reshape(3, 3)
        T[:3, 3] = data.geom_xpos[g]
        R = np.eye(4)
        R[:3, :3] = out_rotation
        m.apply_transform(R @ inv @ T)
        m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile(geom_rgba(model, g), (len(m.faces), 1)))
        parts.append(m)
    if not parts:
        return None
    return trimesh.util.concatenate(parts)


def glb_bytes(mesh: trimesh.Trimesh) -> bytes:
    """Return the GLB bytes of a mesh (vertices written as given: no axis change)."""
    return trimesh.Scene(mesh).export(file_type="glb")
