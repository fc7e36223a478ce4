"""The renderer a process draws with (`sdovon_mj.gl`), on this CPU machine with another EGL vendor offered first.

The stand-in for a GPU machine's NVIDIA vendor: a copy of Mesa's EGL vendor library under another name, listed before
Mesa's ICD file in ``__EGL_VENDOR_LIBRARY_FILENAMES``, with ``GALLIUM_DRIVER=softpipe`` so that what EGL offers first
draws other pixels than llvmpipe (the control shows it does, so the tests can fail). Generation still draws with
llvmpipe there, the same pixels as here, and records it; ``gpu`` is a clear error (the impostor offers a software
device only); ``auto`` falls back to the CPU and says why; a process that cannot get llvmpipe refuses to generate, or
generates with the recorded override. Each case runs in a fresh process: a process keeps the renderer it made first.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj import gl

REPO = Path(__file__).resolve().parents[1]
TINY = """\
seed: 0
world: {scene_seeds: [0], floors: 1, object_variants: 1, object_categories: [can, book]}
observe: {yaw_steps: 2, pitch_angles: [0.0], width: 64, height: 48, camera_heights: [], targeted_views: 0}
"""
# a plain MuJoCo process (no sdovon_mj): the renderer EGL offers first, and which vendor libraries it loaded
CONTROL = """
import mujoco
from OpenGL import GL
c = mujoco.GLContext(1, 1); c.make_current()
print(GL.glGetString(GL.GL_RENDERER).decode())
print(" ".join(sorted({l.split()[-1] for l in open("/proc/self/maps") if "libEGL_" in l})))
c.free()
"""


def _clean_env(**extra: str) -> dict[str, str]:
    """Return this process's environment without what `sdovon_mj.gl` set here, plus `extra`."""
    env = {k: v for k, v in os.environ.items() if k not in ("__EGL_VENDOR_LIBRARY_FILENAMES", "__EGL_VENDOR_LIBRARY_DIRS",
           "MUJOCO_EGL_DEVICE_ID", "SDOVON_RENDER", "LIBGL_ALWAYS_SOFTWARE", "GALLIUM_DRIVER")}
    return {**env, "MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl", **extra}


def _python(code: str, env: dict[str, str], *args: str) -> subprocess.CompletedProcess:
    """Run Python code (or ``-m`` arguments) in a fresh process."""
    cmd = [sys.executable, *(("-c", code) if code else ()), *args]
    return subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def impostor_first(tmp_path_factory) -> dict[str, str]:
    """An environment whose first EGL vendor is a renamed copy of Mesa's, drawing with softpipe."""
    mesa = [f for f in gl.vendor_files({}) if gl.is_mesa(f)]
    assert mesa, "no Mesa EGL vendor file: this machine cannot render offscreen on the CPU"
    gl.ensure()  # Mesa's vendor library is loaded here now: copy it from where it lies
    lib = next(line.split()[-1] for line in open("/proc/self/maps") if "libEGL_mesa" in line)
    d = tmp_path_factory.mktemp("egl")
    shutil.copy(lib, d / "libEGL_impostor.so.0")
    (d / "10_impostor.json").write_text(json.dumps(
        {"file_format_version": "1.0.0", "ICD": {"library_path": str(d / "libEGL_impostor.so.0")}}), encoding="utf-8")
    return _clean_env(__EGL_VENDOR_LIBRARY_FILENAMES=f"{d / '10_impostor.json'}:{mesa[0]}", GALLIUM_DRIVER="softpipe")


def test_generation_draws_with_llvmpipe_when_another_vendor_is_offered_first(impostor_first, tmp_path):
    control = _python(CONTROL, impostor_first)
    assert control.returncode == 0, control.stderr
    renderer, loaded = control.stdout.strip().splitlines()
    assert not renderer.startswith("llvmpipe") and "libEGL_impostor" in loaded, control.stdout  # the test can fail
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY, encoding="utf-8")
    runs = {}
    for name, env in (("impostor", impostor_first), ("plain", _clean_env())):
        runs[name] = tmp_path / name
        p = _python("", env, "-m", "sdovon_mj.cli", "observe", str(runs[name]), "--config", str(cfg), "--quiet")
        assert p.returncode == 0, p.stdout + p.stderr
    rec = json.loads((runs["impostor"] / "manifest.json").read_text())["renderer"]
    assert rec["renderer"].startswith("llvmpipe") and rec["llvmpipe"] and not rec["override"], rec
    # the renders themselves: the same pixels as where Mesa is the only vendor (softpipe draws others)
    shards = sorted((runs["plain"] / "scenes/apt_0000/observe").glob("obs_*.npz"))
    assert shards
    for s in shards:
        a, b = np.load(s), np.load(runs["impostor"] / s.relative_to(runs["plain"]))
        assert sorted(a.files) == sorted(b.files) and all(np.array_equal(a[k], b[k]) for k in a.files), s.name


def test_gpu_without_a_gpu_is_a_clear_error_and_auto_falls_back(impostor_first):
    code = """
from sdovon_mj.errors import RendererError
from sdovon_mj import gl
try:
    gl.use("gpu")
except RendererError as e:
    print("error:", e)
print(gl.use("auto"))
"""
    p = _python(code, impostor_first)
    assert p.returncode == 0, p.stderr
    error, record = p.stdout.strip().splitlines()
    assert "render='gpu'" in error and "no GPU EGL device" in error and "libEGL_impostor" in error, error
    assert "'render': 'cpu'" in record and "'fallback': 'auto: no GPU EGL device" in record, record
    assert "llvmpipe" in record, record


def test_generation_refuses_without_llvmpipe_unless_overridden(tmp_path):
    """A process that drew with softpipe before sdovon_mj chose: generation refuses before touching the run folder;
    with ``SDOVON_RENDER=any`` (``generate --any-renderer``) it goes on and the manifest's record says so."""
    code = f"""
import os
import mujoco
c = mujoco.GLContext(1, 1); c.make_current(); c.free()
from sdovon_mj import pipeline
from sdovon_mj.config import RunConfig
from sdovon_mj.errors import RendererError
from sdovon_mj import gl
try:
    pipeline.generate({str(tmp_path / 'run')!r}, RunConfig())
except RendererError as e:
    print("refused:", e)
os.environ["SDOVON_RENDER"] = "any"
print(gl.manifest_record())
"""
    p = _python(code, _clean_env(GALLIUM_DRIVER="softpipe"))
    assert p.returncode == 0, p.stderr
    refused, record = p.stdout.strip().splitlines()
    assert "needs Mesa llvmpipe" in refused and "softpipe" in refused and "--any-renderer" in refused, refused
    assert not (tmp_path / "run").exists()
    assert "'renderer': 'softpipe'" in record and "'llvmpipe': False" in record and "'override': True" in record


def test_vendor_list_puts_mesa_first(tmp_path):
    """`prepare` lists Mesa's ICD file first and keeps the others, also when the given list leaves Mesa out."""
    mesa = next(f for f in gl.vendor_files({}) if gl.is_mesa(f))
    other = tmp_path / "10_other.json"
    other.write_text(json.dumps({"file_format_version": "1.0.0", "ICD": {"library_path": "libEGL_other.so.0"}}))
    for given in (f"{other}:{mesa}", str(other)):
        env = {"__EGL_VENDOR_LIBRARY_FILENAMES": given}
        assert gl.prepare(env) == [mesa, str(other)] and env["__EGL_VENDOR_LIBRARY_FILENAMES"] == f"{mesa}:{other}"
    env = {"__EGL_VENDOR_LIBRARY_DIRS": str(tmp_path)}
    assert gl.prepare(env) == [mesa, str(other)]


def test_device_choice_on_a_gpu_machines_device_list(monkeypatch):
    """The devices a GPU machine with Mesa offers (Mesa's DRM node of the card, which Mesa cannot drive, Mesa's
    software device, NVIDIA's device): cpu takes the software device with Mesa's software driver, gpu and auto NVIDIA's
    device; without a GPU device gpu is an error and auto falls back; without Mesa cpu is an error, any goes on."""
    from sdovon_mj.errors import RendererError

    offered = ["EGL_EXT_device_drm EGL_EXT_device_drm_render_node", f"{gl.SOFTWARE_DEVICE} EGL_EXT_device_drm_render_node",
               f"{gl.NVIDIA} EGL_EXT_device_drm EGL_EXT_device_drm_render_node"]
    monkeypatch.setattr(gl, "_egl_devices", lambda: offered)
    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.setenv("MESA_LOADER_DRIVER_OVERRIDE", "zink")
    for k in ("MUJOCO_EGL_DEVICE_ID", gl.OURS, *gl.CPU_ENV):
        monkeypatch.delenv(k, raising=False)
    assert gl._pick_device("cpu") == ("1", None, "cpu") and os.environ["MUJOCO_EGL_DEVICE_ID"] == "1"
    assert all(os.environ[k] == v for k, v in gl.CPU_ENV.items()) and "MESA_LOADER_DRIVER_OVERRIDE" not in os.environ
    # a child inherits that choice and chooses again (a user's MUJOCO_EGL_DEVICE_ID would count)
    assert gl._pick_device("gpu") == ("2", None, "gpu") and "LIBGL_ALWAYS_SOFTWARE" not in os.environ
    assert gl._pick_device("auto") == ("2", None, "gpu")
    monkeypatch.setattr(gl, "_egl_devices", lambda: offered[1:2])
    with pytest.raises(RendererError, match="no GPU EGL device"):
        gl._pick_device("gpu")
    device, note, tried = gl._pick_device("auto")
    assert (device, tried) == ("0", "cpu") and note.startswith("auto: no GPU EGL device")
    monkeypatch.setattr(gl, "_egl_devices", lambda: offered[2:])
    with pytest.raises(RendererError, match="CPU renderer .* is not available"):
        gl._pick_device("cpu")
    assert gl._pick_device("any") == (None, None, "cpu") and "MUJOCO_EGL_DEVICE_ID" not in os.environ  # MuJoCo's pick
