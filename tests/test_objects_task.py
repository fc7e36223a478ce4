"""The pipeline's object-library task: conversions in convert_tree's pool, failures reported, the rest kept."""

from __future__ import annotations

import json

import trimesh

from sdovon_mj import stages
from sdovon_mj.records import ObjectAsset, load_json
from sdovon_mj.config import ConvertConfig, RunConfig
from sdovon_mj.pipeline import prepare_run
from sdovon_mj.tasks import StageRunner, TaskResult, TaskSpec


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


def test_urdf_objects_in_a_library_folder(tmp_path):
    """A library folder's URDF is one object (generate took its link mesh as an object and refused a .urdf file)."""
    from sdovon_mj.inputs import check_inputs

    lib = tmp_path / "lib"
    box = lib / "box" / "model.obj"
    box.parent.mkdir(parents=True)
    box.write_text(trimesh.creation.box(extents=(0.1, 0.08, 0.05)).export(file_type="obj"))
    blob = lib / "toy" / "blob" / "blob.urdf"
    blob.parent.mkdir(parents=True)
    (blob.parent / "blob.obj").write_text(trimesh.creation.box(extents=(0.06, 0.05, 0.04)).export(file_type="obj"))
    blob.write_text('<robot name="blob"><link name="base"><inertial><mass value="0.1"/>'
                    '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="0"/></inertial>'
                    '<visual><geometry><mesh filename="blob.obj"/></geometry></visual>'
                    '<collision><geometry><mesh filename="blob.obj"/></geometry></collision></link></robot>')
    (lib / "toy" / "duck").mkdir(parents=True)
    (lib / "toy" / "duck" / "duck.dae").write_text("<COLLADA/>")  # a format the converter does not read
    check_inputs(objects=[str(lib)])
    check_inputs(objects=[str(blob)])  # a URDF named on its own is an object too
    cfg = RunConfig(convert=ConvertConfig(jobs=1))
    store = prepare_run(tmp_path / "run", cfg, None, [str(lib)])
    result = TaskResult(spec=TaskSpec(kind="objects", run_root=str(store.root)), ok=True)
    stages.run_task(store, cfg, StageRunner(store, result), "run")
    failures = json.loads(store.path("objects/failures.json").read_text())
    assert list(failures) == [str(lib / "toy" / "duck" / "duck.dae")], failures  # listed, not passed over
    assert "unsupported format '.dae'" in failures[str(lib / "toy" / "duck" / "duck.dae")]
    from sdovon_mj.commands.generate import library_warnings

    assert [line for line in library_warnings(str(store.root)) if "duck.dae" in line and "left out" in line]
    assets = load_json(store.path("objects/objects.json"), ObjectAsset)
    assert sorted(a.name for a in assets) == ["blob", "box"]  # the URDF's link mesh is not an object of its own
    # categories: lib/box/model.obj is a box (its grandparent is the library folder), lib/toy/blob/blob.urdf a toy
    assert sorted((a.name, a.category) for a in assets) == [("blob", "toy"), ("box", "box")]
    urdf_asset = next(a for a in assets if a.name == "blob")
    assert urdf_asset.mass == 0.1 and store.path(urdf_asset.mjcf).exists()
    # a rerun of the finished task skips it; a file of another format added to the library folder is noticed
    again = TaskResult(spec=result.spec, ok=True)
    stages.run_task(store, cfg, StageRunner(store, again), "run")
    assert again.skipped == ["objects"]
    (lib / "toy" / "duck" / "duck.fbx").write_bytes(b"Kaydara FBX Binary  \x00")
    third = TaskResult(spec=result.spec, ok=True)
    stages.run_task(store, cfg, StageRunner(store, third), "run")
    assert third.skipped == []
    assert str(lib / "toy" / "duck" / "duck.fbx") in json.loads(store.path("objects/failures.json").read_text())


def test_generate_and_convert_give_an_object_one_category(tmp_path):
    """assets.yaml (the user's word) wins over a dataset's meta.json in `convert`; `generate --objects` read meta.json
    first, so one library gave two categories. Both ask the converter now, for a library folder and a single file."""
    from assets_convert.tree import convert_tree

    lib = tmp_path / "lib"
    obj = lib / "7128" / "model.obj"
    obj.parent.mkdir(parents=True)
    obj.write_text(trimesh.creation.box(extents=(0.1, 0.08, 0.05)).export(file_type="obj"))
    (obj.parent / "meta.json").write_text(json.dumps({"category": "StorageFurniture"}))
    (obj.parent / "assets.yaml").write_text("category: tea_box\n")
    report = convert_tree([lib], tmp_path / "out", jobs=1, progress=False, cache_dir="off")
    assert [r["category"] for r in report["items"]] == ["tea_box"]
    cfg = RunConfig(convert=ConvertConfig(jobs=1))
    for inputs, run in (([str(lib)], "run"), ([str(obj)], "run_file")):
        store = prepare_run(tmp_path / run, cfg, None, inputs)
        stages.run_task(store, cfg, StageRunner(store, TaskResult(TaskSpec(kind="objects", run_root=str(store.root)),
                                                                  ok=True)), "run")
        assert [a.category for a in load_json(store.path("objects/objects.json"), ObjectAsset)] == ["tea_box"], run
    (obj.parent / "assets.yaml").unlink()  # without the user's word, the dataset's meta.json names it
    store = prepare_run(tmp_path / "run_meta", cfg, None, [str(lib)])
    stages.run_task(store, cfg, StageRunner(store, TaskResult(TaskSpec(kind="objects", run_root=str(store.root)),
                                                              ok=True)), "run")
    assert [a.category for a in load_json(store.path("objects/objects.json"), ObjectAsset)] == ["StorageFurniture"]


def test_the_library_conversion_shows_objects_done_of_total_with_an_eta(tmp_path, capfd):
    """The objects task prints a progress line per object here (three objects: every one is a tenth or more), the
    last one done of total; the lines before it carry an ETA. Inside a quiet bar (``generate --quiet``) it is silent."""
    from sdovon_mj.progress import Progress

    lib = tmp_path / "lib"
    for k, ext in enumerate(((0.1, 0.08, 0.05), (0.06, 0.06, 0.12), (0.2, 0.1, 0.02))):
        p = lib / f"box{k}" / "model.obj"
        p.parent.mkdir(parents=True)
        p.write_text(trimesh.creation.box(extents=ext).export(file_type="obj"))
    cfg = RunConfig(convert=ConvertConfig(jobs=1))
    for run, quiet in (("run", False), ("quiet", True)):
        store = prepare_run(tmp_path / run, cfg, None, [str(lib)])
        capfd.readouterr()
        with Progress(1, enabled=False if quiet else None):
            stages.run_task(store, cfg, StageRunner(store, TaskResult(TaskSpec(kind="objects", run_root=str(store.root)),
                                                                      ok=True)), "run")
        lines = [ln for ln in capfd.readouterr().err.splitlines() if ln.startswith("[convert objects]")]
        if quiet:
            assert lines == []
            continue
        assert [ln.split()[2] for ln in lines] == ["1/3", "2/3", "3/3"], lines
        assert all("ETA" in ln for ln in lines[:-1]) and "ETA" not in lines[-1], lines
        assert sorted(ln.split(")")[-1].strip() for ln in lines) == [f"box{k}/model.obj" for k in range(3)], lines
