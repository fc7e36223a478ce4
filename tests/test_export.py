"""Exporters: Habitat checklist and frames, self-contained MJCF bundles, output policy, plugins."""

from __future__ import annotations

import gzip
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

import mujoco

from sdovon_mj.export import ExportError, ExportOptions, RunView, run_export
from sdovon_mj.export import export_run
from exporters.habitat import HabitatExporter
from exporters.mjcf_bundle import MjcfBundleExporter, make_standalone
from sdovon_mj import plugins
from sdovon_mj.cli import main
from sdovon_mj.errors import InputError
from sdovon_mj.config import AgentConfig, EpisodeConfig
from support.run_folder import MUG_POSE, build_sample_run
from sdovon_mj.records import Episode, RecordError, load_json, records_equal, save_json
from sdovon_mj.store import dumps
from sdovon_mj.suite import load_bundle, make_environment
from sdovon_mj.sim.camera import pose_cv
from sdovon_mj.sim.model import geom_segment_ids, object_segment_id, segment_image
from sdovon_mj.sim.render import SceneRenderer

REPO = Path(__file__).resolve().parents[1]
EPISODE_KEYS = {"episode_id", "scene_id", "scene_dataset_config", "additional_obj_config_paths", "start_position",
                "start_rotation", "info", "goals", "start_room", "shortest_paths", "object_category"}
GOAL_KEYS = {"object_id", "object_name", "object_name_id", "object_category", "room_id", "room_name", "position",
             "radius", "view_points"}


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    return build_sample_run(tmp_path_factory.mktemp("run"), episodes=True, seed=0)


@pytest.fixture(scope="module")
def habitat_out(run_dir, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("hab")
    rep = run_export(HabitatExporter(), RunView(run_dir), out, ExportOptions(name="sdovon", split="val"))
    assert rep.variants == ["room_v000"] and rep.skipped == {"room_v001": "no valid goals (zero episodes)"}
    return out


def _gz(p: Path):
    with gzip.open(p, "rt", encoding="utf-8") as f:
        return json.load(f)


def test_habitat_checklist(habitat_out):
    root = habitat_out
    split = _gz(root / "data/datasets/objectnav/sdovon/val/val.json.gz")
    assert split["episodes"] == []
    assert split["category_to_task_category_id"] == {"ball": 0, "mug": 1}
    assert split["category_to_scene_annotation_category_id"].keys() == split["category_to_task_category_id"].keys()
    contents = sorted((root / "data/datasets/objectnav/sdovon/val/content").iterdir())
    assert [p.name for p in contents] == ["room_v000.json.gz"]  # zero-goal variant not written
    assert not (root / "data/scene_datasets/sdovon/scenes/room_v001.scene_instance.json").exists()
    c = _gz(contents[0])
    assert c["category_to_task_category_id"] == split["category_to_task_category_id"]
    for ep in c["episodes"]:
        assert set(ep) == EPISODE_KEYS and isinstance(ep["episode_id"], str)
        key = f"{os.path.basename(ep['scene_id'])}_{ep['object_category']}"
        assert key in c["goals_by_category"]
        assert (root / "data/scene_datasets" / ep["scene_id"]).is_file()
        assert (root / ep["scene_dataset_config"]).is_file() and not os.path.isabs(ep["scene_dataset_config"])
        q = np.array(ep["start_rotation"])
        assert q[0] == 0 and q[2] == 0 and abs(np.linalg.norm(q) - 1) < 1e-6  # xyzw yaw about +Y
        assert ep["start_position"][1] == 0.0  # floor height, Y up
        assert {"geodesic_distance", "euclidean_distance", "closest_goal_object_id"} <= set(ep["info"])
    for key, goals in c["goals_by_category"].items():
        for g in goals:
            assert set(g) == GOAL_KEYS and isinstance(g["object_id"], str) and g["view_points"]
            assert int(g["object_id"].split("_")[-1]) >= 0  # OVON-v1 parses '<cat>_<int>'
            for vp in g["view_points"]:
                assert set(vp) == {"agent_state", "iou"} and set(vp["agent_state"]) == {"position", "rotation"}
    cfg = json.loads((root / "data/scene_datasets/sdovon/sdovon.scene_dataset_config.json").read_text())
    assert cfg["stages"]["paths"][".json"] == ["stages"]
    sd = root / "data/scene_datasets/sdovon"
    for conf in list(sd.glob("stages/*.json")) + list(sd.glob("objects/*.json")):
        d = json.loads(conf.read_text())
        assert d["up"] == [0, 1, 0] and d["front"] == [0, 0, -1]
        assert (conf.parent / d["render_asset"]).is_file() and not os.path.isabs(d["render_asset"])
        assert trimesh.load(conf.parent / d["render_asset"], force="mesh").vertices.shape[0] > 0
    inst = json.loads((sd / "scenes/room_v000.scene_instance.json").read_text())
    for o in inst["object_instances"]:
        assert (sd / o["template_name"]).is_file()
    assert (sd / inst["stage_instance"]["template_name"]).is_file()
    # The stage GLB is Y-up: the room's 2.7 m height lies along +Y, its 5 m depth along -Z.
    stage = trimesh.load(sd / "stages/room.glb", force="mesh")
    lo, hi = stage.bounds
    assert hi[1] == pytest.approx(2.7, abs=1e-4) and lo[2] == pytest.approx(-5.1, abs=1e-4) and lo[1] == pytest.approx(-0.1, abs=1e-4)


def test_habitat_frames_hand_computed(habitat_out, run_dir):
    """Mug obj_000 at MuJoCo (1.5, 1.2, 0.75), yaw +90 deg about +Z."""
    sd = habitat_out / "data/scene_datasets/sdovon"
    inst = json.loads((sd / "scenes/room_v000.scene_instance.json").read_text())
    mug = [o for o in inst["object_instances"] if o["template_name"] == "objects/mug_a.object_config.json"]
    mug = next(o for o in mug if np.allclose(o["translation"], [1.5, 0.75, -1.2]))  # (x, z, -y)
    h = math.sqrt(0.5)
    # About +Z by 90 deg in MuJoCo is about +Y by 90 deg in Habitat: wxyz [h, 0, h, 0] (xyzw would be [0, h, 0, h]).
    assert mug["rotation"] == pytest.approx([h, 0.0, h, 0.0], abs=1e-6)
    assert mug["translation_origin"] == "asset_local"
    # The GLB placed by the instance pose lands where MuJoCo has the mug: x 1.45..1.55, y 0.75..0.85, z -1.25..-1.15.
    m = trimesh.load(sd / "objects/mug_a.glb", force="mesh")
    w, x, y, z = mug["rotation"]
    R = trimesh.transformations.quaternion_matrix([w, x, y, z])[:3, :3]
    v = m.vertices @ R.T + np.array(mug["translation"])
    assert v.min(axis=0) == pytest.approx([1.45, 0.75, -1.25], abs=2e-3)
    assert v.max(axis=0) == pytest.approx([1.55, 0.85, -1.15], abs=2e-3)
    c = _gz(habitat_out / "data/datasets/objectnav/sdovon/val/content/room_v000.json.gz")
    goal = next(g for g in c["goals_by_category"]["room_v000.scene_instance.json_mug"] if g["object_id"] == "mug_0")
    assert goal["position"] == pytest.approx([1.5, 0.8, -1.2], abs=1e-6)  # bbox centre (1.5, 1.2, 0.8)
    eps = load_json(run_dir / "scenes/room/variants/room_v000/episodes.json", Episode)
    g_mj = next(g for e in eps for g in e.goals if g.object_id == "obj_000")
    assert len(goal["view_points"]) == len(g_mj.view_points)
    for vp_h, vp in zip(goal["view_points"], g_mj.view_points):
        px, py, pz = vp.position
        assert vp_h["agent_state"]["position"] == pytest.approx([px, pz, -py], abs=1e-6)
        psi = math.atan2(1.2 - py, 1.5 - px)  # faces the mug, hand-computed
        theta = psi - math.pi / 2
        assert vp_h["agent_state"]["rotation"] == pytest.approx([0, math.sin(theta / 2), 0, math.cos(theta / 2)], abs=1e-5)
        # Rotating Habitat's forward (0, 0, -1) by the xyzw quaternion points at the goal in the XZ plane.
        qx, qy, qz, qw = vp_h["agent_state"]["rotation"]
        Rh = trimesh.transformations.quaternion_matrix([qw, qx, qy, qz])[:3, :3]
        f = Rh @ np.array([0.0, 0.0, -1.0])
        d = np.array(goal["position"]) - np.array(vp_h["agent_state"]["position"])
        d[1] = 0
        assert np.dot(f, d / np.linalg.norm(d)) == pytest.approx(1.0, abs=1e-5)
    assert MUJOCO_POSE_OK


MUJOCO_POSE_OK = bool(np.allclose(MUG_POSE[0], [1.5, 1.2, 0.75]) and MUG_POSE[1] == 90.0)


def test_mjcf_bundle_loads_anywhere_and_view_points_see_objects(run_dir, tmp_path, monkeypatch):
    out = tmp_path / "mj"
    rep = run_export(MjcfBundleExporter(), RunView(run_dir), out, ExportOptions(name="ds"))
    assert rep.variants == ["room_v000"] and "room_v001" in rep.skipped
    assert not (out / "ds/room_v001").exists()
    bdir = out / "ds/room_v000"
    # Assets are shared per dataset under their run-relative paths; the bundle refers to them relatively.
    assert (out / "ds/assets/objects/mug_a/mug.obj").is_file() and not (bdir / "assets").exists()
    meta = json.loads((bdir / "bundle.json").read_text())
    assert meta["assets"] == "../assets/"
    # the view points' visibility definition travels with the bundle (the suite's "goal seen" check renders so)
    ecfg, acfg = RunView(run_dir).config().episodes, RunView(run_dir).config().agent
    assert meta["visibility"] == {"width": ecfg.vis_width, "height": ecfg.vis_height, "eta_gt": acfg.eta_gt}
    assert load_bundle(bdir).visibility == meta["visibility"]
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    model = mujoco.MjModel.from_xml_path(str(bdir / "scene.xml"))
    # No path in the bundle points outside the dataset folder.
    xml = (bdir / "scene.xml").read_text()
    assert 'meshdir="../assets"' in xml and str(run_dir) not in xml and "../../" not in xml
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "obj_000")
    assert data.xpos[b] == pytest.approx([1.5, 1.2, 0.75]) and data.xquat[b] == pytest.approx([math.sqrt(.5), 0, 0, math.sqrt(.5)])
    loaded = load_bundle(bdir)  # v4: goals in goals.npz, the navmap shared by the scene's variants
    eps, nm = loaded.episodes, loaded.navmap(0)
    assert (out / "ds/oracle/room/navmap_0.npz").is_file() and not (bdir / "oracle/navmap_0.npz").exists()
    cfg = EpisodeConfig()
    lut = geom_segment_ids(model)
    n_checked = 0
    with SceneRenderer(model, data, width=cfg.vis_width, height=cfg.vis_height, hfov=AgentConfig().hfov) as r:
        seen: set[tuple] = set()
        for e in eps:
            assert nm.is_navigable(e.start_position[None, :2])[0]
            for g in e.goals:
                for vp in g.view_points:
                    key = (g.object_id, *vp.position.round(4))
                    if key in seen:
                        continue
                    seen.add(key)
                    cam = vp.position + np.array([0, 0, AgentConfig().camera_height])
                    d = g.position - cam
                    yaw = math.degrees(math.atan2(d[1], d[0]))
                    best = 0.0
                    for pitch in (math.degrees(math.atan2(d[2], math.hypot(d[0], d[1]))), -30.0, 0.0):
                        seg = segment_image(r.render(pose_cv(cam, yaw, pitch), rgb=False, depth=False, segmentation=True).segmentation, lut)
                        best = max(best, float(np.mean(seg == object_segment_id(g.object_id))))
                    assert best >= AgentConfig().eta_gt, (g.object_id, vp.position)
                    n_checked += 1
    assert n_checked >= 20


def test_bundle_with_a_bad_visibility_record_names_the_file(tmp_path):
    from sdovon_mj.errors import InputError
    from sdovon_mj.suite.bundle import _visibility

    assert _visibility(tmp_path, {}) == {}
    assert _visibility(tmp_path, {"visibility": {"width": 160, "height": 120, "eta_gt": 1e-4}})["width"] == 160
    with pytest.raises(InputError, match="bundle.json.*visibility"):
        _visibility(tmp_path, {"visibility": {"width": 160, "eta_gt": 1e-4}})
    with pytest.raises(InputError, match="eta_gt <= 1"):
        _visibility(tmp_path, {"visibility": {"width": 160, "height": 120, "eta_gt": 5}})


def test_output_policy_refuse_merge(run_dir, tmp_path):
    out = tmp_path / "o"
    export_run(run_dir, "habitat", out, name="a")
    export_run(run_dir, "habitat", out, name="a")  # same run, same dataset: re-export is fine
    with pytest.raises(ExportError, match="--merge"):
        export_run(run_dir, "habitat", out, name="b")
    export_run(run_dir, "habitat", out, name="b", merge=True)  # side by side, never mixed
    assert (out / "data/datasets/objectnav/a/val/val.json.gz").exists() and (out / "data/datasets/objectnav/b/val/val.json.gz").exists()
    other = build_sample_run(tmp_path / "run2", episodes=True, cfg=EpisodeConfig(k_e=1), seed=9)
    with pytest.raises(ExportError, match="another run"):
        export_run(other, "habitat", out, name="a", merge=True)
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "data").mkdir()
    with pytest.raises(ExportError, match="holds no"):
        export_run(run_dir, "mjcf", foreign)
    assert main(["export", str(run_dir), "--format", "mjcf", "--out", str(foreign)]) == 1
    assert main(["export", str(run_dir), "--format", "nope", "--out", str(tmp_path / "x")]) == 1


def test_third_party_exporter_package(run_dir, tmp_path, monkeypatch):
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--no-index", "-q",
                    "--target", str(target), str(REPO / "tests" / "plugin_pkg")], check=True, capture_output=True)
    monkeypatch.syspath_prepend(str(target))
    assert "csv" in plugins.available("exporter")
    cls = plugins.load("exporter", "csv")
    assert cls.__module__ == "sdovon_csv_exporter"
    out = tmp_path / "csv_out"
    assert main(["export", str(run_dir), "--format", "csv", "--out", str(out), "--name", "t"]) == 0
    rows = (out / "t/episodes.csv").read_text().splitlines()
    assert rows[0].startswith("variant,category") and len(rows) == 1 + 6
    assert json.loads((out / "sdovon_export.json").read_text())["exports"][0]["format"] == "csv"


def test_mjcf_standalone_export_and_making_a_copied_bundle_self_contained(run_dir, tmp_path, monkeypatch):
    """--standalone writes today's self-contained bundles; a shared-asset bundle copied alone loads after
    `sdovon-mj export BUNDLE --standalone`, and the suite loads it from another working directory."""
    assert main(["export", str(run_dir), "--format", "mjcf", "--out", str(tmp_path / "alone"), "--standalone"]) == 0
    sb = tmp_path / "alone/sdovon/room_v000"
    assert (sb / "assets/mug.obj").is_file() and not (tmp_path / "alone/sdovon/assets").exists()
    assert (sb / "oracle/navmap_0.npz").is_file() and not (tmp_path / "alone/sdovon/oracle").exists()
    assert "../" not in (sb / "scene.xml").read_text()
    assert main(["export", str(run_dir), "--format", "mjcf", "--out", str(tmp_path / "shared")]) == 0
    from sdovon_mj.suite import find_bundles
    from sdovon_mj.suite.observation import Vocabulary, dataset_vocabulary

    # the dataset's one vocabulary, recorded in index.json: the union over its bundles (goal categories, labels)
    every = Vocabulary.of_bundles(load_bundle(p) for p in find_bundles(tmp_path / "shared/sdovon"))
    assert dataset_vocabulary(tmp_path / "shared/sdovon") == every and every.goal_categories
    assert "vocabulary" in json.loads((tmp_path / "shared/sdovon/index.json").read_text())
    copied = tmp_path / "copy/room_v000"
    shutil.copytree(tmp_path / "shared/sdovon/room_v000", copied)
    with pytest.raises(ValueError):  # alone, its ../assets is missing
        mujoco.MjModel.from_xml_path(str(copied / "scene.xml"))
    assert main(["export", str(tmp_path / "shared/sdovon/room_v000"), "--standalone"]) == 0  # in place
    assert main(["export", str(tmp_path / "shared/sdovon/room_v000"), "--standalone"]) == 0  # idempotent
    shutil.rmtree(copied)
    shutil.copytree(tmp_path / "shared/sdovon/room_v000", copied)
    shutil.rmtree(tmp_path / "shared")  # nothing of the dataset is left but the copy
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    a = mujoco.MjModel.from_xml_path(str(copied / "scene.xml"))
    b = mujoco.MjModel.from_xml_path(str(sb / "scene.xml"))
    assert a.nmesh == b.nmesh == 1 and a.mesh_vertnum.tolist() == b.mesh_vertnum.tolist()
    assert json.loads((copied / "bundle.json").read_text())["assets"] == "assets/"
    assert records_equal(load_bundle(copied).episodes, load_bundle(sb).episodes)
    env = make_environment(copied)
    ts = env.reset()
    assert ts.observation is not None
    assert main(["export", str(tmp_path / "nope"), "--standalone"]) == 1
    # a whole dataset folder (its index.json) at once
    assert main(["export", str(run_dir), "--format", "mjcf", "--out", str(tmp_path / "ds2"), "--name", "d"]) == 0
    assert main(["export", str(tmp_path / "ds2/d"), "--standalone"]) == 0
    assert (tmp_path / "ds2/d/room_v000/assets/mug.obj").is_file()


def _v3_copy(run: RunView, variant: str, v4: Path, dst: Path) -> None:
    """Write a version-3 bundle (whole Episode records, every oracle file as JSON in the bundle) of a variant."""
    var = next(v for v in run.all_variants() if v.name == variant)
    dst.mkdir(parents=True)
    shutil.copy(v4 / "scene.xml", dst / "scene.xml")
    (dst / "episodes.json").write_text(dumps([e.to_dict() for e in run.episodes(var)]))
    for nm in run.navmaps(var.scene):
        save_json(nm, dst / f"oracle/navmap_{nm.floor}.json")
    for rm in run.region_maps(var.scene):
        save_json(rm, dst / f"oracle/region_map_{rm.floor}.json")
    if run.relevance(var.scene) is not None:
        save_json(run.relevance(var.scene), dst / "oracle/relevance.json")
    for name in ("object_labels.json",):
        shutil.copy(v4 / "oracle" / name, dst / "oracle" / name)
    shutil.copy(v4 / "../oracle" / var.scene / "instance_labels.json", dst / "oracle/instance_labels.json")
    meta = json.loads((v4 / "bundle.json").read_text())
    meta.update(bundle_version=3, navmaps={str(nm.floor): f"oracle/navmap_{nm.floor}.json" for nm in run.navmaps(var.scene)})
    for k in ("goals", "scene_oracle", "region_maps", "instance_labels", "relevance", "object_labels"):
        meta.pop(k)
    (dst / "bundle.json").write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")


def test_mjcf_v4_goals_once_and_same_episodes_as_a_v3_bundle(tmp_path):
    """Bundle v4 writes every goal once (goals.npz) and the scene's oracle files once per scene; the suite reads
    from it the run's very Episode records and navmaps, the same as from a v3 bundle of the same run, and the
    environment starts the same episodes; a bundle from a newer exporter or missing its scene files fails clearly."""
    run_path = build_sample_run(tmp_path / "run", episodes=True, cfg=EpisodeConfig(k_e=3), seed=0)
    run = RunView(run_path)
    out = tmp_path / "mj"
    rep = run_export(MjcfBundleExporter(), run, out, ExportOptions(name="ds"))
    var = next(v for v in run.all_variants() if v.name == rep.variants[0])
    v4 = out / "ds" / var.name
    want = run.episodes(var)
    assert len(want) >= 2 and len({g.object_id for e in want for g in e.goals}) < sum(len(e.goals) for e in want)
    text = (v4 / "episodes.json").read_text()
    assert "view_points" not in text and '"EpisodeRef"' in text
    with np.load(v4 / "goals.npz") as z:
        meta = json.loads(bytes(z["__meta__"]).decode())
        assert len(z["vp_position"]) == sum(g["n_view_points"] for g in meta["goals"])
    ids = [g["object_id"] for g in meta["goals"]]
    assert sorted(ids) == sorted({g.object_id for e in want for g in e.goals})  # each goal object once
    with pytest.raises(RecordError, match="expected a Episode record, found EpisodeRef"):
        load_json(v4 / "episodes.json", Episode)  # an old reader fails loudly, never reads goal-less episodes
    _v3_copy(run, var.name, v4, out / "ds" / "v3copy")
    b3, b4 = load_bundle(out / "ds" / "v3copy"), load_bundle(v4)
    assert records_equal(b4.episodes, want) and records_equal(b3.episodes, b4.episodes)
    assert records_equal(b3.navmaps, b4.navmaps) and records_equal(b4.navmaps, run.navmaps(var.scene))
    assert records_equal(b3.region_maps, b4.region_maps) and records_equal(b3.relevance, b4.relevance)
    assert b3.detector_labels() == b4.detector_labels() and b4.object_labels
    envs = [make_environment(b, width=32, height=24) for b in (out / "ds" / "v3copy", v4)]
    for i in range(len(want)):
        obs = []
        for env in envs:
            env.task.set_next_episode(i)
            ts = env.reset()
            obs.append((env.task.episode.episode_id, env.task.shortest, ts.observation["gps"].tolist(),
                        ts.observation["rgb"].tobytes()))
        assert obs[0] == obs[1]
    # Same run, same bytes.
    run_export(MjcfBundleExporter(), run, tmp_path / "again", ExportOptions(name="ds"))
    for rel in ("goals.npz", "episodes.json", "bundle.json"):
        assert (tmp_path / "again/ds" / var.name / rel).read_bytes() == (v4 / rel).read_bytes()
    assert ((tmp_path / "again/ds/oracle" / var.scene / "navmap_0.npz").read_bytes()
            == (out / "ds/oracle" / var.scene / "navmap_0.npz").read_bytes())
    # A bundle from a newer exporter, and one missing its scene's shared files, fail naming the file.
    newer = tmp_path / "newer"
    shutil.copytree(v4, newer)
    meta = json.loads((newer / "bundle.json").read_text())
    (newer / "bundle.json").write_text(json.dumps({**meta, "bundle_version": 99}))
    with pytest.raises(InputError, match="bundle.json.*newer than this reader"):
        load_bundle(newer)
    (newer / "bundle.json").write_text(json.dumps(meta))
    with pytest.raises(InputError, match="navmap_0.npz.*--standalone"):
        load_bundle(newer)  # copied alone: ../oracle/<scene>/ is not beside it
    assert make_standalone(v4) and load_bundle(v4).navmap(0) is not None
    assert json.loads((v4 / "bundle.json").read_text())["navmaps"] == {"0": "oracle/navmap_0.npz"}
