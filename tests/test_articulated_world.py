"""Articulated furniture in the default world (``world.articulated``) through world:scene and convert: the room
programs place cabinets, fridges, microwaves, dressers and wardrobes where they belong, clear of the other
furniture; the scene writer emits each as URDF + meshes with a sidecar; the converted scene MJCF holds them as
bodies with their hinge/slide joints and collision geoms, named as scene instances, and SceneAsset lists them."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import mujoco

from assets_convert.scene import convert_scene
from sdovon_mj.records import SceneAsset, records_equal
from sdovon_mj.sim.model import geom_segment_ids, load_scene_mesh
from sdovon_mj.world import generate_apartment, write_apartment
from sdovon_mj.world.articulated import SIZES

SEEDS = (0, 1, 2, 3)
ROOMS_OF = {"fridge": {"kitchen"}, "cabinet": {"kitchen", "bathroom"}, "microwave": {"kitchen"},
            "wardrobe": {"bedroom"}, "dresser": {"bedroom", "living room", "dining room", "office"}}


def test_switch_off_writes_no_pieces(tmp_path: Path) -> None:
    apt = generate_apartment(0)
    assert apt.articulated == ()
    write_apartment(apt, tmp_path, name="apt_0000")
    assert not list(tmp_path.glob("*.articulated*"))


def test_pieces_in_their_rooms_and_clear_of_other_furniture() -> None:
    kinds: dict[str, int] = {}
    for s in SEEDS:
        apt = generate_apartment(s, articulated=True)
        assert apt.articulated, s
        m = apt.mesh
        furniture = np.isin(m.face_instance, [i.id for i in apt.instances if i.kind != "structure"])
        tri = m.vertices[m.faces[furniture]]
        for p in apt.articulated:
            kinds[p.kind] = kinds.get(p.kind, 0) + 1
            inst = apt.instance(p.id)
            assert inst.kind == "receptacle" and not np.any(m.face_instance == p.id)  # no triangles: it is a URDF
            assert apt.rooms[p.room].type in ROOMS_OF[p.kind], (s, p)
            # the piece's footprint (yaw about its back-centre origin) lies inside its room
            (w0, w1), (d0, d1), (h0, h1) = SIZES[p.kind]
            yaw = math.radians(p.yaw)
            R = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
            # the box of the largest size this kind can have bounds the real one from outside; the smallest inside
            small = np.array([[-w0 / 2, 0], [w0 / 2, 0], [w0 / 2, d0], [-w0 / 2, d0]]) @ R.T + np.asarray(p.position[:2])
            room = apt.rooms[p.room].polygon
            assert np.all(small >= room.min(0)) and np.all(small <= room.max(0)), (s, p)
            # no other furniture triangle reaches into the smallest box this piece can have (1 cm inset)
            lo = np.append(small.min(0) + 0.01, p.position[2] + 0.01)
            hi = np.append(small.max(0) - 0.01, p.position[2] + h0 - 0.01)
            cen = tri.mean(axis=1)
            inside = np.all((cen > lo) & (cen < hi), axis=1)
            assert not inside.any(), (s, p.kind, int(inside.sum()))
    assert {"fridge", "cabinet", "dresser", "wardrobe"} <= set(kinds), kinds


def test_scene_writer_and_convert_keep_the_joints(tmp_path: Path) -> None:
    apt = generate_apartment(0, articulated=True)
    src = tmp_path / "in"
    write_apartment(apt, src, name="apt_0000")
    side = json.loads((src / "apt_0000.articulated.json").read_text())
    assert side["format"] == "sdovon-articulated/1"
    assert [p["id"] for p in side["pieces"]] == [p.id for p in apt.articulated]
    for p in side["pieces"]:
        assert (src / p["urdf"]).is_file() and p["joints"] and p["interiors"]
    # same seed, same bytes
    again = tmp_path / "again"
    write_apartment(generate_apartment(0, articulated=True), again, name="apt_0000")
    for f in sorted(src.rglob("*")):
        if f.is_file():
            assert (again / f.relative_to(src)).read_bytes() == f.read_bytes(), f

    asset = convert_scene(src / "apt_0000.glb", tmp_path / "out", name="apt_0000", cache_dir=tmp_path / "cache")
    assert [f.instance_id for f in asset.articulated] == [p.id for p in apt.articulated]
    assert records_equal(SceneAsset.from_json(asset.to_json()), asset)
    root = tmp_path / "out"
    model = mujoco.MjModel.from_xml_path(str(root / asset.mjcf))
    data = mujoco.MjData(model)
    seg = geom_segment_ids(model)
    V, F, FI = load_scene_mesh(root / asset.mesh)
    for fx in asset.articulated:
        inst = asset.instance(fx.instance_id)
        assert inst.label == fx.label and inst.geoms
        assert all(seg[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g)] == fx.instance_id for g in inst.geoms)
        assert np.any(FI == fx.instance_id)  # in the ray-cast / navigation mesh
        ncoll = sum(1 for g in range(model.ngeom) if model.geom_group[g] == 3 and model.geom_contype[g]
                    and mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g])).startswith(
                        f"art_{fx.instance_id}/"))
        assert ncoll >= 4, fx.label  # carcass panels collide
        assert fx.parts and fx.interiors and (root / fx.model).is_file()
        for part in fx.parts:
            j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, part.joint)
            assert j >= 0 and model.jnt_limited[j]
            lo, hi = model.jnt_range[j]
            assert (lo, hi) == pytest.approx(part.range)
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, part.body)
            mujoco.mj_forward(model, data)
            closed = data.xpos[b].copy(), data.xquat[b].copy()
            data.qpos[model.jnt_qposadr[j]] = hi
            mujoco.mj_forward(model, data)
            moved = np.linalg.norm(data.xpos[b] - closed[0]) + np.linalg.norm(data.xquat[b] - closed[1])
            assert moved > 1e-3, part.joint
            data.qpos[:] = model.qpos0
        for s in fx.interiors:
            assert s.joint is None or s.joint in {p.joint for p in fx.parts}
            # the interior surface lies inside the piece's closed box
            lo, hi = inst.bounds
            assert lo[2] - 1e-6 <= s.height <= hi[2] + 1e-6
            assert np.all(s.polygon >= lo[:2] - 1e-6) and np.all(s.polygon <= hi[:2] + 1e-6)


def test_rigid_scene_json_has_no_articulated_key(tmp_path: Path) -> None:
    apt = generate_apartment(0)
    write_apartment(apt, tmp_path / "in", name="apt_0000")
    asset = convert_scene(tmp_path / "in" / "apt_0000.glb", tmp_path / "out", name="apt_0000",
                          cache_dir=tmp_path / "cache")
    assert asset.articulated == [] and "articulated" not in json.loads(asset.to_json())
