"""Habitat datasets' articulated furniture (issue 44): ``articulated_object_instances`` become articulated receptacles.

A dataset in the ReplicaCAD layout, written by the test (`support.replicacad`: a box-room stage, a URDF fridge with a
door and a kitchen counter with a drawer, placed at their centre of mass with ``translation_origin: "COM"``, a
rotation about +Y and a ``uniform_scale``). The conversion puts each piece's links where habitat-sim would, keeps
their joints, and finds their inside and top surfaces; what the scene holds and is not imported (a template the
dataset lacks, an object instance likewise, a light setup) is named in the scene's `unused` lines and the convert
report. One small generate run shows the rest: the variant holds both pieces with their joints, objects rest on and
inside them, the region is a kitchen, the MJCF bundle and the Habitat export carry them, and generate's last lines
name what was not imported.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mujoco

from assets_convert import convert_scene
from assets_convert.habitat import HAB_TO_MJ
from sdovon_mj.records import ReceptaclePlane, SceneAsset, SceneVariant, load_json
from sdovon_mj.sim.articulation import part_joints, part_state, set_parts
from support.replicacad import EXTRA, expected_link, expected_root, write_replicacad

REPO = Path(__file__).resolve().parents[1]
# MuJoCo's XML writer keeps 6 significant digits (the scene MJCF's attach frames and body poses, coordinates below
# 10 m): up to 5e-5 m per written number, two numbers (frame, body) along a chain: 1e-4 m and 1e-4 in a rotation.
POSE_TOL = 1e-4
SURFACE_TOL = 1e-3  # m: surface heights come from box faces through the same XML (and a mean of their corners)


@pytest.fixture(scope="module")
def converted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, SceneAsset]:
    """The dataset (with the missing template and the light) converted without the cache: (output root, asset)."""
    root = tmp_path_factory.mktemp("replicacad")
    scene = write_replicacad(root / "ds", extra=True)
    return root / "out", convert_scene(scene, root / "out", cache_dir="off")


def _model(out: Path, asset: SceneAsset) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_path(str(out / asset.mjcf))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _mj(T_hab: np.ndarray) -> np.ndarray:
    """Return a Habitat-frame pose in MuJoCo's frame."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = HAB_TO_MJ @ T_hab[:3, :3], HAB_TO_MJ @ T_hab[:3, 3]
    return T


def test_pieces_stand_where_habitat_sim_puts_them(converted) -> None:
    out, asset = converted
    model, data = _model(out, asset)
    by_label = {fx.label: fx for fx in asset.articulated}
    assert sorted(by_label) == ["fridge", "kitchen counter"]
    for label, urdf, link, joint in (("fridge", "fridge", "door", "door_hinge"),
                                     ("kitchen counter", "kitchen_counter", "drawer", "drawer_slide")):
        fx = by_label[label]
        name = f"art_{fx.instance_id}"
        assert [(p.joint, p.kind) for p in fx.parts] == [(f"{name}/{joint}", "hinge" if link == "door" else "slide")]
        inst = asset.instance(fx.instance_id)
        assert inst.receptacle and inst.geoms
        for body, T in ((f"{name}/object", _mj(expected_root(urdf))), (f"{name}/{link}", _mj(expected_link(urdf)))):
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
            assert b >= 0, body
            assert np.allclose(data.xpos[b], T[:3, 3], atol=POSE_TOL), (body, data.xpos[b], T[:3, 3])
            assert np.allclose(data.xmat[b].reshape(3, 3), T[:3, :3], atol=POSE_TOL), body
        # upright on the floor (Habitat +Y is MuJoCo +Z) at the instance's scale: the lowest point on z = 0
        assert inst.bounds[0][2] == pytest.approx(0.0, abs=POSE_TOL)
    fridge, counter = by_label["fridge"], by_label["kitchen counter"]
    assert asset.instance(fridge.instance_id).bounds[1][2] == pytest.approx(1.6 * 1.05, abs=POSE_TOL)
    assert asset.instance(counter.instance_id).bounds[1][2] == pytest.approx(0.9 * 0.98, abs=POSE_TOL)
    # the counter's slide range is scaled with it; opening moves the door and the drawer away from their carcass
    assert counter.parts[0].range == pytest.approx((0.0, 0.4 * 0.98))
    closed = {fx.label: data.xipos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, fx.parts[0].body)].copy()
              for fx in asset.articulated}
    set_parts(model, data, 1.0)
    for fx in asset.articulated:
        carcass = data.xipos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"art_{fx.instance_id}/object")]
        now = data.xipos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, fx.parts[0].body)]
        assert np.linalg.norm((now - carcass)[:2]) > np.linalg.norm((closed[fx.label] - carcass)[:2]) + 0.1, fx.label


def test_inside_and_top_surfaces_from_link_geometry(converted) -> None:
    _out, asset = converted
    by_label = {fx.label: fx for fx in asset.articulated}
    fridge, counter = by_label["fridge"], by_label["kitchen counter"]
    # the fridge: its floor and its shelf, both behind the door; the counter: the drawer's bottom, moving with it
    # (the compartment under the drawer, closed by a fixed panel, opens with no joint and is left out)
    heights = sorted(s.height for s in fridge.interiors)
    assert heights == pytest.approx([0.05 * 1.05, 0.81 * 1.05], abs=SURFACE_TOL)
    assert {s.joint for s in fridge.interiors} == {f"art_{fridge.instance_id}/door_hinge"}
    assert [(s.joint, s.body) for s in counter.interiors] == [(f"art_{counter.instance_id}/drawer_slide",
                                                               f"art_{counter.instance_id}/drawer")]
    assert counter.interiors[0].height == pytest.approx(0.46 * 0.98, abs=SURFACE_TOL)
    tops = {s.instance_id: s.height for s in asset.support_surfaces}
    assert tops == pytest.approx({fridge.instance_id: 1.6 * 1.05, counter.instance_id: 0.9 * 0.98}, abs=SURFACE_TOL)
    for fx in (fridge, counter):  # every surface lies within its piece's box
        lo, hi = asset.instance(fx.instance_id).bounds
        for s in fx.interiors:
            c = np.asarray(s.polygon).mean(axis=0)
            assert np.all(c > lo[:2]) and np.all(c < hi[:2]) and lo[2] < s.height < hi[2]


def test_what_is_not_imported_is_named(converted, tmp_path: Path) -> None:
    _out, asset = converted
    text = "\n".join(asset.unused)
    assert f"'{EXTRA['missing']}'" in text and "articulated_object_instances[2] not imported" in text
    assert "'no_such_chair'" in text and "object_instances[0] not imported" in text
    assert f"default_lighting '{EXTRA['light']}'" in text
    assert len(asset.unused) == 3, asset.unused  # nothing else: every other field of the instances is read
    # the convert command's report names them too (and the pieces it built)
    scene = write_replicacad(tmp_path / "ds", extra=True)
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "convert", str(scene), "--kind", "scene",
                           "--out", str(tmp_path / "conv"), "--cache", "off", "--no-progress"],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    row = json.loads((tmp_path / "conv" / "convert_report.json").read_text())["items"][0]
    assert len(row["unused"]) == 3 and any(EXTRA["missing"] in u for u in row["unused"])
    assert [a.split(" ", 1)[1] for a in row["articulated"]] == ["fridge (1 joints)", "kitchen counter (1 joints)"]
    assert EXTRA["light"] in proc.stderr and "3 thing(s) the inputs held were not used" in proc.stderr


def test_without_extras_nothing_is_unused(tmp_path: Path) -> None:
    asset = convert_scene(write_replicacad(tmp_path / "ds"), tmp_path / "out", cache_dir="off")
    assert asset.unused == [] and len(asset.articulated) == 2


def test_urdf_features_not_converted_are_named(tmp_path: Path) -> None:
    """A URDF element read past (a transmission) is named with its piece; a URDF that does not convert (a floating
    joint) leaves its piece out, named, and the scene goes on; so do fields the reader does not read."""
    scene = write_replicacad(tmp_path / "ds")
    fridge = tmp_path / "ds" / "urdf" / "fridge" / "fridge.urdf"
    fridge.write_text(fridge.read_text().replace("</robot>", '<transmission name="t"><type>x</type></transmission>'
                                                             "</robot>"))
    bad = tmp_path / "ds" / "urdf" / "flying" / "flying.urdf"
    bad.parent.mkdir()
    bad.write_text('<robot name="flying"><link name="a"/><link name="b"/><joint name="j" type="floating">'
                   '<parent link="a"/><child link="b"/></joint></robot>')
    doc = json.loads(scene.read_text())
    doc["articulated_object_instances"].append({"template_name": "flying", "translation": [0, 0, 0]})
    doc["articulated_object_instances"][0]["shiny"] = True
    scene.write_text(json.dumps(doc))
    asset = convert_scene(scene, tmp_path / "out", cache_dir="off")
    assert sorted(fx.label for fx in asset.articulated) == ["fridge", "kitchen counter"]
    assert len(asset.unused) == 3, asset.unused
    assert any("fridge.urdf" in u and "1 <transmission> not converted" in u for u in asset.unused)
    assert any("articulated_object_instances[2] 'flying' not imported" in u and "floating" in u for u in asset.unused)
    assert any("articulated_object_instances[0] 'fridge': fields not used: shiny" in u for u in asset.unused)


# ------------------------------------------------------------------------------------------------
# one small generate run

CONFIG = """\
name: rc-tiny
seed: 0
world:
  object_variants: 1
  object_categories: [can, remote, book, apple]
observe:
  yaw_steps: 4
  pitch_angles: [-30.0, 0.0]
  width: 160
  height: 120
place:
  k_v: 1
  m: 2
episodes:
  k_e: 2
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess]:
    """`generate --scenes <scene instance>` on the dataset with the extras (exports habitat and mjcf by default)."""
    root = tmp_path_factory.mktemp("rcrun")
    scene = write_replicacad(root / "ds", extra=True)
    (root / "rc.yaml").write_text(CONFIG, encoding="utf-8")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "generate", "--out", str(root / "run"), "--scenes",
                           str(scene), "--config", str(root / "rc.yaml"), "--quiet"], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return root / "run", proc


SCENE = "scenes/apt_kitchen"
VARIANT = f"{SCENE}/variants/apt_kitchen_v000/variant.json"


@pytest.mark.slow
def test_generate_names_what_was_not_imported_last(run) -> None:
    _run, proc = run
    last = proc.stderr.strip().splitlines()[-4:]
    assert "articulated_object_instances[2] not imported" in last[-2] and EXTRA["missing"] in last[-2]
    assert EXTRA["light"] in last[0] and "no_such_chair" in last[1]
    assert last[-1].startswith("WARNING: 3 thing(s) the scene inputs held were not used, in 1 scene(s)")


@pytest.mark.slow
def test_variant_holds_both_pieces_objects_on_and_inside_and_a_kitchen(run) -> None:
    root, _proc = run
    scene = load_json(root / SCENE / "scene.json", SceneAsset)
    planes = {p.id: p for p in load_json(root / SCENE / "semantics" / "planes.json", ReceptaclePlane)}
    v = load_json(root / VARIANT, SceneVariant)
    model = mujoco.MjModel.from_xml_path(str(root / v.mjcf))
    names = sorted(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in part_joints(model))
    ids = {fx.label: fx.instance_id for fx in scene.articulated}
    assert names == sorted([f"art_{ids['fridge']}/door_hinge", f"art_{ids['kitchen counter']}/drawer_slide"])
    assert v.articulation is not None and sorted(v.articulation) == names
    assert "kitchen" in {p.region for p in planes.values()}
    resting = [p for p in v.placements if p.status == "resting"]
    inside = {p.part for p in resting if p.part is not None}
    assert inside == set(names), inside  # objects behind the fridge door and in the drawer
    tops = {s.instance_id: s.height for s in scene.support_surfaces}
    on_top = set()
    for p in resting:
        pl = planes[p.plane_id]
        if pl.part is None:
            on_top |= {iid for iid, h in tops.items() if abs(pl.height - h) < 0.04}
    assert on_top == set(tops), (on_top, tops)  # and on the fridge's and the counter's tops
    # episodes: a goal inside a piece names the part to open, or none when it shows with the variant's state
    episodes = json.loads((root / VARIANT).with_name("episodes.json").read_text())
    assert episodes
    where = {p.object_id: p.part for p in v.placements}
    for e in episodes:
        for g in e["goals"]:
            assert g.get("open_part") in (None, where[g["object_id"]]), g
            if g.get("open_part"):
                j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, g["open_part"])
                assert v.articulation[g["open_part"]] < model.jnt_range[j][1], g  # hidden: its part is not open


@pytest.mark.slow
def test_exports_carry_the_pieces(run) -> None:
    import yourdfpy

    from sdovon_mj.geometry import quat_to_mat
    from sdovon_mj.suite.bundle import find_bundles, load_bundle

    root, _proc = run
    scene = load_json(root / SCENE / "scene.json", SceneAsset)
    v = load_json(root / VARIANT, SceneVariant)
    # MJCF bundle: the joints, in the variant's state (its `settled` keyframe)
    b = load_bundle(find_bundles(root / "export" / "mjcf")[0])
    bm = mujoco.MjModel.from_xml_path(str(b.mjcf))
    bd = mujoco.MjData(bm)
    mujoco.mj_resetDataKeyframe(bm, bd, mujoco.mj_name2id(bm, mujoco.mjtObj.mjOBJ_KEY, "settled"))
    assert part_state(bm, bd) == pytest.approx(v.articulation, abs=1e-5)
    # Habitat: one URDF articulated object per piece, at the pose and scale that put its links where MuJoCo has them
    sd = root / "export" / "habitat" / "data" / "scene_datasets" / "rc-tiny"
    inst = json.loads((sd / "scenes" / "apt_kitchen_v000.scene_instance.json").read_text())
    aos = inst["articulated_object_instances"]
    assert sorted(a["user_defined"]["label"] for a in aos) == ["fridge", "kitchen counter"]
    model = mujoco.MjModel.from_xml_path(str(root / v.mjcf))
    data = mujoco.MjData(model)
    data.qpos[:] = v.qpos
    mujoco.mj_forward(model, data)
    for a in aos:
        fx = next(f for f in scene.articulated if f.instance_id == a["user_defined"]["instance_id"])
        urdf = yourdfpy.URDF.load(str(sd / "urdf" / a["template_name"] / f"{a['template_name']}.urdf"))
        s = a["uniform_scale"]
        assert s == fx.scale
        urdf.update_cfg(np.array(a["initial_joint_pose"], float) / np.array(
            [s if j.type == "prismatic" else 1.0 for j in urdf.robot.joints if j.type != "fixed"]))
        # habitat-sim: the instance transform is the root link's inertial frame (scaled)
        Ti = np.eye(4)
        Ti[:3, 3] = np.array(urdf.link_map[urdf.base_link].inertial.origin[:3, 3]) * s
        T = np.eye(4)
        T[:3, :3] = HAB_TO_MJ @ quat_to_mat(np.array(a["rotation"], float))
        T[:3, 3] = HAB_TO_MJ @ np.array(a["translation"], float)
        root_T = T @ np.linalg.inv(Ti)
        for p in fx.parts:
            L = urdf.get_transform(p.link, urdf.base_link).copy()
            L[:3, 3] *= s
            W = root_T @ L
            bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.body)
            assert np.allclose(W[:3, 3], data.xpos[bid], atol=1e-4), (p.body, W[:3, 3], data.xpos[bid])
            assert np.allclose(W[:3, :3], data.xmat[bid].reshape(3, 3), atol=1e-4), p.body
