"""The installed product is the product: the wheel `pip` builds holds the packages and their data, no tests,
no test fixtures (`tests/support/`), no benches and no maintainer tools."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# What .gitignore keeps out of a clone (environments, caches, build leftovers, run folders): not sources.
NOT_SOURCES = (".git", ".venv", "__pycache__", "*.egg-info", "build", "dist", ".pytest_cache", ".hypothesis", ".cache",
               "out", "runs")
PRODUCT = {"sdovon_mj", "assets_convert", "exporters", "mjcf_templates"}


def test_the_wheel_holds_the_product_and_no_tests_fixtures_benches_or_tools(tmp_path):
    src = tmp_path / "src"  # a copy, so the build leaves nothing (build/, *.egg-info) in the checkout
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(*NOT_SOURCES), symlinks=True)
    assert (src / "tests" / "support" / "run_folder.py").exists()  # the fixtures sit in the tree the wheel is built from
    # no build isolation: setuptools and wheel of this environment (run.sh installs them), no download
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-cache-dir",
                           "-q", "-w", str(tmp_path / "dist"), str(src)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    wheels = list((tmp_path / "dist").glob("sdovon_mj-*.whl"))
    assert len(wheels) == 1, wheels
    names = zipfile.ZipFile(wheels[0]).namelist()

    top = {n.split("/")[0] for n in names}
    info = {t for t in top if t.endswith(".dist-info")}
    assert len(info) == 1 and top - info == PRODUCT, sorted(top)
    outside = sorted(n for n in names if {"tests", "support", "testing", "bench", "tools"} & set(n.split("/")[:-1]))
    assert not outside, outside
    # the product is all there: code, data, presets, templates, the licence and the console script
    for need in ("sdovon_mj/cli.py", "sdovon_mj/presets/demo.yaml", "sdovon_mj/data/semantics/learned.json",
                 "assets_convert/plugin.py", "exporters/habitat/__init__.py", f"{info.pop()}/entry_points.txt"):
        assert need in names, need
    assert any(n.endswith(".dist-info/licenses/LICENSE") or n.endswith(".dist-info/LICENSE") for n in names), names[-10:]
    assert any(n.startswith("mjcf_templates/") and n.endswith(".xml") for n in names)
