"""The process pool's workers: Mesa's software rasterizer threads per worker, and the images they make."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys

import pytest

from sdovon_mj.executors import _worker_init, rasterizer_threads

# A small room: floor, walls, furniture-sized boxes, a sphere and a capsule, seen across llvmpipe's 64-pixel tiles.
RENDER = r'''
import hashlib, sys
import sdovon_mj  # first: it chooses the GL backend (EGL) before mujoco is imported
import numpy as np
import mujoco
from sdovon_mj.sim.camera import pose_cv
from sdovon_mj.sim.render import SceneRenderer
xml = """<mujoco><worldbody>
<geom type="plane" size="5 5 0.1" rgba="0.6 0.6 0.5 1"/>
<geom type="box" pos="2 0 1" size="0.05 3 1" rgba="0.8 0.8 0.8 1"/>
<geom type="box" pos="1.2 0.8 0.4" size="0.4 0.3 0.4" rgba="0.5 0.3 0.2 1"/>
<geom type="box" pos="1.0 -0.9 0.75" size="0.3 0.6 0.02" euler="0 0 20" rgba="0.4 0.2 0.1 1"/>
<geom type="sphere" pos="1.0 -0.9 0.85" size="0.08" rgba="0.9 0.1 0.1 1"/>
<geom type="capsule" pos="0.7 0.2 0.3" size="0.05 0.2" euler="30 40 0" rgba="0.1 0.6 0.9 1"/>
</worldbody></mujoco>"""
m = mujoco.MjModel.from_xml_string(xml)
d = mujoco.MjData(m)
mujoco.mj_forward(m, d)
r = SceneRenderer(m, d, width=320, height=240, hfov=79.0)
h = hashlib.sha256()
for yaw in (-30.0, 0.0, 25.0):
    for pitch in (0.0, -30.0):
        f = r.render(pose_cv(np.array([-0.5, 0.1, 0.88]), yaw, pitch), rgb=True, depth=True, segmentation=True)
        assert f.rgb.std() > 0 and (f.segmentation >= 0).any() and np.isfinite(f.depth).all()  # a real image
        for a in (f.rgb, f.depth, f.segmentation):
            h.update(np.ascontiguousarray(a).tobytes())
print(h.hexdigest())
'''


def _render_digest(lp_threads: str | None) -> str:
    env = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    if lp_threads is not None:
        env["LP_NUM_THREADS"] = lp_threads
    proc = subprocess.run([sys.executable, "-c", RENDER], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.strip().splitlines()[-1]


def test_rasterizer_threads_leave_no_core_to_two():
    """A worker per core rasterizes in its own thread; spare cores go to the workers' rasterizers."""
    assert rasterizer_threads(2, cores=2) == 0
    assert rasterizer_threads(16, cores=16) == 0
    assert rasterizer_threads(2, cores=16) == 7
    assert rasterizer_threads(1, cores=1) == 0 and rasterizer_threads(4, cores=2) == 0


def test_worker_init_keeps_the_users_setting(monkeypatch):
    monkeypatch.delenv("LP_NUM_THREADS", raising=False)
    _worker_init(0)
    assert os.environ["LP_NUM_THREADS"] == "0"
    monkeypatch.setenv("LP_NUM_THREADS", "3")
    _worker_init(0)
    assert os.environ["LP_NUM_THREADS"] == "3"


@pytest.mark.skipif(os.environ.get("MUJOCO_GL", "egl") != "egl", reason="the EGL (Mesa) renderer")
def test_images_do_not_depend_on_rasterizer_threads():
    """RGB, depth and segmentation are the same bytes rasterized in the rendering thread or by llvmpipe's threads."""
    assert _render_digest("0") == _render_digest(None) == _render_digest("2")


def test_bad_input_is_not_retried(tmp_path):
    """A bad input fails the same way every time: its task runs once (the manifest's ``attempts`` is 1) and names
    the file, while a failure of another kind is retried up to ``retries`` times."""
    import json

    from sdovon_mj.config import load_config
    from sdovon_mj.executors import LocalExecutor
    from sdovon_mj.manifest import RunSummary, write_manifest
    from sdovon_mj.pipeline import prepare_run
    from sdovon_mj.tasks import TaskSpec

    mug = tmp_path / "lib" / "mug.obj"
    mug.parent.mkdir()
    mug.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", encoding="utf-8")
    cfg = load_config(None)
    store = prepare_run(tmp_path / "run", cfg, objects=[str(mug)])
    mug.unlink()  # the input went away after the run was prepared (a resumed run): the objects task reads it
    ex = LocalExecutor(jobs=1, retries=2, memory_mb=0)
    bad, other = ex.map([TaskSpec("objects", str(store.root)), TaskSpec("scene", str(store.root), "no_such_scene")])
    assert not bad.ok and "mug.obj" in bad.error and bad.deterministic
    assert bad.attempts == 1
    assert not other.ok and not other.deterministic and other.attempts == 3  # 1 + retries
    write_manifest(store, cfg, RunSummary(str(store.root), [], [bad, other], {}))
    failures = json.loads((store.root / "manifest.json").read_text(encoding="utf-8"))["failures"]
    assert [f["attempts"] for f in failures] == [1, 3]
