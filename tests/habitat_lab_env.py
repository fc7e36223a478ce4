"""The habitat-lab client environment: its own venv with habitat-lab 0.3.3 from PyPI, built once and cached.

It stays out of the main venv: habitat-lab pins numpy==1.26.4 and gym<0.23.1 (the main venv has numpy 2),
and opencv 5 breaks `import habitat` (habitat/utils/visualizations/maps.py), so it needs opencv < 5. habitat-sim is not on PyPI; the client in
tests/test_export_habitat_lab.py stubs it. The venv lives in the shared cache folder
(`sdovon_mj.store.user_cache_dir("habitat-venv")`, or $SDOVON_HABITAT_VENV) and is rebuilt when `REQS` changes.

`python tests/habitat_lab_env.py` builds (or reuses) it and prints its python; `./run.sh test` runs it before
pytest, so the habitat-lab client test runs on a clean clone.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

# PyPI spells habitat-lab 0.3.3 as 0.3.3<release date>.
REQS = ["habitat-lab==0.3.320260507", "opencv-python<5"]


def venv_dir() -> Path:
    """Return the folder of the habitat-lab venv ($SDOVON_HABITAT_VENV, else the shared cache folder)."""
    env = os.environ.get("SDOVON_HABITAT_VENV")
    if env:
        return Path(env)
    from sdovon_mj.store import user_cache_dir

    return user_cache_dir("habitat-venv") or Path(tempfile.gettempdir()) / f"sdovon-mj-habitat-venv-{os.getuid()}"


def _mark(venv: Path) -> Path:
    return venv / ".sdovon-ok"


def cached_python() -> Path | None:
    """Return the venv's python when the venv is built for the current `REQS`, else None."""
    venv = venv_dir()
    py = venv / "bin" / "python"
    mark = _mark(venv)
    ok = mark.exists() and py.exists() and mark.read_text().strip() == " ".join(REQS)
    return py if ok else None


def ensure_python() -> Path:
    """Return the habitat-lab venv's python, building the venv from PyPI first when it is missing or stale."""
    py = cached_python()
    if py is not None:
        return py
    venv = venv_dir()
    base = "python3.11" if sys.version_info[:2] != (3, 11) else sys.executable
    if venv.exists():
        shutil.rmtree(venv)
    venv.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([base, "-m", "venv", str(venv)], check=True)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "-q", "--disable-pip-version-check"]
    subprocess.run([*pip, *REQS], check=True)
    _mark(venv).write_text(" ".join(REQS) + "\n")
    return venv / "bin" / "python"


if __name__ == "__main__":
    print(ensure_python())
