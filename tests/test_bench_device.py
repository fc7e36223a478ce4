"""bench/bench_device.py on the CPU path, at tiny sizes: it names the renderer, prints environment steps/s and an
agent's episodes/min on the CPU, and skips the GPU part with a clear line on a machine without one (figures only
printed: no speed is asserted)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from sdovon_mj import gl

REPO = Path(__file__).resolve().parents[1]


def test_bench_device_runs_on_the_cpu_and_skips_a_missing_gpu():
    env = {k: v for k, v in os.environ.items() if k != "SDOVON_RENDER"}
    proc = subprocess.run([sys.executable, str(REPO / "bench" / "bench_device.py"), "--agents", "oracle", "--episodes",
                           "1", "--width", "32", "--height", "24", "--steps", "5", "--max-steps", "10"],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.splitlines()
    assert any(ln.startswith("cpu: llvmpipe") for ln in lines), proc.stdout
    assert any(re.fullmatch(r"cpu: environment \d+\.\d steps/s \(rgb\+depth\+segmentation\)", ln) for ln in lines), \
        proc.stdout
    assert any(re.match(r"cpu: oracle --jobs 1: \d+\.\d episodes/min \(1 episodes in ", ln) for ln in lines), proc.stdout
    gpu = [ln for ln in lines if ln.startswith("gpu: ")]
    if any(gl.SOFTWARE_DEVICE not in e for e in gl._egl_devices()):  # a machine with a GPU EGL device measures it
        assert any(ln.startswith("gpu: environment") for ln in gpu), proc.stdout
    else:
        assert gpu and all(ln.startswith("gpu: skipped: render='gpu' but this machine offers no GPU EGL device")
                           for ln in gpu), proc.stdout
