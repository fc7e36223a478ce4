"""`sdovon-mj place`: variants, pictures and the independent check from the command line."""

from __future__ import annotations

import numpy as np

from sdovon_mj.cli import main
from sdovon_mj.place.synthetic import hand_relevance, write_primitive_library, write_table_scene
from sdovon_mj.records import SceneVariant, load_json, save_json


def _store(root):
    lib = write_primitive_library(root / "objects", root, per_kind=1)
    for a in lib:
        save_json(a, root / "objects" / a.name / "object.json")
    scene, planes = write_table_scene(root / "scenes" / "flat", root)
    save_json(scene, root / "scenes" / "flat" / "scene.json")
    save_json(hand_relevance(), root / "scenes" / "flat" / "semantics" / "relevance.json")
    return scene, planes


def test_place_cli_writes_variants_pictures_and_check(tmp_path, capsys):
    _store(tmp_path)
    rc = main(["place", str(tmp_path / "scenes" / "flat"), "--out", str(tmp_path), "--variants", "2", "--pictures", "--check",
               "--set", "place.m=2"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "flat_v000" in out.out and "worst object-object penetration" in out.out
    for k in range(2):
        d = tmp_path / "scenes" / "flat" / "variants" / f"flat_v{k:03d}"
        v = load_json(d / "variant.json", SceneVariant)
        assert v.resting and (tmp_path / v.mjcf).exists()
        assert (d / "top_down.png").stat().st_size > 1000 and (d / "view.png").stat().st_size > 1000


def test_place_cli_scene_without_receptacles_says_so(tmp_path, capsys):
    scene, _ = _store(tmp_path)
    save_json([], tmp_path / "scenes" / "flat" / "perceive" / "planes.json")
    rc = main(["place", str(tmp_path / "scenes" / "flat" / "scene.json"), "--out", str(tmp_path), "--variants", "1"])
    out = capsys.readouterr()
    assert rc == 1
    assert "no receptacle planes" in out.out and "no object came to rest" in out.err
    v = load_json(tmp_path / "scenes" / "flat" / "variants" / "flat_v000" / "variant.json", SceneVariant)
    assert v.placements == [] and v.notes and np.asarray(v.qpos).size == 0


def test_place_cli_bad_input_names_the_file(tmp_path, capsys):
    _store(tmp_path)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    rc = main(["place", str(tmp_path / "scenes" / "flat"), "--out", str(tmp_path), "--relevance", str(bad)])
    err = capsys.readouterr().err
    assert rc == 1 and "bad.json" in err
