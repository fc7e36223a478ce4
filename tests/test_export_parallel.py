"""Exports as parallel tasks: units on the pipeline's pool give the serial export's bytes, and resume per unit."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest

from sdovon_mj.config import RunConfig, dump_yaml
from sdovon_mj.export import ExportOptions, Exporter, RunView, export_run, exporter_units, make_exporter
from sdovon_mj.executors import LocalExecutor
from sdovon_mj.schedule import ExportSchedule
from support.run_folder import build_sample_run

FORMATS = ("mjcf", "habitat")


def _two_scene_run(root: Path) -> Path:
    """The sample run (scene 'room') plus a renamed copy of its scene ('hall'): two scenes, two units each."""
    run = build_sample_run(root, episodes=True, seed=0)
    src, dst = run / "scenes" / "room", run / "scenes" / "hall"
    for p in sorted(src.rglob("*")):
        if p.is_file():
            q = dst / p.relative_to(src).as_posix().replace("room", "hall")
            q.parent.mkdir(parents=True, exist_ok=True)
            q.write_text(p.read_text(encoding="utf-8").replace("room", "hall"), encoding="utf-8")
    (run / "config.yaml").write_text(dump_yaml(RunConfig()), encoding="utf-8")
    return run


def _tree(folder: Path) -> dict[str, str]:
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _parallel(run: Path, jobs: int) -> list:
    """Run the exports the way `generate` schedules them (all variants already done) on a local pool."""
    sched = ExportSchedule(str(run), list(FORMATS), RunConfig(), [], [])
    return LocalExecutor(jobs=jobs, retries=0).map(sched.ready(), follow=sched.follow)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    return _two_scene_run(tmp_path_factory.mktemp("run2"))


def test_units_are_declared_per_scene(run_dir):
    view = RunView(run_dir)
    mj = exporter_units(make_exporter("mjcf"), view, ExportOptions())
    assert [(u.key, u.scenes) for u in mj] == [("hall", ("hall",)), ("room", ("room",))]
    hab = exporter_units(make_exporter("habitat"), view, ExportOptions())
    assert [u.key for u in hab] == ["hall", "room", "_objects"] and all(u.scenes is None for u in hab)

    class OneShot(Exporter):  # a plugin without units: one task, as before
        name = "oneshot"

    assert exporter_units(OneShot(), view, ExportOptions()) is None


def test_parallel_export_equals_serial_and_resumes_per_unit(run_dir, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(run_dir, run)
    serial = {}
    for fmt in FORMATS:
        rep = export_run(run, fmt, tmp_path / f"serial_{fmt}", name="sdovon", split="val")
        assert rep.variants == ["hall_v000", "room_v000"], rep.variants
        serial[fmt] = _tree(tmp_path / f"serial_{fmt}")
    results = _parallel(run, jobs=2)
    assert all(r.ok for r in results), [r.error for r in results if not r.ok]
    labels = [r.spec.label for r in results]
    assert labels.index("export:mjcf") > max(labels.index("export:mjcf/hall"), labels.index("export:mjcf/room"))
    assert labels.index("export:habitat") > labels.index("export:habitat/_objects")
    for fmt in FORMATS:
        assert _tree(run / "export" / fmt) == serial[fmt], fmt
    # The MJCF bundles of both scenes share one copy of the mug mesh.
    assert (run / "export/mjcf/sdovon/assets/objects/mug_a/mug.obj").is_file()
    assert not list((run / "export/mjcf/sdovon").glob("*_v000/assets"))

    # Killed mid-export: one unit's marker and files gone, the finishing step not done; the resume redoes only those.
    (run / "export/mjcf.stage/.done.json").unlink()
    shutil.rmtree(run / "export/mjcf.units/room")
    shutil.rmtree(run / "export/mjcf/sdovon/room_v000")
    (run / "export/mjcf/sdovon/index.json").unlink()
    again = _parallel(run, jobs=1)
    by = {r.spec.label: r for r in again}
    assert by["export:mjcf/hall"].skipped == ["export/mjcf.units/hall"]  # finished before: not redone
    assert by["export:mjcf/room"].seconds and not by["export:mjcf/room"].skipped
    assert by["export:mjcf"].seconds and by["export:habitat"].skipped == ["export/habitat.stage"]
    for fmt in FORMATS:
        assert _tree(run / "export" / fmt) == serial[fmt], fmt

    # A file left over from an earlier export that no unit writes now is removed by the finishing step.
    stray = run / "export/mjcf/sdovon/old_v009/scene.xml"
    stray.parent.mkdir(parents=True)
    stray.write_text("<mujoco/>")
    (run / "export/mjcf.stage/.done.json").unlink()
    assert all(r.ok for r in _parallel(run, jobs=1))
    assert not stray.parent.exists() and _tree(run / "export/mjcf") == serial["mjcf"]
