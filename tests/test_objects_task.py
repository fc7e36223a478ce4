"""The pipeline's object-library task: conversions in convert_tree's pool, failures reported, the rest kept."""

from __future__ import annotations

import json

import trimesh

from sdovon_mj import stages
from sdovon_mj.records import ObjectAsset, load_json
from sdovon_mj.config import ConvertConfig, RunConfig
from sdovon_mj.pipeline import StageRunner, TaskResult, TaskSpec, prepare_run


def test_bad_object_is_reported_and_the_library_goes_on(tmp_path):
    good = tmp_path / "in" / "box" / "model.obj"
    good.parent.mkdir(parents=True)
    good.write_text(trimesh.creation.box(extents=(0.1, 0.08, 0.05)).export(file_type="obj"))
    bad = tmp_path / "in" / "broken" / "model.obj"
    bad.parent.mkdir(parents=True)
    bad.write_text("v 0 0\nf 1 2 3\n")  # a vertex with two coordinates
    cfg = RunConfig(convert=ConvertConfig(jobs=2))
    store = prepare_run(tmp_path / "run", cfg, None, [str(good), str(bad)])
    result = TaskResult(spec=TaskSpec(kind="objects", run_root=str(store.root)), ok=True)
    stages.run_task(store, cfg, StageRunner(store, result), "run")
    failures = json.loads(store.path("objects/failures.json").read_text())
    assert list(failures) == [str(bad)], failures
    print(failures[str(bad)])
    assert failures[str(bad)], failures  # the cause is given
    assets = load_json(store.path("objects/objects.json"), ObjectAsset)
    assert [a.name for a in assets] == ["box"]
    assert store.path(assets[0].mjcf).exists()
    assert not list(store.root.glob("convert_report.json"))  # the batch report stays out of the run folder
    # a rerun skips the finished task
    again = TaskResult(spec=result.spec, ok=True)
    stages.run_task(store, cfg, StageRunner(store, again), "run")
    assert again.skipped == ["objects"]
