"""Offscreen RGB, depth and segmentation rendering with one reused `mujoco.Renderer`.

A free camera is posed from T_cam (world <- OpenCV camera), so any compiled model renders without a
camera of its own. Speed settings for data generation: no shadows, no reflections, no
multisampling (docs/background.md, "Offscreen rendering speed": RGB at 7.5 fps with them, 59 fps without).
"""

from __future__ import annotations

import atexit
import math
import weakref
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator

import numpy as np

import mujoco

from .. import gl, native
from . import GROUP_AGENT, GROUP_CEILING, GROUP_OBJECT_VISUAL, GROUP_SCENE
from . import occlusion
from .camera import intrinsics, vfov_from_hfov
from .model import label_table, segment_image

# The lit pass draws only the geoms the flat pass shows when the flat pass reads the id colours anyway (segmentation
# asked for), or when the geoms in view hold at least this many triangles: without segmentation the cut costs a
# colour read and its decoding (about 0.5 ms at 320x240 on llvmpipe) and saves about 0.1 us per triangle it leaves
# out (1.5 M triangles: a 390 k-triangle lit pass took 44 ms), so below ~10 k triangles in view it cannot pay.
# Either way the images are the same bytes: this is a choice of speed only (docs/results.md, issue 47).
LIT_CUT_MIN_TRIANGLES = 20_000
PRIMITIVE_TRIANGLES = 200  # what a primitive geom (box, sphere, cylinder...) counts for: MuJoCo tessellates it finely
# The flat pass leaves out the geoms `occlusion` finds behind what it draws when the geoms it tests hold at least this
# many triangles: the test costs about 0.7 ms at 320x240 on a house's frames (bounding the depth from the drawn
# meshes' triangles, then each box) and a geom left out saves about 17 us plus 0.08 us per triangle (llvmpipe; fitted
# over a house's frames: docs/results.md), so below a few thousand triangles it cannot pay. The images are the same
# either way: a choice of speed only.
OCCLUSION_MIN_TRIANGLES = 4_000


@dataclass
class Frame:
    """One rendered frame: what was asked for, others None."""

    rgb: np.ndarray | None
    depth: np.ndarray | None
    segmentation: np.ndarray | None  # (H, W) int32 geom id, -1 = none


def prepare_model(model: mujoco.MjModel, width: int, height: int, multisample: bool = False) -> None:
    """Size the offscreen buffer and set quality flags on a model before building a Renderer."""
    model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), int(width))
    model.vis.global_.offheight = max(int(model.vis.global_.offheight), int(height))
    if not multisample:
        model.vis.quality.offsamples = 0


def _rows_as_read(img: np.ndarray) -> tuple[np.ndarray, int]:
    """Return an image as its buffer holds it and whether its rows are flipped (1: `_pass`'s view of GL's bottom-up
    rows), so a compiled pass can read the buffer once and write the rows top-down."""
    return (img[::-1], 1) if img.strides[0] < 0 else (img, 0)


def _lookup_codes(ids: np.ndarray, codes: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Return int32 table[codes]: per pixel of an id-colour image `ids` (H, W, 3), the table's entry for its colour
    code `codes` (H, W) (`SceneRenderer._decode_table`); one compiled pass when the code is the red channel."""
    lib = native.library()
    rows, flip = _rows_as_read(ids)
    if lib is not None and len(table) == 256 and codes.dtype == np.uint8 and rows.flags.c_contiguous and \
            rows.ndim == 3 and rows.shape[2] == 3:
        tab = np.ascontiguousarray(table, dtype=np.int32)
        out = np.empty(rows.shape[:2], dtype=np.int32)
        lib.sdv_code_lookup(rows.ctypes.data, rows.shape[0], rows.shape[1], 3, flip, tab.ctypes.data,
                            out.ctypes.data)
        return out
    return np.asarray(table, dtype=np.int32).take(codes)


def frustum_out(xpos: np.ndarray, rbound: np.ndarray, axes: np.ndarray, planes: list[float]) -> np.ndarray:
    """Return, per geom, whether its bounding sphere grown by 1 mm lies wholly outside one plane of a view (and its
    radius is positive): before the near plane, beyond the far one, or off a side (`SceneRenderer.outside_view`).

    Parameters
    ----------
    xpos : numpy.ndarray
        (N, 3) geom centres, metres.
    rbound : numpy.ndarray
        (N,) bounding radii, metres (0: a plane, never out).
    axes : numpy.ndarray
        (12,) camera position, right, up and forward axes (`occlusion.camera_of`).
    planes : list of float
        Near and far distances (metres), then for x and for y the side planes' slopes s (c = s z on a plane) and
        unit-normal scales: s_hi, hypot(1, s_hi), s_lo, hypot(1, s_lo).
    """
    p = xpos - axes[None, :3]
    # each dot product summed left to right, as the compiled form (sdv_frustum_out) does
    x, y, z = (p[:, 0] * axes[k] + p[:, 1] * axes[k + 1] + p[:, 2] * axes[k + 2] for k in (3, 6, 9))
    r_out = rbound + 1e-3
    near, far = planes[0], planes[1]
    out = (z + r_out < near) | (z - r_out > far)
    for c, (s_hi, n_hi, s_lo, n_lo) in ((x, planes[2:6]), (y, planes[6:10])):
        out |= (c - s_hi * z) / n_hi > r_out
        out |= (s_lo * z - c) / n_lo > r_out
    return out & (rbound > 0.0)


class SceneRenderer:
    """Renders a compiled model from arbitrary OpenCV camera poses; reuse one per process."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData | None = None, width: int = 640,
                 height: int = 480, hfov: float = 79.0, znear: float = 0.05, zfar: float = 50.0,
                 shadows: bool = False, groups: tuple[int, ...] = (GROUP_SCENE, GROUP_CEILING, GROUP_OBJECT_VISUAL),
                 share: "SceneRenderer | None" = None) -> None:
        """Set up an offscreen renderer of `model` with a pinhole camera of the given size and field of view.

        Parameters
        ----------
        model : mujoco.MjModel
            The compiled model.
        data : mujoco.MjData, optional
            Its state (default: a fresh one, forwarded).
        width, height : int
            Image size, pixels.
        hfov : float
            Horizontal field of view, degrees.
        znear, zfar : float
            Clipping distances, metres.
        shadows : bool
            Render shadows.
        groups : tuple of int
            Geom groups shown.
        share : SceneRenderer, optional
            A live renderer of the same model, at least as large: this one draws with its GL context and uploaded
            meshes (in its own corner of that framebuffer, the same pixels as a framebuffer of its own) instead of
            building and uploading its own; it must be closed first or with it.
        """
        self.model = model
        self.data = data if data is not None else mujoco.MjData(model)
        if data is None:
            mujoco.mj_forward(model, self.data)
        self.width, self.height, self.hfov = int(width), int(height), float(hfov)
        prepare_model(model, width, height)
        # Near/far are fractions of the model extent in MuJoCo; set them so znear/zfar hold in metres.
        extent = float(model.stat.extent) if model.stat.extent > 0 else 1.0
        # the model holds one camera setting for every renderer of it: each renderer sets its own before it draws
        self._view = (znear / extent, zfar / extent, vfov_from_hfov(hfov, width, height))
        self._apply_view()
        self.K = intrinsics(width, height, hfov)
        gl.ensure()  # the process's renderer: llvmpipe unless this process chose otherwise (gl)
        self._shared_from = None  # the renderer whose GL context this one draws with (None: its own)
        if share is not None and share.model is model and share._renderer is not None and \
                _LOW_LEVEL_OK(share._renderer) and self.width <= share.width and self.height <= share.height:
            self._renderer, self._shared_from = share._renderer, share
        else:
            self._renderer = mujoco.Renderer(model, height=self.height, width=self.width)
        self._rect = mujoco.MjrRect(0, 0, self.width, self.height)  # the viewport, from the framebuffer's corner
        self.option = mujoco.MjvOption()
        mujoco.mjv_defaultOption(self.option)
        self.set_groups(groups)
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.shadows = shadows
        # what the lit-pass cut reads of the model that cannot change under it: each geom's triangles (mesh geoms
        # their faces, a primitive PRIMITIVE_TRIANGLES), and whether a texture has an alpha channel
        mesh = np.asarray(model.geom_type) == int(mujoco.mjtGeom.mjGEOM_MESH)
        faces = np.asarray(model.mesh_facenum)[np.where(mesh, np.asarray(model.geom_dataid), 0)] if model.nmesh else 0
        self._triangles = np.where(mesh, faces, PRIMITIVE_TRIANGLES).astype(np.int64)
        self._alpha_texture = bool((np.asarray(getattr(model, "tex_nchannel", np.zeros(0))) > 3).any())
        self._mesh = occlusion.mesh_geoms(model)  # the occluders the occlusion test reads
        self._boxed = np.asarray(model.geom_rbound) > 0.0  # planes (no bounding box) are always drawn
        self._shown_last: np.ndarray | None = None  # per geom, whether the last flat pass showed it (speed only)
        self._occlusion: occlusion.OcclusionTest | None = None  # built on first use
        _register_cleanup()
        _LIVE.add(self)

    def set_groups(self, groups: tuple[int, ...]) -> None:
        """Show exactly these geom groups."""
        for g in range(6):
            self.option.geomgroup[g] = 1 if g in groups else 0

    def _pose_camera(self, T_cam: np.ndarray) -> None:
        """Point the free camera along T_cam's optical axis (roll-free poses)."""
        pos = np.asarray(T_cam[:3, 3], dtype=float)
        fwd = np.asarray(T_cam[:3, 2], dtype=float)
        fwd = fwd / np.linalg.norm(fwd)
        self.camera.lookat[:] = pos + fwd
        self.camera.distance = 1.0
        if abs(fwd[2]) > 0.999:  # looking straight up/down: the image's up vector sets the azimuth
            up = -np.asarray(T_cam[:3, 1], dtype=float)
            self.camera.azimuth = math.degrees(math.atan2(up[1], up[0])) if fwd[2] < 0 else math.degrees(math.atan2(-up[1], -up[0]))
        else:
            self.camera.azimuth = math.degrees(math.atan2(fwd[1], fwd[0]))
        self.camera.elevation = math.degrees(math.asin(np.clip(fwd[2], -1.0, 1.0)))

    def outside_view(self, T_cam: np.ndarray) -> np.ndarray:
        """Return the ids of the geoms that no pixel of a view from T_cam can show (they are not drawn).

        The frustum is MuJoCo's own for the posed free camera (`gl_camera`: position, forward and up axes,
        the near plane's edges, the far distance), as `mujoco.mjr_render` sets it. A geom is out when its bounding
        sphere (grown by 1 mm) lies wholly outside one of the frustum's planes, the four sides widened by 5 % of
        their half-range: beyond the far plane, before the near one, or off a side. A triangle outside a frustum
        plane is clipped away whole, so such a geom covers no pixel. Planes (no bounding radius) always count as
        in view.
        """
        self._pose_camera(T_cam)
        self._apply_view()  # the view's camera alone (mjv_updateScene's last step), not the scene's geoms
        mujoco.mjv_updateCamera(self.model, self.data, self.camera, self._renderer.scene)
        view = occlusion.camera_of(self.gl_camera(), self.width, self.height)  # the occlusion test's camera too
        if view is None:  # a camera the test does not handle: nothing is left out
            return np.zeros(0, dtype=np.int64)
        axes, fr = view
        near, far = float(fr[0]), float(fr[1])
        planes = [near, far]
        for lo, hi in ((float(fr[2]), float(fr[3])), (float(fr[4]), float(fr[5]))):
            grow = 0.05 * (hi - lo) / 2.0
            s_lo, s_hi = (lo - grow) / near, (hi + grow) / near  # the side planes' slopes (c = s z on a plane)
            planes += [s_hi, math.hypot(1.0, s_hi), s_lo, math.hypot(1.0, s_lo)]
        xpos = np.ascontiguousarray(self.data.geom_xpos, dtype=np.float64)
        rb = np.ascontiguousarray(self.model.geom_rbound, dtype=np.float64)
        lib = native.library()
        if lib is not None:  # the same operations compiled (sdv_frustum_out)
            out = np.empty(len(rb), dtype=np.uint8)
            planes = np.asarray(planes, dtype=np.float64)
            lib.sdv_frustum_out(xpos.ctypes.data, rb.ctypes.data, len(rb), axes.ctypes.data, planes.ctypes.data,
                                out.ctypes.data)
            return np.flatnonzero(out)
        return np.flatnonzero(frustum_out(xpos, rb, axes, planes))

    def gl_camera(self) -> mujoco.MjvGLCamera:
        """Return the camera `mujoco.mjr_render` draws a mono scene with: the average of the scene's two eye cameras,
        which sit half the model's inter-pupillary distance (``vis.global_.ipd``, 6.8 cm by default) to either side of
        it (the frustum test once used the left eye's and could cull a geom at the view's edge that the render shows)."""
        scn = self._renderer.scene
        return mujoco.mjv_averageCamera(scn.camera[0], scn.camera[1])

    def render(self, T_cam: np.ndarray, rgb: bool = True, depth: bool = True, segmentation: bool = False,
               labels: np.ndarray | None = None) -> Frame:
        """Render the requested images from pose T_cam (world <- OpenCV camera).

        Geoms out of view (`outside_view`), and in the flat pass those behind what the previous frame showed
        (`_occluded`), are hidden while it renders: the images are those of a render of everything (a geom that
        covers no pixel changes none), made with less geometry to draw. When colour and depth or segmentation are
        asked for, the flat id pass runs first and the lit pass draws only the geoms that pass shows (`_lit_pass`),
        when segmentation is asked for or the view holds enough triangles for the cut to pay
        (`LIT_CUT_MIN_TRIANGLES`).

        Parameters
        ----------
        T_cam : numpy.ndarray
            (4, 4) world <- OpenCV camera pose (x right, y down, z forward), metres.
        rgb, depth, segmentation : bool
            Which images to render: colour (H, W, 3) uint8, metric z-depth (H, W) float32, geom ids (H, W) int32
            (-1 where no geom).
        labels : numpy.ndarray, optional
            Per model geom an integer: the segmentation then holds each pixel's geom's label instead of its id
            (-1 where no geom either way), in one lookup.
        """
        if self._shared_from is not None and self._shared_from._renderer is None:
            raise RuntimeError("SceneRenderer: the renderer whose GL context this one shares was closed")
        hidden = self.outside_view(T_cam)
        self._pose_camera(T_cam)
        cut = segmentation or self._triangles_in_view(hidden) >= LIT_CUT_MIN_TRIANGLES
        with hiding(self.model, hidden):
            return self._render(rgb, depth, segmentation, cut, labels)

    def _in_shown_group(self) -> np.ndarray:
        """Return, per model geom, whether its group is shown now (geoms `hiding` hides are not)."""
        return np.asarray(self.option.geomgroup)[np.clip(np.asarray(self.model.geom_group), 0, 5)] > 0

    def _triangles_in_view(self, hidden: np.ndarray) -> int:
        """Return the triangles of the geoms a render would draw: those of a shown group, less `hidden` (mesh geoms
        their faces, a primitive `PRIMITIVE_TRIANGLES`)."""
        shown = self._in_shown_group()
        shown[hidden] = False
        return int(self._triangles[shown].sum())

    def _render(self, rgb: bool, depth: bool, segmentation: bool, cut: bool = True,
                labels: np.ndarray | None = None) -> Frame:
        """Render the posed camera's requested images (`cut`: the lit pass draws only the geoms the flat pass shows,
        when colour comes with depth or segmentation; `labels`: as `render`'s)."""
        r = self._renderer
        self._update_scene()
        if not _LOW_LEVEL_OK(r):
            f = self._render_passes(rgb, depth, segmentation)
            if labels is not None and f.segmentation is not None:
                f.segmentation = segment_image(f.segmentation, labels)
            return f
        out_rgb = out_depth = out_seg = None
        if depth or segmentation:
            # One flat id-colour pass gives both the segmentation (colour) and the depth buffer; with colour asked
            # for, its ids also tell the lit pass which geoms to draw.
            occluded = self._occluded()
            track = occlusion.available()  # the geoms shown are the next frame's occluders
            with hiding(self.model, occluded):
                if len(occluded):
                    self._update_scene()
                ids, d = self._pass(flat=True, want_rgb=segmentation or (rgb and cut) or track, want_depth=depth)
            shown = None
            if ids is not None:  # decoded through the scene that pass drew (unchanged until the next update)
                codes, lut, present = self._decode_table(ids)
                g = lut[present]
                shown = np.zeros(self.model.ngeom, dtype=bool)
                shown[g[g >= 0]] = True
                if track:
                    self._shown_last = shown
                if segmentation:  # one lookup from colour code to geom id, or through it to the geom's label
                    out_seg = _lookup_codes(ids, codes, lut if labels is None else label_table(labels).take(lut))
            if depth:
                out_depth = self._linear_depth(d)
            if rgb:  # None (no cut): everything in view; the scene the flat pass drew lacks the occluded geoms
                out_rgb = self._lit_pass(shown if cut else None, rebuild=len(occluded) > 0)
        elif rgb:
            out_rgb = np.ascontiguousarray(self._pass(flat=False, want_rgb=True, want_depth=False)[0])
        return Frame(out_rgb, out_depth, out_seg)

    def _apply_view(self) -> None:
        """Set this renderer's near and far planes and vertical field of view on the model (shared by its renderers:
        one of another image shape or range, built later, must not change this one's images)."""
        vis = self.model.vis
        vis.map.znear, vis.map.zfar, vis.global_.fovy = self._view

    def _update_scene(self) -> None:
        """Build the scene of the posed camera with this renderer's view and flags (no shadows unless asked, no
        reflection, no skybox)."""
        self._apply_view()
        r = self._renderer
        r.update_scene(self.data, camera=self.camera, scene_option=self.option)
        scn = r.scene
        scn.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = int(self.shadows)
        scn.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        scn.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = 0

    def _lit_pass(self, shown: np.ndarray | None, rebuild: bool = False) -> np.ndarray:
        """Render the lit colour image, drawing only the geoms the flat pass showed (`shown`: per model geom; None:
        everything in view; `rebuild`: the current scene is not everything in view, so drawing everything builds it
        again).

        Every geom the flat pass drew ends at the same fragments in the lit pass (the same geometry and camera:
        lighting and colour do not move fragments), and with opaque geoms and a depth test a pixel shows the
        nearest fragment whichever others are drawn: leaving out geoms that win no pixel changes no pixel. So the
        cut is made only when it holds: no shadows (an unseen geom may cast one), no texture with an alpha
        channel, and every geom the segmentation shows opaque (a transparent one lets geoms behind it through).
        Otherwise everything in view is drawn.
        """
        m = self.model
        if shown is not None and not self.shadows and not self._alpha_texture:
            if not self._transparent(np.flatnonzero(shown)).any():
                hidden = ~shown
                hidden &= np.asarray(m.geom_group) != GROUP_AGENT  # already hidden: left as they are
                with hiding(m, np.nonzero(hidden)[0]):
                    self._update_scene()
                    return np.ascontiguousarray(self._pass(flat=False, want_rgb=True, want_depth=False)[0])
        if rebuild:
            self._update_scene()
        return np.ascontiguousarray(self._pass(flat=False, want_rgb=True, want_depth=False)[0])

    def _transparent(self, geoms: np.ndarray) -> np.ndarray:
        """Return, per geom id, whether its colour or its material's has alpha below 1 (conservative: either)."""
        m = self.model
        a = np.asarray(m.geom_rgba)[geoms, 3] < 1.0
        mat = np.asarray(m.geom_matid)[geoms]
        has = mat >= 0
        a[has] |= np.asarray(m.mat_rgba)[mat[has], 3] < 1.0
        return a

    def _pass(self, flat: bool, want_rgb: bool, want_depth: bool) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Render once and read colour and/or depth buffers (flipped to image rows top-down)."""
        r = self._renderer
        scn = r.scene
        saved = scn.flags.copy()
        if flat:
            scn.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 1
            scn.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 1
        if r._gl_context:
            r._gl_context.make_current()
        col = np.empty((self.height, self.width, 3), dtype=np.uint8) if want_rgb else None
        dep = np.empty((self.height, self.width), dtype=np.float32) if want_depth else None
        try:
            mujoco.mjr_render(self._rect, scn, r._mjr_context)
            mujoco.mjr_readPixels(col, dep, self._rect, r._mjr_context)
        finally:
            np.copyto(scn.flags, saved)
        if r._gl_context:  # GL rows run bottom-up; callers copy (convert) the flipped views
            col = col[::-1] if col is not None else None
            dep = dep[::-1] if dep is not None else None
        return col, dep

    def _linear_depth(self, buf: np.ndarray) -> np.ndarray:
        """Convert a depth buffer to metric z-depth (the conversion of mujoco.Renderer)."""
        extent = self.model.stat.extent
        znear = np.float32(self.model.vis.map.znear * extent)
        zfar = np.float32(self.model.vis.map.zfar * extent)
        c_coef = -(zfar + znear) / (zfar - znear)
        d_coef = -(np.float32(2) * zfar * znear) / (zfar - znear)
        c_coef = np.float32(-0.5) * c_coef - np.float32(0.5)
        d_coef = np.float32(-0.5) * d_coef
        # float32 is exact enough: at 5 m the buffer term is ~1e-2, float32 keeps ~1e-9 of it
        return d_coef / (buf + c_coef)

    def _decode_table(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return an id-colour image's colour code per pixel, the table code -> geom id (-1: none; filled at least for
        the codes shown) and the codes shown, of the current scene."""
        scn = self._renderer.scene
        n = scn.ngeom
        if n < 255:  # ids fit the red channel
            codes = ids[..., 0]
            lib = native.library()
            buf = _rows_as_read(ids)[0]  # the GL rows flipped back: which codes show is the same
            if lib is not None and buf.flags.c_contiguous and buf.shape[-1] == 3:  # the codes seen, in one pass
                seen = np.empty(256, dtype=np.uint8)
                lib.sdv_codes_seen(buf.ctypes.data, codes.size, 3, seen.ctypes.data)
                present = np.flatnonzero(seen[1 : n + 1]) + 1
            else:
                present = np.flatnonzero(np.bincount(codes.ravel(), minlength=256)[1 : n + 1]) + 1
            lut256 = np.full(256, -1, dtype=np.int32)
            lut256[: n + 1] = self._id_table(scn, n, present)
            return codes, lut256, present
        codes = ids[..., 0].astype(np.int32) | (ids[..., 1].astype(np.int32) << 8) | (ids[..., 2].astype(np.int32) << 16)
        np.clip(codes, 0, n, out=codes)
        present = np.flatnonzero(np.bincount(codes.ravel(), minlength=n + 1)[1:]) + 1
        return codes, self._id_table(scn, n, present), present

    def _occluded(self) -> np.ndarray:
        """Return the geoms in view the flat pass of the posed camera may leave out (`occlusion`): those whose boxes
        lie behind the mesh geoms the previous flat pass showed (none in a first frame) or behind tested meshes the
        test found drawn, all of which this pass draws.

        Empty without the compiled kernels, or when the geoms tested hold fewer than `OCCLUSION_MIN_TRIANGLES`. A
        geom left out can win no pixel of a render of everything (`occlusion`), so the ids and depths are the same;
        what the previous frame showed (the renderer's history) decides only which geoms are the occluders, hence
        how much is left out, never what the images hold.
        """
        none = np.zeros(0, dtype=np.int64)
        if not occlusion.available():
            return none
        m = self.model
        vis = self._in_shown_group()  # in the frustum: `render` hides the geoms outside it
        occluders = vis & self._mesh
        if self._shown_last is not None:
            occluders &= self._shown_last
        else:  # a first frame: the kernel's own depth-ordered occluders only
            occluders[:] = False
        tested = np.flatnonzero(vis & ~occluders & self._boxed)
        if int(self._triangles[tested].sum()) < OCCLUSION_MIN_TRIANGLES:
            return none
        cam = occlusion.camera_of(self.gl_camera(), self.width, self.height)
        if cam is None:
            return none
        if self._occlusion is None:
            self._occlusion = occlusion.OcclusionTest(m)
        return tested[self._occlusion.hidden(self.data, np.flatnonzero(occluders), tested, *cam, self.width,
                                             self.height)]

    @staticmethod
    def _id_table(scn: mujoco.MjvScene, n: int, present: np.ndarray) -> np.ndarray:
        """Return the table id colour -> geom id (-1: none) of the scene's `n` geoms, filled for the colours in
        `present`: the others are never read. Colour c is the geom whose segid is c - 1; MuJoCo numbers segments by
        their place in the scene, so that is scene geom c - 1, checked for each colour (if one is not, every geom is
        read, as a geom's segid is what counts). Reading a few dozen geoms instead of all of them (each a Python
        object) saves most of the table's time."""
        lut = np.full(n + 1, -1, dtype=np.int32)
        geom_type = int(mujoco.mjtObj.mjOBJ_GEOM)
        geoms = scn.geoms
        for c in present.tolist():
            g = geoms[c - 1]
            if g.segid != c - 1:
                lut[:] = -1
                for g in geoms[:n]:
                    if g.segid != -1 and g.objtype == geom_type:
                        lut[g.segid + 1] = g.objid
                return lut
            if g.objtype == geom_type:
                lut[c] = g.objid
        return lut

    def _render_passes(self, rgb: bool, depth: bool, segmentation: bool) -> Frame:
        """Fallback through the public mujoco.Renderer API (one pass per image)."""
        r = self._renderer
        out_rgb = out_depth = out_seg = None
        if rgb:
            r.disable_depth_rendering()
            r.disable_segmentation_rendering()
            out_rgb = r.render().copy()
        if depth:
            r.disable_segmentation_rendering()
            r.enable_depth_rendering()
            out_depth = r.render().astype(np.float32)
            r.disable_depth_rendering()
        if segmentation:
            r.enable_segmentation_rendering()
            seg = r.render()
            r.disable_segmentation_rendering()
            ids = seg[..., 0].astype(np.int32)
            ids[seg[..., 1] != int(mujoco.mjtObj.mjOBJ_GEOM)] = -1
            out_seg = ids
        return Frame(out_rgb, out_depth, out_seg)

    def close(self) -> None:
        """Free the GL context (idempotent; also when the renderer is garbage-collected).

        The context is made current first: mujoco.Renderer.close frees its textures, buffers and framebuffer by
        their GL names in whichever context is current, and another live renderer's objects carry the same names
        (each context counts from 1), so closing one renderer while another was current used to delete the other's
        framebuffer and meshes: its next frames came out wrong, without an error (tests/test_observe.py).
        """
        r = getattr(self, "_renderer", None)
        if r is not None and getattr(self, "_shared_from", None) is not None:  # the owner frees the context
            self._renderer = None  # type: ignore[assignment]
            self._shared_from = None
        elif r is not None:
            if getattr(r, "_gl_context", None) is not None:
                r._gl_context.make_current()
            r.close()
            self._renderer = None  # type: ignore[assignment]
        _LIVE.discard(self)

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # interpreter teardown: EGL may already be gone
            pass

    def __enter__(self) -> "SceneRenderer":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


_LIVE: "weakref.WeakSet[SceneRenderer]" = weakref.WeakSet()


def _LOW_LEVEL_OK(r: mujoco.Renderer) -> bool:
    """Return whether the mujoco.Renderer exposes the context/rect the combined pass needs."""
    return all(hasattr(r, a) for a in ("_rect", "_mjr_context", "_gl_context")) and r._mjr_context is not None


_CLEANUP_REGISTERED = False


def _close_all() -> None:
    """Close renderers before interpreter teardown (EGL errors otherwise)."""
    for r in list(_LIVE):
        try:
            r.close()
        except Exception:  # teardown: the display may already be gone
            pass


def _register_cleanup() -> None:
    """Register `_close_all` after the GL backend's own exit hook, so it runs before it."""
    global _CLEANUP_REGISTERED
    if not _CLEANUP_REGISTERED:
        atexit.register(_close_all)
        _CLEANUP_REGISTERED = True


def spheres_meet_box(centres: np.ndarray, radii: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Return, per geom bounding sphere (world centres (N, 3), radii (N,), metres), whether it may meet the box
    [lo, hi]: the sphere, grown by 1 mm, meets it, or the radius is not positive (a plane: infinite extent)."""
    d = np.maximum(np.maximum(lo[None] - centres, 0.0), centres - hi[None])
    return (np.einsum("ij,ij->i", d, d) <= (radii + 1e-3) ** 2) | (radii <= 0.0)


def spheres_off_cone(p: np.ndarray, r: np.ndarray, u: np.ndarray, sin_a: float | np.ndarray,
                     cos_a: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return whether each sphere lies wholly outside a circular cone, and each centre's distance along its axis.

    The one sphere-versus-cone test of the renderer's view culling and the visibility checker's occluder culling.
    A sphere is outside when it lies wholly behind the apex or off the cone's side: ``q cos a - t sin a`` (``t`` the
    centre's distance along the axis, ``q`` its distance from the axis) is 1-Lipschitz and at most 0 on the cone,
    so a sphere where it exceeds the radius misses the cone. Arrays broadcast over the leading axes.

    Parameters
    ----------
    p : numpy.ndarray
        (..., 3) sphere centres relative to the cone's apex, metres.
    r : numpy.ndarray
        (...) sphere radii, metres (callers add their own margin).
    u : numpy.ndarray
        (..., 3) unit axis of the cone, broadcast against ``p``.
    sin_a, cos_a : float or numpy.ndarray
        Sine and cosine of the cone's half-angle, broadcast against ``r``.

    Returns
    -------
    out : numpy.ndarray
        (...) bool, the sphere misses the cone.
    t : numpy.ndarray
        (...) the centres' distances along the axis, metres.
    """
    t = np.einsum("...k,...k->...", p, u)
    q = np.sqrt(np.maximum(np.einsum("...k,...k->...", p, p) - t * t, 0.0))
    return (t + r < 0.0) | (q * cos_a - t * sin_a > r), t


@contextmanager
def hiding(model: mujoco.MjModel, geoms: np.ndarray) -> Iterator[None]:
    """Hide these geoms (ids) from renders and rays while the block runs: their group becomes GROUP_AGENT, which
    no scene render or ray cast of ours shows, and is restored after."""
    groups = model.geom_group
    saved = groups[geoms].copy()
    groups[geoms] = GROUP_AGENT
    try:
        yield
    finally:
        groups[geoms] = saved


def clip_depth(depth: np.ndarray, dmin: float, dmax: float) -> np.ndarray:
    """Return depth with values outside [dmin, dmax] set to 0 (invalid)."""
    d = depth.astype(np.float32, copy=True)
    d[(d < dmin) | (d > dmax) | ~np.isfinite(d)] = 0.0
    return d


def clip_depth_range(depth: np.ndarray, dmin: float, dmax: float) -> np.ndarray:
    """Return float32 depth clipped to [dmin, dmax] with NaN and +inf read as dmax (a sensor's saturated reading).

    The values of ``np.clip(np.nan_to_num(depth, nan=dmax, posinf=dmax), dmin, dmax).astype(np.float32)``
    (-inf, which `nan_to_num` makes the most negative float, clips to dmin either way) in one clip and, only when a
    NaN is there, one fill."""
    out = np.clip(np.asarray(depth, dtype=np.float32), dmin, dmax)  # NaN stays NaN, +inf -> dmax, -inf -> dmin
    nan = np.isnan(out)
    if nan.any():
        out[nan] = dmax
    return out


def top_down_camera(bounds: np.ndarray, margin: float = 0.5) -> tuple[np.ndarray, float]:
    """Return a T_cam looking straight down at a scene's bounds and the hfov that frames it."""
    lo, hi = np.asarray(bounds[0], float), np.asarray(bounds[1], float)
    c = (lo + hi) / 2.0
    half = max(hi[0] - lo[0], hi[1] - lo[1]) / 2.0 + margin
    hfov = 40.0
    dist = half / math.tan(math.radians(hfov / 2.0))
    T = np.eye(4)
    # Looking down: forward -Z; image right +X, image down -Y (north up).
    T[:3, 0] = [1.0, 0.0, 0.0]
    T[:3, 1] = [0.0, -1.0, 0.0]
    T[:3, 2] = [0.0, 0.0, -1.0]
    T[:3, 3] = [c[0], c[1], hi[2] + dist]
    return T, hfov
