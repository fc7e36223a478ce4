"""A tiny generated run (default world: 1 apartment, 4 object categories, 2 variants) for the simulator-export tests.

`tiny_run(root)` runs `sdovon-mj generate` on it (about a minute on 2 cores); the USD, URDF and Genesis
tests share one such run (`tiny_export_run` in conftest.py, once per session) so they check the same data the
pipeline produces (real hulls, masses, textures).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import test_generate

REPO = Path(__file__).resolve().parents[1]

# test_generate's tiny config with two variants (the exports must load "every variant").
TINY_YAML = test_generate.TINY_YAML.replace("k_v: 1", "k_v: 2").replace("name: sdovon-tiny", "name: sdovon-sim-export")
assert "k_v: 2" in TINY_YAML


def tiny_run(root: Path) -> Path:
    """Generate the tiny run under root/run and return it (raises with the command's stderr on failure)."""
    root.mkdir(parents=True, exist_ok=True)
    cfg = root / "tiny.yaml"
    cfg.write_text(TINY_YAML, encoding="utf-8")
    out = root / "run"
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "generate", "--out", str(out), "--config", str(cfg),
                           *test_generate.TINY_SET, "--quiet"], cwd=REPO, env=env, capture_output=True, text=True, timeout=1800)
    if proc.returncode != 0:
        raise RuntimeError(f"generate failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return out

