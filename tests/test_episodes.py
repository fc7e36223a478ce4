"""Episode generation on the synthetic sample run: view points, visibility, geodesics, starts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sdovon_mj.config import AgentConfig, EpisodeConfig
from sdovon_mj.episodes import episode_report, generate_episodes, n_episodes_formula
from sdovon_mj.episodes.generate import generate_episodes_with_report, ratio_keep_probability
from sdovon_mj.gridgraph import GeodesicField, distance_field
from support.run_folder import build_sample_run
from sdovon_mj.records import NavMap, SceneVariant, load_json, records_equal


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    root = build_sample_run(tmp_path_factory.mktemp("run"))
    nm = load_json(root / "scenes/room/observe/navmap_0.json", NavMap)
    v0 = load_json(root / "scenes/room/variants/room_v000/variant.json", SceneVariant)
    v1 = load_json(root / "scenes/room/variants/room_v001/variant.json", SceneVariant)
    return root, nm, v0, v1


def test_distance_field_hand_computed():
    nav = np.ones((5, 5), bool)
    nav[1:4, 2] = False
    d = distance_field(nav, np.array([[2, 0]]), 0.5)
    assert d[2, 1] == pytest.approx(0.5)
    assert d[1, 1] == pytest.approx(0.5 * math.sqrt(2))
    # No corner cutting past the wall end at (1, 2): (1,1) -> (0,1) -> (0,2).
    assert d[0, 2] == pytest.approx(0.5 * (math.sqrt(2) + 2))
    assert d[2, 3] == pytest.approx(0.5 * (math.sqrt(2) + 5))  # over the wall's end and back down
    assert np.isinf(d[~nav]).all()
    nav2 = nav.copy()
    nav2[0, 2] = nav2[4, 2] = False
    assert np.isinf(distance_field(nav2, np.array([[2, 0]]), 0.5)[2, 4])


def test_goals_view_points_and_starts(run):
    root, nm, v0, _v1 = run
    cfg = EpisodeConfig()
    eps, rep = generate_episodes_with_report(v0, [nm], root, cfg, seed=3)
    assert rep.kept == ["obj_000", "obj_001"]
    assert rep.dropped == {"obj_002": "no view point sees it"}  # shut inside the cabinet
    assert len(eps) == cfg.k_e * 2 and {e.object_category for e in eps} == {"mug", "ball"}
    for e in eps:
        assert nm.is_navigable(e.start_position[None, :2])[0]
        assert e.start_position[2] == nm.height
        vps = np.concatenate([[vp.position[:2] for vp in g.view_points] for g in e.goals])
        geo = GeodesicField(nm.navigable, nm.frame, vps).distance(e.start_position[:2])
        assert math.isfinite(geo) and cfg.min_start_distance <= geo <= cfg.max_start_distance
        assert geo == e.geodesic_distance  # the one geodesic, computed the same way: the same float
        f = e.start_filters
        assert (f["min_geodesic_m"], f["max_geodesic_m"], f["geodesic_to_euclid_min_ratio"]) == (
            cfg.min_start_distance, cfg.max_start_distance, cfg.start_ratio_threshold)
        euclid = float(np.min(np.linalg.norm(vps - e.start_position[None, :2], axis=1)))
        assert f["geodesic_to_euclid_ratio"] == pytest.approx(geo / euclid) and f["geodesic_to_euclid_ratio"] >= 1.0 - 1e-9
        assert geo >= e.euclidean_distance - 1.0  # geodesic to a view point vs straight line to the object
        closest = next(g for g in e.goals if g.object_id == e.closest_goal_object_id)
        assert e.euclidean_distance == pytest.approx(float(np.linalg.norm(closest.position - e.start_position)))
        for g in e.goals:
            assert g.category == e.object_category and len(g.view_points) > 0
            fr = [vp.visible_fraction for vp in g.view_points]
            assert fr == sorted(fr, reverse=True) and min(fr) >= AgentConfig().eta_gt
            for vp in g.view_points:
                assert nm.is_navigable(vp.position[None, :2])[0]
                lo, hi = g.bounds
                dx = max(lo[0] - vp.position[0], 0, vp.position[0] - hi[0])
                dy = max(lo[1] - vp.position[1], 0, vp.position[1] - hi[1])
                assert math.hypot(dx, dy) <= cfg.viewpoint_radius + 1e-9


def test_partition_makes_geodesic_longer_than_straight_line(run):
    root, nm, v0, _ = run
    eps = generate_episodes(v0, [nm], root, EpisodeConfig(k_e=12), seed=0)
    ratios = [e.geodesic_distance / max(e.euclidean_distance, 1e-6) for e in eps]
    assert max(ratios) > 1.3  # some start sits behind the partition wall


def test_zero_goal_variant_and_determinism(run):
    root, nm, v0, v1 = run
    assert generate_episodes(v1, [nm], root, EpisodeConfig(), seed=1) == []
    a = generate_episodes(v0, [nm], root, EpisodeConfig(), seed=5)
    b = generate_episodes(v0, [nm], root, EpisodeConfig(), seed=5)
    c = generate_episodes(v0, [nm], root, EpisodeConfig(), seed=6)
    assert records_equal(a, b) and not records_equal(a, c)


def test_n_formula(run):
    root, nm, v0, v1 = run
    cfg = EpisodeConfig(k_e=2)
    by = {v.name: generate_episodes(v, [nm], root, cfg, seed=0) for v in (v0, v1)}
    r = episode_report(by, cfg.k_e)
    assert (r["k_s"], r["k_v"], r["n_c"], r["k_e"]) == (1, 2.0, 1.0, 2)
    assert r["N_formula"] == n_episodes_formula(1, 2, 1.0, 2) == 4.0 == r["N_actual"]


def test_habitat_ratio_rule():
    """habitat-lab's _ratio_sample_rate below the threshold, always kept at or above it."""
    assert ratio_keep_probability(1.0, 1.05) == pytest.approx(20 * 0.02 ** 2)
    assert ratio_keep_probability(1.04, 1.05) == pytest.approx(20 * 0.06 ** 2)
    assert ratio_keep_probability(1.05, 1.05) == 1.0 and ratio_keep_probability(1.3, 1.05) == 1.0


def test_start_filters_band_and_ratio(run):
    """A distance band admits only starts inside it; a ratio threshold thins straight-line starts."""
    root, nm, v0, _ = run
    band = EpisodeConfig(k_e=12, min_start_distance=2.0, max_start_distance=3.0, start_ratio_threshold=0.0)
    eps = generate_episodes(v0, [nm], root, band, seed=0)
    assert eps and all(2.0 <= e.geodesic_distance <= 3.0 for e in eps)
    free = EpisodeConfig(k_e=12, start_ratio_threshold=0.0)
    strict = EpisodeConfig(k_e=12, start_ratio_threshold=1.05)
    r_free = [e.start_filters["geodesic_to_euclid_ratio"] for e in generate_episodes(v0, [nm], root, free, seed=0)]
    r_strict = [e.start_filters["geodesic_to_euclid_ratio"] for e in generate_episodes(v0, [nm], root, strict, seed=0)]
    # A start below the threshold survives a draw with probability <= 20 * (1.05 - 0.98)^2 = 0.098, so with the
    # filter on, the share of near-straight starts (a large part of an open room's starts) must fall.
    share = lambda rs: sum(r < 1.05 for r in rs) / max(len(rs), 1)
    assert share(r_free) > 0 and share(r_strict) < share(r_free)
