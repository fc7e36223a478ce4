"""`sdovon-mj generate` end to end: default world, resume after SIGKILL, Ray = process pool, failing scenes.

One session-scoped run of the whole pipeline on a tiny default-world config (1 apartment, 4 object
categories, 1 variant, 160x120 images, 4 yaw steps) is the reference the other tests compare to, byte
for byte. Only `timings.json` and the `.timing.json` files (wall seconds) are excluded from comparisons.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

TINY_YAML = """\
name: sdovon-tiny
seed: 0
world:
  scene_seeds: [0]
  floors: 1
  object_variants: 1
  object_categories: [can, remote, book, apple]
observe:
  yaw_steps: 4
  pitch_angles: [-30.0, 0.0]
place:
  k_v: 1
  m: 2
episodes:
  k_e: 2
"""
# Given on the command line, so the tests also show that --set overrides reach the run.
TINY_SET = ["--set", "observe.width=160", "--set", "observe.height=120"]

# Files that hold wall-clock seconds only; everything else must match byte for byte.
TIMING_FILES = {"timings.json", ".timing.json"}


def cli(*args: str, timeout: float = 900, **kw) -> subprocess.CompletedProcess:
    """Run `sdovon-mj ARGS` in a subprocess (non-interactive: stderr is a pipe)."""
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run([sys.executable, "-m", "sdovon_mj.cli", *args], cwd=REPO, env=env, capture_output=True,
                          text=True, timeout=timeout, **kw)


def generate_args(out: Path, config: Path, *extra: str) -> list[str]:
    """Return the generate arguments of the tiny run into `out`."""
    return ["generate", "--out", str(out), "--config", str(config), *TINY_SET, *extra]


def snapshot(root: Path) -> dict[str, str]:
    """Return relative path -> sha256 of every file under a run folder except the timing files."""
    out = {}
    for p in sorted(root.rglob("*")):
        if p.is_file() and p.name not in TIMING_FILES:
            out[p.relative_to(root).as_posix()] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def assert_same_outputs(got: Path, want: Path) -> None:
    """Assert two run folders hold the same files with the same bytes (timing files aside)."""
    a, b = snapshot(got), snapshot(want)
    missing, extra = sorted(set(b) - set(a)), sorted(set(a) - set(b))
    differ = sorted(k for k in set(a) & set(b) if a[k] != b[k])
    assert not missing and not extra and not differ, f"missing {missing[:10]}, extra {extra[:10]}, differ {differ[:10]}"


def markers(root: Path) -> dict[str, int]:
    """Return stage key -> mtime (ns) of every finished stage marker in a run folder."""
    return {p.parent.relative_to(root).as_posix(): p.stat().st_mtime_ns for p in sorted(root.rglob(".done.json"))}


@pytest.fixture(scope="session")
def tiny_config(tmp_path_factory) -> Path:
    """The tiny run config file."""
    p = tmp_path_factory.mktemp("cfg") / "tiny.yaml"
    p.write_text(TINY_YAML, encoding="utf-8")
    return p


@pytest.fixture(scope="session")
def reference_run(tmp_path_factory, tiny_config) -> tuple[Path, subprocess.CompletedProcess]:
    """One uninterrupted `sdovon-mj generate` of the tiny config (the whole pipeline, local executor)."""
    out = tmp_path_factory.mktemp("gen") / "ref"
    proc = cli(*generate_args(out, tiny_config))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out, proc


def test_generate_default_world_end_to_end(reference_run) -> None:
    """The whole pipeline runs on the default world: records, exports, statistics, manifest, summary."""
    out, proc = reference_run
    variant = out / "scenes/apt_0000/variants/apt_0000_v000"
    for rel in ("config.yaml", "manifest.json", "timings.json", "objects/objects.json", "scenes/apt_0000/scene.json",
                "scenes/apt_0000/perceive/instances.npz", "scenes/apt_0000/semantics/relevance.json",
                "stats/statistics.json", "stats/category_frequency_goals.png", "export/habitat.report.json",
                "export/mjcf.report.json"):
        assert (out / rel).is_file(), rel
    episodes = json.loads((variant / "episodes.json").read_text())
    assert len(episodes) > 0
    placed = json.loads((variant / "variant.json").read_text())
    assert len(placed["placements"]) > 0
    stats = json.loads((out / "stats/statistics.json").read_text())
    assert stats["totals"]["episodes"] == len(episodes)

    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["failures"] == []
    # --set overrides reach the resolved config (and so every stage fingerprint).
    assert manifest["config"]["observe"]["width"] == 160 and manifest["config"]["observe"]["height"] == 120
    assert manifest["config"]["world"]["object_categories"] == ["can", "remote", "book", "apple"]
    for stage in ("objects", "inputs/scenes/apt_0000", "scenes/apt_0000/convert", "scenes/apt_0000/observe",
                  "scenes/apt_0000/perceive", "scenes/apt_0000/semantics",
                  "scenes/apt_0000/variants/apt_0000_v000/place", "scenes/apt_0000/variants/apt_0000_v000/episodes",
                  "export/habitat.stage", "export/mjcf.stage"):
        assert len(manifest["stages"][stage]) == 24, stage
    assert manifest["scene_seeds"]["apt_0000"] >= 0

    timings = json.loads((out / "timings.json").read_text())
    for stage in ("objects", "convert", "observe", "perceive", "semantics", "place", "episodes"):
        assert timings["stage_seconds"][stage] > 0, stage
    assert all(t["ok"] and not t["skipped"] for t in timings["tasks"])
    peaks = {k: v for t in timings["tasks"] for k, v in t["peak_rss_mb"].items()}
    assert peaks["perceive"] > 50  # a real process's peak resident memory, MiB

    # Summary table on stdout; progress on stderr as sparse plain lines (stderr is not a terminal here).
    for word in ("scenes", "variants", "episodes", "objects rejected", "seconds per stage", "perceive"):
        assert word in proc.stdout, word
    err_lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert "\r" not in proc.stderr
    progress = [ln for ln in err_lines if ln.startswith("[generate]")]
    assert len(progress) >= 3 and len(err_lines) <= 20, proc.stderr
    # objects, the scene, the variant, then the export tasks: habitat's units (the scene, the object
    # templates) and mjcf's (the scene), each exporter's finishing step: all counted, the last line says done
    assert progress[-1].startswith("[generate] 8/8"), progress[-1]


def test_rerun_skips_finished_stages_and_keeps_bytes(reference_run, tmp_path) -> None:
    """A rerun of a finished run (here moved to another folder) recomputes nothing and changes no byte."""
    ref, _ = reference_run
    run = tmp_path / "moved"
    shutil.copytree(ref, run)
    before = markers(run)
    proc = cli(*generate_args(run, Path(ref / "config.yaml")), "--quiet")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stderr.strip() == ""  # --quiet: no progress lines
    assert markers(run) == before  # no marker rewritten: no stage ran again
    timings = json.loads((run / "timings.json").read_text())
    assert timings["stage_seconds"] == {}
    assert all(t["skipped"] for t in timings["tasks"])
    assert_same_outputs(run, ref)


def test_show_renders_run(reference_run, tmp_path) -> None:
    """`sdovon-mj show RUN_DIR` draws the run's maps, placements and episodes."""
    ref, _ = reference_run
    proc = cli("show", str(ref), "--out", str(tmp_path / "pics"))
    assert proc.returncode == 0, proc.stderr
    pics = sorted((tmp_path / "pics").rglob("*.png"))
    assert len(pics) >= 2
    assert all(p.stat().st_size > 5000 for p in pics)


def test_config_errors_name_the_cause(tmp_path, tiny_config) -> None:
    """Bad --config files and --set keys stop the command with exit code 2 (a usage error) and the cause, before any work."""
    out = tmp_path / "run"
    proc = cli("generate", "--out", str(out), "--config", str(tmp_path / "nope.yaml"))
    assert proc.returncode == 2 and "config file not found" in proc.stderr and "nope.yaml" in proc.stderr
    bad = tmp_path / "bad.yaml"
    bad.write_text("observe: [unclosed\n", encoding="utf-8")
    proc = cli("generate", "--out", str(out), "--config", str(bad))
    assert proc.returncode == 2 and "bad.yaml" in proc.stderr and "YAML" in proc.stderr
    typo = tmp_path / "typo.yaml"
    typo.write_text("observe:\n  widht: 3\n", encoding="utf-8")
    proc = cli("generate", "--out", str(out), "--config", str(typo))
    assert proc.returncode == 2 and "widht" in proc.stderr
    proc = cli("generate", "--out", str(out), "--config", str(tiny_config), "--set", "place.kv=3")
    assert proc.returncode == 2 and "place.kv" in proc.stderr
    proc = cli("generate", "--out", str(out), "--config", str(tiny_config), "--set", "place.k_v")
    assert proc.returncode == 2 and "KEY=VALUE" in proc.stderr
    assert not out.exists()


def _fresh_input_glb(ref: Path, dst: Path) -> Path:
    """Copy the reference run's default-world apartment (GLB + sidecar) into `dst`; return the GLB."""
    src = ref / "inputs/scenes/apt_0000"
    dst.mkdir(parents=True, exist_ok=True)
    for p in sorted(src.iterdir()):
        if p.is_file() and not p.name.startswith("."):
            shutil.copy(p, dst / p.name)
    return dst / "apt_0000.glb"


def test_failing_scene_is_reported_and_others_finish(reference_run, tmp_path) -> None:
    """`--scenes good.glb bad.glb`: the corrupt scene fails with its cause; the good one's variants and exports exist.

    The run folder starts as a copy of the reference run, so the good scene's finished stages are reused (the
    scene is named after its file and fingerprinted by its bytes) and the test stays fast; the slow variant
    below runs both scenes from scratch.
    """
    ref, _ = reference_run
    run = tmp_path / "run"
    shutil.copytree(ref, run)
    good = _fresh_input_glb(ref, tmp_path / "in")
    bad = _pointcloud_glb(tmp_path / "in" / "bad.glb")
    proc = cli(*generate_args(run, ref / "config.yaml", "--scenes", str(good), str(bad)))
    _check_failing_scene(proc, run, bad)


def _pointcloud_glb(path: Path) -> Path:
    """Write a well-formed GLB that holds points and no triangle: it passes the up-front input check (its files exist
    and parse; a truncated or garbage GLB is refused there, exit 2) and fails its scene's conversion."""
    import numpy as np
    import trimesh

    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(trimesh.Scene(trimesh.PointCloud(np.random.default_rng(0).random((50, 3)))).export(file_type="glb"))
    return path


def _check_failing_scene(proc: subprocess.CompletedProcess, run: Path, bad: Path) -> None:
    """Assert exit code 1, the bad scene's cause reported, the good scene's variants and exports written."""
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "failed tasks:" in proc.stdout and "bad" in proc.stdout
    fail_lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("failed: bad")]
    assert len(fail_lines) == 1 and str(bad) in fail_lines[0], proc.stderr  # the file and its cause
    assert len(fail_lines[0].split(str(bad))[-1].strip(": ")) > 5, fail_lines[0]  # ... and a cause after it
    manifest = json.loads((run / "manifest.json").read_text())
    assert [f["task"] for f in manifest["failures"]] == ["bad"]
    assert manifest["failures"][0]["attempts"] == 1  # a bad input fails the same way every time: not retried
    variant = run / "scenes/apt_0000/variants/apt_0000_v000"
    assert json.loads((variant / "episodes.json").read_text())
    assert not (run / "scenes/bad/variants").exists()
    for fmt in ("habitat", "mjcf"):
        report = json.loads((run / f"export/{fmt}.report.json").read_text())
        assert report["variants"] == ["apt_0000_v000"] and report["episodes"] >= 1, report


@pytest.mark.slow
def test_failing_scene_from_scratch(reference_run, tmp_path) -> None:
    """Same as above in a fresh run folder with two workers: the good scene is computed beside the failing one."""
    ref, _ = reference_run
    good = _fresh_input_glb(ref, tmp_path / "in")
    bad = _pointcloud_glb(tmp_path / "in" / "bad.glb")
    run = tmp_path / "run"
    proc = cli(*generate_args(run, ref / "config.yaml", "--scenes", str(good), str(bad), "--jobs", "2"))
    _check_failing_scene(proc, run, bad)
    # The good scene's records equal the reference run's (same bytes in, same bytes out), but for the recorded
    # source: the reference's input lives in its run folder (named run-relative), this one outside (full path).
    got, want = snapshot(run / "scenes/apt_0000"), snapshot(ref / "scenes/apt_0000")
    named = ("asset.json", "scene.json")  # and the convert marker, which records their digests
    keep = lambda d: {k: v for k, v in d.items() if k not in named + ("convert/.done.json",)}  # noqa: E731
    assert keep(got) == keep(want)
    for name in named:
        a, b = (json.loads((r / "scenes/apt_0000" / name).read_text()) for r in (run, ref))
        assert a.pop("source") == str(good) and b.pop("source") == "inputs/scenes/apt_0000/apt_0000.glb"
        assert a == b


def _wait_for(path: Path, proc: subprocess.Popen, timeout: float = 600) -> None:
    """Poll until `path` exists (the process must still be running)."""
    t0 = time.monotonic()
    while not path.exists():
        assert proc.poll() is None, f"generate ended (rc {proc.returncode}) before {path} appeared"
        assert time.monotonic() - t0 < timeout, f"timed out waiting for {path}"
        time.sleep(0.02)


@pytest.mark.slow
def test_sigkill_at_three_moments_then_resume_is_identical(reference_run, tiny_config, tmp_path) -> None:
    """kill -9 mid-observe, mid-perceive and mid-episodes; each rerun resumes; the end result equals the reference."""
    ref, _ = reference_run
    run = tmp_path / "run"
    sdir = run / "scenes/apt_0000"
    vdir = sdir / "variants/apt_0000_v000"
    # Kill as soon as the marker appears: the next stage is then running.
    moments = [sdir / "convert/.done.json", sdir / "observe/.done.json", vdir / "place/.done.json"]
    kept: dict[str, int] = {}
    args = [sys.executable, "-m", "sdovon_mj.cli", *generate_args(run, tiny_config)]
    for marker in moments:
        assert not marker.exists()  # three distinct moments: this stage had not finished at the last kill
        proc = subprocess.Popen(args, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)
        try:
            _wait_for(marker, proc)
            time.sleep(0.3)
        finally:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        assert proc.returncode == -signal.SIGKILL
        now = markers(run)
        for key, mtime in kept.items():  # stages finished before an earlier kill were not redone
            assert now.get(key) == mtime, key
        kept = now
        assert not (run / "manifest.json").exists()  # the run never got to its end
    proc = cli(*generate_args(run, tiny_config))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    final = markers(run)
    for key, mtime in kept.items():
        assert final[key] == mtime, f"{key} recomputed after the last kill"
    timings = json.loads((run / "timings.json").read_text())
    skipped = {k for t in timings["tasks"] for k in t["skipped"]}
    assert {"objects", "scenes/apt_0000/convert", "scenes/apt_0000/observe",
            "scenes/apt_0000/variants/apt_0000_v000/place"} <= skipped
    assert "episodes" in timings["stage_seconds"]  # the stage killed last ran to its end now
    assert not list(run.rglob(".*.tmp"))
    assert_same_outputs(run, ref)


@pytest.mark.slow
def test_ray_executor_matches_process_pool(reference_run, tiny_config, tmp_path) -> None:
    """`--executor ray` on a local Ray cluster (2 CPUs, started by the command) writes the reference bytes."""
    pytest.importorskip("ray")
    ref, _ = reference_run
    run = tmp_path / "ray"
    proc = cli(*generate_args(run, tiny_config, "--executor", "ray", "--jobs", "2"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    timings = json.loads((run / "timings.json").read_text())
    assert timings["stage_seconds"]["perceive"] > 0  # computed on Ray workers, not copied
    assert_same_outputs(run, ref)


@pytest.mark.slow
def test_workers_over_their_memory_limit_hand_on_to_fresh_processes(reference_run, tiny_config, tmp_path) -> None:
    """With a memory limit every process exceeds (1 MiB) and one job, the command runs its first task itself, then
    hands every later task to worker processes; each task goes on in a fresh process after every stage and each
    worker is replaced after each task (`LocalExecutor`): the run writes the reference bytes all the same."""
    ref, _ = reference_run
    run = tmp_path / "fresh"
    proc = cli(*generate_args(run, tiny_config, "--jobs", "1", "--worker-memory", "1"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    handed_on = [line for line in proc.stderr.splitlines() if "went on in a fresh process" in line]
    # every scene stage after the first of the scene task, and the episodes stage of each variant
    assert any(": perceive" in line or ", perceive" in line for line in handed_on), proc.stderr[-3000:]
    assert any("episodes went on" in line for line in handed_on), proc.stderr[-3000:]
    assert_same_outputs(run, ref)
