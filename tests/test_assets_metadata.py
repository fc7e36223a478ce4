"""assets.yaml / <file>.yaml per-file metadata: a mixed library (Z-up OBJ in cm, Y-up glTF in m, an STL folder
declared as one multi-part object) converts in one run with the declared sizes and up axes; clear errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from assets_convert import convert_object, convert_tree
from assets_convert.metadata import meta_for
from sdovon_mj.config import ConvertConfig
from sdovon_mj.errors import InputError

TOL = 0.01  # the 1 % on declared sizes


def _box(extents: tuple[float, float, float], centre: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    m = trimesh.creation.box(extents=extents)
    m.apply_translation(np.asarray(centre) + [0.0, 0.0, 0.0])
    return m


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    lib = tmp_path_factory.mktemp("lib")
    # a 4 x 6 x 3 cm block, Z up, in centimetres: 'auto' units would read 6 units as metres
    (lib / "block").mkdir()
    _box((4.0, 6.0, 3.0), (0, 0, 1.5)).export(lib / "block" / "block.obj")
    # a glTF box 0.3 (x) x 0.2 (up) x 0.1 (z) m, Y up as glTF says
    (lib / "crate").mkdir()
    trimesh.Scene(_box((0.3, 0.2, 0.1), (0, 0.1, 0))).export(lib / "crate" / "crate.glb")
    # a kettle of two STL parts in millimetres, Z up: body 150 x 150 x 200, handle 20 x 60 x 120 beside it
    (lib / "kettle").mkdir()
    _box((150.0, 150.0, 200.0), (0, 0, 100)).export(lib / "kettle" / "body.stl")
    _box((20.0, 60.0, 120.0), (95, 0, 100)).export(lib / "kettle" / "handle.stl")
    (lib / "kettle" / "assets.yaml").write_text("multipart: true\nunits: mm\nup: +Z\ncategory: kettle\n")
    (lib / "assets.yaml").write_text('files:\n  "*.obj": {units: cm, up: +Z, category: block}\n'
                                     '  "*.glb": {units: m, up: +Y}\n')
    return lib


def test_mixed_library_converts_with_declared_sizes(library: Path, tmp_path: Path) -> None:
    # run-wide defaults that are wrong for every file: the metadata must win
    cfg = ConvertConfig(units="in", up="+X")
    report = convert_tree([library], tmp_path, kind="object", jobs=1, progress=False, config=cfg, cache_dir="off")
    rows = {r["name"]: r for r in report["items"]}
    assert report["failed"] == 0, report["items"]
    assert sorted(rows) == ["block", "crate", "kettle"]  # the kettle's two files are one object
    assert sorted(Path(p).name for p in rows["kettle"]["parts"]) == ["body.stl", "handle.stl"]
    from assets_convert.object import load_converted

    want = {"block": (0.04, 0.06, 0.03), "crate": (0.3, 0.1, 0.2), "kettle": (0.18, 0.15, 0.2)}
    for name, ext in want.items():
        a = load_converted(tmp_path, name)
        np.testing.assert_allclose(a.bbox[1] - a.bbox[0], ext, rtol=TOL, err_msg=name)
    assert load_converted(tmp_path, "block").category == "block"
    assert load_converted(tmp_path, "kettle").category == "kettle"
    assert load_converted(tmp_path, "kettle").source == str(library / "kettle")


def test_sidecar_wins_over_folder_metadata(library: Path, tmp_path: Path) -> None:
    obj = library / "block" / "block.obj"
    side = obj.with_name("block.obj.yaml")
    side.write_text("units: mm\n")
    try:
        assert meta_for(obj).units == "mm" and meta_for(obj).category == "block"
        a = convert_object(obj, tmp_path, cache_dir="off")
        np.testing.assert_allclose(a.bbox[1] - a.bbox[0], (0.004, 0.006, 0.003), rtol=TOL)
    finally:
        side.unlink()


def test_unknown_key_names_file_and_key(tmp_path: Path) -> None:
    (tmp_path / "o").mkdir()
    _box((0.1, 0.1, 0.1)).export(tmp_path / "o" / "cube.obj")
    (tmp_path / "o" / "assets.yaml").write_text("unit: cm\n")
    with pytest.raises(InputError, match=r"o/assets\.yaml.*unknown key 'unit'"):
        convert_object(tmp_path / "o" / "cube.obj", tmp_path / "out", cache_dir="off")
    (tmp_path / "o" / "assets.yaml").write_text('files:\n  "*.obj": {up: sideways}\n')
    with pytest.raises(InputError, match=r"key 'files\.\*\.obj\.up': 'sideways'"):
        meta_for(tmp_path / "o" / "cube.obj")


def test_receptacle_flag_per_file_and_node_glob(tmp_path: Path) -> None:
    """`receptacle` for a whole scene file, then per node-name glob (last match wins); wrong types name file and key."""
    from assets_convert.metadata import receptacle_flag
    from assets_convert.scene import convert_scene

    folder = tmp_path / "s"
    folder.mkdir()
    scene = trimesh.Scene()
    for name, centre in (("Table_Top.001", (0, 0, 0.7)), ("Shelf_Unit.002", (2, 0, 0.5)), ("Floor", (1, 0, -0.05))):
        scene.add_geometry(_box((0.8, 0.8, 0.1), centre), node_name=name, geom_name=name)
    scene.export(folder / "room.glb")
    (folder / "assets.yaml").write_text('up: +Z\nfiles:\n  "room.glb":\n    receptacle: false\n'
                                        '    nodes:\n      "Shelf_*": {receptacle: true}\n      "*.002": {receptacle: false}\n'
                                        '      "table top": {receptacle: true}\n')
    meta = meta_for(folder / "room.glb")
    assert meta.receptacle is False
    assert receptacle_flag(meta, "Shelf_Unit.002") is False  # both globs match: the later one wins
    assert receptacle_flag(meta, "Table_Top.001", "table top") is True  # a glob may name the label
    assert receptacle_flag(meta, "Floor", "floor") is False  # the file's flag
    asset = convert_scene(folder / "room.glb", tmp_path / "out", cache_dir="off")
    assert {s.label: s.receptacle for s in asset.instances} == {"table top": True, "shelf unit": False, "floor": False}
    # without metadata the instances carry no flag, and their JSON no key (records keep their bytes)
    (folder / "assets.yaml").write_text("up: +Z\n")
    plain = convert_scene(folder / "room.glb", tmp_path / "out2", cache_dir="off")
    assert all(s.receptacle is None and '"receptacle"' not in s.to_json() for s in plain.instances)
    for text, key in (("receptacle: yes please\n", "receptacle"),
                      ('nodes:\n  "Shelf_*": {receptacle: 1}\n', r"nodes\.Shelf_\*\.receptacle"),
                      ('nodes:\n  "Shelf_*": {category: shelf}\n', r"nodes\.Shelf_\*\.category"),
                      ('nodes: [Shelf_*]\n', "nodes")):
        (folder / "assets.yaml").write_text(text)
        with pytest.raises(InputError, match=rf"s/assets\.yaml.*key '{key}'"):
            meta_for(folder / "room.glb")
