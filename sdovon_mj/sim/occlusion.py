"""Occlusion test of the flat pass: which geoms in view lie wholly behind geoms that pass draws anyway.

The renderer's flat (id-colour) pass draws every geom in MuJoCo's frustum, yet indoors most of them lie behind a wall.
Before it draws, `SceneRenderer` asks here which can be left out. The depth the pass will hold is bounded at each
pixel from triangles of geoms it surely draws: first the mesh geoms the previous frame showed (the occluders, drawn);
then the tested mesh geoms cheap to rasterise (walls, floors, big furniture: few triangles for their size), nearest
box first, each either found behind the bound (left out) or drawn, and then bounding the depth behind it (so a wall a
turn brings into view hides what lies behind it in its first frame); last the other tested geoms. A geom whose
bounding box lies beyond that bound at every pixel its projection can cover can win no pixel, whatever else is drawn.
(Drawing every remaining geom nearest first, detailed ones too, left out more but cost more to test than it saved:
docs/results.md.) Every step errs towards drawing: a triangle counts only at pixels whose centres lie inside it by a
margin (the rasteriser surely covers them), a box reaching the near plane or over a pixel with no bound is drawn,
depths carry a margin. So the images are those of drawing everything (tests/test_observe.py). The test runs compiled
(`sdovon_mj.native`: ``sdv_occlusion_cull``); without the kernels nothing is left out.
"""

from __future__ import annotations

import math

import numpy as np

import mujoco

from .. import native


def mesh_geoms(model: mujoco.MjModel) -> np.ndarray:
    """Return, per model geom, whether it is a mesh geom (type mesh with a mesh): the only geoms with triangles to
    bound depth with; primitives and height fields have none here."""
    return (np.asarray(model.geom_type) == int(mujoco.mjtGeom.mjGEOM_MESH)) & (np.asarray(model.geom_dataid) >= 0)


def available() -> bool:
    """Return whether the occlusion test can run (the compiled kernels are built)."""
    return native.library() is not None


def camera_of(cam: mujoco.MjvGLCamera, width: int, height: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Return the camera of an ``mjvGLCamera`` as the kernels read it (this test's and the renderer's frustum test):
    axes (12,) (position, right, up, forward; right = forward x up in doubles) and frustum (6,) (near, far, left,
    right, bottom, top of the near plane, metres); None for a camera they do not handle (orthographic, no near plane,
    an empty extent)."""
    near, far = float(cam.frustum_near), float(cam.frustum_far)
    top, bottom = float(cam.frustum_top), float(cam.frustum_bottom)
    if cam.orthographic or not (0.0 < near < far) or top <= bottom or not math.isfinite(far):
        return None
    half_w = float(cam.frustum_width) or 0.5 * width / height * (top - bottom)  # mjr_render's own rule
    centre = float(cam.frustum_center)
    (p0, p1, p2), (f0, f1, f2), (u0, u1, u2) = (np.asarray(v, float).tolist() for v in (cam.pos, cam.forward, cam.up))
    right = (f1 * u2 - f2 * u1, f2 * u0 - f0 * u2, f0 * u1 - f1 * u0)
    axes = np.array([p0, p1, p2, *right, u0, u1, u2, f0, f1, f2], dtype=np.float64)
    return axes, np.array([near, far, centre - half_w, centre + half_w, bottom, top])


class OcclusionTest:
    """The occlusion test of one model: its mesh and box tables, read once.

    Parameters
    ----------
    model : mujoco.MjModel
        The compiled model the renderer draws.
    """

    def __init__(self, model: mujoco.MjModel) -> None:
        is_mesh = mesh_geoms(model)
        mesh = np.where(is_mesh, np.asarray(model.geom_dataid), 0)
        has = model.nmesh > 0
        self._vert = np.ascontiguousarray(model.mesh_vert if has else np.zeros((1, 3)), dtype=np.float32)
        self._face = np.ascontiguousarray(model.mesh_face if has else np.zeros((1, 3)), dtype=np.int32)
        # per geom its mesh's tables; a geom that is no mesh (a primitive, a height field) has no triangles to bound
        # depth with: the kernel rasterises only geoms with faces
        table = (lambda a: np.where(is_mesh, np.asarray(a)[mesh], 0).astype(np.int64)) if has else \
            (lambda a: np.zeros(model.ngeom, dtype=np.int64))
        self._vadr, self._fadr, self._fnum = table(model.mesh_vertadr), table(model.mesh_faceadr), table(model.mesh_facenum)
        self._aabb = np.ascontiguousarray(model.geom_aabb, dtype=np.float64)

    def hidden(self, data: mujoco.MjData, occluders: np.ndarray, tested: np.ndarray, axes: np.ndarray,
               frustum: np.ndarray, width: int, height: int) -> np.ndarray:
        """Return, per geom of `tested`, whether the flat pass may leave it out: it lies wholly behind geoms drawn.

        The depth bound comes from the triangles of the mesh geoms `occluders`, which the same pass draws, then from
        those of the tested mesh geoms found drawn, nearest first (``sdv_occlusion_cull``).

        Parameters
        ----------
        data : mujoco.MjData
            The state drawn (geom poses after kinematics).
        occluders : numpy.ndarray
            (K,) ids of mesh geoms the pass draws.
        tested : numpy.ndarray
            (N,) ids of geoms with a bounding box (not planes), the occluders not among them.
        axes, frustum : numpy.ndarray
            The camera (`camera_of`).
        width, height : int
            Image size, pixels.
        """
        lib = native.library()
        out = np.zeros(len(tested), dtype=np.uint8)
        if lib is None or not len(tested):
            return out.astype(bool)
        pos = np.ascontiguousarray(data.geom_xpos, dtype=np.float64)
        mat = np.ascontiguousarray(data.geom_xmat, dtype=np.float64)
        occ = np.ascontiguousarray(occluders, dtype=np.int64)
        ids = np.ascontiguousarray(tested, dtype=np.int64)
        axes = np.ascontiguousarray(axes, dtype=np.float64)
        frustum = np.ascontiguousarray(frustum, dtype=np.float64)
        inv_depth = np.zeros((int(height), int(width)))  # the kernel's bound, as 1 / depth (0: none)
        if lib.sdv_occlusion_cull(self._vert.ctypes.data, self._face.ctypes.data, self._vadr.ctypes.data,
                                  self._fadr.ctypes.data, self._fnum.ctypes.data, pos.ctypes.data, mat.ctypes.data,
                                  self._aabb.ctypes.data, occ.ctypes.data, len(occ), ids.ctypes.data, len(ids),
                                  axes.ctypes.data, frustum.ctypes.data, int(width), int(height),
                                  inv_depth.ctypes.data, out.ctypes.data):
            raise MemoryError("occlusion test: out of memory")
        return out.astype(bool)
