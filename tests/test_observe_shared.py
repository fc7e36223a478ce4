"""Observe stage on the two shared third-party scenes (../shared/assets/scenes).

Until assets_convert.convert_scene lands, the scenes are composed here with trimesh (the living room
from its placements.json, glTF +Y up rotated to +Z up as Drake does; simple_room as loaded).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sdovon_mj.config import ObserveConfig
from sdovon_mj.observe import coverage_viewpoints, find_floors, navigable_map, render_observations
from support.scenes import living_room_parts, write_mesh_scene
from sdovon_mj.sim.camera import backproject
from sdovon_mj.sim.model import load_scene_mesh


@pytest.fixture(scope="module")
def living_room(shared_assets, tmp_path_factory):
    out = tmp_path_factory.mktemp("lr")
    scene = write_mesh_scene(living_room_parts(shared_assets), out, "living_room")
    v, f, fi = load_scene_mesh(out / scene.mesh)
    return scene, out, v, f, fi


# furniture origins of placements.json (world XY, Z up)
FURNITURE = {"cabinet": (-1.7753, 2.5818), "bookshelves": (2.716, -1.0716), "tall_cabinet": (0.0235, 2.6566),
             "sofa": (0.0, -2.4117)}


def test_living_room_floor_and_navmap_excludes_furniture(living_room):
    _s, _o, v, f, _fi = living_room
    cfg = ObserveConfig()
    floors = find_floors(v, f, cfg)
    assert len(floors) == 1 and abs(floors[0].height) < 0.05
    nm = navigable_map(v, f, floors[0], cfg)
    for name, xy in FURNITURE.items():
        assert not nm.is_navigable(np.array([xy]))[0], name
    # the stool (thin legs, seat at ~0.45 m) blocks as a whole: its footprint centre is not free
    assert not nm.free[tuple(nm.frame.to_cell(np.array([(1.7744, 1.6287)]))[0])]
    assert nm.is_navigable(np.array([(0.0, 0.0)]))[0]  # the middle of the room
    area = nm.navigable.sum() * nm.resolution ** 2
    assert 15.0 < area < 36.0  # a 6 x 6 m room minus furniture and the agent-radius margin


def test_living_room_depth_points_lie_on_surfaces(living_room):
    import trimesh

    scene, root, v, f, _fi = living_room
    cfg = dataclasses.replace(ObserveConfig(), width=160, height=120, yaw_steps=4, pitch_angles=(-30.0,))
    nm = navigable_map(v, f, find_floors(v, f, cfg)[0], cfg)
    vps, _mp, _st = coverage_viewpoints(nm, cfg, seed=0)
    mesh = trimesh.Trimesh(v, f, process=False)
    rng = np.random.default_rng(1)
    medians = []
    for o in render_observations(scene, vps[:1], cfg, store_root=root):
        pts = backproject(o.depth, o.K, o.T_cam)
        assert len(pts) > 0.8 * o.depth.size
        sel = rng.choice(len(pts), size=200, replace=False)
        _c, d, _t = trimesh.proximity.closest_point(mesh, pts[sel])
        medians.append(float(np.median(d)))
    assert max(medians) < 0.01, medians


def test_simple_room_floor_table_and_block(shared_assets):
    import trimesh

    s = trimesh.load(shared_assets / "scenes" / "simple_room" / "simple_room.glb", force="scene")
    m = s.to_geometry()
    cfg = ObserveConfig()
    floors = find_floors(m.vertices, m.faces, cfg)
    assert len(floors) == 1 and abs(floors[0].height - 0.145) < 0.02
    nm = navigable_map(m.vertices, m.faces, floors[0], cfg)
    # the table (top 1.4 m square at 1.1 m on four thin legs) and the 2 m block are obstacles
    assert not nm.is_navigable(np.array([(0.25, 0.25), (0.5, 0.5), (2.37, -1.39)])).any()
    assert nm.is_navigable(np.array([(-3.0, -3.0), (3.0, 3.0)])).all()
