"""The README's commands run as written on a fresh clone.

Every fenced block preceded by ``<!-- runnable -->`` runs, in README order, on a copy of the checkout (the files a
clone has; its ``.venv`` is this checkout's), each ``bash`` block in a fresh ``bash -e`` and each ``python`` block with
``.venv/bin/python``, all with the copy as the working directory: later blocks read what earlier ones wrote.

Long commands run with small settings, appended to the line (CONTRIBUTING.md says so too): `SMALL` to every
``./run.sh demo``, ``sdovon-mj demo`` and ``sdovon-mj generate`` (one apartment, four quick-to-convert object categories, small
images, one variant; the demo evaluates one episode), `SMALL_EVAL` to ``sdovon-mj eval``. ``./run.sh test`` is this
suite itself and is not run from inside it. A Python block that reruns a run reads that run's own config, so it
inherits the small settings.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUNNABLE = re.compile(r"^<!-- runnable -->\n```(bash|python)\n(.*?)^```$", re.S | re.M)
SMALL = ("--set world.object_categories=[can,remote,book,apple] --set world.object_variants=1 --set observe.width=160 "
         "--set observe.height=120 --set observe.yaw_steps=4 --set observe.pitch_angles=[-30.0] --set place.k_v=1 "
         "--set episodes.k_e=1")
SMALL_EVAL = "--episodes 1 --width 160 --height 120"
LONG = {("./run.sh", "demo"): SMALL + " --episodes 1", ("sdovon-mj", "demo"): SMALL + " --episodes 1",
        ("sdovon-mj", "generate"): SMALL, ("sdovon-mj", "eval"): SMALL_EVAL}
SELF = ("./run.sh", "test")
NOT_SOURCES = (".git", ".venv", "__pycache__", "*.egg-info", "build", "dist", ".pytest_cache", ".hypothesis", ".cache",
               "out", "runs")


def runnable_blocks(text: str) -> list[tuple[str, str]]:
    """Return (language, code) of every block the README marks runnable, in order."""
    return [(m.group(1), m.group(2)) for m in RUNNABLE.finditer(text)]


def small(line: str) -> str:
    """Return a shell line with the small settings appended (before its comment), or a no-op for ./run.sh test."""
    cmd, sep, comment = line.partition(" #")
    words = cmd.split()
    if tuple(words[:2]) == SELF:
        return ": ./run.sh test is the suite running this test"
    extra = LONG.get(tuple(words[:2]))
    if not extra:
        return line
    return f"{cmd.rstrip()} {extra}" + (f"  #{comment}" if sep else "")


def test_the_marker_finds_blocks_and_small_settings_go_before_comments():
    text = "x\n<!-- runnable -->\n```bash\n./run.sh demo   # go\n```\n\n```bash\nnot marked\n```\n"
    assert runnable_blocks(text) == [("bash", "./run.sh demo   # go\n")]
    assert small("./run.sh demo   # go") == f"./run.sh demo {SMALL} --episodes 1  # go"
    assert small("sdovon-mj world --out w") == "sdovon-mj world --out w"
    assert small("./run.sh test     # all").startswith(":")


def test_the_readme_is_short_and_marks_its_snippets():
    """At most 10,000 bytes (tables live in docs/results.md); every code block runs, except the citation's BibTeX
    (data, not a snippet: tests/test_citation.py checks it)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.encode("utf-8")) <= 10_000, len(text.encode("utf-8"))
    langs = [lang for lang, _ in runnable_blocks(text)]
    assert "bash" in langs and "python" in langs, langs
    fences = text.count("\n```") // 2 - text.count("\n```bibtex\n")
    assert fences == len(langs), f"{fences - len(langs)} code block(s) not marked runnable: mark or remove them"


def _venv_is_current() -> bool:
    """Whether .venv was set up for this checkout's pyproject.toml and run.sh (run.sh's own stamp rule)."""
    stamp = ROOT / ".venv" / ".sdovon-installed"
    want = hashlib.sha256((ROOT / "pyproject.toml").read_bytes() + (ROOT / "run.sh").read_bytes()).hexdigest()[:16]
    return stamp.exists() and stamp.read_text().strip() == want


@pytest.mark.slow
def test_the_readme_snippets_run_as_written_on_a_fresh_clone(tmp_path):
    # With a stale stamp the README's ./run.sh would reinstall the package from the temporary copy into .venv.
    assert _venv_is_current(), "run ./run.sh setup first: .venv was set up for another pyproject.toml or run.sh"
    clone = tmp_path / "clone"
    shutil.copytree(ROOT, clone, ignore=shutil.ignore_patterns(*NOT_SOURCES), symlinks=True)
    (clone / ".venv").symlink_to(ROOT / ".venv")  # the environment ./run.sh set up (its stamp matches the copy)
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH")}
    blocks = runnable_blocks((clone / "README.md").read_text(encoding="utf-8"))
    for i, (lang, code) in enumerate(blocks):
        if lang == "bash":
            script = "\n".join(small(line) for line in code.splitlines())
            cmd = ["bash", "-e", "-c", script]
        else:
            path = tmp_path / f"readme_block_{i}.py"
            path.write_text(code, encoding="utf-8")
            cmd = [str(clone / ".venv" / "bin" / "python"), str(path)]
        done = subprocess.run(cmd, cwd=clone, env=env, capture_output=True, text=True, timeout=1800)
        assert done.returncode == 0, f"README block {i} ({lang}) failed:\n{code}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    # what the blocks promise exists (the small settings kept them real)
    assert list((clone / "out" / "demo" / "pictures").glob("*_render.png"))
    assert (clone / "out" / "demo" / "eval").is_dir()
    assert (clone / "runs" / "mine" / "export" / "mjcf" / "sdovon" / "apt_0001_v001" / "bundle.json").exists()
    assert (clone / "runs" / "mine" / "eval").is_dir()
