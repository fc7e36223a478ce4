"""Episode generation on the synthetic sample run: view points, visibility, geodesics, starts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sdovon_mj.config import AgentConfig, EpisodeConfig
from sdovon_mj.episodes import distance_field, episode_report, generate_episodes, n_episodes_formula
from sdovon_mj.episodes.generate import generate_episodes_with_report
from sdovon_mj.episodes.geodesic import GeodesicField
from sdovon_mj.testing.run_folder import build_sample_run
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
        geo = GeodesicField(nm, vps).at(e.start_position[None, :2])[0]
        assert math.isfinite(geo) and geo >= cfg.min_start_distance
        assert geo == pytest.approx(e.geodesic_distance)
        assert geo >= e.euclidean_distance - 1.0  # geodesic to a view point vs straight line to the object
        closest = next(g for g in e.goals if g.object_id == e.closest_goal_object_id)
        assert e.euclidean_distance == pytest.approx(float(np.linalg.norm(closest.position - e.start_position)))
        for g in e.goals:
            assert g.category == e.object_category and 0 < len(g.view_points) <= cfg.max_viewpoints
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
