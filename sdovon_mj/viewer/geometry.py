"""Light triangle meshes of MJCF models for the browser viewer: geoms to world-frame triangles, coloured, decimated.

The viewer draws a scene's visual geoms and each placed object's visual geoms from their compiled MuJoCo models (the
same MJCF the renderer and the suite load), so what the page shows is what the agent's camera sees, minus textures:
a textured material is drawn in its texture's mean colour. Converted scans can hold millions of triangles; the page
gets at most a budget of them (`cluster_decimate`), so it stays responsive on a laptop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

import mujoco


@dataclass
class Triangles:
    """World-frame triangles: vertices (N, 3) float32 m, faces (M, 3) int64, per-vertex colour (N, 3) uint8 and
    per-face id (M,) int64 (a scene instance id, -1 for none)."""

    vertices: np.ndarray
    faces: np.ndarray
    colors: np.ndarray
    face_id: np.ndarray

    @property
    def face_count(self) -> int:
        """Return the number of triangles."""
        return int(len(self.faces))

    @staticmethod
    def empty() -> "Triangles":
        """Return a mesh without triangles."""
        return Triangles(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64), np.zeros((0, 3), np.uint8),
                         np.zeros(0, np.int64))

    @staticmethod
    def concat(parts: list["Triangles"]) -> "Triangles":
        """Return the union of meshes (vertex indices shifted)."""
        parts = [p for p in parts if p.face_count]
        if not parts:
            return Triangles.empty()
        offsets = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
        return Triangles(np.concatenate([p.vertices for p in parts]).astype(np.float32),
                         np.concatenate([p.faces + o for p, o in zip(parts, offsets)]),
                         np.concatenate([p.colors for p in parts]), np.concatenate([p.face_id for p in parts]))


def _primitive(gtype: int, size: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Return (vertices, faces) of a primitive geom in its own frame (None for planes and unknown types)."""
    import trimesh

    T = mujoco.mjtGeom
    if gtype == T.mjGEOM_BOX:
        m = trimesh.creation.box(extents=2.0 * np.asarray(size[:3], float))
    elif gtype == T.mjGEOM_SPHERE:
        m = trimesh.creation.icosphere(subdivisions=2, radius=float(size[0]))
    elif gtype == T.mjGEOM_ELLIPSOID:
        m = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        m.vertices *= np.asarray(size[:3], float)
    elif gtype == T.mjGEOM_CYLINDER:
        m = trimesh.creation.cylinder(radius=float(size[0]), height=2.0 * float(size[1]), sections=20)
    elif gtype == T.mjGEOM_CAPSULE:
        m = trimesh.creation.capsule(radius=float(size[0]), height=2.0 * float(size[1]), count=[12, 12])
    else:
        return None
    return np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)


def _texture_mean(model: mujoco.MjModel, tex: int) -> np.ndarray:
    """Return a texture's mean RGB (0-1); a strided sample of its texels is enough for a flat colour."""
    adr, h, w, nc = int(model.tex_adr[tex]), int(model.tex_height[tex]), int(model.tex_width[tex]), int(model.tex_nchannel[tex])
    texels = np.asarray(model.tex_data[adr:adr + h * w * nc]).reshape(-1, nc)
    step = max(1, len(texels) // 4096)
    return texels[::step, :3].astype(float).mean(axis=0) / 255.0 if nc >= 3 else np.ones(3) * texels[::step, 0].mean() / 255.0


def geom_color(model: mujoco.MjModel, g: int) -> np.ndarray:
    """Return a geom's displayed RGB (0-1): its material's colour times its texture's mean colour, else its rgba."""
    mat = int(model.geom_matid[g])
    if mat < 0:
        return np.asarray(model.geom_rgba[g, :3], float)
    rgb = np.asarray(model.mat_rgba[mat, :3], float)
    texid = np.asarray(model.mat_texid[mat]).reshape(-1)
    tex = next((int(t) for t in texid if int(t) >= 0), -1)
    return rgb * _texture_mean(model, tex) if tex >= 0 else rgb


def model_triangles(model: mujoco.MjModel, data: mujoco.MjData, select: Callable[[int], bool],
                    face_id: Callable[[int], int] | None = None) -> Triangles:
    """Return the world-frame triangles of the selected geoms of a model in the pose `data` holds (kinematics run).

    Parameters
    ----------
    model, data
        A compiled model and its data; `mujoco.mj_kinematics` is run on `data` here.
    select
        geom id -> whether to take it (e.g. by group).
    face_id
        geom id -> the id its triangles carry (default -1).
    """
    mujoco.mj_kinematics(model, data)
    parts: list[Triangles] = []
    for g in range(model.ngeom):
        if not select(g):
            continue
        gtype = int(model.geom_type[g])
        if gtype == mujoco.mjtGeom.mjGEOM_MESH:
            mid = int(model.geom_dataid[g])
            va, vn = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
            fa, fn = int(model.mesh_faceadr[mid]), int(model.mesh_facenum[mid])
            v = np.asarray(model.mesh_vert[va:va + vn], float)
            f = np.asarray(model.mesh_face[fa:fa + fn], np.int64)
        else:
            prim = _primitive(gtype, model.geom_size[g])
            if prim is None:
                continue
            v, f = prim
        if not len(f):
            continue
        R = np.asarray(data.geom_xmat[g], float).reshape(3, 3)
        world = v @ R.T + np.asarray(data.geom_xpos[g], float)
        rgb = np.clip(np.round(geom_color(model, g) * 255.0), 0, 255).astype(np.uint8)
        fid = -1 if face_id is None else int(face_id(g))
        parts.append(Triangles(world.astype(np.float32), f, np.repeat(rgb[None], len(world), axis=0),
                               np.full(len(f), fid, np.int64)))
    return Triangles.concat(parts)


def cluster_decimate(mesh: Triangles, max_faces: int) -> Triangles:
    """Return the mesh with at most `max_faces` triangles, by vertex clustering (unchanged when already below).

    Vertices are snapped to a cubic grid, merged per (cell, face id), and triangles that collapse or repeat are
    dropped; the cell doubles from 1 cm until the budget holds. Cruder than quadric decimation, but linear, exact
    per face id (an instance never borrows another's vertices or colour) and the same output on every machine.
    """
    if mesh.face_count <= max_faces:
        return mesh
    v = mesh.vertices.astype(np.float64)
    lo = v.min(axis=0)
    cell = 0.01
    while True:
        q = np.floor((v - lo) / cell).astype(np.int64)
        # cluster key per face corner: (cell, face id) -> one vertex
        corner_v = mesh.faces.reshape(-1)
        corner_id = np.repeat(mesh.face_id, 3)
        keys = np.column_stack([q[corner_v], corner_id])
        uniq, inv = np.unique(keys, axis=0, return_inverse=True)
        f = inv.reshape(-1, 3)
        ok = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
        f, fid = f[ok], mesh.face_id[ok]
        f_sorted = np.sort(f, axis=1)
        _, first = np.unique(f_sorted, axis=0, return_index=True)
        first = np.sort(first)
        if len(first) <= max_faces:
            break
        cell *= 2.0
    f, fid = f[first], fid[first]
    n = len(uniq)
    sums = np.zeros((n, 3))
    cols = np.zeros((n, 3))
    counts = np.zeros(n)
    np.add.at(sums, inv, v[corner_v])
    np.add.at(cols, inv, mesh.colors[corner_v].astype(float))
    np.add.at(counts, inv, 1.0)
    verts = (sums / counts[:, None]).astype(np.float32)
    colors = np.clip(np.round(cols / counts[:, None]), 0, 255).astype(np.uint8)
    used = np.unique(f)
    remap = np.full(n, -1, np.int64)
    remap[used] = np.arange(len(used))
    return Triangles(verts[used], remap[f], colors[used], fid)
