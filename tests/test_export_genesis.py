"""Genesis (genesis-world, CPU backend) loads every MJCF bundle of a tiny generated run as it is, with the objects
at their settled poses, and steps it for 1 s without the state blowing up; how far each object moved is printed.

Genesis compiles its rigid-body kernels on the first scene build (minutes on 2 CPU cores; cached afterwards)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.export import ExportOptions, RunView, run_export
from exporters.mjcf_bundle import MjcfBundleExporter

pytest.importorskip("genesis")

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


# Runs in a fresh process: genesis.init turns on flush-to-zero / denormals-are-zero for the whole process it runs
# in, which would change the arithmetic of every later test in a pytest worker (tests/conftest.py checks for it).
CHECK = """
import json, sys
import numpy as np
import mujoco
import genesis as gs

DT, SECONDS = float(sys.argv[1]), float(sys.argv[2])
gs.init(backend=gs.cpu, logging_level="warning")
out = []
for xml in sys.argv[3:]:
    model = mujoco.MjModel.from_xml_path(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)  # bundle qpos0 = the settled poses
    objs = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(model.nbody)]
    objs = [n for n in objs if n and n.startswith("obj_")]
    scene = gs.Scene(sim_options=gs.options.SimOptions(dt=DT),
                     rigid_options=gs.options.RigidOptions(enable_torsional_friction=True, enable_rolling_friction=True),
                     show_viewer=False)
    ent = scene.add_entity(gs.morphs.MJCF(file=xml))
    scene.build()
    links = {link.name: i for i, link in enumerate(ent.links)}
    idx = [links[n] for n in objs if n in links]
    want = [data.xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n)].tolist() for n in objs]
    p0 = np.asarray(ent.get_links_pos(idx), dtype=float).reshape(len(idx), 3)
    for _ in range(int(round(SECONDS / DT))):
        scene.step()
    p1 = np.asarray(ent.get_links_pos(idx), dtype=float).reshape(len(idx), 3)
    out.append({"xml": xml, "objects": objs, "links": sorted(links), "want": want, "p0": p0.tolist(),
                "p1": p1.tolist()})
print(json.dumps(out))  # a blown-up state stays NaN / Infinity (json writes and reads them back)
"""


def test_every_bundle_loads_and_steps_on_cpu(bundles):
    proc = subprocess.run([sys.executable, "-c", CHECK, str(DT), str(SECONDS), *(str(b / "scene.xml") for b in bundles)],
                          capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr[-3000:]
    results = json.loads(proc.stdout.strip().splitlines()[-1])
    assert len(results) == len(bundles)
    for r in results:
        xml, objs = r["xml"], r["objects"]
        assert objs, xml
        assert set(objs) <= set(r["links"]), sorted(set(objs) - set(r["links"]))
        want = np.asarray(r["want"], float)
        assert np.abs(np.asarray(r["p0"], float) - want).max() < 1e-3, xml  # loaded at the settled poses
        p1 = np.asarray(r["p1"], float)
        assert np.isfinite(p1).all(), xml
        moved = np.linalg.norm(p1 - want, axis=1)
        print(f"genesis {Path(xml).parent.name}: {int((moved <= 0.02).sum())}/{len(objs)} objects within 0.02 m after "
              f"{SECONDS} s; moved: {dict((n, round(float(m), 4)) for n, m in zip(objs, moved) if m > 0.02)}")
