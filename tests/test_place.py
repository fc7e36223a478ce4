"""Place stage: sampling, support, settling, the independent check, edge cases, determinism."""

from __future__ import annotations

import os
import shutil

import mujoco
import numpy as np
import pytest

from sdovon_mj.config import PlaceConfig
from sdovon_mj.place.check import check_variant, format_report, per_category
from sdovon_mj.geometry import fan_triangles, points_in_convex_polygon, sample_in_polygon, shrink_polygon
from sdovon_mj.place.sample import category_distribution, sample_placements, top_pair_share
from support.placement import hand_relevance, write_primitive_library, write_primitive_object, write_table_scene
from sdovon_mj.place.variants import place_variant, place_variants, run_variant
from sdovon_mj.seeds import variant_seed
from sdovon_mj.records import ReceptaclePlane, Relevance, SceneVariant, load_json


@pytest.fixture(scope="module")
def flat(tmp_path_factory):
    """A two-room table scene and a primitive object library in one store."""
    root = tmp_path_factory.mktemp("store")
    lib = write_primitive_library(root / "objects", root, per_kind=2)
    scene, planes = write_table_scene(root / "scene", root)
    return root, scene, planes, lib


def test_polygon_sampling_is_uniform_and_inside():
    rng = np.random.default_rng(0)
    poly = np.array([[0, 0], [3, 0], [4, 1], [2, 3], [0, 2]], dtype=float)
    pts = sample_in_polygon(poly, 20000, rng)
    assert points_in_convex_polygon(poly, pts).all()
    tris, areas = fan_triangles(poly)
    # Each fan triangle receives points in proportion to its area (paper appendix B).
    counts = np.zeros(len(tris))
    for k, t in enumerate(tris):
        counts[k] = points_in_convex_polygon(t[[0, 1, 2]] if np.cross(t[1] - t[0], t[2] - t[0]) > 0 else t[[0, 2, 1]], pts, tol=1e-9).sum()
    assert np.allclose(counts / len(pts), areas / areas.sum(), atol=0.015)
    # Uniform in x on a unit square: the mean and variance of a uniform law.
    sq = sample_in_polygon(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float), 20000, rng)
    assert abs(sq[:, 0].mean() - 0.5) < 0.01 and abs(sq[:, 0].var() - 1 / 12) < 0.004
    inner = shrink_polygon(poly, 0.3)
    assert len(inner) >= 3 and points_in_convex_polygon(poly, inner).all()
    assert len(shrink_polygon(np.array([[0, 0], [0.1, 0], [0.1, 0.1], [0, 0.1]], float), 0.06)) == 0


def test_category_distribution_top_k_and_temperature():
    rel = hand_relevance()
    cats, p = category_distribution(rel, "kitchen", "counter", ["box", "mug", "ball", "can"], 1.0, 2)
    assert cats == ["box", "mug"] and np.isclose(p.sum(), 1.0)
    _, p_cold = category_distribution(rel, "kitchen", "counter", ["box", "mug", "ball", "can"], 0.2, 0)
    _, p_warm = category_distribution(rel, "kitchen", "counter", ["box", "mug", "ball", "can"], 5.0, 0)
    assert p_cold.max() > p_warm.max()
    assert category_distribution(rel, "kitchen", "counter", ["sofa"], 1.0, 0)[0] == []


def _popular_and_specific() -> tuple[Relevance, list[tuple[str, str]]]:
    """A learned pair model of a popular object (0.9 everywhere) and a specific one (0.5 at the bathroom sink, 0.05
    elsewhere), and a scene of three pairs."""
    objs, regs, recs = ["popular", "specific"], ["bathroom", "living room"], ["sink", "shelf"]
    pp = np.full((2, 2, 2), 0.05)
    pp[0] = 0.9
    pp[1, 0, 0] = 0.5
    rel = Relevance(objects=objs, regions=regs, receptacles=recs, p_obj_region=np.full((2, 2), 0.5),
                    p_obj_receptacle=np.full((2, 2), 0.5), p_pair=pp, sources=["learned", "learned"])
    return rel, [("bathroom", "sink"), ("living room", "shelf"), ("bathroom", "shelf")]


def test_category_distribution_pair_model_prefers_what_belongs_here_more_than_elsewhere():
    """With a pair model, a pair draws the categories that fit it more than the scene's other pairs.

    A popular object (0.9 everywhere) and a specific one (0.5 at the sink, 0.05 elsewhere): the share of
    the raw scores would favour the popular one everywhere; Bayes' rule over the scene's pairs gives the
    sink to the specific one (0.5 / 0.6 of its weight there against 0.9 / 2.7) and the shelf to the popular one.
    """
    rel, scene = _popular_and_specific()
    objs = rel.objects
    cats, p = category_distribution(rel, "bathroom", "sink", objs, 1.0, 0, scene)
    assert cats[0] == "specific" and np.isclose(p.sum(), 1.0)
    assert p[0] == pytest.approx((0.5 / 0.6) / (0.5 / 0.6 + 0.9 / 2.7))  # proportional at temperature 1
    cats, _p = category_distribution(rel, "living room", "shelf", objs, 1.0, 0, scene)
    assert cats[0] == "popular"
    # the paper's eq. 5 (no learned pair model: the share of the raw pair scores): the popular object everywhere
    rel.sources = ["table", "table"]
    assert category_distribution(rel, "bathroom", "sink", objs, 1.0, 0, scene)[0][0] == "popular"
    eq5 = hand_relevance()  # no p_pair: `pairs` changes nothing
    assert category_distribution(eq5, "kitchen", "counter", ["box", "mug"], 1.0, 0, [("kitchen", "counter")])[1] == \
        pytest.approx(category_distribution(eq5, "kitchen", "counter", ["box", "mug"], 1.0, 0)[1])


def test_top_pairs_keep_each_category_where_it_belongs_most():
    """`Relevance.top_pairs` is the one definition of a category's best pairs in a scene; placement keeps each
    category to them (``place.top_pairs``) and a pair that is nobody's best takes any category."""
    rel, scene = _popular_and_specific()
    objs = rel.objects
    top1 = rel.top_pairs(scene, 1)
    assert top1["specific"] == {("bathroom", "sink")}
    assert len(top1["popular"]) == 1 and top1["popular"] != top1["specific"]
    assert rel.top_pairs(scene, 3) == {o: set(scene) for o in objs}
    cats, p = category_distribution(rel, "bathroom", "sink", objs, 1.0, 0, scene, allowed={"specific"})
    assert cats == ["specific"] and p.tolist() == [1.0]
    # nothing allowed is known: every category stays drawable
    assert category_distribution(rel, "bathroom", "sink", objs, 1.0, 0, scene, allowed={"sofa"})[0] == ["specific", "popular"]


def test_variant_rests_on_intended_planes_and_passes_independent_check(flat):
    root, scene, planes, lib = flat
    rel = hand_relevance()
    checks = []
    for mode in ("paper", "stable"):
        cfg = PlaceConfig(m=3, spawn_mode=mode)
        for k in range(2):
            v = place_variant(scene, planes, rel, lib, root, cfg, variant_seed(7, k), k + (10 if mode == "stable" else 0))
            assert len(v.placements) >= 10
            c = check_variant(v, planes, root)
            assert c.max_penetration <= 0.005, c.penetrations
            checks.append(c)
            # Settled poses really are on the plane: the object's COM sits above its plane, not below.
            for p in v.resting:
                plane = next(q for q in planes if q.id == p.plane_id)
                assert p.settled_pos[2] > plane.height - 0.01
    report = format_report(checks)
    print(report)
    ok = sum(c.ok_count for c in checks)
    total = sum(len(c.objects) for c in checks)
    assert ok / total >= 0.95, report
    assert set(per_category(checks)) <= {"box", "mug", "ball", "can"}


def test_check_fails_lifted_shifted_and_overlapping_objects(flat):
    root, scene, planes, lib = flat
    v = place_variant(scene, planes, hand_relevance(), lib, root, PlaceConfig(m=3, spawn_mode="stable"), 3, 30)
    assert all(o.ok for o in check_variant(v, planes, root).objects)
    kept = v.resting
    # Lift the first object 5 cm: no contact any more.
    lifted = SceneVariant.from_dict(v.to_dict())
    lifted.qpos = v.qpos.copy()
    lifted.qpos[2] += 0.05
    c = check_variant(lifted, planes, root)
    assert not c.objects[[p.object_id for p in v.placements].index(kept[0].object_id)].ok
    # Move the second object 3 m sideways (off every table): the ray misses its support.
    moved = SceneVariant.from_dict(v.to_dict())
    moved.qpos = v.qpos.copy()
    moved.qpos[7] += 3.0
    bad = [o for o in check_variant(moved, planes, root).objects if o.object_id == kept[1].object_id][0]
    assert not bad.ok and "ray" in bad.reason
    # Put the third object into the fourth: deep interpenetration is reported.
    inter = SceneVariant.from_dict(v.to_dict())
    inter.qpos = v.qpos.copy()
    inter.qpos[14:17] = v.qpos[21:24] + np.array([0.01, 0.0, 0.0])
    assert check_variant(inter, planes, root).max_penetration > 0.005


def test_deterministic_bytes_and_model_loads_from_anywhere(flat, tmp_path):
    root, scene, planes, lib = flat
    cfg = PlaceConfig(m=2)
    a = place_variant(scene, planes, hand_relevance(), lib, root, cfg, 11, 40)
    xml_a = (root / a.mjcf).read_bytes()
    json_a = (root / "scenes" / scene.name / "variants" / a.name / "variant.json").read_bytes()
    b = place_variant(scene, planes, hand_relevance(), lib, root, cfg, 11, 40)
    assert (root / b.mjcf).read_bytes() == xml_a
    assert (root / "scenes" / scene.name / "variants" / b.name / "variant.json").read_bytes() == json_a
    assert load_json(root / "scenes" / scene.name / "variants" / b.name / "variant.json", SceneVariant).to_json() == a.to_json()
    c = place_variant(scene, planes, hand_relevance(), lib, root, cfg, 12, 41)
    assert not np.array_equal(c.qpos, a.qpos)
    # The composed model loads from another cwd and after moving the whole store.
    moved = tmp_path / "moved"
    shutil.copytree(root, moved)
    cwd = os.getcwd()
    try:
        os.chdir("/")
        m = mujoco.MjModel.from_xml_path(str(moved / a.mjcf))
    finally:
        os.chdir(cwd)
    assert m.nq == len(a.qpos)
    names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(m.nbody)}
    assert {p.object_id for p in a.resting} <= names
    geoms = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, i) or "" for i in range(m.ngeom)]
    assert any(g.startswith(a.resting[0].object_id + "/") for g in geoms)
    assert any(g.startswith("inst_") for g in geoms) and any(g.startswith("support_plane_") for g in geoms)
    assert len(place_variants(scene, planes, hand_relevance(), lib, root, PlaceConfig(k_v=2, m=1), 5)) == 2


def test_unknown_categories_give_an_empty_variant_that_says_why(flat):
    root, scene, planes, lib = flat
    rel = Relevance(objects=["sofa", "lamp"], regions=["kitchen"], receptacles=["table"],
                    p_obj_region=np.array([[0.5], [0.5]]), p_obj_receptacle=np.array([[0.5], [0.5]]))
    v = place_variant(scene, planes, rel, lib, root, PlaceConfig(), 1, 50)
    assert v.placements == [] and any("no object category" in n and "mug" in n for n in v.notes)
    assert (root / v.mjcf).exists()


def test_plane_smaller_than_every_object_and_no_receptacles(flat):
    root, scene, planes, lib = flat
    tiny = ReceptaclePlane(id=9, instance_id=1, label="table", height=0.75, region="kitchen", normal=np.array([0, 0, 1.0]),
                           polygon=np.array([[1.5, 2.2], [1.52, 2.2], [1.52, 2.22], [1.5, 2.22]]))
    v = place_variant(scene, [tiny], hand_relevance(), lib, root, PlaceConfig(), 1, 51)
    assert v.placements == [] and any("smaller than every object" in n for n in v.notes)
    v = place_variant(scene, planes[:1] + [tiny], hand_relevance(), lib, root, PlaceConfig(m=2), 1, 52)
    assert len(v.placements) == 2 and any("plane 9" in n for n in v.notes)
    v = place_variant(scene, [], hand_relevance(), lib, root, PlaceConfig(), 1, 53)
    assert v.placements == [] and any("no receptacle planes" in n for n in v.notes)


def test_failures_are_resampled_then_dropped_with_a_reason(flat, tmp_path):
    root, scene, planes, lib = flat
    # A narrow ledge 10 cm wide: mugs tumbling down from 0.3 m sometimes do not land well and are retried.
    ledge = ReceptaclePlane(id=0, instance_id=4, label="shelf", height=1.2, region="living room", normal=np.array([0, 0, 1.0]),
                            polygon=np.array([[6.0, 3.6], [7.0, 3.6], [7.0, 3.7], [6.0, 3.7]]))
    mugs = [write_primitive_object(root / "objects", root, "mug", "small_mug", scale=0.6)]
    rel = hand_relevance()
    seen = []
    for s in range(6):
        v, _ = run_variant(scene, [ledge], rel, mugs, root, PlaceConfig(m=4, resample_attempts=1), s, 60 + s)
        seen += v.placements
    assert any(p.attempts > 1 for p in seen)
    assert all(p.status in ("resting", "dropped") for p in seen)
    assert sum(p.status == "resting" for p in seen) >= 0.9 * len(seen)
    # A settle cap too short for anything to come to rest: every object is retried, then dropped with the reason.
    v, _ = run_variant(scene, planes, rel, lib, root, PlaceConfig(m=1, resample_attempts=2, max_settle_time=0.05), 1, 66)
    assert v.placements and all(p.status == "dropped" for p in v.placements)
    assert all(p.attempts == 3 and "unstable" in p.reason and "after 3 attempts" in p.reason for p in v.placements)
    assert any("dropped 4 of 4" in n for n in v.notes) and any("no object came to rest" in n for n in v.notes)
    assert np.asarray(v.qpos).size == 0 and check_variant(v, planes, root).ok_count == 0


def test_semantics_share_beats_random_placement():
    """Across 50 variants, placements concentrate on each category's top-3 (region, receptacle) pairs."""
    regions = ["kitchen", "living room", "bedroom", "bathroom", "office"]
    receptacles = ["counter", "table", "coffee table", "nightstand", "shelf", "desk"]
    objects = ["mug", "pillow", "toothbrush", "book", "laptop", "plate"]
    rng = np.random.default_rng(0)
    # Peaked tables, as an LLM gives: each object likes one or two regions and receptacles.
    p_rgn = np.full((len(objects), len(regions)), 0.02)
    p_rec = np.full((len(objects), len(receptacles)), 0.02)
    likes = {"mug": ("kitchen", "counter"), "pillow": ("bedroom", "nightstand"), "toothbrush": ("bathroom", "shelf"),
             "book": ("living room", "shelf"), "laptop": ("office", "desk"), "plate": ("kitchen", "table")}
    for i, o in enumerate(objects):
        p_rgn[i, regions.index(likes[o][0])] = 1.0
        p_rec[i, receptacles.index(likes[o][1])] = 1.0
    rel = Relevance(objects=objects, regions=regions, receptacles=receptacles,
                    p_obj_region=p_rgn / p_rgn.sum(0), p_obj_receptacle=p_rec / p_rec.sum(0))
    uniform = Relevance(objects=objects, regions=regions, receptacles=receptacles,
                        p_obj_region=np.ones_like(p_rgn), p_obj_receptacle=np.ones_like(p_rec))
    planes = []
    for k, (rg, rc) in enumerate((rg, rc) for rg in regions for rc in receptacles):
        if rng.random() < 0.7 or (rg, rc) in likes.values():
            x, y = 3.0 * (k % 6), 3.0 * (k // 6)
            planes.append(ReceptaclePlane(id=k, instance_id=k, label=rc, height=0.7, region=rg, normal=np.array([0, 0, 1.0]),
                                          polygon=np.array([[x, y], [x + 1.2, y], [x + 1.2, y + 0.8], [x, y + 0.8]])))
    from sdovon_mj.records import ObjectAsset

    lib = [ObjectAsset(name=f"{o}_0", category=o, mjcf="", bbox=np.array([[-0.04, -0.04, 0], [0.04, 0.04, 0.08]]),
                       mass=0.2, hull_count=1) for o in objects]
    cfg = PlaceConfig(m=3, max_objects=200)
    sem, rnd = [], []
    for k in range(50):
        sem += sample_placements(planes, rel, lib, cfg, np.random.default_rng(variant_seed(1, k))).placements
        rnd += sample_placements(planes, uniform, lib, cfg, np.random.default_rng(variant_seed(1, k))).placements
    share_sem = top_pair_share(sem, rel, planes)
    share_rnd = top_pair_share(rnd, rel, planes)
    print("category      semantic  random   (share on its top-3 (region, receptacle) pairs; 50 variants)")
    for c in sorted(share_sem):
        print(f"{c:<12} {share_sem[c][0]:>8.1%} {share_rnd[c][0]:>8.1%}   n={share_sem[c][1]}/{share_rnd[c][1]}")
    mean_sem = np.mean([v[0] for v in share_sem.values()])
    mean_rnd = np.mean([v[0] for v in share_rnd.values()])
    print(f"mean         {mean_sem:>8.1%} {mean_rnd:>8.1%}")
    # Stated threshold: at least 3x the random share and at least 40 points above it.
    assert mean_sem >= 3 * mean_rnd and mean_sem - mean_rnd >= 0.40


def test_heightfield_support_on_a_cushion(flat, tmp_path):
    """A bumpy cushion in the scene mesh gets a heightfield from ray casts; objects rest on it."""
    from sdovon_mj.records import SceneAsset
    from sdovon_mj.sim.model import save_scene_mesh

    root, scene, planes, lib = flat
    # A 1.0 x 0.6 m cushion at 0.45 m with 1.5 cm bumps, as a triangle grid.
    nx, ny = 41, 25
    xs, ys = np.linspace(4.5, 5.5, nx), np.linspace(1.2, 1.8, ny)
    gx, gy = np.meshgrid(xs, ys)
    gz = 0.45 + 0.0075 * np.sin(gx * 12.0) * np.cos(gy * 12.0)
    verts = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])
    faces = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a = j * nx + i
            faces += [[a, a + 1, a + nx + 1], [a, a + nx + 1, a + nx]]
    save_scene_mesh(root / "scene" / "cushion.npz", verts, np.array(faces), np.full(len(faces), 3))
    sc = SceneAsset.from_dict(scene.to_dict())
    sc.mesh = "scene/cushion.npz"
    cushion = ReceptaclePlane(id=5, instance_id=3, label="coffee table", height=0.45, region="living room",
                              normal=np.array([0, 0, 1.0]), polygon=np.array([[4.5, 1.2], [5.5, 1.2], [5.5, 1.8], [4.5, 1.8]]))
    cfg = PlaceConfig(m=4, spawn_mode="stable", support_hfield=True)
    flat_based = [a for a in lib if a.category in ("box", "mug")]  # balls roll down the bumps, as they should
    v, _ = run_variant(sc, [cushion], hand_relevance(), flat_based, root, cfg, 4, 70)
    xml = (root / v.mjcf).read_text()
    assert "hfield" in xml and 'name="support_plane_5"' in xml
    c = check_variant(v, [cushion], root)
    assert c.ok_count >= 3, [o.reason for o in c.objects]
    # Resting heights follow the bumps (not one flat plane): the object bases differ by more than 1 mm.
    zs = [p.settled_pos[2] for p in v.resting]
    assert len(zs) >= 3 and np.ptp(zs) > 0.001


def test_spawn_respects_the_shelf_board_above(flat):
    """On a shelf level, the paper's 0.3 m drop is lowered so objects spawn under the board above."""
    from sdovon_mj.geometry import quat_to_mat
    from sdovon_mj.place.sample import plane_headroom

    root, scene, planes, lib = flat
    poly = np.array([[6.0, 3.45], [7.0, 3.45], [7.0, 3.75], [6.0, 3.75]])
    levels = [ReceptaclePlane(id=k, instance_id=4, label="shelf", height=h, region="living room", normal=np.array([0, 0, 1.0]),
                              polygon=poly) for k, h in enumerate((0.4, 0.65, 0.9))]
    assert np.isclose(plane_headroom(levels[0], levels, 0.02), 0.23) and np.isinf(plane_headroom(levels[2], levels, 0.02))
    small = [a for a in lib if a.category in ("box", "ball", "can")]
    v, _ = run_variant(scene, levels, hand_relevance(), small, root, PlaceConfig(m=3), 8, 80)
    assert len(v.placements) >= 6
    assets = {a.name: a for a in small}
    for p in v.placements:
        if p.plane_id == 2:
            continue
        a = assets[p.asset]
        lo, hi = a.bbox
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        top = (corners @ quat_to_mat(p.spawn_quat).T + p.spawn_pos)[:, 2].max()
        assert top <= levels[p.plane_id + 1].height - 0.02 - 0.02 + 1e-9
    c = check_variant(v, levels, root)
    assert c.ok_count >= 0.95 * len(c.objects), [o.reason for o in c.objects if not o.ok]
