"""A closed wall cabinet's underside is no support surface: perceive records, per fused point, how high an
observing camera was above it, and the EM plane detection keeps only planes seen from above.

An up-facing surface can only be observed by a camera above it; a wall cabinet's bottom face (a closed box:
its inside is never seen, so no point of the cabinet covers the face from just above) is seen only from
below. The scene is rendered with real MuJoCo from agent-like heights below the cabinet and a raised camera
above it.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pytest

from test_perceive_scenes import BoxPart, RoomInstance, mjcf, render_observations, scene_asset, table
from sdovon_mj.config import PerceiveConfig, ReceptacleConfig
from sdovon_mj.perceive import backproject_detections, detect_stream, fuse_instances, perceive_scene
from sdovon_mj.perceive.gt_detector import GroundTruthDetector
from sdovon_mj.receptacles import find_receptacle_planes
from sdovon_mj.records import Instance, load_npz, save_npz

BOTTOM, TOP = 1.5, 2.2  # the wall cabinet's bottom and top faces, m


def _instances() -> list[RoomInstance]:
    """A table and a closed cabinet box hung at BOTTOM..TOP against a wall (the wall is a non-receptacle)."""
    cab = RoomInstance(2, "cabinet", [BoxPart((0.0, 1.5, (BOTTOM + TOP) / 2), (0.55, 0.175, (TOP - BOTTOM) / 2))])
    wall = RoomInstance(3, "wall", [BoxPart((0.0, 1.725, 1.3), (2.0, 0.05, 1.3))])
    return [table(1, 0.0, -0.4), cab, wall]


def _poses() -> list[np.ndarray]:
    """Agent-like views from below the cabinet (0.9 m and 1.3 m, some looking up) and raised views from 2.6 m."""
    from sdovon_mj.sim.camera import pose_cv

    poses = []
    for k in range(5):
        ang = math.radians(-150 + k * 30)  # in front of the wall (y < 1.3)
        for height, pitch, dist in ((0.9, -20.0, 2.2), (0.9, 25.0, 1.6), (1.3, 15.0, 1.8), (2.6, -45.0, 1.8)):
            pos = np.array([dist * math.cos(ang), 1.0 + dist * math.sin(ang), height])
            yaw = math.degrees(math.atan2(0.6 - pos[1], -pos[0]))
            poses.append(pose_cv(pos, yaw, pitch))
    return poses


@functools.lru_cache(maxsize=None)
def _scene() -> tuple:
    """The rendered scene, its asset and its fused instances (cached per process)."""
    insts = _instances()
    scene = scene_asset(insts)
    obs = render_observations(mjcf(insts, room=4.0), _poses(), width=240, height=180)
    fused = perceive_scene(obs, scene, PerceiveConfig())
    return insts, scene, obs, fused


def _by_label(fused: list[Instance], label: str) -> Instance:
    (inst,) = [i for i in fused if i.label == label]
    return inst


def test_fused_points_record_how_high_the_camera_was() -> None:
    _insts, _scene_asset, obs, fused = _scene()
    cams = np.array([o.T_cam[2, 3] for o in obs])
    cab = _by_label(fused, "cabinet")
    vh = np.asarray(cab.view_height, dtype=float)
    assert cab.view_height is not None and vh.shape == (len(cab.points),) and cab.view_height.dtype == np.float32
    p = cab.world_points
    z = p[:, 2]
    # a point's value is some camera's height minus a point of its voxel: below the highest camera's height
    assert np.all(vh <= cams.max() - z + PerceiveConfig().voxel_size)
    # the bottom face (away from its edges, where the front face's voxels begin) was seen only from below,
    # the top face only from the raised cameras above it
    inner = (np.abs(p[:, 0]) < 0.5) & (np.abs(p[:, 1] - 1.5) < 0.125)
    bottom, top = inner & (np.abs(z - BOTTOM) < 0.005), inner & (np.abs(z - TOP) < 0.005)
    assert bottom.sum() >= ReceptacleConfig().rho_min and top.sum() >= ReceptacleConfig().rho_min
    assert np.all(vh[bottom] < 0) and np.all(vh[top] > 0)


def test_cabinet_underside_is_no_plane_but_the_table_and_the_cabinet_top_are() -> None:
    _insts, _scene_asset, _obs, fused = _scene()
    cfg = ReceptacleConfig()
    tol = 2 * cfg.eps_t

    def heights(planes: list, label: str) -> list[float]:
        return sorted(p.height for p in planes if p.label == label)

    # the premise (the bug): without the test the closed box's bottom face passes as a receptacle plane
    off = find_receptacle_planes(fused, dataclasses.replace(cfg, min_seen_above=0.0))
    assert any(abs(h - BOTTOM) <= tol for h in heights(off, "cabinet"))
    planes = find_receptacle_planes(fused, cfg)
    cab = heights(planes, "cabinet")
    assert not any(abs(h - BOTTOM) <= tol for h in cab)
    assert any(abs(h - TOP) <= tol for h in cab)  # the top, seen from the raised cameras, is a surface
    assert any(abs(h - 0.75) <= tol for h in heights(planes, "table"))
    # the other planes are the same planes either way
    key = [(p.label, round(p.height, 6), p.inliers) for p in planes]
    assert key == [(p.label, round(p.height, 6), p.inliers) for p in off if not (p.label == "cabinet" and abs(p.height - BOTTOM) <= tol)]


def test_instances_without_view_heights_are_not_tested() -> None:
    _insts, _scene_asset, _obs, fused = _scene()
    plain = [dataclasses.replace(i, view_height=None) for i in fused]
    cfg = ReceptacleConfig()
    off = find_receptacle_planes(fused, dataclasses.replace(cfg, min_seen_above=0.0))
    assert [(p.label, p.height) for p in find_receptacle_planes(plain, cfg)] == [(p.label, p.height) for p in off]


def test_view_heights_leave_the_fused_points_byte_identical_and_round_trip(tmp_path) -> None:
    _insts, scene, obs, fused = _scene()
    pcfg = PerceiveConfig()
    det = GroundTruthDetector(pcfg, scene)
    per_view = [i for o, dets in detect_stream(obs, det, pcfg.score_threshold) for i in backproject_detections(o, dets, pcfg)]
    assert all(i.view_height is not None and len(i.view_height) == len(i.points) for i in per_view)
    with_h = fuse_instances(per_view, pcfg)
    without = fuse_instances([dataclasses.replace(i, view_height=None) for i in per_view], pcfg)
    assert [i.points.tobytes() for i in with_h] == [i.points.tobytes() for i in without]
    assert all(i.view_height is None for i in without)
    # fusion keeps, per voxel, the highest camera: at least every constituent's value at that voxel
    cab_views = [i for i in per_view if i.label == "cabinet"]
    cab = _by_label(with_h, "cabinet")
    assert float(np.nanmax(cab.view_height)) == pytest.approx(max(float(np.max(i.view_height)) for i in cab_views), abs=1e-5)
    # instances.npz round trip, and a file written before the array existed still loads (None)
    save_npz(fused, tmp_path / "instances.npz")
    back = load_npz(tmp_path / "instances.npz")
    assert all(np.array_equal(a.view_height, b.view_height) and a.points.tobytes() == b.points.tobytes()
               for a, b in zip(fused, back))
    # an old file: its records have no view_height key at all
    import json

    from sdovon_mj.records import _savez_deterministic

    with np.load(tmp_path / "instances.npz") as z:
        arrays = {k: z[k] for k in z.files if not k.endswith("/view_height")}
    meta = json.loads(bytes(arrays["__meta__"]).decode("utf-8"))
    for d in meta:
        del d["view_height"]
    arrays["__meta__"] = np.frombuffer(json.dumps(meta).encode("utf-8"), dtype=np.uint8)
    import io

    buf = io.BytesIO()
    _savez_deterministic(buf, arrays)
    (tmp_path / "old.npz").write_bytes(buf.getvalue())
    old = load_npz(tmp_path / "old.npz")
    assert all(o.view_height is None and o.points.tobytes() == f.points.tobytes() for o, f in zip(old, fused))


def test_mismatched_view_heights_are_a_clear_error() -> None:
    from sdovon_mj.perceive.backproject import make_instance
    from sdovon_mj.receptacles.em_planes import detect_planes

    with pytest.raises(ValueError, match="view heights"):
        make_instance(np.zeros((4, 3)), "table", [1.0], [0], view_height=np.zeros(3))
    inst = dataclasses.replace(make_instance(np.random.default_rng(0).random((80, 3)), "table", [1.0], [0]),
                               view_height=np.zeros(5, np.float32))
    with pytest.raises(ValueError, match="view heights"):
        detect_planes(inst, ReceptacleConfig())
