"""Round trip: our Habitat export re-imported with the Habitat scene-dataset reader gives back the scene and the
placed objects' poses (1 mm, 0.5 deg)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

import mujoco

from assets_convert import convert_scene
from exporters.habitat import HabitatExporter, _body_geoms, _variant_model
from exporters.habitat.glb import geoms_mesh
from sdovon_mj.export import ExportOptions, RunView, run_export
from sdovon_mj.sim import GROUP_OBJECT_VISUAL
from sdovon_mj.sim.model import load_scene_mesh
from support.run_folder import build_sample_run

MM = 1e-3
DEG = 0.5


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    run = build_sample_run(tmp_path_factory.mktemp("run"), episodes=True, seed=0)
    out = tmp_path_factory.mktemp("hab")
    run_export(HabitatExporter(), RunView(run), out, ExportOptions(name="sdovon", split="val"))
    return run, out


def _kabsch(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return R, t minimising |R a + t - b| over paired points."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _s, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    R = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return R, cb - R @ ca


def test_habitat_export_reimports_scene_and_object_poses(exported: tuple[Path, Path], tmp_path: Path) -> None:
    run_dir, out = exported
    view = RunView(run_dir)
    variant = next(v for v in view.all_variants() if v.name == "room_v000")
    scene_file = out / "data/scene_datasets/sdovon/scenes/room_v000.scene_instance.json"
    asset = convert_scene(scene_file, tmp_path, cache_dir="off")
    mesh = load_scene_mesh(tmp_path / asset.mesh)
    V, F, FI = mesh[0], mesh[1], mesh[2]
    # the stage: the original scene's extent back within 1 mm
    scene = view.scene(variant.scene)
    smodel = mujoco.MjModel.from_xml_path(str(view.path(scene.mjcf)))
    sdata = mujoco.MjData(smodel)
    mujoco.mj_forward(smodel, sdata)
    orig_stage = geoms_mesh(smodel, sdata, list(range(smodel.ngeom)), np.eye(4), np.eye(3))
    stage_ids = [i.id for i in asset.instances if i.kind == "structure"]
    stage_v = V[np.unique(F[np.isin(FI, stage_ids)])]
    np.testing.assert_allclose([stage_v.min(axis=0), stage_v.max(axis=0)], orig_stage.bounds, atol=MM)
    # every placed object: same surface, same pose
    model, data = _variant_model(view, variant)
    objects = [i for i in asset.instances if i.kind == "furniture"]
    placed = sorted(variant.placements, key=lambda p: p.object_id)
    assert len(objects) == len(placed)
    for inst, p in zip(objects, placed):
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.object_id)
        ref = geoms_mesh(model, data, _body_geoms(model, b, (GROUP_OBJECT_VISUAL,)), np.eye(4), np.eye(3))
        got = V[np.unique(F[FI == inst.id])]
        d, nn = cKDTree(ref.vertices).query(got)
        assert d.max() <= MM, (p.object_id, d.max())
        R, t = _kabsch(ref.vertices[nn], got)
        angle = np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))
        assert angle <= DEG and np.linalg.norm(t) <= MM, (p.object_id, angle, t)
        # and the reverse direction: nothing of the original object is missing
        assert cKDTree(got).query(ref.vertices)[0].max() <= MM
        assert inst.label == p.asset.replace("_", " ")  # no lexicon in our export: the template name


def test_eval_finds_a_run_folders_mjcf_export(tmp_path: Path) -> None:
    """`sdovon-mj eval RUN_DIR`: a run folder stands for its MJCF export (not its unbundled variant folders)."""
    from exporters.mjcf_bundle import MjcfBundleExporter
    from sdovon_mj.config import RunConfig, dump_yaml
    from sdovon_mj.errors import InputError
    from sdovon_mj.suite.bundle import find_bundles, load_bundle

    run = build_sample_run(tmp_path / "run", episodes=True, seed=0)
    (run / "config.yaml").write_text(dump_yaml(RunConfig()), encoding="utf-8")
    with pytest.raises(InputError, match="run folder without an MJCF export"):
        find_bundles(run)
    run_export(MjcfBundleExporter(), RunView(run), run / "export" / "mjcf", ExportOptions(name="sdovon", split="val"))
    found = find_bundles(run)
    assert found and all((run / "export" / "mjcf") in p.parents for p in found)
    assert load_bundle(found[0]).episodes


def test_empty_run_is_loud(tmp_path: Path) -> None:
    """A scene without episodes is named (and why); a run with episodes gives no warning."""
    from sdovon_mj.commands.generate import empty_warnings

    full = build_sample_run(tmp_path / "full", episodes=True, seed=0)
    assert empty_warnings(str(full)) == []
    empty = build_sample_run(tmp_path / "empty", episodes=False, seed=0)
    lines = empty_warnings(str(empty))
    # the scene has no labelled instance: no setting helps, and the warning does not pretend one does
    assert lines[0].startswith("scene room: no receptacle plane found") and "--set" not in lines[0]
    assert lines[-1] == "the run has 0 episodes in its 1 scene(s)"
    assert empty_warnings(str(empty), failed={"scene room"}) == ["the run has 0 episodes in its 1 scene(s)"]
