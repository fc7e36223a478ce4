"""Habitat-native scene inputs: HM3D-Semantics and Habitat scene datasets, written by the world writers and the
MIT-licensed habitat-sim test datasets (../shared/assets/habitat_fixtures); round trips against the clean layout."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh

import mujoco

from assets_convert import convert_scene
from assets_convert.habitat import HAB_TO_MJ, layout_of, read_semantic_txt
from assets_convert.tree import find_inputs
from sdovon_mj.errors import InputError
from sdovon_mj.records import SceneAsset
from sdovon_mj.world import generate_apartment
from sdovon_mj.world.io import semantic_colour, write_apartment

MM = 1e-3  # the round-trip tolerance the issue states (1 mm)


@pytest.fixture(scope="module")
def layouts(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, SceneAsset]]:
    """Default apartment 0 written in the clean, hm3d, mp3d and habitat layouts and converted (no cache)."""
    root = tmp_path_factory.mktemp("layouts")
    apt = generate_apartment(0)
    out = {}
    for mode in ("clean", "hm3d", "mp3d", "habitat"):
        path = write_apartment(apt, root / mode, mode, "apt")
        out[mode] = (path, convert_scene(path, root / f"out_{mode}", cache_dir="off"))
    return out


def _by_id(asset: SceneAsset) -> dict[int, object]:
    return {i.id: i for i in asset.instances}


def test_hm3d_layout_files_and_detection(layouts: dict) -> None:
    path, _asset = layouts["hm3d"]
    assert layout_of(path) == "hm3d" and layout_of(layouts["clean"][0]) is None
    assert not (path.parent / "apt.semantics.json").exists()  # nothing beyond what HM3D ships
    table = read_semantic_txt(path.parent / "apt.semantic.txt")
    apt = generate_apartment(0)
    assert {d["id"] for d in table.values()} <= {i.id for i in apt.instances}
    assert all(h == semantic_colour(d["id"]) for h, d in table.items())
    # the visual GLB is Z up (HM3D's raw convention): its vertical extent is the apartment's height
    mesh = trimesh.load(str(path), force="mesh", process=False)
    assert mesh.extents[2] == pytest.approx(np.ptp(apt.mesh.vertices[:, 2]), abs=MM)


def test_hm3d_round_trip_matches_clean(layouts: dict) -> None:
    """default world -> HM3D layout -> convert gives the clean conversion's instances, labels, regions, geometry."""
    ref, got = _by_id(layouts["clean"][1]), _by_id(layouts["hm3d"][1])
    assert sorted(ref) == sorted(got)
    for k, r in ref.items():
        g = got[k]
        assert (g.label, g.room) == (r.label, r.room), k
        np.testing.assert_allclose(g.bounds, r.bounds, atol=MM, err_msg=f"instance {k} ({r.label})")
    np.testing.assert_allclose(layouts["hm3d"][1].bounds, layouts["clean"][1].bounds, atol=MM)


def test_mp3d_round_trip_matches_clean(layouts: dict) -> None:
    """default world -> Matterport3D layout (.glb, _semantic.ply, .house) -> convert: same instances, regions."""
    path, asset = layouts["mp3d"]
    assert layout_of(path) == "mp3d" and not (path.parent / "apt.semantics.json").exists()
    ref, got = _by_id(layouts["clean"][1]), _by_id(asset)
    assert sorted(ref) == sorted(got)
    for k, r in ref.items():
        assert (got[k].label, got[k].room) == (r.label, r.room), k
        np.testing.assert_allclose(got[k].bounds, r.bounds, atol=MM, err_msg=f"instance {k} ({r.label})")
    ref_rooms = layouts["clean"][1].rooms
    assert [(x.id, x.type, x.floor) for x in asset.rooms] == [(x.id, x.type, x.floor) for x in ref_rooms]
    for a, b in zip(asset.rooms, ref_rooms):  # each region's S surface V vertices: the room polygon
        np.testing.assert_allclose(a.polygon, b.polygon, atol=MM)


def test_mp3d_object_absent_from_house_is_named(layouts: dict, tmp_path: Path) -> None:
    d = _copy(layouts["mp3d"][0].parent, tmp_path / "m")
    house = d / "apt.house"
    lines = [line for line in house.read_text().splitlines() if not line.startswith("O 5 ")]
    h = next(k for k, line in enumerate(lines) if line.startswith("H "))
    house.write_text("".join(line + "\n" for line in lines))  # the H line still counts object 5: a cut file
    with pytest.raises(InputError, match=r"apt\.house.*H line says \d+ objects, the file has \d+ O lines"):
        convert_scene(d / "apt.glb", tmp_path / "out", cache_dir="off")
    f = lines[h].split()
    f[8] = str(int(f[8]) - 1)  # the header agrees: the semantic mesh names an object the house lacks
    lines[h] = " ".join(f)
    house.write_text("".join(line + "\n" for line in lines))
    with pytest.raises(InputError, match=r"apt_semantic\.ply.*1 object id\(s\) absent from apt\.house: 5"):
        convert_scene(d / "apt.glb", tmp_path / "out", cache_dir="off")
    house.unlink()
    with pytest.raises(InputError, match=r"apt\.house.*missing"):
        convert_scene(d / "apt.glb", tmp_path / "out", cache_dir="off")


HOUSE = """ASCII 1.1
H  tiny  house  0 1  10 2 1  2 2 2 1 1  0 0 0 0 0  0 0 0 4 3 2.5  0 0 0 0 0
L  0 2 -  2 1.5 0  0 0 0 4 3 2.5  0 0 0 0 0
R  0 0 0 0 k  1 1 0  0 0 0 3 2 2.5  2.5  0 0 0 0
R  1 0 0 0 b  3.5 1.5 0  3 0 0 4 3 2.5  2.5  0 0 0 0
P  0 0 1 -  3 0.5 0 3 1.5 2  0 0 0 0
S  0 0 0 f  1 1 0  0 0 1  0 0 0 3 2 0  0 0 0 0 0
V  0 0 f  0 0 0  0 0 1  0 0 0
V  1 0 f  0 2 0  0 0 1  0 0 0
V  2 0 f  1 2 0  0 0 1  0 0 0
V  3 0 f  1 1 0  0 0 1  0 0 0
V  4 0 f  3 1 0  0 0 1  0 0 0
V  5 0 f  3 0 0  0 0 1  0 0 0
S  1 1 0 f  3.5 1.5 0  0 0 1  3 0 0 4 3 0  0 0 0 0 0
V  6 1 f  3 0 0  0 0 1  0 0 0
V  7 1 f  4 0 0  0 0 1  0 0 0
V  8 1 f  4 3 0  0 0 1  0 0 0
V  9 1 f  3 3 0  0 0 1  0 0 0
P  0a1b2c  0 0 0  1 1 1.5  0 0 0 0 0
C  0 5 kitchen#cabinet 7 cabinet  0 0 0 0 0
C  1 9 - 3 chair  0 0 0 0 0
O  0 0 0  0.5 1.5 0.4  1 0 0  0 1 0  0.5 0.3 0.4  0 0 0 0 0 0 0 0
O  1 1 1  3.5 1.5 0.4  1 0 0  0 1 0  0.2 0.2 0.4  0 0 0 0 0 0 0 0
E  0 0 17 1.2  0.5 1.5 0.4  0 1.2 0 1 1.8 0.8  0 0 0 0 0
"""


def test_house_file_in_matterport_layout(tmp_path: Path) -> None:
    """A .house in the exact layout of Matterport's data_organization.md: header counts, S/V region polygons."""
    from assets_convert.habitat import read_house

    path = tmp_path / "tiny.house"
    path.write_text(HOUSE)
    regions, cats, objects = read_house(path)
    assert [(k, r["label"], r["level"]) for k, r in sorted(regions.items())] == [(0, "kitchen", 0), (1, "bedroom", 0)]
    # region 0 is L-shaped (its box would add the 1 m x 1 m corner it lacks); its V vertices are kept in order
    np.testing.assert_allclose(regions[0]["polygon"], [[0, 0], [0, 2], [1, 2], [1, 1], [3, 1], [3, 0]])
    assert regions[0]["box"] == [0, 0, 0, 3, 2, 2.5]
    # '#' joins the words of a raw category name; '-' (no raw name) falls back to the mpcat40 name
    assert cats == {0: "kitchen cabinet", 1: "chair"}
    assert objects == {0: {"region": 0, "category": 0}, 1: {"region": 1, "category": 1}}
    # a file cut after its header: the counts say so, naming the file
    path.write_text("".join(line + "\n" for line in HOUSE.splitlines() if not line.startswith("V  9 ")))
    with pytest.raises(InputError, match=r"tiny\.house.*H line says 10 vertices, the file has 9 V lines"):
        read_house(path)
    path.write_text(HOUSE.replace("R  1 0 0 0 b  3.5 1.5 0  3 0 0 4 3 2.5  2.5  0 0 0 0", "R  1 0 0 0 b  3.5 1.5 0  3 0"))
    with pytest.raises(InputError, match=r"tiny\.house.*line 5: malformed R record"):
        read_house(path)


def test_hm3d_scene_compiles_with_instance_geoms(layouts: dict, tmp_path: Path) -> None:
    path, asset = layouts["hm3d"]
    xml = Path(path).parent.parent / "out_hm3d" / asset.mjcf
    model = mujoco.MjModel.from_xml_path(str(xml))
    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in range(model.ngeom)}
    for inst in asset.instances:
        assert set(inst.geoms) <= names


def test_habitat_layout_round_trip(layouts: dict) -> None:
    """default world -> Habitat scene dataset (yawed, COM-placed, centimetre objects) -> convert: same scene."""
    ref = layouts["clean"][1]
    got = layouts["habitat"][1]
    assert len(got.instances) == len(ref.instances)
    unmatched = list(got.instances)
    for r in ref.instances:
        hits = [g for g in unmatched if g.label == r.label and np.abs(g.bounds - r.bounds).max() <= MM]
        assert hits, f"no converted instance matches {r.id} {r.label} {r.bounds.tolist()}"
        assert hits[0].room == r.room, (r.id, r.label)
        unmatched.remove(hits[0])
    assert [(x.id, x.type, x.floor) for x in got.rooms] == [(x.id, x.type, x.floor) for x in ref.rooms]
    for a, b in zip(got.rooms, ref.rooms):
        np.testing.assert_allclose(a.polygon, b.polygon, atol=MM)


def test_stage_origin_moves_the_stage_only(layouts: dict, tmp_path: Path) -> None:
    """A stage config's ``origin`` (Habitat world frame) puts the stage asset there; object instances stay put."""
    d = _copy(layouts["habitat"][0].parent.parent, tmp_path / "h")
    stage_cfg = d / "stages" / "apt.stage_config.json"
    cfg = json.loads(stage_cfg.read_text())
    origin_hab = np.array([0.5, -0.25, 2.0])  # x, up, back in Habitat's frame
    stage_cfg.write_text(json.dumps({**cfg, "origin": origin_hab.tolist()}))
    moved = convert_scene(d / "scenes" / "apt.scene_instance.json", tmp_path / "out", cache_dir="off")
    ref = layouts["habitat"][1]
    assert [(i.id, i.label) for i in moved.instances] == [(i.id, i.label) for i in ref.instances]
    shift = HAB_TO_MJ @ origin_hab  # (0.5, -2.0, -0.25) in MuJoCo's Z-up frame
    for a, b in zip(moved.instances, ref.instances):
        expect = b.bounds + shift if b.kind == "structure" else b.bounds  # stage nodes vs object instances
        np.testing.assert_allclose(a.bounds, expect, atol=MM, err_msg=f"{b.id} {b.label} ({b.kind})")
    assert any(i.kind == "structure" for i in ref.instances) and any(i.kind != "structure" for i in ref.instances)
    stage_cfg.write_text(json.dumps({**cfg, "origin": [0, 1]}))
    with pytest.raises(InputError, match=r"'origin' of template .* must be a 3-vector"):
        convert_scene(d / "scenes" / "apt.scene_instance.json", tmp_path / "out2", cache_dir="off")


def test_folder_of_habitat_dataset_lists_its_scene_instances(layouts: dict) -> None:
    root = layouts["habitat"][0].parent.parent
    assert find_inputs(root, kind="scene") == [layouts["habitat"][0]]
    hm3d = layouts["hm3d"][0].parent
    assert find_inputs(hm3d, kind="scene") == [hm3d / "apt.glb"]  # the .semantic.glb is its companion


# ------------------------------------------------------------------------------------------------
# habitat-sim's MIT test datasets


def _fixtures(shared_assets: Path) -> Path:
    return shared_assets / "habitat_fixtures" / "dataset_tests"


def _glb_bounds_hab(path: Path, scale: float = 1.0) -> np.ndarray:
    return trimesh.load(str(path), force="scene", process=False).bounds * scale


def _to_mj_bounds(b_hab: np.ndarray) -> np.ndarray:
    pts = np.array([[x, y, z] for x in b_hab[:, 0] for y in b_hab[:, 1] for z in b_hab[:, 2]]) @ HAB_TO_MJ.T
    return np.stack([pts.min(axis=0), pts.max(axis=0)])


def test_habitat_fixture_dataset_0_loads_with_transforms(shared_assets: Path, tmp_path: Path) -> None:
    ds = _fixtures(shared_assets) / "dataset_0"
    scene = ds / "scenes" / "dataset_test_scene.scene_instance.json"
    asset = convert_scene(scene, tmp_path, cache_dir="off")
    assert asset.name == "dataset_test_scene"
    # stage 'modified_test_stage': stages/dataset_test_stage.glb, scale overridden to 1, translated (1.1, 2.2, 3.3)
    stage = _glb_bounds_hab(ds / "stages" / "dataset_test_stage.glb") + np.array([1.1, 2.2, 3.3])
    objs = [_glb_bounds_hab(ds / "objects" / f"dataset_test_object{k}.glb") + np.array(t)
            for k, t in ((1, [0.1, 0.2, 0.3]), (2, [0.3, 0.4, 0.5]))]
    by_label: dict[str, list] = {}
    for inst in asset.instances:
        by_label.setdefault(inst.label, []).append(inst)
    stage_insts = [i for i in asset.instances if i.kind == "structure"]
    lo = np.min([i.bounds[0] for i in stage_insts], axis=0)
    hi = np.max([i.bounds[1] for i in stage_insts], axis=0)
    np.testing.assert_allclose(np.stack([lo, hi]), _to_mj_bounds(stage), atol=MM)
    furniture = [i for i in asset.instances if i.kind == "furniture"]
    assert [i.label for i in furniture] == ["dataset test object", "dataset test object"]
    for inst, exp in zip(furniture, objs):
        np.testing.assert_allclose(inst.bounds, _to_mj_bounds(exp), atol=MM)
    # semantic_scene_instance from default_attributes (%%CONFIG_NAME_AS_ASSET_FILENAME%%): two region annotations
    assert [(r.type, r.floor) for r in asset.rooms] == [("bedroom", 0), ("bathroom", 0)]
    # poly_loop point (-25, -2, 0) in Habitat -> (-25, 0) in MuJoCo XY; polygons are CCW
    assert any(np.allclose(p, [-25.0, 0.0]) for p in asset.rooms[0].polygon)
    for r in asset.rooms:
        x, y = r.polygon[:, 0], r.polygon[:, 1]
        assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0


def test_habitat_fixture_dataset_1_templates_resolve_by_substring(shared_assets: Path, tmp_path: Path) -> None:
    """dataset_1's scenes name 'modified_test_stage' and 'dataset_test_object1': habitat-sim resolves them to the
    first registered handle containing the name (modified_test_stage_0, objects/object_0/dataset_test_object1_0)."""
    ds = _fixtures(shared_assets) / "dataset_1"
    asset = convert_scene(ds / "scenes" / "scene_0" / "dataset_test_scene_0.scene_instance.json", tmp_path,
                          cache_dir="off")
    furniture = [i for i in asset.instances if i.kind == "furniture"]
    exp = _glb_bounds_hab(ds / "objects" / "object_0" / "dataset_test_object1_0.glb") + np.array([0.1, 0.2, 0.3])
    np.testing.assert_allclose(furniture[0].bounds, _to_mj_bounds(exp), atol=MM)
    exp2 = _glb_bounds_hab(ds / "objects" / "object_1" / "dataset_test_object2_1.glb") + np.array([0.3, 0.4, 0.5])
    np.testing.assert_allclose(furniture[1].bounds, _to_mj_bounds(exp2), atol=MM)
    assert asset.rooms == []  # its semantic descriptor handles name no file


def test_dataset_config_with_two_scenes_lists_them(shared_assets: Path, tmp_path: Path) -> None:
    cfg = _fixtures(shared_assets) / "dataset_1" / "test_dataset_1.scene_dataset_config.json"
    with pytest.raises(InputError, match="holds 2 scenes.*dataset_test_scene_0.*dataset_test_scene_1"):
        convert_scene(cfg, tmp_path, cache_dir="off")  # one conversion is one scene: the commands expand a dataset
    assert [p.name for p in find_inputs(cfg, kind="scene")] == ["dataset_test_scene_0.scene_instance.json",
                                                                 "dataset_test_scene_1.scene_instance.json"]


# ------------------------------------------------------------------------------------------------
# clear errors


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    for p in dst.rglob("*"):
        p.chmod(0o755 if p.is_dir() else 0o644)
    return dst


def test_missing_semantic_txt_is_named(layouts: dict, tmp_path: Path) -> None:
    d = _copy(layouts["hm3d"][0].parent, tmp_path / "h")
    (d / "apt.semantic.txt").unlink()
    with pytest.raises(InputError, match=r"apt\.semantic\.txt.*missing"):
        convert_scene(d / "apt.glb", tmp_path / "out", cache_dir="off")


def test_colour_absent_from_txt_is_named(layouts: dict, tmp_path: Path) -> None:
    d = _copy(layouts["hm3d"][0].parent, tmp_path / "h")
    txt = d / "apt.semantic.txt"
    lines = txt.read_text().splitlines()
    dropped = lines.pop(3)  # instance 2
    txt.write_text("\n".join(lines) + "\n")
    colour = dropped.split(",")[1]
    with pytest.raises(InputError, match=rf"apt\.semantic\.glb.*absent from apt\.semantic\.txt: {colour}"):
        convert_scene(d / "apt.glb", tmp_path / "out", cache_dir="off")


def test_scene_instance_naming_missing_template_is_named(shared_assets: Path, tmp_path: Path) -> None:
    """An object instance whose template the dataset lacks is left out and named (issue 44); the stage's is an error."""
    d = _copy(_fixtures(shared_assets) / "dataset_0", tmp_path / "ds")
    scene = d / "scenes" / "dataset_test_scene.scene_instance.json"
    doc = json.loads(scene.read_text())
    full = convert_scene(scene, tmp_path / "full", cache_dir="off")
    doc["object_instances"][1]["template_name"] = "no_such_chair"
    scene.write_text(json.dumps(doc))
    asset = convert_scene(scene, tmp_path / "out", cache_dir="off")
    assert len(asset.instances) == len(full.instances) - 1
    missing = [u for u in asset.unused if "object_instances[1] not imported" in u]
    assert len(missing) == 1 and "object template 'no_such_chair' is not in the dataset" in missing[0]
    assert "dataset_test_scene.scene_instance.json" in missing[0]
    doc["stage_instance"]["template_name"] = "no_such_stage"
    scene.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"dataset_test_scene\.scene_instance\.json.*stage template 'no_such_stage'"):
        convert_scene(scene, tmp_path / "out2", cache_dir="off")


# ------------------------------------------------------------------------------------------------
# labels as they come, scenes without a floor


@pytest.mark.parametrize("node, label", [
    ("stove1 burner box", "stove"), ("kitchen_cabinet_2_door_cylinder", "kitchen cabinet"),
    ("fridge1 door_left Box", "fridge"), ("mug_Cylinder.002", "mug"), ("RoomFurniture_03.002_Cube.017", "roomfurniture"),
    # clean or plain names keep what they said before
    ("frl_apartment_chair_05", "frl apartment chair"), ("Cube.001", "cube"), ("003_cracker_box", "003 cracker box"),
    ("sofa", "sofa"), ("instance_12", "instance")])
def test_label_from_node_normalises_part_names(node: str, label: str) -> None:
    from assets_convert.scene import label_from_node

    assert label_from_node(node) == label


def _floorless_kitchen(path: Path) -> Path:
    """A GLB of node-named fixtures standing at z = 0 (Y up) with no floor: counter top, cabinet door, fridge body."""
    scene = trimesh.Scene()
    for name, size, pos in (("counter1 top box", (2.0, 0.9, 0.6), (0.0, 0.45, 0.0)),
                            ("cabinet2 door box", (0.6, 0.7, 0.02), (1.5, 0.35, 0.31)),
                            ("fridge1 body box", (0.7, 1.8, 0.7), (-1.6, 0.9, 0.0))):
        box = trimesh.creation.box(extents=size)
        box.apply_translation(pos)
        scene.add_geometry(box, node_name=name, geom_name=name)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(scene.export(file_type="glb"))
    return path


def test_add_floor_gives_a_navigable_floor(tmp_path: Path) -> None:
    from sdovon_mj.config import ObserveConfig
    from sdovon_mj.observe.stage import scene_floors_and_maps
    from sdovon_mj.sim.model import load_scene_mesh

    glb = _floorless_kitchen(tmp_path / "kitchen" / "kitchen.glb")
    plain = convert_scene(glb, tmp_path / "a", cache_dir="off")
    assert sorted(i.label for i in plain.instances) == ["cabinet", "counter", "fridge"]
    v, f, _fi = load_scene_mesh(tmp_path / "a" / plain.mesh)
    with pytest.raises(InputError, match="convert.add_floor=true"):
        scene_floors_and_maps(v, f, ObserveConfig(), "kitchen")
    floored = convert_scene(glb, tmp_path / "b", cache_dir="off", add_floor=True)
    floor = next(i for i in floored.instances if i.label == "floor")
    # the slab's top is the scene's lowest point and it reaches 0.5 m beyond the footprint on every side
    assert floor.bounds[1, 2] == pytest.approx(plain.bounds[0, 2], abs=1e-9)
    np.testing.assert_allclose(floor.bounds[0, :2], plain.bounds[0, :2] - 0.5, atol=1e-9)
    np.testing.assert_allclose(floor.bounds[1, :2], plain.bounds[1, :2] + 0.5, atol=1e-9)
    v, f, _fi = load_scene_mesh(tmp_path / "b" / floored.mesh)
    floors, maps, _skipped = scene_floors_and_maps(v, f, ObserveConfig(), "kitchen")
    assert len(floors) == 1 and maps and maps[0].navigable.any()


def test_input_regions_give_the_region_map(layouts: dict) -> None:
    """semantics.regions=input: the Habitat layout's region annotations become the floor's region map."""
    from sdovon_mj.config import ObserveConfig
    from sdovon_mj.observe.stage import scene_floors_and_maps
    from sdovon_mj.semantics import input_region_map
    from sdovon_mj.sim.model import load_scene_mesh

    path, asset = layouts["habitat"]
    v, f, _fi = load_scene_mesh(Path(path).parents[2] / "out_habitat" / asset.mesh)
    _floors, maps, _skipped = scene_floors_and_maps(v, f, ObserveConfig(), "apt")
    rm = input_region_map(asset.rooms, maps[0])
    assert rm.backend == "input" and sorted(rm.labels) == sorted({r.type for r in asset.rooms})
    for room in asset.rooms:  # the cell at each (convex, rectangular) room's centre carries its type
        cell = rm.frame.to_cell(np.asarray(room.polygon).mean(axis=0)[None])[0]
        assert rm.labels[rm.label_map[cell[0], cell[1]]] == room.type
    with pytest.raises(ValueError, match="no region annotations on floor 0"):
        input_region_map(layouts["hm3d"][1].rooms, maps[0])


def test_cli_convert_then_observe_on_that_folder(layouts: dict, tmp_path: Path) -> None:
    """`sdovon-mj convert --kind scene` output is a valid input of the next command (one scene inside -> used)."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    out = tmp_path / "conv"

    def cli(*a: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "sdovon_mj.cli", *a], env=env, capture_output=True, text=True,
                              timeout=600)

    proc = cli("convert", str(layouts["hm3d"][0]), "--kind", "scene", "--out", str(out), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    proc = cli("observe", str(out), "--set", "observe.width=64", "--set", "observe.height=48",
               "--set", "observe.yaw_steps=2", "--set", "observe.pitch_angles=[-30.0]", "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert (out / "scenes" / "apt" / "observe" / "navmap_0.json").is_file()
    # a folder with no scene in it is named (exit 2); one with several gives a scene each (tests/test_datasets.py)
    (tmp_path / "none").mkdir()
    proc = cli("observe", str(tmp_path / "run2"), "--scenes", str(tmp_path / "none"), "--quiet")
    assert proc.returncode == 2 and "none" in proc.stderr and "holds no scene" in proc.stderr, proc.stderr


def test_hm3d_semantic_texture_colours(tmp_path: Path) -> None:
    """HM3D's semantic GLBs paint instances in a texture: the colour at each triangle's UV centroid names it."""
    from PIL import Image
    from trimesh.visual.material import PBRMaterial

    # 2 x 2 palette: row 0 (top) red | green, row 1 (bottom) blue | white
    palette = Image.fromarray(np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 255]]], dtype=np.uint8))
    a = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    b = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    b.apply_translation((3.0, 0.0, 0.0))
    visual = trimesh.Scene()
    visual.add_geometry(trimesh.util.concatenate([a, b]), node_name="mesh", geom_name="mesh")
    visual.export(tmp_path / "s.glb")
    sem = trimesh.util.concatenate([a, b])
    tri = sem.vertices[sem.faces].reshape(-1, 3)
    # box a -> bottom-left texel (blue), box b -> top-right texel (green), in trimesh's (OBJ) uv convention
    uv = np.repeat(np.where(np.arange(len(sem.faces)) < len(a.faces), 0, 1), 3)[:, None] * [0.5, 0.5] + [0.25, 0.25]
    mesh = trimesh.Trimesh(tri, np.arange(len(tri)).reshape(-1, 3), process=False,
                           visual=trimesh.visual.TextureVisuals(uv=uv, material=PBRMaterial(baseColorTexture=palette)))
    trimesh.Scene(mesh).export(tmp_path / "s.semantic.glb")
    (tmp_path / "s.semantic.txt").write_text('HM3D Semantic Annotations\n1,FF0000,"red thing",0\n2,00FF00,"sofa",0\n'
                                             '3,0000FF,"table",1\n4,FFFFFF,"white thing",1\n')
    asset = convert_scene(tmp_path / "s.glb", tmp_path / "out", cache_dir="off")
    got = {i.label: i for i in asset.instances}
    assert sorted(got) == ["sofa", "table"]
    assert got["table"].bounds[1, 0] < 1.0 < got["sofa"].bounds[0, 0]  # box a is the table, box b the sofa
    assert (got["table"].room, got["sofa"].room) == (1, 0)


def test_scene_conversion_same_bytes_in_two_processes(layouts: dict, tmp_path: Path) -> None:
    """trimesh names the nodes of multi-primitive glTF meshes with random suffixes; the part order must not follow
    them (before: the geoms of a multi-material instance were numbered differently in every process)."""
    import hashlib
    import os
    import subprocess
    import sys

    src = layouts["clean"][0]
    code = ("import sys; from assets_convert.scene import convert_scene; "
            "convert_scene(sys.argv[1], sys.argv[2], name='apt', cache_dir='off')")
    digests = []
    for k in (0, 1):
        out = tmp_path / f"p{k}"
        subprocess.run([sys.executable, "-c", code, str(src), str(out)], check=True, timeout=300,
                       env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")})
        digests.append({p.relative_to(out).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
                        for p in sorted(out.rglob("*")) if p.is_file()})
    differ = sorted(k for k in digests[0].keys() | digests[1].keys() if digests[0].get(k) != digests[1].get(k))
    assert not differ, f"{len(differ)} files differ between the two processes: {differ[:8]}"
