"""Targeted views (observe.targeted): cameras that show what coverage views left unseen of a surface."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from sdovon_mj.config import AgentConfig, ConfigError, ObserveConfig
from sdovon_mj.observe import make_renderer
from sdovon_mj.observe.targeted import (ViewTarget, aim, candidate_positions, plan_target_views, render_poses,
                                        surface_cells)
from sdovon_mj.records import NavMap
from sdovon_mj.sim.camera import backproject

# A 6 x 6 m room: a bookshelf (two open levels between side panels, a back panel and a top) against the
# north wall, and a table in the middle. Shelf level tops at 0.40 and 0.80 m, the table top at 0.75 m.
XML = """
<mujoco>
  <worldbody>
    <light pos="0 0 5" dir="0 0 -1" directional="true"/>
    <geom name="inst_0" type="box" size="3 3 0.05" pos="0 0 -0.05"/>
    <geom name="inst_1" type="box" size="3 0.05 1.2" pos="0 3.05 1.2"/>
    <geom name="inst_2" type="box" size="0.5 0.3 0.02" pos="0 0 0.73"/>
    <geom name="inst_3" type="box" size="0.6 0.2 0.02" pos="0 2.75 0.38"/>
    <geom name="inst_3b" type="box" size="0.6 0.2 0.02" pos="0 2.75 0.78"/>
    <geom name="inst_3c" type="box" size="0.6 0.2 0.02" pos="0 2.75 1.18"/>
    <geom name="inst_3d" type="box" size="0.02 0.2 0.6" pos="-0.62 2.75 0.6"/>
    <geom name="inst_3e" type="box" size="0.02 0.2 0.6" pos="0.62 2.75 0.6"/>
    <geom name="inst_3f" type="box" size="0.6 0.01 0.6" pos="0 2.96 0.6"/>
  </worldbody>
</mujoco>
"""
RES = 0.05


def _navmap() -> NavMap:
    n = int(6 / RES)
    nav = np.ones((n, n), dtype=bool)
    origin = np.array([-3.0, -3.0])
    rows, cols = np.mgrid[0:n, 0:n]
    x, y = origin[0] + (cols + 0.5) * RES, origin[1] + (rows + 0.5) * RES
    blocked = (np.abs(x) < 0.5 + 0.2) & (np.abs(y) < 0.3 + 0.2)  # table + agent radius
    blocked |= (np.abs(x) < 0.64 + 0.2) & (y > 2.55 - 0.2)  # bookshelf
    blocked |= (np.abs(x) > 2.8) | (np.abs(y) > 2.8)  # walls
    nav &= ~blocked
    return NavMap(floor=0, height=0.0, origin=origin, resolution=RES, navigable=nav, free=nav.copy())


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(XML)


def _fraction(model: mujoco.MjModel, poses: list, target: ViewTarget, cfg: ObserveConfig) -> float:
    """Fraction of the target's cells that the full-size renders of `poses` show."""
    r = make_renderer(model, cfg)
    try:
        cells = [surface_cells(target, backproject(o.depth, o.K, o.T_cam), cfg.targeted_cell)
                 for o in render_poses(r, poses, cfg)]
    finally:
        r.close()
    nx = int(np.ceil((target.hi[0] - target.lo[0]) / cfg.targeted_cell))
    ny = int(np.ceil((target.hi[1] - target.lo[1]) / cfg.targeted_cell))
    return len(np.unique(np.concatenate(cells))) / (nx * ny) if cells else 0.0


def test_targeted_views_show_a_hidden_shelf_level_and_are_deterministic(model):
    cfg = ObserveConfig(width=160, height=120)
    small = dataclasses.replace(cfg, width=cfg.targeted_width, height=cfg.targeted_width * 3 // 4)
    # the lower shelf level (top at 0.40 m) between side panels, and the table top
    shelf = ViewTarget(lo=np.array([-0.6, 2.55]), hi=np.array([0.6, 2.95]), height=0.40, floor=0)
    table = ViewTarget(lo=np.array([-0.5, -0.3]), hi=np.array([0.5, 0.3]), height=0.75, floor=0)
    # an oblique view from the side (what random coverage often gives) shows little of the shelf level
    oblique = aim(np.array([-2.4, 1.2, 0.88]), np.array([0.0, 2.75, 0.4]))
    before = _fraction(model, [oblique], shelf, cfg)
    r = make_renderer(model, small)
    try:
        poses = plan_target_views(r, [_navmap()], [shelf, table], cfg)
        again = plan_target_views(r, [_navmap()], [shelf, table], cfg)
    finally:
        r.close()
    assert 1 <= len(poses) <= 2 * cfg.targeted_views
    assert all(np.array_equal(a, b) for a, b in zip(poses, again)) and len(poses) == len(again)
    nm = _navmap()
    for T in poses:  # cameras stand on navigable cells, at a camera height of the observe config
        assert nm.is_navigable(T[None, :2, 3])[0]
        assert any(abs(T[2, 3] - h) < 1e-9 for h in (AgentConfig().camera_height, *cfg.camera_heights))
    after = _fraction(model, poses, shelf, cfg)
    print(f"shelf level seen: oblique view {before:.2f}, targeted views {after:.2f}")
    assert before < 0.6 and after > 0.85, (before, after)
    assert _fraction(model, poses, table, cfg) > 0.95


def test_candidate_renders_skip_far_geometry_and_keep_the_plan(model, monkeypatch):
    """Scoring candidates with only the geoms near camera and surface drawn chooses the very poses that scoring
    with everything drawn chooses (the surface cells of every candidate are the same)."""
    import sdovon_mj.observe.targeted as targeted

    cfg = ObserveConfig(width=160, height=120)
    shelf = ViewTarget(lo=np.array([-0.6, 2.55]), hi=np.array([0.6, 2.95]), height=0.40, floor=0)
    table = ViewTarget(lo=np.array([-0.5, -0.3]), hi=np.array([0.5, 0.3]), height=0.75, floor=0)
    real = targeted.spheres_meet_box
    hidden = []

    def counting(*args):
        keep = real(*args)
        hidden.append(int((~keep).sum()))
        return keep

    r = make_renderer(model, dataclasses.replace(cfg, width=96, height=72))
    try:
        monkeypatch.setattr(targeted, "spheres_meet_box", counting)
        culled = plan_target_views(r, [_navmap()], [shelf, table], cfg)
        monkeypatch.setattr(targeted, "spheres_meet_box", lambda c, rad, lo, hi: np.ones(len(rad), dtype=bool))
        full = plan_target_views(r, [_navmap()], [shelf, table], cfg)
    finally:
        r.close()
    assert max(hidden) > 0  # the table's candidates do not draw the bookshelf, and the shelf's not the table
    assert len(culled) == len(full) >= 2 and all(np.array_equal(a, b) for a, b in zip(culled, full))


def test_already_seen_surface_gets_no_view_and_zero_views_turns_it_off(model):
    cfg = ObserveConfig(width=160, height=120)
    lo, hi = np.array([-0.5, -0.3]), np.array([0.5, 0.3])
    g = np.stack(np.meshgrid(np.arange(-0.49, 0.5, 0.01), np.arange(-0.29, 0.3, 0.01)), -1).reshape(-1, 2)
    seen = np.column_stack([g, np.full(len(g), 0.75)])
    table = ViewTarget(lo=lo, hi=hi, height=0.75, floor=0, seen_points=seen)
    r = make_renderer(model, dataclasses.replace(cfg, width=96, height=72))
    try:
        assert plan_target_views(r, [_navmap()], [table], cfg) == []
        fresh = dataclasses.replace(table, seen_points=None)
        assert plan_target_views(r, [_navmap()], [fresh], dataclasses.replace(cfg, targeted_views=0)) == []
        assert plan_target_views(r, [_navmap()], [dataclasses.replace(fresh, floor=3)], cfg) == []  # no such floor
    finally:
        r.close()


def test_candidates_keep_their_distance_and_bad_range_is_a_config_error():
    cfg = ObserveConfig()
    t = ViewTarget(lo=np.array([-0.5, -0.3]), hi=np.array([0.5, 0.3]), height=0.75, floor=0)
    xy = candidate_positions(_navmap(), t, cfg)
    assert 0 < len(xy) <= cfg.targeted_candidates
    d = np.linalg.norm(np.maximum(np.maximum(t.lo - xy, xy - t.hi), 0.0), axis=1)
    assert d.min() >= cfg.targeted_distance[0] - 1e-9 and d.max() <= cfg.targeted_distance[1] + 1e-9
    with pytest.raises(ConfigError, match="targeted_distance"):
        candidate_positions(_navmap(), t, dataclasses.replace(cfg, targeted_distance=(1.0,)))
