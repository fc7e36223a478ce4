"""USD export: stages open with pxr, UsdValidation (usdchecker's rules, UsdPhysics included) finds no error,
every rigid body has mass and a collider, the scene collider exists, object world poses equal the settled
MuJoCo poses (1 mm / 0.5 deg), textures resolve to files inside the export, and the bytes are reproducible."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pytest

import mujoco

from sdovon_mj.export import ExportOptions, RunView, run_export

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdPhysics, UsdShade, UsdValidation  # noqa: E402

from exporters.usd import UsdExporter  # noqa: E402



@pytest.fixture(scope="module")
def usd_out(tiny_export_run, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("usd")
    rep = run_export(UsdExporter(), RunView(tiny_export_run), out, ExportOptions(name="ds"))
    assert rep.variants and rep.episodes > 0, rep.summary()
    return out / "ds"


def _errors(path: Path) -> list[str]:
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    errs = UsdValidation.ValidationContext(validators).Validate(Usd.Stage.Open(str(path)))
    return [f"{e.GetName()}: {e.GetMessage()}" for e in errs]


@pytest.mark.slow
def test_stages_validate_and_physics_schemas(usd_out):
    idx = json.loads((usd_out / "index.json").read_text())
    for v in idx["variants"]:
        path = usd_out / v["stage"]
        assert _errors(path) == [], path
        stage = Usd.Stage.Open(str(path))
        assert any(p.IsA(UsdPhysics.Scene) for p in stage.Traverse())
        scene_colliders = [p for p in Usd.PrimRange(stage.GetPrimAtPath("/World/Scene")) if p.HasAPI(UsdPhysics.CollisionAPI)]
        assert scene_colliders and all(UsdPhysics.MeshCollisionAPI(p).GetApproximationAttr().Get() == "none" for p in scene_colliders)
        for oid, ppath in v["object_prims"].items():
            prim = stage.GetPrimAtPath(ppath)
            assert prim.HasAPI(UsdPhysics.RigidBodyAPI) and UsdPhysics.MassAPI(prim).GetMassAttr().Get() > 0
            cols = [p for p in Usd.PrimRange(prim) if p.HasAPI(UsdPhysics.CollisionAPI)]
            assert cols and all(UsdPhysics.MeshCollisionAPI(p).GetApproximationAttr().Get() == "convexHull" for p in cols)
        eps = json.loads((usd_out / v["episodes"]).read_text())
        for e in eps["episodes"]:
            for g in e["goals"]:
                assert stage.GetPrimAtPath(g["prim_path"]).IsValid()


def test_validation_catches_a_broken_stage(tmp_path):
    """The validators are live: a stage without stage metadata and with a dangling reference fails."""
    bad = tmp_path / "bad.usda"
    stage = Usd.Stage.CreateNew(str(bad))
    stage.DefinePrim("/World", "Xform").GetReferences().AddReference("missing.usdc")
    stage.Save()
    assert _errors(bad)


@pytest.mark.slow
def test_object_poses_equal_settled_mujoco(tiny_export_run, usd_out):
    run = RunView(tiny_export_run)
    idx = json.loads((usd_out / "index.json").read_text())
    for v in idx["variants"]:
        variant = next(x for x in run.all_variants() if x.name == v["variant"])
        model = mujoco.MjModel.from_xml_path(str(run.path(variant.mjcf)))
        data = mujoco.MjData(model)
        data.qpos[:] = variant.qpos
        mujoco.mj_forward(model, data)
        stage = Usd.Stage.Open(str(usd_out / v["stage"]))
        for oid, ppath in v["object_prims"].items():
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, oid)
            M = np.array(pxr.UsdGeom.Xformable(stage.GetPrimAtPath(ppath)).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
            R, t = M[:3, :3].T, M[3, :3]  # Gf matrices are row-vector: p' = p M
            assert np.linalg.norm(t - data.xpos[b]) < 1e-3
            cos = (np.trace(R.T @ data.xmat[b].reshape(3, 3)) - 1) / 2
            assert math.degrees(math.acos(min(1.0, max(-1.0, cos)))) < 0.5


@pytest.mark.slow
def test_textures_resolve_inside_export(usd_out):
    found = 0
    for layer_file in sorted((usd_out / "scenes").glob("*.usdc")) + sorted((usd_out / "objects").glob("*.usdc")):
        stage = Usd.Stage.Open(str(layer_file))
        for prim in stage.Traverse():
            sh = UsdShade.Shader(prim)
            if sh and sh.GetIdAttr().Get() == "UsdUVTexture":
                asset = sh.GetInput("file").Get()
                p = Path(asset.resolvedPath)
                assert p.is_file() and usd_out.resolve() in p.resolve().parents, asset
                found += 1
    assert found > 0  # the default world's scene has textured materials


@pytest.mark.slow
def test_same_run_same_bytes(tiny_export_run, usd_out, tmp_path):
    out = tmp_path / "again"
    run_export(UsdExporter(), RunView(tiny_export_run), out, ExportOptions(name="ds"))
    digest = lambda root: {p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()  # noqa: E731
                           for p in sorted(root.rglob("*")) if p.is_file()}
    assert digest(out / "ds") == digest(usd_out)

