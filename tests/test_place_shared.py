"""Place real third-party objects (../shared/assets/objects) converted by assets_convert."""

from __future__ import annotations

import numpy as np
import pytest

from sdovon_mj.config import PlaceConfig
from sdovon_mj.place import check_variant, format_report, run_variant
from support.placement import write_table_scene
from sdovon_mj.records import Relevance

ITEMS = (("banana", "banana/bullet_banana/banana.obj"), ("toy block", "toy_block/ycb_061_foam_brick"))


@pytest.mark.slow
def test_converted_shared_objects_settle_on_tables(shared_assets, tmp_path):
    convert = pytest.importorskip("assets_convert.object")
    lib = []
    for cat, rel in ITEMS:
        p = shared_assets / "objects" / rel
        if p.is_dir():
            p = sorted(p.glob("*.obj"))[0]
        lib.append(convert.convert_object(p, tmp_path, category=cat))  # cached in the user cache after the first run
    scene, planes = write_table_scene(tmp_path / "scene", tmp_path)
    cats = sorted({a.category for a in lib})
    rel = Relevance(objects=cats, regions=["kitchen", "living room"], receptacles=["counter", "table", "coffee table", "shelf"],
                    p_obj_region=np.ones((len(cats), 2)), p_obj_receptacle=np.ones((len(cats), 4)))
    checks = []
    for mode in ("paper", "stable"):
        for k in range(2):
            v, _ = run_variant(scene, planes, rel, lib, tmp_path, PlaceConfig(m=3, spawn_mode=mode), k, k + 10 * (mode == "stable"))
            assert len(v.placements) >= 10
            xml = (tmp_path / v.mjcf).read_text()
            assert "texture" in xml or ".png" in xml  # real textured visuals came along
            checks.append(check_variant(v, planes, tmp_path))
    print(format_report(checks))
    ok = sum(c.ok_count for c in checks)
    assert ok >= 0.95 * sum(len(c.objects) for c in checks)
    assert max(c.max_penetration for c in checks) <= 0.005
