"""Genesis (genesis-world, CPU backend) loads every MJCF bundle of a tiny generated run as it is, with the objects
at their settled poses, and steps it for 1 s without the state blowing up; how far each object moved is printed.

Genesis compiles its rigid-body kernels on the first scene build (minutes on 2 CPU cores; cached afterwards)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import mujoco

from sdovon_mj.export import ExportOptions, RunView, run_export
from exporters.mjcf_bundle import MjcfBundleExporter

gs = pytest.importorskip("genesis")

pytestmark = pytest.mark.slow
DT = 0.01  # s
SECONDS = 1.0


@pytest.fixture(scope="module")
def bundles(tiny_export_run, tmp_path_factory) -> list[Path]:
    out = tmp_path_factory.mktemp("mjcf")
    rep = run_export(MjcfBundleExporter(), RunView(tiny_export_run), out, ExportOptions(name="ds"))
    assert rep.variants, rep.summary()
    idx = json.loads((out / "ds" / "index.json").read_text())
    return [out / "ds" / b["path"] for b in idx["bundles"]]


def test_every_bundle_loads_and_steps_on_cpu(bundles):
    if not getattr(gs, "_initialized", False):
        gs.init(backend=gs.cpu, logging_level="warning")
    for bdir in bundles:
        xml = bdir / "scene.xml"
        model = mujoco.MjModel.from_xml_path(str(xml))
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)  # bundle qpos0 = the settled poses
        objs = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(model.nbody)]
        objs = [n for n in objs if n and n.startswith("obj_")]
        assert objs, xml
        scene = gs.Scene(sim_options=gs.options.SimOptions(dt=DT),
                         rigid_options=gs.options.RigidOptions(enable_torsional_friction=True, enable_rolling_friction=True),
                         show_viewer=False)
        ent = scene.add_entity(gs.morphs.MJCF(file=str(xml)))
        scene.build()
        links = {link.name: i for i, link in enumerate(ent.links)}
        assert set(objs) <= set(links), sorted(set(objs) - set(links))
        idx = [links[n] for n in objs]
        want = np.array([data.xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n)] for n in objs])
        p0 = np.asarray(ent.get_links_pos(idx), dtype=float).reshape(len(objs), 3)
        assert np.abs(p0 - want).max() < 1e-3, xml  # loaded at the settled poses
        for _ in range(int(round(SECONDS / DT))):
            scene.step()
        p1 = np.asarray(ent.get_links_pos(idx), dtype=float).reshape(len(objs), 3)
        assert np.isfinite(p1).all(), xml
        moved = np.linalg.norm(p1 - want, axis=1)
        print(f"genesis {bdir.name}: {int((moved <= 0.02).sum())}/{len(objs)} objects within 0.02 m after {SECONDS} s; "
              f"moved: {dict((n, round(float(m), 4)) for n, m in zip(objs, moved) if m > 0.02)}")
