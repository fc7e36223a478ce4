"""Reliability: bad inputs fail fast and clearly, one writer per run folder, verified resume, faults on purpose.

One uninterrupted `sdovon-mj generate` of a tiny config (one default-world apartment, apple and book, 160x120
images, k_v=1) is the reference. Each fault test works on a copy of it in which some stages are unfinished
(their done-markers removed) or damaged, injects its fault, checks the message, then resumes and compares
every byte with the reference (timing files aside). Faults that need the pipeline's own process (a full
disk, a read-only folder) run `generate` in this process with a patched system call.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_generate import _wait_for as wait_for  # the run-folder helpers of the generate tests: one home
from test_generate import TINY_YAML, assert_same_outputs, cli, snapshot

REPO = Path(__file__).resolve().parents[1]
# test_generate's tiny run with two cheap object categories and its image size in the file
TINY = (TINY_YAML.replace("object_categories: [can, remote, book, apple]", "object_categories: [apple, book]")
        .replace("observe:\n", "observe:\n  width: 160\n  height: 120\n"))
assert "[apple, book]" in TINY and "width: 160" in TINY, "test_generate.TINY_YAML changed shape"
SCENE = "scenes/apt_0000"
VARIANT = f"{SCENE}/variants/apt_0000_v000"


def popen(*args: str) -> subprocess.Popen:
    """Start `sdovon-mj ARGS` in its own process group; stderr is captured."""
    return subprocess.Popen([sys.executable, "-m", "sdovon_mj.cli", *args], cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


def unfinish(run: Path, *keys: str) -> None:
    """Remove the done-markers of these stages (the run then redoes them: same fingerprint, same bytes)."""
    for k in keys:
        (run / k / ".done.json").unlink()


LATER = (f"{VARIANT}/place", f"{VARIANT}/episodes", "export/habitat.stage", "export/mjcf.stage")


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    """The tiny config file (beside the reference run)."""
    folder = tmp_path_factory.mktemp("reliability")
    (folder / "tiny.yaml").write_text(TINY, encoding="utf-8")
    return folder / "tiny.yaml"


@pytest.fixture(scope="module")
def reference(tiny) -> Path:
    """One uninterrupted generate of the tiny config: the bytes every resumed run must end with."""
    proc = cli("generate", "--out", str(tiny.parent / "reference"), "--config", str(tiny), "--quiet")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return tiny.parent / "reference"


def start_on_copy(reference: Path, tiny: Path, run: Path, *unfinished: str) -> subprocess.Popen:
    """Copy the reference into `run` with these stages unfinished, start generate on it, return once it holds the lock."""
    copy_run(reference, run)
    unfinish(run, *unfinished)
    proc = popen("generate", "--out", str(run), "--config", str(tiny), "--quiet")
    try:
        wait_for(run / ".sdovon.lock", proc)
    except BaseException:
        os.killpg(proc.pid, signal.SIGKILL)
        raise
    return proc


def copy_run(reference: Path, dst: Path) -> Path:
    """Copy the reference run folder (files are copied, never hard-linked: damage must not reach the reference)."""
    shutil.copytree(reference, dst, copy_function=shutil.copy2)
    return dst


# ----------------------------------------------------------------------------------------------
# Bad inputs: a clear error before any work


@pytest.mark.parametrize("case", ["negative k_v", "missing scene", "empty scene", "wrong format", "empty objects folder",
                                  "zero image size", "probability above 1", "non-UTF-8 file name"])
def test_bad_input_fails_before_any_work(case: str, tmp_path: Path) -> None:
    """Each case of the issue's "Why" ends with exit code 2 and its cause named, before the run folder exists."""
    out = tmp_path / "run"
    bad = tmp_path / "in"
    bad.mkdir()
    (bad / "empty.glb").write_bytes(b"")
    (bad / "notes.glb").write_text("these are my notes, not a GLB\n", encoding="utf-8")
    (bad / "objs").mkdir()
    (bad / "objs" / "readme.txt").write_text("no meshes here\n", encoding="utf-8")
    latin1 = os.fsdecode(os.fsencode(bad) + b"/caf\xe9.glb")  # a Latin-1 name: not UTF-8
    Path(latin1).write_bytes(b"glTF\x02\x00\x00\x00")
    args, words = {
        "negative k_v": (["--set", "place.k_v=-3"], ["'place.k_v'", "-3", ">= 1"]),
        "missing scene": (["--scenes", str(tmp_path / "nothere.glb")], ["nothere.glb", "file not found"]),
        "empty scene": (["--scenes", str(bad / "empty.glb")], ["empty.glb", "empty (0 bytes)"]),
        "wrong format": (["--scenes", str(bad / "notes.glb"), str(tmp_path / "gone.obj")],
                         ["notes.glb", "is not a GLB file", "gone.obj", "file not found"]),
        "empty objects folder": (["--objects", str(bad / "objs")], ["objs", "holds no"]),
        "zero image size": (["--set", "observe.width=0"], ["'observe.width'", "0"]),
        "probability above 1": (["--set", "perceive.score_threshold=1.5"], ["'perceive.score_threshold'", "1.5"]),
        "non-UTF-8 file name": (["--scenes", latin1], ["caf\\xe9.glb", "not UTF-8", "rename"]),
    }[case]
    t0 = time.monotonic()
    proc = cli("generate", "--out", str(out), *args)
    seconds = time.monotonic() - t0
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr  # one message naming every bad input, no traceback, no follow-on errors
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not out.exists(), "the run folder was created: work started before the inputs were checked"
    print(f"{case}: exit 2 after {seconds:.2f} s")


# ----------------------------------------------------------------------------------------------
# One writer per run folder


def test_second_writer_refuses_and_first_keeps_lone_run_bytes(reference: Path, tiny: Path, tmp_path: Path) -> None:
    """Two generates into one folder: the second refuses naming the first's pid and host; the first ends as a lone run."""
    run = tmp_path / "run"
    first = start_on_copy(reference, tiny, run, f"{SCENE}/semantics", *LATER)
    try:
        second = cli("generate", "--out", str(run), "--config", str(tiny), "--quiet")
        assert first.poll() is None, "the first run ended before the second one asked: no contention was tried"
    finally:
        _, err = first.communicate(timeout=900)
    assert second.returncode == 2, second.stderr
    assert f"pid {first.pid} on host {socket.gethostname()}" in second.stderr, second.stderr
    assert first.returncode == 0, err
    assert not (run / ".sdovon.lock").exists()
    assert_same_outputs(run, reference)


def test_stale_lock_is_taken_over_with_a_note(reference: Path, tiny: Path, tmp_path: Path) -> None:
    """A lock whose process is gone (killed) is taken over; the run says so and finishes with the reference bytes."""
    run = copy_run(reference, tmp_path / "run")
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (run / ".sdovon.lock").write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname(), "started": "1"}),
                                      encoding="utf-8")
    proc = cli("generate", "--out", str(run), "--config", str(tiny), "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert f"took over a stale lock of pid {dead.pid}" in proc.stderr
    assert not (run / ".sdovon.lock").exists()
    assert_same_outputs(run, reference)


# ----------------------------------------------------------------------------------------------
# Verified resume


def test_damaged_outputs_are_reported_by_verify_and_recomputed(reference: Path, tiny: Path, tmp_path: Path) -> None:
    """A truncated npz, a hand-edited JSON and a damaged export file: verify names each, resume redoes those stages."""
    run = copy_run(reference, tmp_path / "run")
    shard = sorted((run / SCENE / "observe").glob("obs_*.npz"))[0]
    shard.write_bytes(shard.read_bytes()[: shard.stat().st_size // 2])
    eps = run / VARIANT / "episodes.json"  # edited by hand, same size: only the digest can tell
    eps.write_text(eps.read_text(encoding="utf-8").replace('"apt_0000_v000_0000"', '"apt_0000_v000_HAND"', 1), encoding="utf-8")
    mjcf_files = sorted(p for p in (run / "export/mjcf").rglob("*") if p.is_file())
    mjcf_files[0].write_bytes(mjcf_files[0].read_bytes() + b"\n")
    damaged = {f"{SCENE}/observe", f"{VARIANT}/episodes", "export/mjcf.units/apt_0000"}  # the scene's export unit

    proc = cli("verify", str(run))
    assert proc.returncode == 1, proc.stdout + proc.stderr
    reported = {ln.split()[1] for ln in proc.stdout.splitlines() if ln.startswith("DAMAGED")}
    assert reported == damaged, proc.stdout
    for p, why in ((shard, "size"), (eps, "sha256"), (mjcf_files[0], "size")):
        assert any(p.relative_to(run).as_posix() in ln and why in ln for ln in proc.stdout.splitlines()), (p, proc.stdout)

    proc = cli("generate", "--out", str(run), "--config", str(tiny), "--quiet")
    assert proc.returncode == 0, proc.stderr
    noted = {ln.split(": ")[2] for ln in proc.stderr.splitlines() if "recomputing the stage" in ln}
    assert noted == damaged, proc.stderr
    timings = json.loads((run / "timings.json").read_text(encoding="utf-8"))
    assert {"observe", "episodes", "export:mjcf"} == set(timings["stage_seconds"])  # only those ran again
    assert_same_outputs(run, reference)
    assert cli("verify", str(run), "--quiet").returncode == 0


def test_verify_refuses_a_folder_that_is_not_a_run(tmp_path: Path) -> None:
    """`verify` on a plain folder names it and says why (exit 1)."""
    proc = cli("verify", str(tmp_path))
    assert proc.returncode == 1 and str(tmp_path) in proc.stderr and "not a run folder" in proc.stderr


# ----------------------------------------------------------------------------------------------
# Signals


@pytest.mark.slow
@pytest.mark.parametrize("moment", ["semantics", "place"])
def test_sigterm_mid_stage_then_resume_is_identical(reference: Path, tiny: Path, tmp_path: Path, moment: str) -> None:
    """SIGTERM as semantics starts / as place starts: a clear message, exit 143, no lock or temp file left, the
    stages after it not done; the rerun resumes to the reference bytes."""
    run = tmp_path / "run"
    proc = start_on_copy(reference, tiny, run, f"{SCENE}/semantics", *LATER)
    try:
        if moment == "place":
            wait_for(run / SCENE / "semantics/.done.json", proc)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert "stopped by SIGTERM" in err and "run the same command again to resume" in err, err
    assert not (run / ".sdovon.lock").exists() and not list(run.rglob(".*.tmp"))
    assert not (run / "export/mjcf.stage/.done.json").exists()  # it stopped before the end
    again = cli("generate", "--out", str(run), "--config", str(tiny), "--quiet")
    assert again.returncode == 0, again.stderr
    assert_same_outputs(run, reference)


@pytest.mark.slow
@pytest.mark.parametrize("moment", ["habitat", "mjcf"])
def test_sigkill_during_an_exporter_then_resume_is_identical(reference: Path, tiny: Path, tmp_path: Path,
                                                             moment: str) -> None:
    """kill -9 while an exporter writes; the resume takes over the dead run's lock and ends with the reference bytes."""
    run = copy_run(reference, tmp_path / "run")
    unfinish(run, *LATER[2:])
    for fmt in ("habitat", "mjcf"):
        shutil.rmtree(run / "export" / fmt)
    # the habitat exporter is writing once its folder appears; mjcf's once habitat's marker is written
    signal_at = run / "export/habitat" if moment == "habitat" else run / "export/habitat.stage/.done.json"
    proc = popen("generate", "--out", str(run), "--config", str(tiny), "--quiet")
    try:
        wait_for(signal_at, proc)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
    assert proc.returncode == -signal.SIGKILL
    assert not (run / f"export/{moment}.stage/.done.json").exists()
    again = cli("generate", "--out", str(run), "--config", str(tiny), "--quiet")
    assert again.returncode == 0, again.stderr
    assert f"took over a stale lock of pid {proc.pid}" in again.stderr
    assert not list(run.rglob(".*.tmp"))
    assert_same_outputs(run, reference)


# ----------------------------------------------------------------------------------------------
# Write failures (in this process, with a patched system call)


@pytest.mark.parametrize("err", [errno.ENOSPC, errno.EROFS])
def test_write_failure_mid_stage_is_reported_then_resume_is_identical(reference: Path, tiny: Path, tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch, err: int) -> None:
    """Disk full / read-only while episodes.json is written: the cause names the file, the exports are reported as
    not run because of it (one root cause), no temp file stays; with the fault gone the resume equals the reference."""
    from sdovon_mj.config import load_config
    from sdovon_mj.pipeline import generate

    run = copy_run(reference, tmp_path / "run")
    unfinish(run, *LATER)
    real_fsync = os.fsync

    def failing_fsync(fd: int) -> None:
        if os.readlink(f"/proc/self/fd/{fd}").rsplit("/", 1)[-1].startswith(".episodes.json."):
            raise OSError(err, os.strerror(err))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", failing_fsync)
    cfg = load_config(tiny)
    summary = generate(run, cfg, progress=False)
    roots = summary.root_failures
    assert [r.spec.label for r in roots] == ["apt_0000/v000"]
    assert os.strerror(err) in roots[0].error and str(run / VARIANT / "episodes.json") in roots[0].error, roots[0].error
    follow = [r for r in summary.failures if r.caused_by]
    assert sorted(r.spec.label for r in follow) == ["export:habitat", "export:mjcf"]
    assert all(r.caused_by == "apt_0000/v000" for r in follow)
    assert "not run because of the failures above: export:habitat, export:mjcf" in summary.table()
    assert not list(run.rglob(".*.tmp")) and not (run / ".sdovon.lock").exists()

    monkeypatch.setattr(os, "fsync", real_fsync)
    again = generate(run, cfg, progress=False)
    assert not again.failures
    assert_same_outputs(run, reference)


def test_unwritable_run_folder_is_named(tmp_path: Path, tiny: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A run folder that cannot be written (read-only file system) is named with the cause before any work."""
    from sdovon_mj.config import load_config
    from sdovon_mj.errors import InputError
    from sdovon_mj.pipeline import generate

    real_open = os.open

    def ro_open(path, flags, *a, **kw):  # noqa: ANN001 - os.open's own signature
        if str(path).startswith(str(tmp_path)) and flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))
        return real_open(path, flags, *a, **kw)

    monkeypatch.setattr(os, "open", ro_open)
    with pytest.raises(InputError, match="cannot write to the run folder.*Read-only file system") as e:
        generate(tmp_path / "run", load_config(tiny), progress=False)
    assert str(tmp_path / "run") in str(e.value)


# ----------------------------------------------------------------------------------------------
# Damaged caches


def converted(out: Path) -> dict[str, str]:
    """Return the digests of a conversion's files."""
    return snapshot(out / "objects")


@pytest.mark.parametrize("damage", ["truncated file", "asset.json not JSON", "record gone"])
def test_corrupt_converter_cache_entry_is_discarded_and_converted_again(tmp_path: Path, damage: str) -> None:
    """A cache entry whose files no longer match its record is never linked out: the object is converted again,
    to the same bytes, and the entry is stored anew."""
    from assets_convert import cache
    from assets_convert.object import convert_object_report
    from sdovon_mj.world import write_object_library

    src = write_object_library(0, tmp_path / "lib", variants=1, categories=["book"])[0]
    store = tmp_path / "cache"
    first, info = convert_object_report(src, tmp_path / "a", cache_dir=store)
    assert not info.get("cache_hit", False)
    entry = next(p for p in store.iterdir() if not p.name.startswith("."))
    assert not cache.entry_problem(entry)
    assert not (tmp_path / "a/objects" / first.name / cache.ENTRY).exists()  # the record stays in the cache
    if damage == "truncated file":
        victim = entry / "model.xml"
        victim.write_bytes(victim.read_bytes()[:100])
    elif damage == "asset.json not JSON":
        (entry / "asset.json").write_bytes(b"\xff\xfe not json")
    else:
        (entry / cache.ENTRY).unlink()
    assert cache.entry_problem(entry)
    second, info2 = convert_object_report(src, tmp_path / "b", cache_dir=store)
    assert not info2.get("cache_hit", False)  # converted again, not linked from the damaged entry
    assert converted(tmp_path / "b") == converted(tmp_path / "a")
    assert not cache.entry_problem(entry)  # stored anew
    third, info3 = convert_object_report(src, tmp_path / "c", cache_dir=store)
    assert info3["cache_hit"] and (second.name, second.content_hash) == (third.name, third.content_hash)  # repaired entry
    assert converted(tmp_path / "c") == converted(tmp_path / "a")


def test_zero_byte_texture_is_named_and_the_rest_of_the_library_converts(tmp_path: Path) -> None:
    """An OBJ whose MTL names a 0-byte texture fails with that texture named; the other objects still convert."""
    from sdovon_mj.config import ConvertConfig
    from sdovon_mj.stages import converter
    from sdovon_mj.world import write_object_library

    good = write_object_library(0, tmp_path / "lib", variants=1, categories=["apple"])[0]
    box = tmp_path / "bad" / "box.obj"
    box.parent.mkdir()
    corners = [(x, y, z) for z in (0, 0.1) for y in (0, 0.1) for x in (0, 0.1)]
    quads = [(1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (2, 6, 8, 4), (4, 8, 7, 3), (3, 7, 5, 1)]
    box.write_text("mtllib box.mtl\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in corners)
                   + "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl m\n"
                   + "".join("f " + " ".join(f"{v}/{k + 1}" for k, v in enumerate(q)) + "\n" for q in quads), encoding="utf-8")
    (box.parent / "box.mtl").write_text("newmtl m\nKd 1 1 1\nmap_Kd empty.png\n", encoding="utf-8")
    (box.parent / "empty.png").write_bytes(b"")
    assets, failures = converter().convert_library([(good, "apple"), (box, "box")], tmp_path / "out",
                                                       ConvertConfig(jobs=1))
    assert [a.category for a in assets] == ["apple"]
    assert list(failures) == [str(box)] and "texture file 'empty.png' referenced by box.mtl is empty (0 bytes)" in failures[str(box)]


# Every stage and exporter of the tiny run, in the order a run finishes them (the tiny config has one variant).
ALL_STAGES = ("inputs/objects", "objects", "inputs/scenes/apt_0000", f"{SCENE}/convert", f"{SCENE}/observe",
              f"{SCENE}/perceive", f"{SCENE}/semantics", f"{VARIANT}/place", f"{VARIANT}/episodes",
              "export/habitat.units/apt_0000", "export/habitat.units/_objects", "export/mjcf.units/apt_0000",
              "export/habitat.stage", "export/mjcf.stage")  # export units (schedule.ExportSchedule), then finishing


@pytest.mark.slow
def test_a_signal_in_every_stage_and_exporter_then_resume_is_identical(reference: Path, tiny: Path,
                                                                        tmp_path: Path) -> None:
    """One run is stopped once in each stage and exporter in turn, SIGTERM and SIGKILL alternating: each time the
    signal comes as that stage starts (the one before it has just written its marker); every restart resumes
    from what is finished, and the run ends with the reference bytes.

    A SIGTERM ends with exit 143 and the resume message; a SIGKILL leaves a stale lock the next start takes over.
    A stage so short that it finishes before the signal lands is simply done: what is asserted is the way out
    (exit status, message) and the final bytes.
    """
    assert sorted(str(p.parent.relative_to(reference)) for p in reference.rglob(".done.json")) == sorted(ALL_STAGES)
    run = copy_run(reference, tmp_path / "run")
    unfinish(run, *ALL_STAGES)
    for k, stage in enumerate(ALL_STAGES):
        sig = signal.SIGTERM if k % 2 == 0 else signal.SIGKILL
        proc = popen("generate", "--out", str(run), "--config", str(tiny), "--quiet")
        try:
            wait_for(run / ".sdovon.lock" if k == 0 else run / ALL_STAGES[k - 1] / ".done.json", proc)
            if sig == signal.SIGKILL:
                os.killpg(proc.pid, sig)
            else:
                proc.send_signal(sig)
            _, err = proc.communicate(timeout=300)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.communicate()
        if sig == signal.SIGTERM and proc.returncode != 0:  # 0: the whole run was done before the signal landed
            assert proc.returncode == 128 + signal.SIGTERM, (stage, err)
            assert "run the same command again to resume" in err, (stage, err)
        elif sig == signal.SIGKILL:
            assert proc.returncode == -signal.SIGKILL, stage
    again = cli("generate", "--out", str(run), "--config", str(tiny), "--quiet")
    assert again.returncode == 0, again.stderr
    assert not (run / ".sdovon.lock").exists() and not list(run.rglob(".*.tmp"))
    assert_same_outputs(run, reference)


@pytest.mark.slow
def test_a_scene_of_a_million_tiny_triangles_ends_clearly_and_resumes(tiny: Path, tmp_path: Path) -> None:
    """A 10 m x 5 m floor of 1,000,000 triangles (1 cm cells) with one box on it: the run converts, observes and
    ends with the empty-run warning (nothing there is a receptacle) and exit 1; a rerun finds every stage done
    and leaves the same bytes."""
    import trimesh

    nx, ny = 1000, 500
    xs, ys = np.meshgrid(np.linspace(0.0, 10.0, nx + 1), np.linspace(0.0, 5.0, ny + 1))
    v = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], 1)
    i = (np.arange(ny)[:, None] * (nx + 1) + np.arange(nx)[None, :]).ravel()
    f = np.concatenate([np.stack([i, i + 1, i + nx + 2], 1), np.stack([i, i + nx + 2, i + nx + 1], 1)])
    floor = trimesh.Trimesh(v, f, process=False)
    box = trimesh.creation.box(extents=(0.8, 0.5, 0.7))
    box.apply_translation((5.0, 2.5, 0.35))
    scene = tmp_path / "million.ply"
    trimesh.util.concatenate([floor, box]).export(scene)
    assert len(f) == 1_000_000
    run = tmp_path / "run"
    first = cli("generate", "--out", str(run), "--config", str(tiny), "--scenes", str(scene), "--quiet", timeout=1200)
    assert first.returncode == 1, first.stderr
    assert "empty result" in first.stderr and "--allow-empty" in first.stderr, first.stderr
    before = snapshot(run)
    again = cli("generate", "--out", str(run), "--config", str(tiny), "--scenes", str(scene), "--quiet",
                "--allow-empty", timeout=1200)
    assert again.returncode == 0, again.stderr
    after = snapshot(run)
    assert {k: v for k, v in after.items() if k != "manifest.json"} == {k: v for k, v in before.items()
                                                                        if k != "manifest.json"}


def test_replacing_a_converted_folder_removes_what_killed_processes_left_beside_it(tmp_path: Path) -> None:
    """A SIGKILL between the two renames of `replace_dir` (or during a build in a scratch folder) leaves a dot-folder
    beside the target; the next replace of that target removes those of dead processes, never a live one's."""
    from assets_convert.cache import replace_dir, scratch_dir

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    target = tmp_path / "scenes" / "apt_0000"
    target.mkdir(parents=True)
    stale = [tmp_path / "scenes" / f".apt_0000.old.{dead.pid}", tmp_path / "scenes" / f".apt_0000.tmp.{dead.pid}.x1"]
    live = tmp_path / "scenes" / f".apt_0000.tmp.{os.getppid()}.x2"  # the test runner's parent: alive
    other = tmp_path / "scenes" / f".apt_0001.old.{dead.pid}"  # another target's: not this replace's business
    for p in stale + [live, other]:
        p.mkdir()
        (p / "asset.json").write_text("{}", encoding="utf-8")
    tmp = scratch_dir(target)
    (tmp / "asset.json").write_text('{"new": 1}', encoding="utf-8")
    replace_dir(tmp, target)
    assert (target / "asset.json").read_text(encoding="utf-8") == '{"new": 1}'
    assert not any(p.exists() for p in stale) and live.exists() and other.exists()
    assert sorted(p.name for p in (tmp_path / "scenes").iterdir()) == sorted(["apt_0000", live.name, other.name])
