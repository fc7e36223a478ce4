"""URDF export: every variant of a tiny generated run loads in PyBullet (DIRECT) and in SAPIEN, and after 2 s of
simulation at least 90 % of the objects still rest within 2 cm of their exported pose (the falls are reported
per engine). The clients are the real ones from PyPI (extra `sim-export`); a missing client fails, never skips."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import mujoco

from sdovon_mj.export import ExportOptions, RunView, make_exporter, run_export
from exporters.urdf import UrdfExporter

pybullet = pytest.importorskip("pybullet")
sapien = pytest.importorskip("sapien")

REST_TOL = 0.02  # m: the resting criterion
MIN_RESTING = 0.9


@pytest.fixture(scope="module")
def urdf_out(tiny_export_run, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("urdf")
    rep = run_export(UrdfExporter(), RunView(tiny_export_run), out, ExportOptions(name="ds"))
    assert rep.variants, rep.summary()
    return out / "ds"


def _variants(urdf_out: Path) -> list[Path]:
    idx = json.loads((urdf_out / "index.json").read_text())
    return [urdf_out / v["path"] for v in idx["variants"]]


def _com_world(pos, quat_wxyz, com_local) -> np.ndarray:
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(quat_wxyz, float))
    return np.asarray(pos, float) + R.reshape(3, 3) @ np.asarray(com_local, float)


def _com_local(urdf: Path) -> np.ndarray:
    return np.array([float(x) for x in ET.parse(urdf).find("link/inertial/origin").get("xyz").split()])


@pytest.mark.slow
def test_export_matches_mujoco_and_files_resolve(tiny_export_run, urdf_out):
    """Poses in scene.json are the settled MuJoCo body poses; masses are MuJoCo's; every mesh/texture file exists."""
    run = RunView(tiny_export_run)
    for vdir in _variants(urdf_out):
        meta = json.loads((vdir / "scene.json").read_text())
        variant = next(v for v in run.all_variants() if v.name == meta["variant"])
        model = mujoco.MjModel.from_xml_path(str(run.path(variant.mjcf)))
        data = mujoco.MjData(model)
        data.qpos[:] = variant.qpos
        mujoco.mj_forward(model, data)
        assert meta["objects"], vdir
        for o in meta["objects"]:
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, o["object_id"])
            assert np.allclose(o["position"], data.xpos[b], atol=1e-9)
            assert abs(abs(float(np.dot(o["quaternion_wxyz"], data.xquat[b]))) - 1) < 1e-9
            root = ET.parse(vdir / o["urdf"]).getroot()
            assert float(root.find("link/inertial/mass").get("value")) == pytest.approx(model.body_mass[b], rel=1e-6)
            assert len(root.findall("link/collision")) >= 1
        for urdf in vdir.glob("*.urdf"):
            for m in ET.parse(urdf).getroot().iter("mesh"):
                assert (vdir / m.get("filename")).is_file(), (urdf, m.get("filename"))
    for mtl in (urdf_out / "meshes").glob("*.mtl"):
        for line in mtl.read_text().splitlines():
            if line.startswith("map_Kd"):
                assert (mtl.parent / line.split()[1]).is_file()


def _physics_only(urdf: Path) -> str:
    """Return the path of a copy of a URDF without <visual> elements, beside it (same relative mesh paths)."""
    tree = ET.parse(urdf)
    for link in tree.getroot().iter("link"):
        for v in link.findall("visual"):
            link.remove(v)
    out = urdf.with_name(f".physics_{urdf.name}")
    tree.write(out)
    return str(out)


def _report(engine: str, moved: dict[str, float], n: int) -> str:
    bad = {k: round(v, 4) for k, v in sorted(moved.items()) if v > REST_TOL}
    return f"{engine}: {n - len(bad)}/{n} objects within {REST_TOL} m after 2 s; moved: {bad}"


@pytest.mark.slow
def test_pybullet_loads_and_objects_rest(urdf_out):
    """PyBullet DIRECT: the scene (fixed, triangle-mesh colliders) and every object load; >= 90 % rest 2 s."""
    for vdir in _variants(urdf_out):
        meta = json.loads((vdir / "scene.json").read_text())
        cid = pybullet.connect(pybullet.DIRECT)
        try:
            pybullet.setGravity(*meta["gravity"], physicsClientId=cid)
            pybullet.setTimeStep(1 / 240, physicsClientId=cid)
            pybullet.loadURDF(str(vdir / meta["scene_urdf"]), useFixedBase=True, physicsClientId=cid)
            ids, want = {}, {}
            for o in meta["objects"]:
                ids[o["object_id"]] = pybullet.loadURDF(str(vdir / o["urdf"]), basePosition=o["position"],
                                                        baseOrientation=o["quaternion_xyzw"],
                                                        flags=pybullet.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
                want[o["object_id"]] = _com_world(o["position"], o["quaternion_wxyz"], _com_local(vdir / o["urdf"]))
                # PyBullet's base frame is the inertial frame: it must start where the export put the centre of mass.
                p0, _ = pybullet.getBasePositionAndOrientation(ids[o["object_id"]], physicsClientId=cid)
                assert np.allclose(p0, want[o["object_id"]], atol=1e-5)
                # Mass and the inertia tensor (principal moments in the principal-axes frame) are MuJoCo's.
                info = pybullet.getDynamicsInfo(ids[o["object_id"]], -1, physicsClientId=cid)
                assert info[0] == o["mass"]
                R = np.array(pybullet.getMatrixFromQuaternion(info[4])).reshape(3, 3)
                q = np.asarray(o["inertia_principal_axes_wxyz"], float)
                Rm = np.zeros(9)
                mujoco.mju_quat2Mat(Rm, q)
                Rm = Rm.reshape(3, 3)
                I_pb, I_mj = R @ np.diag(info[2]) @ R.T, Rm @ np.diag(o["inertia_principal"]) @ Rm.T
                # Written with 17 digits: only float64 round-off (rpy -> matrix) may remain, ~1e-15 relative.
                assert np.abs(I_pb - I_mj).max() <= 1e-9 * max(o["inertia_principal"])
            for _ in range(480):  # 2 s
                pybullet.stepSimulation(physicsClientId=cid)
            moved = {k: float(np.linalg.norm(np.array(pybullet.getBasePositionAndOrientation(i, physicsClientId=cid)[0]) - want[k]))
                     for k, i in ids.items()}
        finally:
            pybullet.disconnect(cid)
        msg = _report(f"pybullet {vdir.name}", moved, len(moved))
        print(msg)
        assert sum(v <= REST_TOL for v in moved.values()) >= MIN_RESTING * len(moved), msg


@pytest.mark.slow
def test_sapien_loads_and_objects_rest(urdf_out):
    """SAPIEN (ManiSkill's engine): the scene loads fixed, every object as a free body; >= 90 % rest 2 s."""
    for vdir in _variants(urdf_out):
        meta = json.loads((vdir / "scene.json").read_text())
        # Physics only: SAPIEN's render system (and its URDF loader's visual materials) need a Vulkan device,
        # which a CPU machine lacks; the loader then reads physics-only copies (<visual> removed, nothing else).
        scene = sapien.Scene([sapien.physx.PhysxCpuSystem()])
        scene.set_timestep(1 / 240)
        assert np.allclose(meta["gravity"], [0, 0, -9.81])  # SAPIEN's default gravity
        loader = scene.create_urdf_loader()
        loader.fix_root_link = True
        loader.load_multiple(_physics_only(vdir / meta["scene_urdf"]))
        bodies, want = {}, {}
        for o in meta["objects"]:
            loader = scene.create_urdf_loader()
            loader.fix_root_link = False
            arts, actors = loader.load_multiple(_physics_only(vdir / o["urdf"]))
            ent = (actors or [a.root.entity for a in arts])[0]
            ent.set_pose(sapien.Pose(o["position"], o["quaternion_wxyz"]))
            bodies[o["object_id"]] = ent
            want[o["object_id"]] = _com_world(o["position"], o["quaternion_wxyz"], _com_local(vdir / o["urdf"]))
        for _ in range(480):  # 2 s
            scene.step()
        moved = {}
        for k, ent in bodies.items():
            pose = ent.pose
            moved[k] = float(np.linalg.norm(_com_world(pose.p, pose.q, _com_local(vdir / f"{k}.urdf")) - want[k]))
        msg = _report(f"sapien {vdir.name}", moved, len(moved))
        print(msg)
        assert sum(v <= REST_TOL for v in moved.values()) >= MIN_RESTING * len(moved), msg


@pytest.mark.parametrize("fmt", ["urdf", "usd"])
def test_sample_run_primitives_and_missing_mjcf(fmt, tmp_path):
    """Primitive geoms (the sample run's sphere and cylinder colliders) export, twice to the same bytes; a missing
    MJCF is named in the error."""
    from sdovon_mj.errors import InputError
    from support.run_folder import build_sample_run

    run = build_sample_run(tmp_path / "run", episodes=True)
    rep = run_export(make_exporter(fmt), RunView(run), tmp_path / "out", ExportOptions(name="ds"))
    assert rep.variants == ["room_v000"] and rep.skipped == {"room_v001": "no valid goals (zero episodes)"}
    run_export(make_exporter(fmt), RunView(run), tmp_path / "again", ExportOptions(name="ds"))
    files = sorted(p.relative_to(tmp_path / "out") for p in (tmp_path / "out").rglob("*") if p.is_file())
    assert files and all((tmp_path / "out" / f).read_bytes() == (tmp_path / "again" / f).read_bytes() for f in files)
    mjcf = run / "scenes" / "room" / "variants" / "room_v000" / "variant.xml"
    mjcf.unlink()
    with pytest.raises(InputError, match="variant.xml"):
        run_export(make_exporter(fmt), RunView(run), tmp_path / "out2", ExportOptions(name="ds"))
