"""Triangle meshes of compiled MuJoCo geoms (mesh and primitive types) written as GLB, with their textures.

`geoms_mesh` merges geoms into one coloured mesh (geometry checks, bounds). `geoms_scene` keeps one glTF mesh per
geom with its material: a mesh geom whose material has a 2D base-colour texture and whose mesh has texture
coordinates is written with that texture (PNG inside the GLB) and its UVs, so Habitat shows what MuJoCo rendered;
MuJoCo's ``texrepeat`` is baked into the UVs (glTF samplers repeat), so no KHR_texture_transform is needed.
MuJoCo stores texture row 0 at the image top and flips OBJ texture coordinates on load (v_mj = 1 - v_obj); the
UVs written are (u * repeat_u, 1 - v_mj * repeat_v) in trimesh's (OBJ) convention, which its glTF export flips
once more to glTF's top-left origin. Other geoms keep their material colour.
"""

from __future__ import annotations

import numpy as np
import trimesh

import mujoco

_T = mujoco.mjtGeom
_RGB = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)


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


def geom_texture(model: mujoco.MjModel, g: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Return (image (H, W, 3|4) uint8, row 0 at the top; per-corner UVs (F, 3, 2) in MuJoCo's convention,
    texrepeat applied) of a textured mesh geom, or None (no 2D base-colour texture or no texture coordinates)."""
    mat = int(model.geom_matid[g])
    if int(model.geom_type[g]) != _T.mjGEOM_MESH or mat < 0:
        return None
    tex = int(model.mat_texid[mat, _RGB])
    if tex < 0 or int(model.tex_type[tex]) != int(mujoco.mjtTexture.mjTEXTURE_2D):
        return None
    mid = int(model.geom_dataid[g])
    ta, tn = int(model.mesh_texcoordadr[mid]), int(model.mesh_texcoordnum[mid])
    if ta < 0 or tn == 0:
        return None
    h, w, c = int(model.tex_height[tex]), int(model.tex_width[tex]), int(model.tex_nchannel[tex])
    img = np.asarray(model.tex_data[int(model.tex_adr[tex]):int(model.tex_adr[tex]) + h * w * c], dtype=np.uint8)
    fa, fn = int(model.mesh_faceadr[mid]), int(model.mesh_facenum[mid])
    uv = model.mesh_texcoord[ta:ta + tn].astype(float)[model.mesh_facetexcoord[fa:fa + fn]]
    return img.reshape(h, w, c), uv * np.asarray(model.mat_texrepeat[mat], dtype=float)


def _placed(m: trimesh.Trimesh, data: mujoco.MjData, g: int, inv: np.ndarray, out_rotation: np.ndarray) -> trimesh.Trimesh:
    """Move a geom's surface into the output frame (T_frame^-1 T_geom, then out_rotation)."""
    T = np.eye(4)
    T[:3, :3] = data.geom_xmat[g].reshape(3, 3)
    T[:3, 3] = data.geom_xpos[g]
    R = np.eye(4)
    R[:3, :3] = out_rotation
    m.apply_transform(R @ inv @ T)
    return m


def geoms_mesh(model: mujoco.MjModel, data: mujoco.MjData, geoms: list[int], T_frame: np.ndarray,
               out_rotation: np.ndarray) -> trimesh.Trimesh | None:
    """Return geoms merged into one coloured mesh in a frame (T_frame: world <- frame), then rotated by out_rotation.

    Parameters
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
        The compiled model and its state (geom poses).
    geoms : list of int
        The geom ids to merge.
    T_frame : ndarray (4, 4)
        The frame the mesh is written in (world <- frame).
    out_rotation : ndarray (3, 3)
        A rotation applied after (e.g. Z up to Y up).
    """
    inv = np.linalg.inv(T_frame)
    parts = []
    for g in geoms:
        m = geom_trimesh(model, g)
        if m is None or len(m.faces) == 0:
            continue
        m = _placed(m, data, g, inv, out_rotation)
        m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile(geom_rgba(model, g), (len(m.faces), 1)))
        parts.append(m)
    if not parts:
        return None
    return trimesh.util.concatenate(parts)


def geoms_scene(model: mujoco.MjModel, data: mujoco.MjData, geoms: list[int], T_frame: np.ndarray,
                out_rotation: np.ndarray) -> trimesh.Scene | None:
    """Return geoms as a scene of one mesh per geom in a frame (as `geoms_mesh`), textured geoms with their texture.

    Parameters
    ----------
    model, data, geoms, T_frame, out_rotation : as in `geoms_mesh`
    """
    from PIL import Image
    from trimesh.visual.material import PBRMaterial

    inv = np.linalg.inv(T_frame)
    scene = trimesh.Scene()
    images: dict[int, Image.Image] = {}
    for g in geoms:
        m = geom_trimesh(model, g)
        if m is None or len(m.faces) == 0:
            continue
        rgba = geom_rgba(model, g)
        texture = geom_texture(model, g)
        if texture is not None:
            img, uv = texture
            tex = int(model.mat_texid[int(model.geom_matid[g]), _RGB])
            if tex not in images:
                images[tex] = Image.fromarray(img[..., :3] if img.shape[2] >= 3 else np.repeat(img, 3, axis=2))
            tri = m.vertices[m.faces]  # unweld: MuJoCo indexes positions and texture coordinates separately
            uv_obj = np.stack([uv[..., 0], 1.0 - uv[..., 1]], axis=-1).reshape(-1, 2)
            m = trimesh.Trimesh(tri.reshape(-1, 3), np.arange(3 * len(m.faces)).reshape(-1, 3), process=False)
            m.visual = trimesh.visual.TextureVisuals(uv=uv_obj, material=PBRMaterial(
                baseColorTexture=images[tex], baseColorFactor=[int(c) for c in rgba], metallicFactor=0.0,
                roughnessFactor=float(1.0 - model.mat_shininess[int(model.geom_matid[g])])))
        else:
            m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile(rgba, (len(m.faces), 1)))
        m = _placed(m, data, g, inv, out_rotation)
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom_{g}"
        scene.add_geometry(m, node_name=name, geom_name=name)
    return scene if scene.geometry else None


def glb_bytes(mesh: trimesh.Trimesh | trimesh.Scene) -> bytes:
    """Return the GLB bytes of a mesh or scene (vertices written as given: no axis change)."""
    scene = mesh if isinstance(mesh, trimesh.Scene) else trimesh.Scene(mesh)
    return scene.export(file_type="glb")
