"""Multi-scene inputs as users own them: a Habitat scene dataset config (scene instances sharing one stage and its
object templates, written from the default world: `support.datasets`), an HM3D dataset config whose scenes
are its stages, folders of such scenes, and the folders `sdovon-mj convert` writes (the root or one scene's).
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import pytest

from assets_convert import habitat
from assets_convert.plugin import MeshConverter
from assets_convert.scene import check_scene, convert_scene
from sdovon_mj.config import RunConfig
from sdovon_mj.errors import InputError, InputsError
from sdovon_mj.inputs import check_inputs
from sdovon_mj.stages import expand_scene_inputs, name_scenes, select_scenes
from support.datasets import write_scene_dataset
from sdovon_mj.world import generate_apartment, write_apartment

from test_generate import cli

# the least observation that still walks the whole observe stage (convert, floors, navmap, coverage, renders)
TINY_OBSERVE = ["--set", "observe.width=64", "--set", "observe.height=48", "--set", "observe.yaw_steps=2",
                "--set", "observe.pitch_angles=[-30.0]", "--set", "observe.camera_heights=[]"]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """house_a, house_b, house_c over one stage and one set of object templates, and house_broken."""
    return write_scene_dataset(tmp_path_factory.mktemp("ds") / "apt_dataset", scenes=3, broken=True)


def _scene(dataset: Path, name: str) -> Path:
    return dataset.parent / "scenes" / f"{name}.scene_instance.json"


def test_a_dataset_config_is_each_of_its_scenes(dataset: Path) -> None:
    conv = MeshConverter()
    names = ["house_a", "house_b", "house_broken", "house_c"]
    assert conv.scene_files(dataset) == [_scene(dataset, n) for n in names]
    assert conv.scene_files(dataset.parent) == [_scene(dataset, n) for n in names]  # the dataset's folder: the same
    expanded = expand_scene_inputs([str(dataset)], RunConfig())
    assert list(name_scenes(expanded)) == names
    assert select_scenes(names, ["house_[ab]", "*broken"]) == ["house_a", "house_b", "house_broken"]
    with pytest.raises(InputError, match="'kitchen\\*' matches no scene.*house_a"):
        select_scenes(names, ["house_a", "kitchen*"])
    # each scene instance finds the config that registers it, and with it the shared stage and templates
    assert habitat.dataset_of(_scene(dataset, "house_c")) == dataset
    files = habitat.scene_files(_scene(dataset, "house_c"))
    assert dataset in files and any(f.name.endswith(".stage_config.json") for f in files)


def test_shared_stage_and_templates_are_read_once_and_textures_encoded_once(dataset: Path, tmp_path: Path) -> None:
    """Three scenes over one stage and one set of object templates: each render asset is parsed once in this process
    (scenes of a dataset, and instances of a template in a scene, reuse it) and each texture encoded once (the three
    converted scenes' PNGs of the shared stage are one file, hard links of the texture cache)."""
    habitat._TEMPLATES.clear()
    habitat.TEMPLATE_LOADS.clear()
    assets = []
    for name in ("house_a", "house_b", "house_c"):
        assets.append(convert_scene(_scene(dataset, name), tmp_path / "out", cache_dir=tmp_path / "cache"))
    loads = habitat.TEMPLATE_LOADS
    used = set()
    for name in ("house_a", "house_b", "house_c"):
        doc = json.loads(_scene(dataset, name).read_text())
        used |= {(dataset.parent / t["template_name"]).with_name(Path(t["template_name"]).name.replace(
            ".object_config.json", ".glb").replace(".stage_config.json", ".glb")).resolve()
            for t in [doc["stage_instance"]] + doc["object_instances"]}
    assert len(loads) == len(set(loads)), "a render asset was parsed twice"
    assert {Path(p) for p in loads} == used
    assert len(assets[0].instances) > max(len(assets[1].instances), len(assets[2].instances))  # house_a has all
    pngs = [sorted((tmp_path / "out" / "scenes" / a.name / "assets").glob("*.png")) for a in assets]
    assert pngs[0], "the stage has textured materials"
    inodes = {p.stat().st_ino for scene in pngs for p in scene}
    assert len(inodes) == len({p.stat().st_ino for p in pngs[0]})  # the same files in all three scenes


def test_scene_selects_and_a_broken_scene_is_named_while_the_others_finish(dataset: Path, tmp_path: Path) -> None:
    """`--scene` patterns pick scenes of the dataset; house_broken (one template's GLB holds no triangle: its files
    exist and parse, its conversion fails) fails with its cause while house_a and house_b go through observe."""
    run = tmp_path / "run"
    proc = cli("observe", str(run), "--scenes", str(dataset), "--scene", "house_[ab]", "--scene", "*broken",
               *TINY_OBSERVE, "--quiet")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    fails = [ln for ln in proc.stderr.splitlines() if ln.startswith("failed: ")]
    assert len(fails) == 1 and fails[0].startswith("failed: house_broken: "), proc.stderr
    assert "broken_points.glb" in fails[0] and "no triangles" in fails[0], fails[0]
    for name in ("house_a", "house_b"):
        assert (run / "scenes" / name / "observe" / "navmap_0.json").is_file(), name
    assert not (run / "scenes" / "house_c").exists()  # not selected
    manifest = json.loads((run / "manifest.json").read_text())
    assert [f["task"] for f in manifest["failures"]] == ["house_broken"]
    assert len(json.loads((run / "inputs.json").read_text())["scenes"]) == 4  # the run knows every scene


def test_missing_referenced_file_is_an_input_error_before_any_work(dataset: Path, tmp_path: Path) -> None:
    ds = shutil.copytree(dataset.parent, tmp_path / "ds") / dataset.name
    first = json.loads(_scene(ds, "house_a").read_text())["object_instances"][0]["template_name"]
    glb = (ds.parent / first).with_name(Path(first).name.replace(".object_config.json", ".glb"))
    glb.unlink()  # object 0: placed in house_a and house_broken, left out of house_b and house_c
    t0 = time.perf_counter()
    with pytest.raises(InputsError) as err:
        check_inputs(expand_scene_inputs([str(ds)], RunConfig()))
    print(f"input check of the 4-scene dataset: {time.perf_counter() - t0:.2f} s")
    named = [p for p, _c in err.value.problems]
    assert len(named) == 2 and "house_a" in named[0] and "house_broken" in named[1], err.value.problems
    assert all(glb.name in c and "not found" in c for _p, c in err.value.problems), err.value.problems
    check_inputs([str(_scene(ds, "house_b")), str(_scene(ds, "house_c"))])  # the scenes that do not use it are fine
    run = tmp_path / "run"
    proc = cli("generate", "--out", str(run), "--scenes", str(ds), "--quiet")
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "house_a" in lines[0] and glb.name in lines[0], proc.stderr
    assert not run.exists(), "the run folder was made: work began before the inputs were checked"
    # --scene limits the check to the selected scenes; a pattern that matches none is a usage error
    proc = cli("generate", "--out", str(run), "--scenes", str(ds), "--scene", "kitchen*", "--quiet")
    assert proc.returncode == 2 and "'kitchen*' matches no scene" in proc.stderr and not run.exists(), proc.stderr


def test_hm3d_dataset_config_and_its_folder_give_a_scene_per_stage(tmp_path: Path) -> None:
    """HM3D ships configs that register ``<split>/<NNNNN-id>/<id>.basis.glb`` stages by glob (one annotated, one
    plain, beside each other) and no scene instance: each stage is a scene, once."""
    root = tmp_path / "hm3d"
    for k in (0, 1):
        folder = root / "val" / f"0000{k}-apt{k}"
        glb = write_apartment(generate_apartment(k, floors=1), folder, mode="hm3d", name=f"apt{k}")
        glb.rename(folder / f"apt{k}.basis.glb")
    attrs = {"up": [0, 0, 1], "front": [0, 1, 0], "origin": [0, 0, 0]}
    semantic = {"semantic_asset": "%%CONFIG_NAME_AS_ASSET_FILENAME%%.semantic.glb",
                "semantic_descriptor_filename": "%%CONFIG_NAME_AS_ASSET_FILENAME%%.semantic.txt"}
    for name, extra in (("hm3d_annotated_basis", semantic), ("hm3d_basis", {})):
        (root / f"{name}.scene_dataset_config.json").write_text(json.dumps(
            {"stages": {"default_attributes": {**attrs, **extra}, "paths": {".glb": ["val/*/*.basis.glb"]}}}))
    want = [root / "val" / f"0000{k}-apt{k}" / f"apt{k}.basis.glb" for k in (0, 1)]
    conv = MeshConverter()
    assert conv.scene_files(root / "hm3d_annotated_basis.scene_dataset_config.json") == want
    assert conv.scene_files(root) == want  # two configs register the same stages: each scene once
    assert list(name_scenes([str(p) for p in want])) == ["apt0", "apt1"]
    assert [habitat.layout_of(p) for p in want] == ["hm3d", "hm3d"]
    check_scene(want[1])
    (want[1].parent / "apt1.semantic.txt").unlink()
    with pytest.raises(InputError, match=r"apt1\.semantic\.txt.*missing"):
        check_scene(want[1])


@pytest.mark.slow
def test_converted_folders_are_inputs_of_every_stage_command_and_generate(tmp_path: Path) -> None:
    """`sdovon-mj convert --kind scene` output, as its root or as the scene's own folder (recognised by its
    asset.json), goes into observe, perceive, semantics, place, episodes and generate; each command adds its stage
    to one run folder and reuses what the one before it made (the same scene, named by its folder)."""
    from support.artist_kitchen import write_artist_kitchen
    from test_artist_kitchen import SMALL

    glb = write_artist_kitchen(tmp_path / "in" / "kitchen.glb")
    conv = tmp_path / "conv"
    proc = cli("convert", str(glb), "--kind", "scene", "--out", str(conv), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    one = conv / "scenes" / "kitchen"
    run = tmp_path / "run"
    for stage, src in (("observe", one), ("perceive", conv), ("semantics", one), ("place", conv), ("episodes", one)):
        proc = cli(stage, str(run), "--scenes", str(src), *SMALL, "--quiet")
        assert proc.returncode == 0, (stage, proc.stderr[-2000:])
        assert f"ran: {stage}" in proc.stdout or f", {stage}" in proc.stdout, (stage, proc.stdout)
    proc = cli("generate", "--out", str(run), "--scenes", str(conv), *SMALL, "--quiet")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert json.loads((run / "inputs.json").read_text())["scenes"] == [str(one.resolve())]
    assert json.loads((run / "scenes" / "kitchen" / "variants" / "kitchen_v000" / "episodes.json").read_text())
    timings = json.loads((run / "timings.json").read_text())
    ran = {k for t in timings["tasks"] for k in t["seconds"]}
    assert not ran & {"convert", "observe", "perceive", "semantics", "place", "episodes"}, ran  # all reused
