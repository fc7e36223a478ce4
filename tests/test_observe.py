"""Observe stage: floors, navigable maps, coverage sampling, rendering, shards, CLI (synthetic scenes)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sdovon_mj.config import AgentConfig, ObserveConfig
from sdovon_mj.errors import InputError, SdovonError, StageError
from sdovon_mj.observe import (OffFloorError, coverage_viewpoints, find_floors, load_shards, locate, navigable_map,
                               observe_scene, render_observations, uniform_viewpoints)
from support.scenes import Box, apartment_boxes, write_box_scene
from sdovon_mj.world.shapes import box
from sdovon_mj.records import CoverageCamera, NavMap, load_json
from sdovon_mj.sim.model import load_scene_mesh


def _mesh(boxes: list[Box]) -> tuple[np.ndarray, np.ndarray]:
    vs, fs, off = [], [], 0
    for b in boxes:
        v, f = box(b.lo, b.hi)
        vs.append(v)
        fs.append(f + off)
        off += len(v)
    return np.concatenate(vs), np.concatenate(fs)


@pytest.fixture(scope="module")
def two_storey(tmp_path_factory):
    out = tmp_path_factory.mktemp("apt2")
    scene = write_box_scene(apartment_boxes(2), out)
    v, f, fi = load_scene_mesh(out / scene.mesh)
    return scene, out, v, f, fi


@pytest.fixture(scope="module")
def maps(two_storey):
    _s, _o, v, f, _fi = two_storey
    cfg = ObserveConfig()
    return [navigable_map(v, f, fl, cfg) for fl in find_floors(v, f, cfg)]


# ---------------------------------------------------------------------------------------------- floors

def test_two_storey_gives_two_floors_and_roof_is_not_a_floor(two_storey):
    _s, _o, v, f, _fi = two_storey
    floors = find_floors(v, f, ObserveConfig())
    # storey 0 at z=0, storey 1 on the 0.2 m slab at 2.8; the roof top at 5.6 carries no walls
    assert [round(fl.height, 3) for fl in floors] == [0.0, 2.8]
    assert [fl.index for fl in floors] == [0, 1]
    assert all(fl.area >= 40.0 for fl in floors)


def test_one_storey_and_furniture_is_not_a_floor():
    v, f = _mesh(apartment_boxes(1, size=(5.0, 4.0)))
    floors = find_floors(v, f, ObserveConfig())
    assert [fl.height for fl in floors] == [0.0]  # bed (3 m^2 at 0.5 m) and table top are not floors


def test_noisy_scan_floor():
    rng = np.random.default_rng(3)
    # a finely tessellated 6x5 m floor with 1 cm height noise, plus walls and a bed (the ScanNet look)
    n = 60
    xs, ys = np.meshgrid(np.linspace(0, 6, n), np.linspace(0, 5, n))
    z = rng.normal(0.02, 0.01, xs.shape)
    vf = np.stack([xs.ravel(), ys.ravel(), z.ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    ff = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    vb, fb = _mesh([Box("wall", (0, 0, 0), (6, 0.1, 2.5)), Box("bed", (0.5, 0.5, 0), (2.5, 2.0, 0.55))])
    v = np.concatenate([vf, vb])
    f = np.concatenate([ff, fb + len(vf)])
    floors = find_floors(v, f, ObserveConfig())
    assert len(floors) == 1 and abs(floors[0].height - 0.02) < 0.01


def test_scene_without_floor_is_a_clear_error():
    v, f = _mesh([Box("wall", (0, 0, 0), (4, 0.1, 2.5)), Box("cup", (1, 1, 1), (1.1, 1.1, 1.1))])
    with pytest.raises(StageError, match="no floor found"):
        find_floors(v, f, ObserveConfig())


# ---------------------------------------------------------------------------------------------- navmaps

def test_navmap_excludes_furniture_and_walls(maps):
    for nm in maps:
        z = nm.height
        # thin-legged table: under the top, at a leg, and just beside it
        blocked = [(1.8, 1.6), (1.22, 1.22), (7.0, 5.0),  # table centre, table leg, bed
                   (4.0, 1.0), (4.0, 5.0), (0.05, 3.0), (7.95, 3.0), (3.0, 0.05),  # inner and outer walls
                   (5.1, 0.4)]  # under the shelf hanging at 0.4-1.2 m
        assert not nm.is_navigable(np.array(blocked)).any(), f"floor {nm.floor} at {z}"
        assert not nm.free[tuple(nm.frame.to_cell(np.array([(1.8, 1.6), (7.0, 5.0), (4.0, 1.0)])).T)].any()
        open_pts = np.array([(2.0, 4.5), (6.0, 2.5), (4.0, 3.0)])  # two rooms and the door gap
        assert nm.is_navigable(open_pts).all()
        # eroded by the agent radius: nothing navigable within 0.18 m of a wall
        assert not nm.is_navigable(np.array([(0.2, 3.0), (3.0, 0.2)])).any()


def test_paper_plane_slice_misses_what_the_band_catches(two_storey):
    _s, _o, v, f, _fi = two_storey
    fl = find_floors(v, f, ObserveConfig())[0]
    plane = navigable_map(v, f, fl, dataclasses.replace(ObserveConfig(), nav_slice="plane"))
    band = navigable_map(v, f, fl, ObserveConfig())
    under_table = np.array([(1.8, 1.6)])
    assert plane.is_navigable(under_table).all() and not band.is_navigable(under_table).any()


def test_rooms_connected_through_door_and_small_components_dropped(maps):
    import cv2

    for nm in maps:
        n, _lab = cv2.connectedComponents(nm.navigable.astype(np.uint8), connectivity=8)
        assert n - 1 == 1  # one component: both rooms joined through the 1 m door


def test_locate_point_and_off_floor_error(maps):
    assert locate(maps, np.array([2.0, 4.5, 0.88])).floor == 0
    assert locate(maps, np.array([2.0, 4.5, 2.8 + 0.88])).floor == 1
    with pytest.raises(OffFloorError, match="outside the free area of every floor"):
        locate(maps, np.array([20.0, 4.5, 0.88]))
    with pytest.raises(OffFloorError):
        locate(maps, np.array([1.8, 1.6, 0.88]), navigable=True)  # under the table
    assert isinstance(OffFloorError("x"), SdovonError)


def test_navmap_json_round_trip(maps, tmp_path):
    from sdovon_mj.records import records_equal, save_json

    save_json(maps[0], tmp_path / "m.json")
    assert records_equal(load_json(tmp_path / "m.json", NavMap), maps[0])


# ---------------------------------------------------------------------------------------------- coverage

def test_coverage_sampling_reaches_threshold_and_is_seeded(maps):
    cfg = ObserveConfig()
    nm = maps[0]
    vps, mp, st = coverage_viewpoints(nm, cfg, seed=7)
    assert st.reached and st.coverage >= cfg.coverage_threshold
    assert float((mp[nm.navigable] >= cfg.eps_p_obs).mean()) == pytest.approx(st.coverage)
    assert mp.min() >= 0.0 and mp.max() <= 1.0
    assert all(nm.is_navigable(vp.position[None, :2])[0] for vp in vps)
    assert all(abs(vp.position[2] - (nm.height + AgentConfig().camera_height)) < 1e-9 for vp in vps)
    vps2, mp2, _ = coverage_viewpoints(nm, cfg, seed=7)
    assert np.array_equal(mp, mp2) and all(np.array_equal(a.position, b.position) for a, b in zip(vps, vps2))
    # candidates near obstacles are rejected: every viewpoint has clearance
    from sdovon_mj.observe.navmap import clearance

    cl = clearance(nm.free, nm.resolution)
    rc = nm.frame.to_cell(np.array([vp.position[:2] for vp in vps]))
    assert (cl[rc[:, 0], rc[:, 1]] >= cfg.min_obstacle_distance).all()


def test_coverage_invalid_radius_and_max_iterations(maps):
    nm = maps[0]
    cfg = dataclasses.replace(ObserveConfig(), max_iterations=1, min_obstacle_distance=0.0)
    vps, mp, st = coverage_viewpoints(nm, cfg, seed=1)
    assert st.iterations == 1 and len(vps) == 1 and not st.reached
    rc = nm.frame.to_cell(vps[0].position[None, :2])[0]
    assert mp[rc[0], rc[1]] == 0.0  # the invalid observation region r_min gets nothing
    ring = nm.frame.to_cell(vps[0].position[None, :2] + np.array([[cfg.r_min + 0.1, 0.0]]))[0]
    assert mp[ring[0], ring[1]] > 0.9


def test_coverage_needs_fewer_viewpoints_than_uniform(tmp_path):
    # a wide single storey (16 x 12 m, two rooms): stated margin: >= 15% fewer viewpoints on average
    scene = write_box_scene(apartment_boxes(1, size=(16.0, 12.0)), tmp_path)
    v, f, _fi = load_scene_mesh(tmp_path / scene.mesh)
    cfg = dataclasses.replace(ObserveConfig(), coverage_threshold=0.95, r_max=1.5)
    nm = navigable_map(v, f, find_floors(v, f, cfg)[0], cfg)
    seeds = range(8)
    cov = [coverage_viewpoints(nm, cfg, s) for s in seeds]
    uni = [uniform_viewpoints(nm, cfg, s) for s in seeds]
    assert all(c[2].reached for c in cov) and all(u[2].reached for u in uni)
    n_cov = np.mean([len(c[0]) for c in cov])
    n_uni = np.mean([len(u[0]) for u in uni])
    print(f"coverage {n_cov:.2f} vs uniform {n_uni:.2f} viewpoints")
    assert n_cov <= 0.85 * n_uni, (n_cov, n_uni)


# ---------------------------------------------------------------------------------------------- rendering

def _surface_distance(points: np.ndarray, v: np.ndarray, f: np.ndarray) -> np.ndarray:
    import trimesh

    mesh = trimesh.Trimesh(v, f, process=False)
    _c, d, _t = trimesh.proximity.closest_point(mesh, points)
    return d


def test_backprojected_depth_lies_on_scene_surfaces(two_storey):
    from sdovon_mj.sim.camera import backproject

    scene, root, v, f, fi = two_storey
    cfg = dataclasses.replace(ObserveConfig(), width=160, height=120, yaw_steps=3, pitch_angles=(-30.0, 0.0))
    vps = [CoverageCamera(floor=0, position=np.array([2.0, 4.0, 0.88])), CoverageCamera(floor=1, position=np.array([6.0, 2.5, 3.68]))]
    obs = list(render_observations(scene, vps, cfg, store_root=root))
    per_vp = 3 * (2 + len(cfg.camera_heights) * len(cfg.camera_height_pitches))
    assert len(obs) == 2 * per_vp and [o.view_id for o in obs] == list(range(2 * per_vp))
    # the raised camera views come after the agent-height ones, at floor + camera_heights
    z = [float(o.T_cam[2, 3]) for o in obs[:per_vp]]
    assert np.allclose(z[:6], 0.88) and np.allclose(z[6:], cfg.camera_heights[0])
    rng = np.random.default_rng(0)
    seg_ok = seg_n = 0
    medians: list[float] = []
    for o in obs:
        assert o.rgb.shape == (120, 160, 3) and o.depth.dtype == np.float32 and o.segmentation.dtype == np.int32
        valid = o.depth > 0
        assert valid.mean() > 0.9
        assert (o.depth[valid] >= cfg.depth_min).all() and (o.depth[valid] <= cfg.depth_max).all()
        pts = backproject(o.depth, o.K, o.T_cam)
        sel = rng.choice(len(pts), size=min(300, len(pts)), replace=False)
        d = _surface_distance(pts[sel], v, f)
        assert np.median(d) < 0.01, np.median(d)
        medians.append(float(np.median(d)))
        assert np.percentile(d, 90) < 0.03
        # segmentation: the instance of the nearest face matches the pixel's id
        import trimesh

        _c, _d, tri = trimesh.proximity.closest_point(trimesh.Trimesh(v, f, process=False), pts[sel])
        vv, uu = np.nonzero(valid)
        seg_ok += int((fi[tri] == o.segmentation[vv[sel], uu[sel]]).sum())
        seg_n += len(sel)
    print(f"median surface distance {max(medians) * 1000:.2f} mm (worst view), seg agreement {seg_ok / seg_n:.3f}")
    assert seg_ok / seg_n > 0.9


def test_combined_pass_equals_separate_passes(two_storey):
    from sdovon_mj.observe.render_views import load_model, make_renderer
    from sdovon_mj.sim.camera import pose_cv

    scene, root, *_ = two_storey
    r = make_renderer(load_model(scene, root), dataclasses.replace(ObserveConfig(), width=160, height=120))
    try:
        T = pose_cv(np.array([2.0, 4.0, 0.88]), 40.0, -20.0)
        a = r.render(T, rgb=True, depth=True, segmentation=True)
        b = r._render_passes(True, True, True)
        assert np.array_equal(a.rgb, b.rgb) and np.array_equal(a.segmentation, b.segmentation)
        assert np.allclose(a.depth, b.depth, rtol=1e-5, atol=1e-5)
    finally:
        r.close()


def test_views_hide_only_geoms_no_pixel_shows(two_storey, monkeypatch):
    """A render that skips the geoms outside the view frustum, and draws in its lit pass only the geoms its flat pass
    shows, gives the images of a render of everything, byte for byte; the geoms it skips are none of those the full
    render shows, and both cuts do leave geoms out."""
    from sdovon_mj.observe.render_views import load_model, make_renderer
    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim import render as render_module
    from sdovon_mj.sim.render import SceneRenderer

    scene, root, *_ = two_storey
    r = make_renderer(load_model(scene, root), dataclasses.replace(ObserveConfig(), width=160, height=120))
    spots = ((2.0, 4.0, 0.88), (6.0, 2.5, 3.68), (1.0, 1.0, 2.0))
    poses = [pose_cv(np.array(xyz), yaw, pitch) for xyz in spots for yaw in (0.0, 100.0, 215.0)
             for pitch in (-60.0, -10.0, 25.0)]
    poses.append(pose_cv(np.array([3.0, 3.0, 2.5]), 30.0, -90.0))  # straight down: the image's up sets the roll
    lit_geoms: list[int] = []
    lit = SceneRenderer._lit_pass

    def counted(self, seg, rebuild=False):
        out = lit(self, seg, rebuild)
        lit_geoms.append(self._renderer.scene.ngeom)
        return out

    try:
        monkeypatch.setattr(SceneRenderer, "_lit_pass", counted)
        culled = [r.render(T, rgb=True, depth=True, segmentation=True) for T in poses]
        rgb_depth = [r.render(T, rgb=True, depth=True, segmentation=False) for T in poses]  # a small scene: no cut
        monkeypatch.setattr(render_module, "LIT_CUT_MIN_TRIANGLES", 0)  # the cut without segmentation asked for
        rgb_depth_cut = [r.render(T, rgb=True, depth=True, segmentation=False) for T in poses]
        skipped = [r.outside_view(T) for T in poses]
        monkeypatch.setattr(SceneRenderer, "outside_view", lambda self, T: np.zeros(0, dtype=np.int64))
        monkeypatch.setattr(SceneRenderer, "_lit_pass",  # draw everything
                            lambda self, seg, rebuild=False: counted(self, None, rebuild))
        full = [r.render(T, rgb=True, depth=True, segmentation=True) for T in poses]
    finally:
        r.close()
    assert sum(len(s) for s in skipped) > 0  # the frustum cull does hide geoms in these views
    n = len(poses)
    assert all(a < b for a, b in zip(lit_geoms[:n], lit_geoms[3 * n:]))  # and the lit pass draws fewer than all
    assert all(a < b for a, b in zip(lit_geoms[2 * n:3 * n], lit_geoms[3 * n:]))
    # below the triangle count that pays: everything in the frustum, more than the cut draws
    assert all(a >= b for a, b in zip(lit_geoms[n:2 * n], lit_geoms[2 * n:3 * n]))
    assert any(a > b for a, b in zip(lit_geoms[n:2 * n], lit_geoms[2 * n:3 * n]))
    for a, c, cc, b, out in zip(culled, rgb_depth, rgb_depth_cut, full, skipped):
        assert np.array_equal(a.rgb, b.rgb) and np.array_equal(a.depth, b.depth)
        assert np.array_equal(c.rgb, b.rgb) and np.array_equal(c.depth, b.depth) and c.segmentation is None
        assert np.array_equal(cc.rgb, b.rgb) and np.array_equal(cc.depth, b.depth) and cc.segmentation is None
        assert np.array_equal(a.segmentation, b.segmentation)
        assert not set(np.unique(b.segmentation).tolist()) & set(out.tolist())


def test_occlusion_cull_leaves_every_image_unchanged(two_storey, monkeypatch):
    """Walks through the two-storey apartment (steps, turns, looking down and up; each walk's first frame without a
    previous one): with the occlusion test on every frame (no triangle floor), the flat pass leaves out geoms lying
    behind those the previous frame showed and those the test found drawn, and every image (geom ids, depth, colour)
    equals that of a second renderer drawing everything in view."""
    import math

    from sdovon_mj import native
    from sdovon_mj.observe.render_views import load_model, make_renderer
    from sdovon_mj.sim import render as render_module
    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer

    assert native.library() is not None, native.status()  # the test needs the compiled kernels
    scene, root, *_ = two_storey
    model = load_model(scene, root)
    cfg = dataclasses.replace(ObserveConfig(), width=160, height=120)
    culled, full = make_renderer(model, cfg), make_renderer(model, cfg)
    monkeypatch.setattr(render_module, "OCCLUSION_MIN_TRIANGLES", 0)
    left_out: list[int] = []
    occluded = SceneRenderer._occluded

    def counted(self):
        if self is full:  # the reference draws everything in view
            return np.zeros(0, dtype=np.int64)
        out = occluded(self)
        left_out.append(len(out))
        return out

    monkeypatch.setattr(SceneRenderer, "_occluded", counted)
    rng = np.random.default_rng(4756)
    try:
        for x, y, z in ((2.0, 4.0, 0.88), (6.0, 2.5, 3.68), (1.0, 1.0, 2.0), (4.0, 3.0, 1.2)):
            yaw, pitch = float(rng.uniform(0.0, 360.0)), 0.0
            for step in range(24):
                move = int(rng.integers(4))
                if move == 0:
                    x, y = x + 0.25 * math.cos(math.radians(yaw)), y + 0.25 * math.sin(math.radians(yaw))
                elif move == 1:
                    yaw += 30.0
                elif move == 2:
                    yaw -= 30.0
                else:
                    pitch = -30.0 if pitch == 0.0 else (25.0 if pitch < 0.0 else 0.0)
                T = pose_cv(np.array([x, y, z]), yaw, pitch)
                rgb = step % 3 == 0
                if step == 0:  # a first frame: no previous one, the test's own depth-ordered occluders only
                    culled._shown_last = None
                a = culled.render(T, rgb=rgb, depth=True, segmentation=True)
                b = full.render(T, rgb=rgb, depth=True, segmentation=True)
                assert np.array_equal(a.segmentation, b.segmentation), (x, y, yaw, pitch)
                assert np.array_equal(a.depth, b.depth), (x, y, yaw, pitch)
                assert not rgb or np.array_equal(a.rgb, b.rgb), (x, y, yaw, pitch)
    finally:
        culled.close()
        full.close()
    assert sum(n > 0 for n in left_out) > 10  # the test does leave geoms out in these views


def _box_mesh(name: str, lo: tuple, hi: tuple) -> str:
    v = " ".join(f"{x} {y} {z}" for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2]))
    return f'<mesh name="{name}" vertex="{v}"/>'


def test_occlusion_test_leaves_out_only_what_lies_behind_drawn_triangles(monkeypatch):
    """A camera at the origin looking along +x at a wall 3 m away: a box wholly behind the wall is left out; a box
    poking 4 cm out of the wall's face, and a box behind a one-sided quad that faces away (MuJoCo culls its back
    face, so the box shows) are drawn; the floor reaching behind the camera bounds depth only beyond the near plane;
    a primitive box in front bounds nothing (it has no mesh). The images equal a render of everything, after a
    previous frame and in a first one. (A kernel counting back faces, or lowering its depth bound by 3 %, or raising a
    box's limit, or reading a primitive as the first mesh, fails here.)"""
    import mujoco

    from sdovon_mj import native
    from sdovon_mj.sim import render as render_module
    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer

    assert native.library() is not None, native.status()  # the test needs the compiled kernels
    names = ("block", "wall", "poke", "behind", "seen", "floor", "quad", "prim")
    xml = ("<mujoco><asset>" + _box_mesh("block", (-6.0, -1.0, -1.0), (-4.0, 1.0, 1.0))  # the first mesh, out of view
           + _box_mesh("wall", (3.0, -3.0, -2.0), (3.1, 3.0, 2.0))
           + _box_mesh("poke", (2.96, 0.5, 0.0), (3.05, 0.7, 0.2)) + _box_mesh("behind", (3.5, -0.3, -0.3), (3.7, 0.3, 0.3))
           + _box_mesh("seen", (2.0, -1.2, -0.2), (2.2, -0.8, 0.2)) + _box_mesh("floor", (-2.0, -3.0, -1.0), (3.0, 3.0, -0.9))
           + '<mesh name="quad" vertex="1.5 -1.5 -0.5  1.5 -0.5 -0.5  1.5 -0.5 0.5  1.5 -1.5 0.5  1.6 -1 0" '
             'face="0 1 2 0 2 3" inertia="shell"/>'  # a one-sided quad whose front faces +x (away from the camera)
           + "</asset><worldbody>" + "".join(f'<geom name="{n}" type="mesh" mesh="{n}"/>' for n in names[:-1])
           # a primitive box, big enough on screen to be tested first: no mesh, so no triangles (read as the first
           # mesh's, a 2 m cube's, it would hide the boxes behind it)
           + '<geom name="prim" type="box" size="0.3 0.3 0.3" pos="1.5 -0.9 0.6"/>'
           + "</worldbody></mujoco>")
    model = mujoco.MjModel.from_xml_string(xml)
    gid = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in names}
    monkeypatch.setattr(render_module, "OCCLUSION_MIN_TRIANGLES", 0)
    culled = SceneRenderer(model, width=160, height=120, hfov=79.0, groups=(0,))
    full = SceneRenderer(model, width=160, height=120, hfov=79.0, groups=(0,))
    full._occluded = lambda: np.zeros(0, dtype=np.int64)  # the reference draws everything in view
    try:
        T = pose_cv(np.zeros(3), 0.0, 0.0)
        want = full.render(T, rgb=True, depth=True, segmentation=True)
        assert {gid[n] for n in ("wall", "poke", "seen", "floor", "prim")} <= set(np.unique(want.segmentation).tolist())
        assert gid["quad"] not in want.segmentation and gid["behind"] not in want.segmentation
        culled._shown_last = np.zeros(model.ngeom, dtype=bool)  # as if the last frame had shown these
        culled._shown_last[[gid["wall"], gid["quad"], gid["floor"]]] = True
        culled._pose_camera(T)
        culled._update_scene()
        assert sorted(culled._occluded().tolist()) == [gid["behind"]]
        got = culled.render(T, rgb=True, depth=True, segmentation=True)
        assert np.array_equal(got.segmentation, want.segmentation) and np.array_equal(got.depth, want.depth)
        assert np.array_equal(got.rgb, want.rgb)
        # a first frame: no occluders from a previous one; the tested meshes, nearest box first, bound the depth for
        # the rest when drawn (the quad, facing away, bounds nothing: the box behind it is drawn)
        culled._shown_last = None
        assert sorted(culled._occluded().tolist()) == [gid["behind"]]
        culled._shown_last = None
        got = culled.render(T, rgb=True, depth=True, segmentation=True)
        assert np.array_equal(got.segmentation, want.segmentation) and np.array_equal(got.depth, want.depth)
    finally:
        culled.close()
        full.close()


def test_render_labels_equal_the_lookup_of_the_geom_ids(two_storey):
    """`SceneRenderer.render(..., labels=)` gives per pixel the label of its geom (-1 where none): the geom-id image
    looked up through the labels (`segment_image`), with and without colour."""
    from sdovon_mj.observe.render_views import load_model, make_renderer
    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.model import segment_image

    scene, root, *_ = two_storey
    model = load_model(scene, root)
    r = make_renderer(model, dataclasses.replace(ObserveConfig(), width=96, height=72))
    labels = np.random.default_rng(4757).integers(-1, 100_500, size=model.ngeom)  # -1: a geom of no segment
    seen: set[int] = set()
    try:
        for yaw in (0.0, 130.0, 250.0):
            T = pose_cv(np.array([2.0, 4.0, 0.88]), yaw, -20.0)
            ids = r.render(T, rgb=False, depth=False, segmentation=True).segmentation
            for rgb in (False, True):
                got = r.render(T, rgb=rgb, depth=True, segmentation=True, labels=labels).segmentation
                want = segment_image(ids, labels)
                assert got.dtype == want.dtype and np.array_equal(got, want)
            seen |= set(np.unique(ids).tolist())
    finally:
        r.close()
    assert len(seen) > 4


def test_renderers_of_one_model_keep_their_own_view():
    """Two renderers of one model with different image shapes and depth ranges (the model holds one camera setting):
    the first one's images are the same before the second is built, after it, and after it draws."""
    import mujoco

    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer

    xml = ('<mujoco><worldbody><light pos="0 0 4"/><geom type="box" size="0.1 2 2" pos="3 0 0" rgba="0 0 1 1"/>'
           '<geom type="sphere" size="0.3" pos="2 0.8 0.5" rgba="1 0 0 1"/></worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    T = pose_cv(np.zeros(3), 0.0, 0.0)
    a = SceneRenderer(model, width=96, height=72, hfov=79.0, znear=0.05, zfar=50.0, groups=(0,))
    try:
        first = a.render(T, rgb=True, depth=True, segmentation=True)
        b = SceneRenderer(model, width=128, height=48, hfov=60.0, znear=0.2, zfar=10.0, groups=(0,))
        try:
            after_build = a.render(T, rgb=True, depth=True, segmentation=True)
            other = b.render(T, rgb=True, depth=True, segmentation=True)
            after_draw = a.render(T, rgb=True, depth=True, segmentation=True)
        finally:
            b.close()
    finally:
        a.close()
    for f in (after_build, after_draw):
        assert np.array_equal(f.rgb, first.rgb) and np.array_equal(f.depth, first.depth)
        assert np.array_equal(f.segmentation, first.segmentation)
    assert other.depth.shape == (48, 128) and np.count_nonzero(other.segmentation == 1) > 0


def test_a_renderer_sharing_another_ones_context_draws_its_own_images(two_storey):
    """A smaller renderer drawing with a larger one's GL context (`share=`) gives the images of a renderer of its
    own (colour, depth, geom ids, at several poses, its field of view and range too), and the larger one's images
    stay its own; closing the larger one first makes the smaller one refuse to draw."""
    from sdovon_mj.observe.render_views import load_model
    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer

    scene, root, *_ = two_storey
    model = load_model(scene, root)
    big = SceneRenderer(model, width=160, height=120, hfov=79.0)
    small = SceneRenderer(model, width=96, height=48, hfov=60.0, znear=0.1, zfar=20.0, share=big)
    alone = SceneRenderer(model, width=96, height=48, hfov=60.0, znear=0.1, zfar=20.0)
    poses = [pose_cv(np.array(p), yaw, pitch) for p in ((2.0, 4.0, 0.88), (6.0, 2.5, 3.68))
             for yaw in (0.0, 140.0, 260.0) for pitch in (-30.0, 0.0)]
    try:
        assert small._renderer is big._renderer and alone._renderer is not big._renderer
        for T in poses:
            before = big.render(T, rgb=True, depth=True, segmentation=True)
            a = small.render(T, rgb=True, depth=True, segmentation=True)
            b = alone.render(T, rgb=True, depth=True, segmentation=True)
            after = big.render(T, rgb=True, depth=True, segmentation=True)
            assert a.rgb.shape == (48, 96, 3)
            assert np.array_equal(a.rgb, b.rgb) and np.array_equal(a.depth, b.depth)
            assert np.array_equal(a.segmentation, b.segmentation)
            assert np.array_equal(before.rgb, after.rgb) and np.array_equal(before.depth, after.depth)
        big.close()
        with pytest.raises(RuntimeError, match="shares was closed"):
            small.render(poses[0], rgb=False, depth=True)
    finally:
        for r in (small, alone, big):
            r.close()


def test_frustum_cull_uses_the_camera_mujoco_draws_with():
    """The frustum test reads the camera mjr_render draws a mono scene with (the average of the scene's two eye
    cameras, half the inter-pupillary distance either side): a small box near the right edge of the view, close to
    the camera, lies outside the left eye's frustum yet shows in the render, and it is not culled."""
    import mujoco

    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer

    # camera at the origin looking along +x (image right is -y); hfov 79 degrees: the right edge at 0.3 m ahead
    # lies 0.3 * tan(39.5 deg) = 0.247 m to the right, the left eye's (3.4 cm further left, its side widened 5 %)
    # 0.226 m: a 2 mm box centred 0.243 m to the right lies between, 13 mm beyond the left eye's side plane
    xml = ('<mujoco><worldbody><geom type="box" size="0.002 0.002 0.002" pos="0.3 -0.243 0" rgba="1 0 0 1"/>'
           '<geom type="box" size="0.1 2 2" pos="3 0 0" rgba="0 0 1 1"/></worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    r = SceneRenderer(model, width=320, height=240, hfov=79.0, groups=(0,))
    try:
        T = pose_cv(np.array([0.0, 0.0, 0.0]), 0.0, 0.0)
        seg = r.render(T, rgb=False, depth=False, segmentation=True).segmentation
        r._pose_camera(T)
        r._update_scene()
        eye = r._renderer.scene.camera[0]
        assert abs(float(np.linalg.norm(np.asarray(eye.pos) - np.asarray(r.gl_camera().pos))) - 0.034) < 1e-6
        assert 0 not in r.outside_view(T).tolist()
        assert np.count_nonzero(seg == 0) > 0  # the box shows at the right edge
        assert np.flatnonzero((seg == 0).any(axis=0)).min() > 300
    finally:
        r.close()


GLASS = """<mujoco>
  <asset><material name="glass" rgba="0.2 0.4 0.9 0.4"/></asset>
  <worldbody>
    <light pos="0 0 4" dir="0 0 -1"/>
    <geom name="floor" type="plane" size="5 5 0.1" rgba="0.6 0.6 0.6 1"/>
    <geom name="pane" type="box" pos="1.5 0 1" size="0.02 1 1" material="glass"/>
    <geom name="red" type="box" pos="3 0 1" size="0.3 0.3 0.3" rgba="1 0 0 1"/>
  </worldbody>
</mujoco>"""


def test_lit_pass_draws_what_shows_through_glass(monkeypatch):
    """A geom behind a see-through one wins no pixel of the flat pass, yet shows in the lit image: with a transparent
    geom in the segmentation the lit pass draws everything in view, and the images are a full render's."""
    import mujoco

    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer, hiding

    model = mujoco.MjModel.from_xml_string(GLASS)
    r = SceneRenderer(model, width=96, height=72, hfov=60.0, groups=(0,))
    T = pose_cv(np.array([0.0, 0.0, 1.0]), 0.0, 0.0)
    red = model.geom("red").id
    lit = SceneRenderer._lit_pass
    try:
        a = r.render(T, rgb=True, depth=True, segmentation=True)
        with hiding(model, np.array([red])):
            no_red = r.render(T, rgb=True, depth=True, segmentation=True)
        monkeypatch.setattr(SceneRenderer, "_lit_pass",  # draw everything
                            lambda self, seg, rebuild=False: lit(self, None, rebuild))
        b = r.render(T, rgb=True, depth=True, segmentation=True)
    finally:
        r.close()
    assert red not in set(np.unique(a.segmentation).tolist())  # the pane hides it from the flat pass
    assert np.array_equal(a.rgb, b.rgb) and np.array_equal(a.depth, b.depth)
    assert not np.array_equal(a.rgb, no_red.rgb)  # and it shows through the pane in the lit image


def test_a_geom_the_occlusion_test_leaves_out_behind_glass_still_shows_in_the_lit_image(monkeypatch):
    """A mesh pane of glass in front of a box: the flat pass draws the pane opaque, so the occlusion test leaves the box
    out of it; the lit pass, seeing a transparent geom, draws everything in view again (the scene rebuilt with the
    box), and every image equals that of a renderer drawing everything in view."""
    import mujoco

    from sdovon_mj.sim import render as render_module
    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer

    xml = ("<mujoco><asset>" + _box_mesh("pane", (1.0, -2.0, -2.0), (1.02, 2.0, 2.0))
           # the box off the pane's diagonal: its two triangles leave the pixels along their shared edge unbounded
           + _box_mesh("box", (4.0, 0.9, -0.3), (4.6, 1.5, 0.3)) + "</asset><worldbody>"
           + '<light pos="0 0 4" dir="0 0 -1"/><geom name="pane" type="mesh" mesh="pane" rgba="0.5 0.5 1 0.3"/>'
           + '<geom name="box" type="mesh" mesh="box" rgba="1 0 0 1"/></worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    monkeypatch.setattr(render_module, "OCCLUSION_MIN_TRIANGLES", 0)
    culled = SceneRenderer(model, width=96, height=72, hfov=60.0, groups=(0,))
    full = SceneRenderer(model, width=96, height=72, hfov=60.0, groups=(0,))
    full._occluded = lambda: np.zeros(0, dtype=np.int64)  # the reference draws everything in view
    T = pose_cv(np.zeros(3), 0.0, 0.0)
    try:
        culled._pose_camera(T)
        culled._update_scene()
        assert culled._occluded().tolist() == [model.geom("box").id]  # left out of the flat pass
        for _ in range(2):  # a first frame, then one after it
            a = culled.render(T, rgb=True, depth=True, segmentation=True)
            b = full.render(T, rgb=True, depth=True, segmentation=True)
            assert np.array_equal(a.rgb, b.rgb) and np.array_equal(a.depth, b.depth)
            assert np.array_equal(a.segmentation, b.segmentation)
    finally:
        culled.close()
        full.close()


@pytest.mark.parametrize("how", ["close", "collect"])
def test_closing_one_renderer_leaves_another_intact(how):
    """Closing (or dropping) a renderer while another one's GL context is current frees its own GL objects, not the
    other's: the other renderer's next frames are the same as before (mujoco.Renderer.close frees by GL name in the
    current context; without making its own current first the other's framebuffer went and its frames changed)."""
    import gc

    import mujoco

    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer

    model = mujoco.MjModel.from_xml_string(GLASS)
    T = pose_cv(np.array([0.0, 0.0, 1.0]), 0.0, 0.0)
    keep = SceneRenderer(model, width=96, height=72, hfov=60.0, groups=(0,))
    try:
        before = keep.render(T, rgb=True, depth=True, segmentation=True)
        other = SceneRenderer(model, width=96, height=72, hfov=60.0, groups=(0,))
        other.render(T, rgb=True, depth=True, segmentation=True)
        keep.render(T, rgb=True, depth=True, segmentation=True)  # the kept renderer's context is current
        if how == "close":
            other.close()
        else:
            del other
            gc.collect()
        after = keep.render(T, rgb=True, depth=True, segmentation=True)
    finally:
        keep.close()
    assert np.array_equal(before.rgb, after.rgb) and np.array_equal(before.depth, after.depth)
    assert np.array_equal(before.segmentation, after.segmentation)


# ---------------------------------------------------------------------------------------------- stage + CLI

def test_observe_scene_writes_everything_deterministically(two_storey, tmp_path):
    scene, root, *_ = two_storey
    cfg = dataclasses.replace(ObserveConfig(), width=96, height=72, yaw_steps=2, pitch_angles=(0.0,), frames_per_shard=5)
    s1 = observe_scene(scene, root, "observe", cfg, seed=3, out_root=tmp_path / "a")
    observe_scene(scene, root, "observe", cfg, seed=3, out_root=tmp_path / "b")
    assert [fl["height"] for fl in s1["floors"]] == [0.0, 2.8]
    assert s1["frames"] == s1["viewpoints"] * 2 * (1 + len(cfg.camera_heights) * len(cfg.camera_height_pitches)) and len(s1["shards"]) == -(-s1["frames"] // 5)
    for rel in s1["outputs"]:
        assert (tmp_path / "a" / rel).read_bytes() == (tmp_path / "b" / rel).read_bytes(), rel
    obs = list(load_shards([tmp_path / "a" / p for p in s1["shards"]]))
    assert len(obs) == s1["frames"] and obs[0].K.shape == (3, 3) and obs[0].T_cam.shape == (4, 4)
    vps = load_json(tmp_path / "a" / "observe" / "viewpoints.json", CoverageCamera)
    assert {vp.floor for vp in vps} == {0, 1}
    for k in (0, 1):
        assert (tmp_path / "a" / "observe" / f"coverage_{k}.png").read_bytes()[:4] == b"\x89PNG"
        assert load_json(tmp_path / "a" / "observe" / f"navmap_{k}.json", NavMap).floor == k


def test_observe_scene_without_floor_names_the_mesh(tmp_path):
    scene = write_box_scene([Box("wall", (0, 0, 0), (4, 0.1, 2.5))], tmp_path)
    with pytest.raises(InputError) as e:
        observe_scene(scene, tmp_path, "observe", ObserveConfig(), render=False)
    assert scene.mesh in str(e.value) and "no floor found" in str(e.value)


@pytest.mark.parametrize("boxes", [60, 300])
def test_id_decoding_reads_only_the_colours_shown_and_equals_the_full_table(boxes):
    """SceneRenderer._decode_table builds its colour -> geom table from the colours the image shows (checking that
    scene geom c - 1 holds segment c - 1): the same geom-id image as the table of every scene geom, with the ids in
    the red channel (under 255 geoms) and in all three (more)."""
    import mujoco

    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer

    side = int(np.ceil(np.sqrt(boxes)))
    geoms = "".join(f'<geom type="box" size="0.04 0.04 0.04" pos="3 {(k % side - side / 2) * 0.1:.2f} '
                    f'{1 + (k // side - side / 2) * 0.1:.2f}" rgba="0.5 0.5 0.5 1"/>' for k in range(boxes))
    model = mujoco.MjModel.from_xml_string(f"<mujoco><worldbody><light pos='0 0 4'/>{geoms}</worldbody></mujoco>")
    r = SceneRenderer(model, width=96, height=72, hfov=90.0, groups=(0,))
    try:
        r.render(pose_cv(np.array([0.0, 0.0, 1.0]), 0.0, 0.0), rgb=False, segmentation=True)  # posed and updated
        ids, _ = r._pass(flat=True, want_rgb=True, want_depth=False)
        codes, lut, _ = r._decode_table(ids)
        got = lut.take(codes)
        scn = r._renderer.scene
        n = scn.ngeom
        table = np.full(n + 1, -1, dtype=np.int32)
        for g in scn.geoms[:n]:  # the table of every geom, as the code before built it
            if g.segid != -1 and g.objtype == int(mujoco.mjtObj.mjOBJ_GEOM):
                table[g.segid + 1] = g.objid
        if n < 255:
            want = np.concatenate([table, np.full(255 - n, -1, np.int32)]).take(ids[..., 0])
        else:
            seg = ids[..., 0].astype(np.int32) | (ids[..., 1].astype(np.int32) << 8) | (ids[..., 2].astype(np.int32) << 16)
            want = table.take(np.clip(seg, 0, n))
    finally:
        r.close()
    assert (n >= 255) == (boxes >= 255)
    assert np.array_equal(got, want) and len(np.unique(got)) > min(boxes, 40)
