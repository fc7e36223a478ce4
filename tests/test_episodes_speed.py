"""The visibility short cuts of the episodes stage give exactly what the plain checks give.

Each short cut is checked against the plain computation on the synthetic sample run's variants (real
MuJoCo rays, real renders): the ray pre-test with far geoms hidden and only undecided cameras re-cast
against every ray cast with every geom; the batched occluder masks against renders of everything;
the pixel bound that skips renders against rendered pixel counts; one `to_world` call for all view
points against one per cell.
"""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from sdovon_mj.config import AgentConfig, EpisodeConfig
from sdovon_mj.episodes.generate import generate_episodes_with_report
from sdovon_mj.episodes.viewpoints import (VisibilityChecker, candidate_cells, facing, floor_navmap,
                                           load_variant_model, object_box)
from sdovon_mj.records import NavMap, SceneVariant, _encode, load_json
from sdovon_mj.sim import GROUP_AGENT
from sdovon_mj.sim.camera import pose_cv
from sdovon_mj.sim.model import object_segment_id, segment_image
from sdovon_mj.store import dumps
from support.run_folder import build_sample_run


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    root = build_sample_run(tmp_path_factory.mktemp("run"))
    nm = load_json(root / "scenes/room/observe/navmap_0.json", NavMap)
    variants = [load_json(root / f"scenes/room/variants/room_v00{i}/variant.json", SceneVariant) for i in (0, 1)]
    return root, nm, variants


def _cases(root, nm, variant, cfg):
    """Yield (checker, box, cameras (N, 3)) for every placed object of a variant: its candidate cells."""
    model, data = load_variant_model(variant, root)
    agent = AgentConfig()
    checker = VisibilityChecker(model, data, cfg, agent)
    try:
        for p in sorted(variant.placements, key=lambda p: p.object_id):
            box = object_box(model, data, p.object_id)
            if box is None or floor_navmap([nm], float(box.lo[2])) is None:
                continue
            cells = candidate_cells(nm, box, cfg.viewpoint_radius, 1)
            xy = nm.frame.to_world(cells)
            cams = np.column_stack([xy, np.full(len(xy), nm.height + agent.camera_height)])
            yield checker, box, cams
    finally:
        checker.close()


def _rays_clear_plain(checker, cams, box):
    """The ray pre-test with every geom shown and every camera cast from all 27 points."""
    m, d = checker.model, checker.data
    own = checker._own_geom(box)
    half = 0.45 * (box.hi - box.lo)
    out = np.zeros(len(cams), dtype=bool)
    for g in [[x, y, z] for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)]:
        src = box.center + np.array(g, float) * half
        vec = cams - src[None]
        length = np.linalg.norm(vec, axis=1)
        near = length < 1e-6
        unit = np.where(near[:, None], np.array([0.0, 0.0, 1.0]), vec / np.maximum(length, 1e-12)[:, None])
        gid = np.zeros(len(cams), np.int32)
        dist = np.zeros(len(cams))
        mujoco.mj_multiRay(m, d, src, np.ascontiguousarray(unit.ravel()), checker._scene_groups, 1, box.body, gid,
                           dist, None, len(cams), float(length.max()) + 1.0)
        out |= near | (dist < 0) | (dist >= length - 1e-3) | ((gid >= 0) & own[np.maximum(gid, 0)])
    return out


def test_ray_pretest_equals_plain_cast(run):
    root, nm, variants = run
    cfg = EpisodeConfig()
    n = blocked = 0
    for v in variants:
        for checker, box, cams in _cases(root, nm, v, cfg):
            before = checker.model.geom_group.copy()
            got = checker.rays_clear(cams, box)
            assert np.array_equal(checker.model.geom_group, before), "geom groups not restored"
            want = _rays_clear_plain(checker, cams, box)
            assert np.array_equal(got, want), box.object_id
            n += len(cams)
            blocked += int((~want).sum())
    assert n > 100 and blocked > 0, (n, blocked)  # both outcomes occur, so the comparison says something


def _object_pixels(checker, T, box, hidden=None):
    """Object pixels in the visibility render from pose T (optionally with geoms hidden)."""
    groups = checker.model.geom_group
    hidden = np.zeros(0, int) if hidden is None else hidden
    saved = groups[hidden].copy()
    groups[hidden] = GROUP_AGENT
    try:
        frame = checker.renderer.render(T, rgb=False, depth=False, segmentation=True)
    finally:
        groups[hidden] = saved
    return int(np.count_nonzero(segment_image(frame.segmentation, checker.lut) == object_segment_id(box.object_id)))


def test_occluder_masks_and_pixel_bound_against_full_renders(run):
    """Hiding the geoms outside the batched occluder mask keeps the object's pixel count; the pixel bound
    that lets a pitch go unrendered is never below the rendered count (pitches aimed, -30, 0 and 30 deg)."""
    root, nm, variants = run
    cfg = EpisodeConfig()
    rng = np.random.default_rng(0)
    tested = seen = zero_bound = 0
    for checker, box, cams in _cases(root, nm, variants[0], cfg):
        sample = cams[rng.choice(len(cams), size=min(6, len(cams)), replace=False)]
        masks = checker.occluder_masks(sample, box)
        for cam, keep in zip(sample, masks):
            assert np.array_equal(keep, checker.occluder_candidates(cam, box))
            yaw, pitch0 = facing(cam, box.center)
            for pitch in (float(np.clip(pitch0, -80, 80)), -30.0, 0.0, 30.0):
                T = pose_cv(cam, yaw, pitch)
                full = _object_pixels(checker, T, box)
                assert _object_pixels(checker, T, box, checker._drawn[~keep]) == full
                bound = checker._pixel_bound(T, box)
                assert full <= bound, (box.object_id, pitch, full, bound)
                tested += 1
                seen += full > 0
                zero_bound += bound == 0
    assert tested > 20 and seen > 5 and zero_bound > 0, (tested, seen, zero_bound)


def test_stage_output_independent_of_batching(run):
    """Two objects' view points through `generate_episodes_with_report` equal a per-cell recomputation of
    each stored view point's position (one to_world per cell) and are sorted as documented."""
    root, nm, variants = run
    eps, rep = generate_episodes_with_report(variants[0], [nm], root, EpisodeConfig(), 0, AgentConfig())
    assert eps and rep.kept
    for g in eps[0].goals:
        for vp in g.view_points:
            rc = nm.frame.to_cell(vp.position[None, :2])[0]
            xy = nm.frame.to_world(np.array([[rc[0], rc[1]]]))[0]
            assert vp.position[0] == xy[0] and vp.position[1] == xy[1] and vp.position[2] == nm.height
        fr = [vp.visible_fraction for vp in g.view_points]
        assert fr == sorted(fr, reverse=True)


def test_dumps_of_real_episodes_is_json_dumps(run):
    """store.dumps (the fast encoder) gives json.dumps' bytes on real episode records of the sample run."""
    root, nm, variants = run
    eps, _rep = generate_episodes_with_report(variants[0], [nm], root, EpisodeConfig(), 0, AgentConfig())
    data = _encode(eps)
    assert len(eps) > 0
    want = json.dumps(data, sort_keys=True, indent=1, ensure_ascii=False, allow_nan=False) + "\n"
    assert dumps(data) == want


def _ray_pixels_plain(checker, cam, box, yaw, pitch, max_rays=64):
    """The pixel-ray confirmation with one cast against every geom (no hiding, no first cast on the object)."""
    import math

    T = pose_cv(cam, yaw, pitch)
    pc = (box.corners - T[:3, 3]) @ T[:3, :3]
    if (pc[:, 2] <= 1e-3).any():
        return None
    K, w, h = checker.renderer.K, checker.renderer.width, checker.renderer.height
    uv = (pc @ K.T)[:, :2] / pc[:, 2:3]
    u0, u1 = max(0, int(math.floor(uv[:, 0].min()))), min(w - 1, int(math.ceil(uv[:, 0].max())))
    v0, v1 = max(0, int(math.floor(uv[:, 1].min()))), min(h - 1, int(math.ceil(uv[:, 1].max())))
    if u0 > u1 or v0 > v1:
        return None
    step = max(1, int(math.ceil(math.sqrt((u1 - u0 + 1) * (v1 - v0 + 1) / float(max_rays)))))
    us = np.arange(u0 + step // 2, u1 + 1, step, dtype=float) + 0.5
    vs = np.arange(v0 + step // 2, v1 + 1, step, dtype=float) + 0.5
    uu, vv = np.meshgrid(us, vs)
    d_cam = np.stack([(uu.ravel() - K[0, 2]) / K[0, 0], (vv.ravel() - K[1, 2]) / K[1, 1], np.ones(uu.size)], 1)
    d = d_cam @ T[:3, :3].T
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    gid = np.zeros(len(d), np.int32)
    dist = np.zeros(len(d))
    mujoco.mj_multiRay(checker.model, checker.data, cam, np.ascontiguousarray(d.ravel()), checker._scene_groups, 1, -1,
                       gid, dist, None, len(d), 1e6)
    hits = int(np.count_nonzero((gid >= 0) & checker._own_geom(box)[np.maximum(gid, 0)]))
    need = max(int(math.ceil(checker.agent.eta_gt * w * h - 1e-9)), 1)
    return None if hits < need else max(hits * step * step / float(w * h), checker.agent.eta_gt)


def test_pixel_rays_equal_one_plain_cast(run):
    """`ray_pixels` (object-only cast first, occluder hiding) returns what one cast against everything gives."""
    root, nm, variants = run
    confirmed = refused = 0
    for checker, box, cams in _cases(root, nm, variants[0], EpisodeConfig()):
        groups = checker.model.geom_group
        for cam, keep in zip(cams, checker.occluder_masks(cams, box)):
            yaw, pitch0 = facing(cam, box.center)
            for pitch in (float(np.clip(pitch0, -80, 80)), -30.0):
                want = _ray_pixels_plain(checker, cam, box, yaw, pitch)
                hidden = checker._drawn[~keep]
                saved = groups[hidden].copy()
                groups[hidden] = GROUP_AGENT
                try:
                    got = checker.ray_pixels(cam, box, yaw, pitch)
                finally:
                    groups[hidden] = saved
                assert got == want, (box.object_id, cam, pitch, got, want)
                confirmed += got is not None
                refused += got is None
    assert confirmed > 20 and refused > 20, (confirmed, refused)
