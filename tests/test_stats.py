"""Dataset statistics: exact numbers from hand-made run folders, files, byte-identical reruns, partial runs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.config import PlaceConfig
from sdovon_mj.errors import InputError
from sdovon_mj.records import (
    Episode,
    Floor,
    Goal,
    NavMap,
    ObjectAsset,
    Placement,
    ReceptaclePlane,
    RegionMap,
    SceneAsset,
    SceneVariant,
    SemanticInstance,
    SupportSurface,
    ViewPoint,
    save_json,
)
from sdovon_mj.stats import CHARTS, dataset_statistics, rejection_key, summary_table, write_statistics

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.0, 0.5]])


def _placement(oid: str, cat: str, asset: str, plane: int, inst: int, region: str, status: str = "resting", reason: str = "") -> Placement:
    return Placement(object_id=oid, asset=asset, category=cat, plane_id=plane, receptacle_instance=inst, region=region,
                     spawn_pos=np.zeros(3), spawn_quat=np.array([1.0, 0, 0, 0]), status=status, reason=reason)


def _episode(i: int, variant: str, cat: str, geo: float, euc: float, n_vp: int = 2) -> Episode:
    vps = [ViewPoint(position=np.zeros(3), rotation=np.array([1.0, 0, 0, 0])) for _ in range(n_vp)]
    return Episode(episode_id=str(i), scene="apt_a", variant=variant, object_category=cat, start_position=np.zeros(3),
                   start_rotation=np.array([1.0, 0, 0, 0]), goals=[Goal(object_id="obj_000", category=cat, position=np.zeros(3), view_points=vps)],
                   geodesic_distance=geo, euclidean_distance=euc)


def _navmap(floor: int, shape: tuple[int, int], nav_cells: int, free_cells: int, res: float = 0.1) -> NavMap:
    nav = np.zeros(shape, dtype=bool)
    nav.flat[:nav_cells] = True
    free = np.zeros(shape, dtype=bool)
    free.flat[:free_cells] = True
    return NavMap(floor=floor, height=3.0 * floor, origin=np.zeros(2), resolution=res, navigable=nav, free=free)


def _write_scene(root: Path, name: str, support: bool = True) -> None:
    insts = [SemanticInstance(id=5, label="table"), SemanticInstance(id=7, label="shelf")]
    surfaces = [SupportSurface(instance_id=5, height=0.7, polygon=SQUARE), SupportSurface(instance_id=7, height=1.2, polygon=SQUARE)] if support else []
    save_json(SceneAsset(name=name, mjcf=f"scenes/{name}/scene.xml", floors=[Floor(0, 0.0), Floor(1, 3.0)], instances=insts,
                         support_surfaces=surfaces), root / "scenes" / name / "scene.json")


def build_fake_run(root: Path) -> Path:
    """Two scenes: apt_a (planes.json, regions, 2 variants with episodes), apt_b (ground-truth surfaces only, no variants)."""
    _write_scene(root, "apt_a")
    _write_scene(root, "apt_b")
    a = root / "scenes" / "apt_a"
    save_json(_navmap(0, (10, 10), 40, 60), a / "observe" / "navmap_0.json")  # 0.40 m^2 navigable, 0.60 free
    save_json(_navmap(1, (10, 10), 10, 20), a / "observe" / "navmap_1.json")  # 0.10, 0.20
    save_json(_navmap(0, (4, 5), 20, 20, res=0.5), root / "scenes" / "apt_b" / "observe" / "navmap_0.json")  # 5.0, 5.0
    planes = [ReceptaclePlane(id=0, instance_id=5, label="table", height=0.7, polygon=SQUARE, normal=np.array([0, 0, 1.0]), region="kitchen"),
              ReceptaclePlane(id=1, instance_id=7, label="shelf", height=1.2, polygon=SQUARE, normal=np.array([0, 0, 1.0]), region="bedroom"),
              ReceptaclePlane(id=2, instance_id=7, label="shelf", height=1.6, polygon=SQUARE, normal=np.array([0, 0, 1.0]), region="bedroom")]
    save_json(planes, a / "perceive" / "planes.json")
    lm = np.full((4, 4), -1, dtype=np.int16)
    lm[:2] = 0
    lm[2:, :2] = 2  # "living room" (index 1) never appears
    save_json(RegionMap(floor=0, origin=np.zeros(2), resolution=0.5, labels=["kitchen", "living room", "bedroom"], label_map=lm,
                        scores=np.zeros((4, 4, 3), dtype=np.float32)), a / "semantics" / "regions_0.json")
    v0 = [
        _placement("obj_000", "mug", "mug_a", 0, 5, "kitchen"),
        _placement("obj_001", "mug", "mug_b", 0, 5, "kitchen"),
        _placement("obj_002", "book", "book_a", 1, 7, "bedroom"),
        _placement("obj_003", "ball", "ball_a", 2, 7, ""),
        _placement("obj_004", "cup", "cup_a", 1, 7, "bedroom", "dropped", "fell (rests on the floor) after 2 attempts"),
        _placement("obj_005", "cup", "cup_a", 0, 5, "kitchen", "dropped", "fell (centre 0.12 m below its plane); no free spot left on its plane to retry"),
    ]
    v1 = [
        _placement("obj_000", "book", "book_a", 1, 7, "bedroom"),
        _placement("obj_001", "ball", "ball_a", 9, 5, "kitchen"),  # plane 9 unknown: receptacle from the instance label
        _placement("obj_002", "mug", "mug_a", 2, 7, "bedroom", "dropped",
                   "unstable (still moving after 2.0 s (|v| 0.100 m/s, |w| 0.20 rad/s)) after 3 attempts"),
        _placement("obj_003", "mug", "mug_a", 2, 7, "bedroom", "dropped", "resting_elsewhere (not on its plane; touching inst_3) after 2 attempts"),
        _placement("obj_004", "ball", "ball_a", 2, 7, "bedroom", "dropped", "fell (rests on the floor) after 3 attempts"),
    ]
    for index, placements in enumerate([v0, v1]):
        v = SceneVariant(scene="apt_a", index=index, seed=index, placements=placements)
        save_json(v, a / "variants" / v.name / "variant.json")
    eps0 = [_episode(0, "apt_a_v000", "mug", 4.0, 2.0), _episode(1, "apt_a_v000", "mug", 2.0, 2.0),
            _episode(2, "apt_a_v000", "book", 3.0, 1.5), _episode(3, "apt_a_v000", "ball", 5.0, 4.0, n_vp=4)]
    eps1 = [_episode(4, "apt_a_v001", "book", 6.0, 3.0), _episode(5, "apt_a_v001", "book", 1.0, 1.0)]
    save_json(eps0, a / "variants" / "apt_a_v000" / "episodes.json")
    save_json(eps1, a / "variants" / "apt_a_v001" / "episodes.json")
    lib = [ObjectAsset(name=n, category=c, mjcf=f"objects/{n}/model.xml", bbox=np.zeros((2, 3)), mass=0.1, hull_count=1, source=s)
           for n, c, s in [("mug_a", "mug", "ycb"), ("mug_b", "mug", "ycb"), ("book_a", "book", "hssd"), ("ball_a", "ball", "ycb"), ("cup_a", "cup", "hssd")]]
    save_json(lib[:3], root / "objects" / "objects.json")
    for o in lib[2:]:  # book_a in both places: counted once
        save_json(o, root / "objects" / o.name / "object.json")
    (root / "config.yaml").write_text("name: mini\nepisodes:\n  k_e: 2\n", encoding="utf-8")
    return root


def test_statistics_numbers(tmp_path: Path) -> None:
    s = dataset_statistics(build_fake_run(tmp_path / "run"))
    t = s["totals"]
    assert s["dataset"] == "mini"
    assert (t["scenes"], t["scenes_with_variants"], t["floors"], t["variants"], t["variants_with_episodes"]) == (2, 1, 4, 2, 2)
    assert t["navigable_area_m2"] == pytest.approx(5.5) and t["free_area_m2"] == pytest.approx(5.8)
    # apt_a: 3 planes from planes.json; apt_b: 2 ground-truth support surfaces labelled by their instances
    assert s["frequency"]["receptacle_planes"] == {"shelf": 3, "table": 2}
    assert (t["receptacle_planes"], t["receptacle_categories"]) == (5, 2)
    assert [(x["name"], x["receptacle_planes_source"], x["regions"], x["region_labels"]) for x in s["scenes"]] == [
        ("apt_a", "perceive", 2, ["bedroom", "kitchen"]), ("apt_b", "ground_truth", 0, [])]
    assert s["scenes"][0]["receptacle_plane_area_m2"] == pytest.approx(1.5)
    assert (t["regions"], t["region_labels"]) == (2, 2)
    assert (t["placements"], t["placed_objects"], t["objects_rejected"]) == (11, 6, 5)
    assert (t["placed_object_assets"], t["placed_categories"]) == (4, 3)
    assert (t["object_assets"], t["object_categories"]) == (5, 4)
    assert s["objects"]["by_source"] == {"hssd": {"categories": 2, "instances": 2}, "ycb": {"categories": 2, "instances": 3}}
    assert s["placements"]["by_status"] == {"dropped": 5, "resting": 6}
    assert s["placements"]["rejected_by_reason"] == {
        "fell: centre # m below its plane": 1, "fell: rests on the floor": 2,
        "resting_elsewhere: not on its plane": 1, "unstable: still moving after # s": 1}
    f = s["frequency"]
    assert f["placed_categories"] == {"ball": 2, "book": 2, "mug": 2}
    assert f["variants_with_category"] == {"ball": 2, "book": 2, "mug": 1}
    assert f["receptacle_categories"] == {"shelf": 3, "table": 3}
    assert f["placement_regions"] == {"bedroom": 2, "kitchen": 3, "unknown": 1}
    assert f["goal_categories"] == {"ball": 1, "book": 3, "mug": 2}
    assert (t["episodes"], t["goal_categories"], t["mean_episodes_per_variant"], t["mean_placed_objects_per_variant"]) == (6, 3, 3.0, 3.0)
    e = s["episodes"]
    assert e["geodesic_distance_m"] == {"mean": 3.5, "min": 1.0, "max": 6.0}
    assert e["euclidean_distance_m"] == {"mean": round(13.5 / 6, 4), "min": 1.0, "max": 4.0}
    ratios = [0.5, 1.0, 0.5, 0.8, 0.5, 1.0]
    assert e["euclidean_geodesic_ratio"] == {"mean": round(sum(ratios) / 6, 4), "min": 0.5, "max": 1.0}
    assert e["view_points_per_goal"] == {"mean": round(14 / 6, 4), "min": 2.0, "max": 4.0}
    # N = k_s k_v n_c k_e: 1 scene with variants, 2 variants, (3 + 1) / 2 categories per variant, 6 / 4 episodes per category
    assert s["episode_count_formula"] == {"k_s": 1, "k_v": 2.0, "n_c": 2.0, "k_e": 1.5, "N": 6.0, "k_e_config": 2, "k_v_config": PlaceConfig().k_v}


def test_rejection_key() -> None:
    p = _placement("o", "mug", "mug_a", 0, 0, "", "dropped", "resting_elsewhere (centre overhangs its plane's edge); no free spot left on its plane to retry")
    assert rejection_key(p) == "resting_elsewhere: centre overhangs its plane's edge"
    assert rejection_key(_placement("o", "mug", "mug_a", 0, 0, "")) == ""
    assert rejection_key(_placement("o", "mug", "mug_a", 0, 0, "", "fell", "centre 0.31 m below its plane")) == "fell: centre # m below its plane"
    assert rejection_key(_placement("o", "mug", "mug_a", 0, 0, "", "pending")) == "pending"


def test_write_files_and_bytes_identical(tmp_path: Path) -> None:
    root = build_fake_run(tmp_path / "run")
    paths = write_statistics(root)
    names = sorted(p.name for p in paths)
    assert names == sorted(["statistics.json", "statistics.md", *(v[0] for v in CHARTS.values())])
    assert all(p.parent == root / "stats" and p.stat().st_size > 0 for p in paths)
    for p in paths:
        if p.suffix == ".png":
            data = p.read_bytes()
            assert data[:8] == b"\x89PNG\r\n\x1a\n" and b"Software" not in data and b"matplotlib" not in data.lower()
    first = {p.name: p.read_bytes() for p in paths}
    # A copy of the run elsewhere, written again: the same bytes (nothing depends on paths, time or versions).
    import shutil

    other = tmp_path / "copy"
    shutil.copytree(root, other, ignore=shutil.ignore_patterns("stats"))
    second = {p.name: p.read_bytes() for p in write_statistics(other, out_rel="stats")}
    assert first == second
    md = (root / "stats" / "statistics.md").read_text()
    assert "| mini | 3 | 2 | 2 | 6 |" in md
    assert "| fell: rests on the floor | 2 |" in md
    assert "| ycb | 3 | 2 |" in md
    assert json.loads((root / "stats" / "statistics.json").read_text())["totals"]["episodes"] == 6
    table = summary_table(dataset_statistics(root))
    for line in ["scenes", "variants", "episodes", "objects rejected", "fell: rests on the floor"]:
        assert line in table
    assert [ln.split()[-1] for ln in table.splitlines() if ln.startswith("episodes")] == ["6"]


def test_chart_changes_with_data(tmp_path: Path) -> None:
    from sdovon_mj.stats import bar_chart_png

    a = bar_chart_png({"mug": 3, "ball": 1}, "t", "x", "y")
    assert a == bar_chart_png({"ball": 1, "mug": 3}, "t", "x", "y")
    assert a != bar_chart_png({"mug": 3, "ball": 2}, "t", "x", "y")


def test_partial_runs(tmp_path: Path) -> None:
    # scenes only (no variants, no navmaps): zeros, every file still written
    root = tmp_path / "scenes_only"
    _write_scene(root, "apt_a", support=False)
    paths = write_statistics(root)
    assert len(paths) == 6 and all(p.exists() for p in paths)
    s = dataset_statistics(root)
    assert s["totals"]["scenes"] == 1 and s["totals"]["variants"] == 0 and s["totals"]["episodes"] == 0
    assert s["episodes"]["geodesic_distance_m"] == {"mean": 0.0, "min": 0.0, "max": 0.0}
    assert s["episode_count_formula"]["N"] == 0.0
    assert "objects rejected" in summary_table(s)
    # nothing at all
    empty = tmp_path / "empty"
    empty.mkdir()
    s = dataset_statistics(empty)
    assert s["totals"]["scenes"] == 0 and s["scenes"] == []
    # variants without episodes yet: placements counted, no episode statistics
    root = build_fake_run(tmp_path / "no_eps")
    for p in (root / "scenes").glob("*/variants/*/episodes.json"):
        p.unlink()
    s = dataset_statistics(root)
    assert (s["totals"]["variants"], s["totals"]["variants_with_episodes"], s["totals"]["episodes"], s["totals"]["placed_objects"]) == (2, 0, 0, 6)
    assert s["totals"]["mean_episodes_per_variant"] == 0.0


def test_corrupt_record_names_the_file(tmp_path: Path) -> None:
    root = build_fake_run(tmp_path / "run")
    bad = root / "scenes" / "apt_a" / "variants" / "apt_a_v001" / "variant.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(InputError) as e:
        dataset_statistics(root)
    assert str(bad) in str(e.value)


def test_sample_run(tmp_path: Path) -> None:
    from support.run_folder import build_sample_run

    root = build_sample_run(tmp_path / "sample", episodes=True)
    s = dataset_statistics(root)
    t = s["totals"]
    assert (t["scenes"], t["variants"], t["placed_objects"], t["object_assets"]) == (1, 2, 4, 2)
    assert t["episodes"] == sum(s["frequency"]["goal_categories"].values()) > 0
    assert s["episode_count_formula"]["N"] == pytest.approx(t["episodes"])
    assert s["episodes"]["geodesic_distance_m"]["min"] > 0


def test_llm_fallbacks_counted_per_stage_from_the_records(tmp_path):
    """A server that only answers prose: every question falls back to the offline backend; the records say so
    (Relevance.backend names what answered) and `stats.llm_fallbacks` sums them per stage from the run folder."""
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from test_semantics_backends import FakeLLM, cfg_for
    from test_semantics_regions import two_rooms

    from sdovon_mj.records import save_json
    from sdovon_mj.semantics import get_backend, identify_receptacles, region_map, relevance
    from sdovon_mj.stats import llm_fallbacks

    navmap, insts = two_rooms()
    fake = FakeLLM("ollama", "prose")
    try:
        cfg = cfg_for("ollama", fake.url, retries=0)
        b_perceive = get_backend(cfg)
        named = identify_receptacles(["bed", "pillow", "sink"], b_perceive)
        b = get_backend(cfg)
        rm = region_map(insts, navmap, b, cfg)
        n_regions = len(b.fallbacks)
        rel = relevance(["towel", "book"], ["bedroom", "bathroom"], ["bed", "sink"], b)
    finally:
        fake.close()
    assert "bed" in named and len(b_perceive.fallbacks) == 1
    assert n_regions >= 2 and len(rm.fallbacks) == n_regions  # one per distinct window label set
    assert rel.backend == "offline" and len(rel.fallbacks) == 4 and rel.sources == ["fallback:offline"] * 2
    sd = tmp_path / "scenes" / "s0"
    (sd / "perceive").mkdir(parents=True)
    (sd / "semantics").mkdir(parents=True)
    (sd / "perceive" / "llm.json").write_text(json.dumps({"backend": b_perceive.label, "fallbacks": b_perceive.fallbacks}))
    save_json(rm, sd / "semantics" / "regions_0.json")
    save_json(rel, sd / "semantics" / "relevance.json")
    (tmp_path / "scenes" / "s1").mkdir()  # a scene not yet through perceive adds nothing
    assert llm_fallbacks(tmp_path) == {"perceive.receptacle_naming": 1, "semantics.region_proposals": n_regions,
                                       "semantics.relevance": 4}


def test_placement_top_pairs_exact_on_a_hand_made_run(tmp_path):
    """Share on the top-k pairs and the uniform random baseline, checked by hand on a two-category scene.

    Six planes: (kitchen, counter) x2, (bathroom, sink), (bedroom, bed) x3. Cups rank kitchen-counter,
    then bathroom-sink; pillows bedroom-bed, then bathroom-sink. With k=1: three cups on counters (hit),
    one pillow on a bed (hit), one pillow on the counter (miss), one cup dropped (not counted).
    Random: a cup's top pair holds 2 of 6 planes, a pillow's 3 of 6.
    """
    from sdovon_mj.records import Placement, ReceptaclePlane, Relevance, SceneVariant, save_json
    from sdovon_mj.stats import placement_top_pairs

    sd = tmp_path / "scenes" / "s0"
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    spec = [("kitchen", "counter"), ("kitchen", "counter"), ("bathroom", "sink"), ("bedroom", "bed"),
            ("bedroom", "bed"), ("bedroom", "bed")]
    planes = [ReceptaclePlane(id=i, instance_id=i, label=c, height=0.5, polygon=sq, normal=np.array([0, 0, 1.0]),
                              region=r) for i, (r, c) in enumerate(spec)]
    sd.joinpath("semantics").mkdir(parents=True)
    save_json(planes, sd / "semantics" / "planes.json")
    regs, recs = ["bathroom", "bedroom", "kitchen"], ["bed", "counter", "sink"]
    pair = np.full((2, 3, 3), 0.05)
    pair[0, 2, 1], pair[0, 0, 2] = 0.9, 0.5  # cup: kitchen-counter, then bathroom-sink
    pair[1, 1, 0], pair[1, 0, 2] = 0.8, 0.3  # pillow: bedroom-bed, then bathroom-sink
    rel = Relevance(objects=["cup", "pillow"], regions=regs, receptacles=recs, p_obj_region=np.full((2, 3), 0.5),
                    p_obj_receptacle=np.full((2, 3), 0.5), backend="offline", p_pair=pair, sources=["learned"] * 2)
    save_json(rel, sd / "semantics" / "relevance.json")

    def put(k: int, cat: str, plane: int, status: str = "resting") -> Placement:
        return Placement(object_id=f"obj_{k}", asset=cat + "_a", category=cat, plane_id=plane, receptacle_instance=plane,
                         region=spec[plane][0], spawn_pos=np.zeros(3), spawn_quat=np.array([1.0, 0, 0, 0]), status=status)

    pls = [put(0, "cup", 0), put(1, "cup", 1), put(2, "cup", 0), put(3, "pillow", 4), put(4, "pillow", 1),
           put(5, "cup", 3, "fell")]
    (sd / "variants" / "v0").mkdir(parents=True)
    save_json(SceneVariant(scene="s0", index=0, seed=1, placements=pls), sd / "variants" / "v0" / "variant.json")
    got = placement_top_pairs(tmp_path, k=1)
    assert (got["placed"], got["on_top_k"]) == (5, 4)
    assert got["share"] == pytest.approx(4 / 5)
    assert got["random_share"] == pytest.approx((3 * 2 / 6 + 2 * 3 / 6) / 5)
    assert got["ratio"] == pytest.approx(got["share"] / got["random_share"])
    # ceiling: every counted plane drawn among the categories whose top pair it is (counters: cup, bed: pillow)
    assert got["ceiling"] == pytest.approx(1.0 / ((4 * 2 / 6 + 3 / 6) / 5))
    two = placement_top_pairs(tmp_path, k=2)  # the sink joins both categories' top 2
    assert two["on_top_k"] == 4 and two["random_share"] == pytest.approx((3 * 3 / 6 + 2 * 4 / 6) / 5)


def test_homes_statistics_rooms_clutter_and_geodesic_quartiles(tmp_path: Path) -> None:
    """Per scene: labelled instances per room (mean and median room) and the episodes' geodesic quartiles; over the
    scenes: their medians (what `sdovon-mj show RUN --stats` prints for the default world's houses)."""
    from sdovon_mj.records import Room
    from sdovon_mj.stats import homes_table

    root = build_fake_run(tmp_path / "run")
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    for name, per_room in (("apt_a", (3, 1, 2)), ("apt_b", (4, 4))):
        insts = [SemanticInstance(id=k, label="wall", room=r) for k, r in
                 enumerate(r for r, n in enumerate(per_room) for _ in range(n))]
        rooms = [Room(id=r, type="bedroom", floor=0, polygon=sq) for r in range(len(per_room))]
        save_json(SceneAsset(name=name, mjcf=f"scenes/{name}/scene.xml", floors=[Floor(0, 0.0)], instances=insts, rooms=rooms),
                  root / "scenes" / name / "scene.json")
    s = dataset_statistics(root)
    a, b = s["scenes"]
    assert (a["rooms"], a["instances_per_room"], a["room_instances_median"]) == (3, 2.0, 2.0)
    assert (b["rooms"], b["instances_per_room"], b["room_instances_median"]) == (2, 4.0, 4.0)
    assert a["geodesic_quartiles_m"] == [2.25, 3.5, 4.75]  # episodes 1, 2, 3, 4, 5, 6 m
    assert b["geodesic_quartiles_m"] == [0.0, 0.0, 0.0] and s["totals"]["geodesic_quartiles_m"] == [2.25, 3.5, 4.75]
    h = s["homes"]
    assert (h["scenes"], h["rooms_median"], h["instances_per_room_median"]) == (2, 2.5, 3.0)
    assert h["room_instances_median"] == 3.0  # rooms of 3, 1, 2, 4, 4 instances
    assert h["geodesic_median_m"] == 3.5  # only scenes with episodes
    table = homes_table(s).splitlines()
    assert table[0].split()[:3] == ["scene", "storeys", "rooms"] and len(table) == 2 + 2 + 1 + 2
    assert table[-2].startswith("median of scenes") and "3.50 (scene medians)" in table[-2]
