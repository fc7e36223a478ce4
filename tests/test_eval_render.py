"""`sdovon-mj eval --render`: ``cpu`` gives the results of the default path (``auto``, which on this machine, without a
GPU, falls back to the CPU and says so in every table row); ``gpu`` without a GPU is a clear error before any work.

The fixture apartment, the oracle (fast) over three episodes at 32x24, through the command line in this process.
"""

from __future__ import annotations

import json
from pathlib import Path

from sdovon_mj import cli
from sdovon_mj import gl
from support.bundles import fixture_bundle

ARGS = ["--agent", "oracle", "--episodes", "3", "--width", "32", "--height", "24", "--pictures", "0"]
WALL = ("seconds", "setup_seconds", "render_fallback")  # wall-clock figures; auto's note on why it drew on the CPU


def _results(out: Path) -> dict[str, dict]:
    """Return episode id -> result (wall-clock figures and the fallback note left out) of an eval folder."""
    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k not in WALL}
        return [strip(v) for v in x] if isinstance(x, list) else x
    return {p.stem: strip(json.loads(p.read_text())) for p in sorted((out / "episodes" / "oracle").glob("*.json"))}


def test_eval_render_cpu_equals_the_default_path_and_gpu_without_one_is_an_error(tmp_path, capsys):
    dataset = fixture_bundle()
    assert not any(gl.SOFTWARE_DEVICE not in e for e in gl._egl_devices()), "this test is written for a GPU-less machine"
    assert cli.main(["eval", str(dataset), *ARGS, "--render", "gpu", "--out", str(tmp_path / "gpu")]) == 1
    err = capsys.readouterr().err
    assert "sdovon-mj eval: error: render='gpu' but this machine offers no GPU EGL device" in err, err
    assert not (tmp_path / "gpu").exists()  # refused before any work
    runs = {}
    for name, extra in (("cpu", ["--render", "cpu"]), ("default", [])):
        runs[name] = tmp_path / name
        assert cli.main(["eval", str(dataset), *ARGS, *extra, "--out", str(runs[name])]) == 0
    cpu, default = _results(runs["cpu"]), _results(runs["default"])
    assert len(cpu) == 3 and cpu == default  # the same episodes, outcomes, paths and renderer record
    assert all(r["render"] == "cpu" and r["renderer"].startswith("llvmpipe") for r in cpu.values())
    fell_back = [json.loads(p.read_text()) for p in (runs["default"] / "episodes" / "oracle").glob("*.json")]
    assert all(r["render_fallback"].startswith("auto") for r in fell_back)  # auto records why it drew on the CPU
    tables = {n: (runs[n] / "tables.md").read_text() for n in runs}
    assert "| oracle | " in tables["cpu"] and ", cpu, open split |" in tables["cpu"] and "auto: no GPU" not in tables["cpu"]
    assert ", cpu (auto: no GPU), open split |" in tables["default"]
