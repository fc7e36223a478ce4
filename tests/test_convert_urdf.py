"""URDF -> MJCF (assets_convert.urdf): a third-party-style cabinet converts, its door and drawer move within their
limits in MuJoCo, objects on its interior shelf stay there when the door closes; bad URDFs name the file and the
link/joint; a Habitat ao_config beside a URDF is honoured; the URDF parses with a third-party parser."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mujoco

from assets_convert.object import convert_object_report
from assets_convert.urdf import read_urdf
from sdovon_mj.errors import InputError
from sdovon_mj.records import ObjectAsset, records_equal

W, D, H, T = 0.60, 0.50, 0.80, 0.02  # carcass width (x), depth (y), height (z), panel thickness (m)
SHELF_Z = 0.55  # interior shelf centre height (m)
DOOR_OPEN = 1.9  # door limit (rad)
DRAWER_OUT = 0.35  # drawer limit (m)
LIMIT_SLACK = 0.05  # rad / m: MuJoCo joint limits are soft constraints; a pushed joint may sit this far past them


def _box_obj(size: tuple[float, float, float], centre: tuple[float, float, float]) -> str:
    """Return OBJ text of an axis-aligned box."""
    c, h = np.asarray(centre), np.asarray(size) / 2
    v = [c + h * np.array([sx, sy, sz]) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    f = [(1, 3, 4), (1, 4, 2), (5, 6, 8), (5, 8, 7), (1, 2, 6), (1, 6, 5), (3, 7, 8), (3, 8, 4), (1, 5, 7), (1, 7, 3),
         (2, 4, 8), (2, 8, 6)]
    return "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in v) + "".join(f"f {a} {b} {c}\n" for a, b, c in f)


def _handle_obj() -> str:
    """Return OBJ text of a U-shaped bar handle (non-convex: a grip 12 cm tall on two 4 cm standoffs towards +y)."""
    boxes = [((0.016, 0.016, 0.12), (0, -0.032, 0)),  # grip, 4 cm in front of the door
             ((0.016, 0.032, 0.016), (0, -0.016, 0.052)), ((0.016, 0.032, 0.016), (0, -0.016, -0.052))]
    text, base = "", 0
    for size, centre in boxes:
        part = _box_obj(size, centre).splitlines()
        text += "".join(ln + "\n" for ln in part if ln.startswith("v "))
        text += "".join("f " + " ".join(str(int(t) + base) for t in ln.split()[1:]) + "\n" for ln in part if ln.startswith("f "))
        base += 8
    return text


def _box(size: tuple[float, ...], xyz: tuple[float, ...], rgba: str = "0.7 0.6 0.5 1") -> str:
    s = " ".join(f"{x:g}" for x in size)
    o = " ".join(f"{x:g}" for x in xyz)
    return (f'<visual><origin xyz="{o}"/><geometry><box size="{s}"/></geometry>'
            f'<material name="wood"><color rgba="{rgba}"/></material></visual>'
            f'<collision><origin xyz="{o}"/><geometry><box size="{s}"/></geometry></collision>')


def cabinet_urdf(folder: Path, name: str = "cabinet") -> Path:
    """Write a cabinet URDF the way third-party tools write them: a carcass of boxes, a hinged door (OBJ visual in
    centimetres, scale 0.01, authored Y-up and turned by its visual rpy; box collision), a bar handle on the door
    with only a (non-convex) visual mesh, a drawer of boxes on a prismatic joint, an interior shelf on a fixed joint turned by
    its rpy. Meshes under ``meshes/`` named with ``package://``."""
    pkg = folder / "cabinet_pkg"
    (pkg / "meshes").mkdir(parents=True, exist_ok=True)
    # door panel in cm, Y up: 60 wide (x), 45 tall (y), 2 thick (z, towards +z = out of the cabinet)
    (pkg / "meshes" / "door.obj").write_text(_box_obj((60, 45, 2), (30, 22.5, 1)))
    (pkg / "meshes" / "handle.obj").write_text(_handle_obj())
    hw, hd = W / 2, D / 2
    carcass = "".join([
        _box((W, D, T), (0, 0, T / 2)),  # bottom
        _box((W, D, T), (0, 0, H - T / 2)),  # top
        _box((T, D, H), (-hw + T / 2, 0, H / 2)),  # left side
        _box((T, D, H), (hw - T / 2, 0, H / 2)),  # right side
        _box((W, T, H), (0, hd - T / 2, H / 2)),  # back
        _box((W, D, T), (0, 0, 0.32)),  # divider above the drawer
    ])
    dw, dd, dh = W - 2 * T - 0.01, D - T - 0.03, 0.25  # drawer box, closed inside the lower bay
    drawer = "".join([
        _box((dw, dd, 0.01), (0, 0, 0.005)),  # bottom
        _box((W - 0.004, T, 0.28), (0, -dd / 2 - T / 2, 0.13)),  # front panel (in front of the carcass)
        _box((dw, 0.01, dh), (0, dd / 2 - 0.005, dh / 2)),  # back
        _box((0.01, dd, dh), (-dw / 2 + 0.005, 0, dh / 2)),  # left
        _box((0.01, dd, dh), (dw / 2 - 0.005, 0, dh / 2)),  # right
    ])
    urdf = f"""<?xml version="1.0"?>
<robot name="{name}">
  <material name="steel"><color rgba="0.8 0.8 0.85 1"/></material>
  <link name="carcass">
    {carcass}
    <inertial><origin xyz="0 0 0.4"/><mass value="25"/><inertia ixx="2" ixy="0" ixz="0" iyy="2" iyz="0" izz="1.5"/></inertial>
  </link>
  <link name="door">
    <visual>
      <origin xyz="0 0 0" rpy="1.5707963267948966 0 0"/>
      <geometry><mesh filename="package://cabinet_pkg/meshes/door.obj" scale="0.01 0.01 0.01"/></geometry>
      <material name="white"><color rgba="0.95 0.95 0.9 1"/></material>
    </visual>
    <collision><origin xyz="0.3 -0.01 0.225"/><geometry><box size="0.6 0.02 0.45"/></geometry></collision>
    <inertial><origin xyz="0.3 -0.01 0.225"/><mass value="2.0"/>
      <inertia ixx="0.034" ixy="0" ixz="0" iyy="0.094" iyz="0" izz="0.06"/></inertial>
  </link>
  <link name="handle">
    <visual><geometry><mesh filename="package://cabinet_pkg/meshes/handle.obj"/></geometry>
      <material name="steel"/></visual>
  </link>
  <link name="drawer">
    {drawer}
  </link>
  <link name="shelf">
    <visual><geometry><box size="{D - T - 0.02:g} {W - 2 * T:g} 0.02"/></geometry></visual>
    <collision><geometry><box size="{D - T - 0.02:g} {W - 2 * T:g} 0.02"/></geometry></collision>
  </link>
  <joint name="door_hinge" type="revolute">
    <parent link="carcass"/><child link="door"/>
    <origin xyz="{-hw:g} {-hd:g} 0.33" rpy="0 0 0"/>
    <axis xyz="0 0 -1"/>
    <limit lower="0" upper="{DOOR_OPEN:g}" effort="60" velocity="2"/>
    <dynamics damping="0.5" friction="0.05"/>
  </joint>
  <joint name="handle_mount" type="fixed">
    <parent link="door"/><child link="handle"/>
    <origin xyz="0.52 -0.02 0.225"/>
  </joint>
  <joint name="drawer_slide" type="prismatic">
    <parent link="carcass"/><child link="drawer"/>
    <origin xyz="0 {-(T + 0.03) / 2 + 0.0:g} {T + 0.002:g}"/>
    <axis xyz="0 -1 0"/>
    <limit lower="0" upper="{DRAWER_OUT:g}" effort="200" velocity="0.5"/>
    <dynamics damping="5" friction="0.5"/>
  </joint>
  <joint name="shelf_mount" type="fixed">
    <parent link="carcass"/><child link="shelf"/>
    <origin xyz="0 {(T + 0.02) / 2 - 0.01:g} {SHELF_Z:g}" rpy="0 0 1.5707963267948966"/>
  </joint>
</robot>
"""
    path = pkg / f"{name}.urdf"
    path.write_text(urdf)
    return path


@pytest.fixture(scope="module")
def cabinet(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, ObjectAsset, dict]:
    src = tmp_path_factory.mktemp("urdf_src")
    out = tmp_path_factory.mktemp("urdf_out")
    urdf = cabinet_urdf(src)
    asset, info = convert_object_report(urdf, out, category="cabinet", cache_dir=tmp_path_factory.mktemp("urdf_cache"))
    return out, asset, info


def _model(out: Path, asset: ObjectAsset, objects: int = 0) -> tuple[mujoco.MjModel, list[str]]:
    """Load the converted cabinet with position actuators on its joints (+ `objects` free boxes/cylinders)."""
    spec = mujoco.MjSpec.from_file(str(out / asset.mjcf))
    spec.option.timestep = 0.002
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[3, 3, 0.1])
    for p in asset.parts or []:
        kp = 200.0 if p.kind == "hinge" else 2000.0
        spec.add_actuator(name=f"act_{p.joint}", target=p.joint, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                          gaintype=mujoco.mjtGain.mjGAIN_FIXED, biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                          gainprm=[kp] + [0] * 9, biasprm=[0, -kp, -0.1 * kp] + [0] * 7)
    names = []
    for k in range(objects):
        x = -0.16 + 0.11 * (k % 4)
        y = -0.14 + 0.14 * (k // 4)
        b = spec.worldbody.add_body(name=f"item_{k}", pos=[x, y, SHELF_Z + 0.01 + 0.05])
        b.add_freejoint()
        if k % 2:
            b.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.02, 0.03, 0], density=600)
        else:
            b.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.025, 0.02, 0.02], density=600)
        names.append(f"item_{k}")
    return spec.compile(), names


def _drive(model: mujoco.MjModel, data: mujoco.MjData, targets: dict[str, float], seconds: float) -> None:
    for name, q in targets.items():
        data.ctrl[model.actuator(f"act_{name}").id] = q
    mujoco.mj_step(model, data, nstep=int(seconds / model.opt.timestep))


def test_cabinet_structure(cabinet: tuple[Path, ObjectAsset, dict]) -> None:
    out, asset, info = cabinet
    assert asset.category == "cabinet"
    by_joint = {p.joint: p for p in asset.parts or []}
    assert set(by_joint) == {"door_hinge", "drawer_slide"}  # fixed joints weld, they are no parts
    door, drawer = by_joint["door_hinge"], by_joint["drawer_slide"]
    assert (door.kind, door.body, door.range) == ("hinge", "door", (0.0, DOOR_OPEN))
    assert (drawer.kind, drawer.body, drawer.range) == ("slide", "drawer", (0.0, DRAWER_OUT))
    assert np.allclose(door.axis, (0, 0, -1)) and np.allclose(drawer.axis, (0, -1, 0))
    # the record round-trips, and a rigid object's record has no articulation keys at all
    again = ObjectAsset.from_json(asset.to_json())
    assert records_equal(again, asset) and again.parts == asset.parts
    rigid = ObjectAsset("a", "b", "m.xml", np.zeros((2, 3)), 1.0, 1)
    assert "parts" not in rigid.to_json() and "semantic_id" not in rigid.to_json()
    model = mujoco.MjModel.from_xml_path(str(out / asset.mjcf))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    j = model.joint("door_hinge")
    assert j.type[0] == mujoco.mjtJoint.mjJNT_HINGE and np.allclose(j.range, (0, DOOR_OPEN))
    assert np.isclose(model.dof_damping[j.dofadr[0]], 0.5) and np.isclose(model.dof_frictionloss[j.dofadr[0]], 0.05)
    assert model.dof_armature[j.dofadr[0]] > 0 and np.allclose(model.jnt_actfrcrange[j.id], (-60, 60))
    assert model.joint("drawer_slide").type[0] == mujoco.mjtJoint.mjJNT_SLIDE
    assert model.body("handle").parentid[0] == model.body("door").id  # nested along the tree
    assert model.body("door").mass[0] == pytest.approx(2.0)  # URDF inertial kept
    for g in range(model.ngeom):  # visual geoms: group 2, no contacts; collision geoms: group 3
        name = model.geom(g).name
        if "/visual" in name:
            assert model.geom_group[g] == 2 and model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0
        else:
            assert model.geom_group[g] == 3 and model.geom_contype[g] == 1
    # the door's OBJ (cm, scale 0.01, Y-up turned by the visual rpy) lands exactly on its box collision
    vis = _world_aabb(model, data, "door/visual_0_0")
    col = _world_aabb(model, data, "door/collision_0")
    assert np.allclose(vis, col, atol=1e-5)
    # the shelf box turned 90 deg by its joint rpy spans the carcass width along x and its depth along y
    sh = _world_aabb(model, data, "shelf/collision_0")
    assert np.allclose(sh[:, 0], (-W / 2 + T, W / 2 - T), atol=1e-6)
    assert sh[1, 1] - sh[0, 1] == pytest.approx(D - T - 0.02)
    # the handle has only a visual mesh: it gets hulls of its own (group 3, on the handle body)
    hid = [g for g in range(model.ngeom) if model.geom(g).name.startswith("handle/collision")]
    assert hid and all(model.geom_bodyid[g] == model.body("handle").id for g in hid)
    assert info["hulls"] == len(hid) and info["coacd_links"] == ["handle"]
    assert len(hid) >= 2  # CoACD splits the U (one convex hull would fill the gap behind the grip)
    assert np.allclose(asset.bbox[0], (-W / 2, -D / 2 - 0.02 - 0.04, 0), atol=2e-3)


def _world_aabb(model: mujoco.MjModel, data: mujoco.MjData, geom: str) -> np.ndarray:
    """Return the (2, 3) world AABB of a box or mesh geom."""
    g = model.geom(geom).id
    R, p = data.geom_xmat[g].reshape(3, 3), data.geom_xpos[g]
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
        m = model.geom_dataid[g]
        v = model.mesh_vert[model.mesh_vertadr[m]: model.mesh_vertadr[m] + model.mesh_vertnum[m]]
    else:
        h = model.geom_size[g]
        v = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
    w = v @ R.T + p
    return np.stack([w.min(axis=0), w.max(axis=0)])


def test_door_and_drawer_move_within_limits(cabinet: tuple[Path, ObjectAsset, dict]) -> None:
    out, asset, _info = cabinet
    model, _ = _model(out, asset)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    door_q = model.joint("door_hinge").qposadr[0]
    drawer_q = model.joint("drawer_slide").qposadr[0]
    edge0 = data.geom_xpos[model.geom("door/collision_0").id].copy()
    front0 = data.xpos[model.body("drawer").id].copy()
    _drive(model, data, {"door_hinge": 1.0, "drawer_slide": 0.2}, 2.0)
    assert data.qpos[door_q] == pytest.approx(1.0, abs=0.02)
    assert data.qpos[drawer_q] == pytest.approx(0.2, abs=0.005)
    edge1 = data.geom_xpos[model.geom("door/collision_0").id]
    assert edge1[1] < edge0[1] - 0.1  # the door swung outwards (towards -y), about its hinge at the left edge
    hinge = data.xpos[model.body("door").id]
    assert np.linalg.norm((edge1 - hinge)[:2]) == pytest.approx(np.linalg.norm((edge0 - hinge)[:2]), abs=1e-6)
    assert data.xpos[model.body("drawer").id][1] == pytest.approx(front0[1] - 0.2, abs=0.005)  # drawer slid out
    # past the limits: the joints stop at them
    _drive(model, data, {"door_hinge": DOOR_OPEN + 0.8, "drawer_slide": DRAWER_OUT + 0.3}, 3.0)
    assert DOOR_OPEN - LIMIT_SLACK < data.qpos[door_q] < DOOR_OPEN + LIMIT_SLACK
    assert DRAWER_OUT - LIMIT_SLACK < data.qpos[drawer_q] < DRAWER_OUT + LIMIT_SLACK
    _drive(model, data, {"door_hinge": -0.8, "drawer_slide": -0.3}, 3.0)
    assert -LIMIT_SLACK < data.qpos[door_q] < LIMIT_SLACK and -LIMIT_SLACK < data.qpos[drawer_q] < LIMIT_SLACK


def test_objects_on_shelf_stay_when_the_door_closes(cabinet: tuple[Path, ObjectAsset, dict]) -> None:
    out, asset, _info = cabinet
    model, items = _model(out, asset, objects=8)
    data = mujoco.MjData(model)
    door_q = model.joint("door_hinge").qposadr[0]
    data.qpos[door_q] = DOOR_OPEN
    data.ctrl[model.actuator("act_door_hinge").id] = DOOR_OPEN
    mujoco.mj_forward(model, data)
    mujoco.mj_step(model, data, nstep=int(1.5 / model.opt.timestep))  # dropped 5 cm onto the shelf: settle
    shelf_top = SHELF_Z + 0.01
    settled = {n: data.xpos[model.body(n).id].copy() for n in items}
    assert max(np.abs(data.qvel[6:]).max(), 0) < 0.05  # at rest before the door moves
    _drive(model, data, {"door_hinge": 0.0}, 2.5)
    assert abs(data.qpos[door_q]) < LIMIT_SLACK  # closed
    resting = 0
    for n in items:
        p = data.xpos[model.body(n).id]
        b = model.body(n).id
        half = model.geom_size[model.body_geomadr[b]][2 if model.geom_type[model.body_geomadr[b]] == 6 else 1]
        on_shelf = abs(p[2] - (shelf_top + half)) < 0.005 and abs(p[0]) < W / 2 - T and -D / 2 < p[1] < D / 2 - T
        still = np.linalg.norm(p - settled[n]) < 0.01
        resting += bool(on_shelf and still)
    assert resting >= math.ceil(0.95 * len(items))


def _write(folder: Path, body: str, name: str = "bad") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / f"{name}.urdf"
    p.write_text(f'<robot name="{name}">{body}</robot>')
    return p


LINK = '<link name="{n}"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>'


def _joint(name: str, parent: str, child: str, kind: str = "revolute", limit: str = '<limit lower="0" upper="1"/>') -> str:
    return f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>{limit}</joint>'


@pytest.mark.parametrize("case, body, expect", [
    ("missing mesh", '<link name="base"><visual><geometry><mesh filename="meshes/gone.obj"/></geometry></visual></link>',
     ["link 'base' visual 0", "gone.obj", "not found"]),
    ("unknown joint type", LINK.format(n="a") + LINK.format(n="b") + _joint("j1", "a", "b", "floating"),
     ["joint 'j1'", "floating"]),
    ("missing child", LINK.format(n="a") + _joint("j1", "a", "ghost"), ["joint 'j1'", "child link 'ghost' does not exist"]),
    ("missing parent", LINK.format(n="a") + _joint("j1", "ghost", "a"), ["joint 'j1'", "parent link 'ghost'"]),
    ("cycle", LINK.format(n="a") + LINK.format(n="b") + _joint("j1", "a", "b") + _joint("j2", "b", "a"),
     ["cycle", "'a'", "'b'"]),
    ("two roots", LINK.format(n="a") + LINK.format(n="b") + LINK.format(n="c") + _joint("j1", "a", "c"),
     ["2 root links", "'a'", "'b'"]),
    ("lower > upper", LINK.format(n="a") + LINK.format(n="b") + _joint("j1", "a", "b", limit='<limit lower="1" upper="-1"/>'),
     ["joint 'j1'", "lower 1 > upper -1"]),
])
def test_bad_urdf_names_file_and_part(tmp_path: Path, case: str, body: str, expect: list[str]) -> None:
    path = _write(tmp_path / case.replace(" ", "_").replace(">", "gt"), body)
    with pytest.raises(InputError) as e:
        convert_object_report(path, tmp_path / "out", cache_dir=tmp_path / "cache")
    msg = str(e.value)
    assert str(path) in msg, msg
    for s in expect:
        assert s in msg, (case, msg)


def test_mesh_scale_of_four_numbers_is_named(tmp_path: Path) -> None:
    """A mesh scale of neither 1 nor 3 numbers (racecar_differential.urdf in pybullet_data has '1 1 1 1')."""
    folder = tmp_path / "scale"
    folder.mkdir()
    (folder / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    path = _write(folder, '<link name="base"><visual><geometry><mesh filename="m.obj" scale="1 1 1 1"/></geometry></visual></link>')
    with pytest.raises(InputError) as e:
        read_urdf(path)
    msg = str(e.value)
    for s in (str(path), "link 'base' visual 0", "mesh scale needs 1 or 3 numbers", "'1 1 1 1'"):
        assert s in msg, msg


def test_unphysical_urdf_inertia_is_replaced_with_a_warning(tmp_path: Path) -> None:
    """izz=0 (pybullet_data's random objects) or A + B < C: MuJoCo refuses to compile it, PyBullet runs it.

    The link keeps the URDF mass and centre of mass and takes a solid box of its geometry's extent; the report warns.
    """
    from assets_convert.urdf import box_inertia, inertia_problem

    assert inertia_problem(np.diag([1.0, 1.0, 0.0])) is not None
    assert inertia_problem(np.diag([1.0, 1.0, 3.0])) is not None  # 1 + 1 < 3
    assert inertia_problem(np.diag([1.0, 2.0, 3.0])) is None
    assert np.allclose(box_inertia(12.0, np.array([[0, 0, 0], [1, 2, 3]])), [13, 10, 5])
    body = ('<link name="base"><inertial><origin xyz="0.01 0 0"/><mass value="0.1"/>'
            '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="0"/></inertial>'
            '<collision><geometry><box size="0.1 0.2 0.3"/></geometry></collision></link>')
    path = _write(tmp_path / "in", body, "blob")
    asset, report = convert_object_report(path, tmp_path / "out", cache_dir=tmp_path / "cache")
    assert any("URDF inertia has principal moments" in w and "not all positive" in w for w in report["warnings"]), report
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "out" / asset.mjcf))
    body_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "object")
    assert m.body_mass[body_id] == pytest.approx(0.1)
    want = sorted(box_inertia(0.1, np.array([[-0.05, -0.1, -0.15], [0.05, 0.1, 0.15]])))
    assert sorted(m.body_inertia[body_id]) == pytest.approx(want, rel=1e-5)
    assert m.body_ipos[body_id][0] == pytest.approx(0.01)


def test_cycle_with_a_root_elsewhere(tmp_path: Path) -> None:
    """A cycle beside a proper tree (one root) is still found."""
    body = LINK.format(n="r") + LINK.format(n="a") + LINK.format(n="b") + _joint("j1", "a", "b") + _joint("j2", "b", "a")
    with pytest.raises(InputError, match="cycle"):
        read_urdf(_write(tmp_path, body))


def test_habitat_ao_config(tmp_path: Path) -> None:
    src = tmp_path / "src"
    urdf = cabinet_urdf(src, name="cab")
    plain, _ = convert_object_report(urdf, tmp_path / "plain", category="cabinet", cache_dir=tmp_path / "cache")
    (urdf.parent / "cab_render.obj").write_text(_box_obj((W, D, H), (0, 0, H / 2)))
    (urdf.parent / "cab.ao_config.json").write_text(json.dumps(
        {"urdf_filepath": "cab.urdf", "render_asset": "cab_render.obj", "semantic_id": 27, "uniform_scale": 0.5}))
    asset, info = convert_object_report(urdf, tmp_path / "hab", category="cabinet", cache_dir=tmp_path / "cache")
    assert info["cache_hit"] is False  # the ao_config is part of the cache key
    assert asset.semantic_id == 27 and plain.semantic_id is None
    assert json.loads(asset.to_json())["semantic_id"] == 27
    assert np.allclose(asset.bbox, plain.bbox * 0.5, atol=1e-6)  # every length halved
    by_joint = {p.joint: p for p in asset.parts or []}
    assert by_joint["drawer_slide"].range == pytest.approx((0.0, DRAWER_OUT * 0.5))  # slide limits are lengths
    assert by_joint["door_hinge"].range == pytest.approx((0.0, DOOR_OPEN))  # angles are not
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "hab" / asset.mjcf))
    root_vis = [model.geom(g).name for g in range(model.ngeom)
                if model.geom_bodyid[g] == model.body("object").id and "/visual" in model.geom(g).name]
    assert root_vis == ["object/visual_0_0"]  # the render asset replaces the root link's box visuals
    assert model.mesh_vertnum[model.geom("object/visual_0_0").dataid[0]] == 8  # the render asset's box
    again, info2 = convert_object_report(urdf, tmp_path / "hab2", category="cabinet", cache_dir=tmp_path / "cache")
    assert info2["cache_hit"] is True and records_equal(again, asset)  # the cached record keeps parts and semantic id
    bad = urdf.parent / "cab.ao_config.json"
    bad.write_text(json.dumps({"render_asset": "nothing.glb"}))
    with pytest.raises(InputError, match="render_asset 'nothing.glb' not found") as e:
        read_urdf(urdf)
    assert "cab.ao_config.json" in str(e.value)


def test_third_party_parser_reads_the_urdf(tmp_path: Path) -> None:
    yourdfpy = pytest.importorskip("yourdfpy")
    urdf = cabinet_urdf(tmp_path)
    ours = read_urdf(urdf)
    cwd = os.getcwd()
    try:  # yourdfpy resolves package:// against the working folder's parents
        os.chdir(urdf.parent)
        theirs = yourdfpy.URDF.load(str(urdf), load_meshes=False, build_scene_graph=False)
    finally:
        os.chdir(cwd)
    assert set(theirs.link_map) == set(ours.links)
    for j in ours.joints:
        tj = theirs.joint_map[j.name]
        assert (tj.type, tj.parent, tj.child) == (j.type, j.parent, j.child)
        assert np.allclose(tj.origin, j.origin)
        if j.type != "fixed":
            assert np.allclose(tj.axis, j.axis)
        if j.lower is not None:
            assert (tj.limit.lower, tj.limit.upper) == pytest.approx((j.lower, j.upper))


def test_cli_converts_a_urdf_folder_as_one_object(tmp_path: Path) -> None:
    """`sdovon-mj convert FOLDER --kind object`: the URDF is one object, its meshes are not objects of their own."""
    urdf = cabinet_urdf(tmp_path / "lib")
    out = tmp_path / "out"
    env = dict(os.environ, SDOVON_CACHE=str(tmp_path / "cache"))
    r = subprocess.run([str(Path(sys.executable).parent / "sdovon-mj"), "convert", str(tmp_path / "lib"), "--out", str(out),
                        "--kind", "object", "--jobs", "1", "--no-progress"], capture_output=True, text=True, env=env,
                       cwd=str(Path(__file__).resolve().parents[1]))
    assert r.returncode == 0, r.stderr
    report = json.loads((out / "convert_report.json").read_text())
    assert [row["file"] for row in report["items"]] == [str(urdf)]
    assert (out / "objects" / "cabinet" / "model.xml").is_file()
    stored = json.loads((out / "objects" / "cabinet" / "asset.json").read_text())
    assert {p["joint"] for p in stored["parts"]} == {"door_hinge", "drawer_slide"}


def test_closed_door_holds_a_shoved_object(cabinet: tuple[Path, ObjectAsset, dict]) -> None:
    """An object shoved towards the front leaves the shelf through the open door and stays in behind the closed one."""
    out, asset, _info = cabinet
    final = {}
    for state in (0.0, DOOR_OPEN):
        model, items = _model(out, asset, objects=1)
        data = mujoco.MjData(model)
        door_q = model.joint("door_hinge").qposadr[0]
        data.qpos[door_q] = data.ctrl[model.actuator("act_door_hinge").id] = state
        mujoco.mj_forward(model, data)
        mujoco.mj_step(model, data, nstep=int(1.0 / model.opt.timestep))
        free = model.joint(model.body(items[0]).jntadr[0]).dofadr[0]
        data.qvel[free + 1] = -3.0  # 3 m/s towards the front: with friction 1 it slides ~0.45 m, past the front edge
        mujoco.mj_step(model, data, nstep=int(1.5 / model.opt.timestep))
        final[state] = data.xpos[model.body(items[0]).id].copy()
    assert final[0.0][1] > -D / 2 and final[0.0][2] > SHELF_Z  # held in by the closed door, still on the shelf
    assert final[DOOR_OPEN][1] < -D / 2 and final[DOOR_OPEN][2] < SHELF_Z  # out through the open door, fallen


@pytest.mark.parametrize("label", ["cabinet", "dresser", "wardrobe", "fridge", "microwave"])
def test_procedural_articulated_furniture_converts_and_opens(tmp_path: Path, label: str) -> None:
    """world.articulated: seeded URDF + OBJ pieces convert; nothing overlaps when closed; every part opens fully."""
    from sdovon_mj.world.articulated import BUILDERS

    build = BUILDERS[label]
    piece = build(np.random.default_rng(7), tmp_path / "a")
    twin = build(np.random.default_rng(7), tmp_path / "b")
    assert piece.urdf.read_bytes() == twin.urdf.read_bytes()  # same seed, same bytes
    assert build(np.random.default_rng(8), tmp_path / "c").urdf.read_bytes() != piece.urdf.read_bytes()
    asset, _info = convert_object_report(piece.urdf, tmp_path / "out", cache_dir=tmp_path / "cache")
    assert sorted(p.joint for p in asset.parts or []) == sorted(piece.joints) and piece.joints
    assert np.allclose(asset.bbox[0][[0, 2]], (-piece.width / 2, 0), atol=1e-3)
    assert asset.bbox[1][2] == pytest.approx(piece.height, abs=1e-3) and asset.bbox[0][1] == pytest.approx(0, abs=1e-3)
    for inside in piece.interiors:  # interior surfaces lie inside the piece, closed by one of its joints
        assert inside.joint in piece.joints and 0 < inside.height < piece.height
        assert (np.abs(inside.polygon[:, 0]) <= piece.width / 2).all() and (inside.polygon[:, 1] <= piece.depth).all()
    model, _ = _model(tmp_path / "out", asset)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    deep = [c for c in data.contact[: data.ncon] if c.dist < -1e-4]
    assert not deep, [(model.geom(c.geom1).name, model.geom(c.geom2).name, c.dist) for c in deep]
    upper = {p.joint: p.range[1] for p in asset.parts or [] if p.range}
    _drive(model, data, upper, 3.0)
    for joint, hi in upper.items():  # each door and drawer reaches its open stop (nothing in its way)
        assert data.qpos[model.joint(joint).qposadr[0]] == pytest.approx(hi, abs=LIMIT_SLACK), joint
    yourdfpy = pytest.importorskip("yourdfpy")
    parsed = yourdfpy.URDF.load(str(piece.urdf), load_meshes=False, build_scene_graph=False)
    assert sorted(j for j, v in parsed.joint_map.items() if v.type != "fixed") == sorted(piece.joints)


def test_collision_mesh_hull_continuous_joint_and_primitives(tmp_path: Path) -> None:
    """A collision mesh becomes its convex hull; a continuous joint an unlimited hinge; cylinder/sphere stay primitives."""
    (tmp_path / "u.obj").write_text(_handle_obj())
    urdf = _write(tmp_path, """
      <link name="base"><collision><geometry><cylinder radius="0.1" length="0.3"/></geometry></collision></link>
      <link name="wheel">
        <visual><geometry><sphere radius="0.05"/></geometry></visual>
        <collision><origin xyz="0 0 0.2" rpy="0 1.5707963 0"/><geometry><mesh filename="u.obj" scale="2"/></geometry></collision>
        <inertial><mass value="0.5"/><inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
      </link>
      <joint name="spin" type="continuous"><parent link="base"/><child link="wheel"/><origin xyz="0 0 0.15"/>
        <axis xyz="0 0 1"/></joint>""", name="spinner")
    asset, _ = convert_object_report(urdf, tmp_path / "out", cache_dir=tmp_path / "cache")
    assert [(p.joint, p.kind, p.range) for p in asset.parts or []] == [("spin", "hinge", None)]
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "out" / asset.mjcf))
    assert model.jnt_limited[model.joint("spin").id] == 0
    assert model.geom("object/collision_0").type[0] == mujoco.mjtGeom.mjGEOM_CYLINDER
    assert np.allclose(model.geom("object/collision_0").size[:2], (0.1, 0.15))
    hull = model.geom("wheel/collision_0")
    assert hull.type[0] == mujoco.mjtGeom.mjGEOM_MESH and model.ngeom == 3  # one hull for the whole U mesh
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    box = _world_aabb(model, data, "wheel/collision_0")
    # the U (1.6 x 4.8 x 12 cm, scale 2) turned 90 deg about y: its 24 cm length lies along x, centred 35 cm up
    assert box[1, 0] - box[0, 0] == pytest.approx(0.24, abs=1e-4) and np.mean(box[:, 2]) == pytest.approx(0.35, abs=1e-4)
    assert model.geom("wheel/visual_0").type[0] == mujoco.mjtGeom.mjGEOM_SPHERE


def test_converter_plugin_library_with_a_urdf(tmp_path: Path) -> None:
    """The converter plugin's convert_library: a URDF listed with its own mesh files is one articulated object."""
    from assets_convert.plugin import MeshConverter
    from sdovon_mj.config import ConvertConfig

    urdf = cabinet_urdf(tmp_path / "lib")
    items = [(f, None) for f in sorted((tmp_path / "lib").rglob("*")) if f.is_file()]
    assert len(items) == 3  # the URDF, the door and the handle OBJ
    conv = MeshConverter()
    assert {p.name for p in conv.extra_inputs(urdf)} == {"door.obj", "handle.obj"}  # fingerprints cover the meshes
    assets, failures = conv.convert_library(items, tmp_path / "run", ConvertConfig(jobs=1))
    assert failures == {} and [a.name for a in assets] == ["cabinet"]
    assert {p.joint for p in assets[0].parts or []} == {"door_hinge", "drawer_slide"}
    stored = ObjectAsset.from_json((tmp_path / "run" / "objects" / "cabinet" / "object.json").read_text())
    assert records_equal(stored, assets[0])


def test_textured_mesh_keeps_its_texture_and_urdf_colour_fills_plain_meshes(tmp_path: Path) -> None:
    """A link's textured OBJ keeps its PNG texture (as the mesh converter writes it); a plain mesh takes the URDF colour."""
    from PIL import Image

    Image.fromarray(np.tile(np.array([[[200, 30, 30]], [[30, 30, 200]]], np.uint8), (8, 16, 1))).save(tmp_path / "wood.png")
    (tmp_path / "panel.mtl").write_text("newmtl wood\nKd 1 1 1\nmap_Kd wood.png\n")
    box = _box_obj((0.4, 0.02, 0.3), (0, 0, 0.15)).splitlines()
    uv = "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    faces = [ln.split()[1:] for ln in box if ln.startswith("f ")]
    (tmp_path / "panel.obj").write_text("mtllib panel.mtl\nusemtl wood\n" + "".join(ln + "\n" for ln in box if ln.startswith("v "))
                                        + uv + "".join(f"f {a}/1 {b}/2 {c}/3\n" for a, b, c in faces))
    (tmp_path / "plain.obj").write_text(_box_obj((0.1, 0.1, 0.1), (0, 0, 0.05)))
    urdf = _write(tmp_path, """
      <link name="base"><visual><geometry><mesh filename="panel.obj"/></geometry></visual>
        <visual><origin xyz="0 0.2 0"/><geometry><mesh filename="plain.obj"/></geometry>
          <material name="red"><color rgba="0.9 0.1 0.1 1"/></material></visual></link>""", name="panel")
    asset, _ = convert_object_report(urdf, tmp_path / "out", cache_dir=tmp_path / "cache")
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "out" / asset.mjcf))
    textured = model.geom("object/visual_0_0")
    plain = model.geom("object/visual_1_0")
    assert model.ntex == 1 and model.mat_texid[textured.matid[0]].max() == 0
    assert model.mat_texid[plain.matid[0]].max() == -1 and np.allclose(model.mat_rgba[plain.matid[0]], (0.9, 0.1, 0.1, 1))
    assert (tmp_path / "out" / "objects" / "panel" / "assets" / "texture_0.png").is_file()
    assert asset.hull_count >= 1  # a link with only visual meshes gets hulls


def test_urdf_category_is_not_its_robot_name(tmp_path):
    """A URDF's robot name is copied about (pybullet_data's duck_vhacd.urdf calls its robot 'cube.urdf', the spheres
    'urdf_robot'): the category comes from the file, as a mesh object's does."""
    from assets_convert.object import convert_object_report

    body = ('<link name="base"><inertial><mass value="0.2"/><inertia ixx="1e-3" ixy="0" ixz="0" iyy="1e-3" iyz="0" '
            'izz="1e-3"/></inertial><collision><geometry><box size="0.1 0.08 0.06"/></geometry></collision>'
            '<visual><geometry><box size="0.1 0.08 0.06"/></geometry></visual></link>')
    urdf = tmp_path / "lib" / "duck_vhacd.urdf"
    urdf.parent.mkdir()
    urdf.write_text(f'<robot name="cube.urdf">{body}</robot>')
    asset, _info = convert_object_report(urdf, tmp_path / "out", cache_dir="off")
    assert (asset.name, asset.category) == ("duck_vhacd", "duck_vhacd")
