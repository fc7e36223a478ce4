"""Fair episodes: the stored geodesic is the suite's SPL denominator; view points cover what sees the object.

The coverage check computes visibility on its own: full-resolution renders (the agent's sensor size, no
geom culling, no ray pre-test) from sampled navigable cells within the view radius, at the pitches that
define a view point (aimed at the object's centre, then ``episodes.pitches``).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj import suite
from sdovon_mj.config import load_config
from sdovon_mj.episodes.viewpoints import facing, load_variant_model, object_box
from sdovon_mj.export import ExportOptions, RunView, run_export
from sdovon_mj.gridgraph import GeodesicField
from sdovon_mj.records import Episode, NavMap, SceneVariant, load_json
from sdovon_mj.sim import GROUP_CEILING, GROUP_OBJECT_VISUAL, GROUP_SCENE
from sdovon_mj.sim.camera import pose_cv
from sdovon_mj.sim.model import geom_segment_ids, object_segment_id, segment_image
from sdovon_mj.sim.render import SceneRenderer
from support.run_folder import build_sample_run
from exporters.mjcf_bundle import MjcfBundleExporter

REPO = Path(__file__).resolve().parents[1]


def test_stored_geodesic_is_the_suite_spl_denominator(tmp_path):
    """For every generated episode, the suite's shortest-path length at reset is the stored geodesic."""
    root = build_sample_run(tmp_path / "run", episodes=True, seed=0)
    out = tmp_path / "mj"
    run_export(MjcfBundleExporter(), RunView(root), out, ExportOptions(name="ds"))
    bdir = out / "ds/room_v000"
    stored = load_json(root / "scenes/room/variants/room_v000/episodes.json", Episode)
    env = suite.load("objectnav", task_kwargs={"bundle": bdir, "width": 32, "height": 24})
    task = env.task
    assert len(task.bundle.episodes) == len(stored) > 0
    for i, ep in enumerate(stored):
        task.set_next_episode(i)
        env.reset()
        assert task.episode.episode_id == ep.episode_id
        assert task.shortest == pytest.approx(ep.geodesic_distance, rel=0, abs=1e-9)
        assert task.shortest >= ep.start_filters["min_geodesic_m"]


DENSE_YAML = """\
name: sdovon-dense
seed: 0
world:
  scene_seeds: [0]
  floors: 1
  object_variants: 1
  object_categories: [mug, bowl, book, bottle, apple, remote]
observe:
  width: 160
  height: 120
  yaw_steps: 4
  pitch_angles: [-30.0, 0.0]
place:
  k_v: 5
  m: 1
episodes:
  k_e: 1
"""


def _sees(renderer: SceneRenderer, lut: np.ndarray, cam: np.ndarray, centre: np.ndarray, seg_id: int,
          pitches: tuple[float, ...], eta: float) -> bool:
    """Return whether a full-resolution render from `cam` (facing the object) shows it at >= eta of the image."""
    yaw, pitch0 = facing(cam, centre)
    for pitch in [float(np.clip(pitch0, -80.0, 80.0)), *pitches]:
        seg = segment_image(renderer.render(pose_cv(cam, yaw, pitch), rgb=False, depth=False, segmentation=True).segmentation, lut)
        if np.count_nonzero(seg == seg_id) / seg.size >= eta:
            return True
    return False


@pytest.mark.slow
def test_view_points_cover_every_cell_that_sees_the_object(tmp_path):
    """On 5 generated default-world variants, >= 95 % of sampled navigable cells within the view radius
    that see a goal (eta_gt, full resolution) are within the success distance of a stored view point."""
    cfg_path = tmp_path / "dense.yaml"
    cfg_path.write_text(DENSE_YAML, encoding="utf-8")
    root = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "generate", "--out", str(root), "--config",
                           str(cfg_path), "--quiet"], cwd=REPO, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr[-3000:]
    cfg = load_config(cfg_path)
    ecfg, agent = cfg.episodes, cfg.agent
    rng = np.random.default_rng(0)
    visible = covered = variants = 0
    for vf in sorted(root.glob("scenes/*/variants/*/variant.json")):
        variant = load_json(vf, SceneVariant)
        eps = load_json(vf.parent / "episodes.json", Episode)
        if not eps:
            continue
        variants += 1
        nm = load_json(next(root.glob(f"scenes/{variant.scene}/observe/navmap_0.json")), NavMap)
        model, data = load_variant_model(variant, root)
        renderer = SceneRenderer(model, data, width=agent.sensor_width, height=agent.sensor_height, hfov=agent.hfov,
                                 groups=(GROUP_SCENE, GROUP_CEILING, GROUP_OBJECT_VISUAL))
        lut = geom_segment_ids(model)
        try:
            goals = {g.object_id: g for e in eps for g in e.goals}
            for oid in sorted(goals)[:3]:
                g = goals[oid]
                box = object_box(model, data, oid)
                # Navigable cells within the view radius of the box footprint (every cell, not a lattice).
                rows, cols = np.nonzero(nm.navigable)
                xy = nm.frame.to_world(np.stack([rows, cols], 1))
                dx = np.maximum(np.maximum(box.lo[0] - xy[:, 0], 0), xy[:, 0] - box.hi[0])
                dy = np.maximum(np.maximum(box.lo[1] - xy[:, 1], 0), xy[:, 1] - box.hi[1])
                near = xy[np.hypot(dx, dy) <= ecfg.viewpoint_radius]
                sample = near[rng.choice(len(near), size=min(40, len(near)), replace=False)]
                field = GeodesicField(nm.navigable, nm.frame, np.array([vp.position[:2] for vp in g.view_points]))
                for p in sample:
                    cam = np.array([p[0], p[1], nm.height + agent.camera_height])
                    if _sees(renderer, lut, cam, box.center, object_segment_id(oid), ecfg.pitches, agent.eta_gt):
                        visible += 1
                        covered += field.distance(p) < ecfg.success_distance
        finally:
            renderer.close()
    assert variants == 5
    assert visible >= 100, f"only {visible} sampled cells see a goal: the sample says little"
    assert covered / visible >= 0.95, f"{covered}/{visible} cells that see the object are near a view point"


def test_candidates_cover_strips_between_lattice_rows():
    """A navigable strip that falls between the lattice's rows (one cell wide, beside a counter) is tested cell by
    cell: every navigable cell within the radius lies within the success distance of a first-pass candidate."""
    from sdovon_mj.episodes.viewpoints import ObjectBox, candidate_cells, covering_cells, lattice_stride

    nav = np.zeros((40, 40), bool)
    nav[5:20, 5:35] = True  # an open area
    nav[25, 5:35] = True  # a strip on row 25, off the stride-3 lattice (rows 0, 3, ..., 24, 27)
    nm = NavMap(floor=0, height=0.0, origin=np.zeros(2), resolution=0.05, navigable=nav, free=nav.copy())
    box = ObjectBox("obj_000", 0, np.array([0.9, 1.35, 0.8]), np.array([1.0, 1.45, 0.9]))  # beside the strip
    stride = lattice_stride(0.05, 0.0, 0.1)
    assert stride == 3
    lattice = candidate_cells(nm, box, 1.0, stride)
    assert not np.any(lattice[:, 0] == 25)  # the lattice alone never stands on the strip
    cand = covering_cells(nm, box, 1.0, stride, 0.1)
    fine = candidate_cells(nm, box, 1.0, 1)
    xy, cxy = nm.frame.to_world(fine), nm.frame.to_world(cand)
    gap = np.min(np.linalg.norm(xy[:, None, :] - cxy[None, :, :], axis=2), axis=1)
    assert gap.max() < 0.1 and np.any(cand[:, 0] == 25)
    # in the open area the lattice is enough: cells are added only at the rim of the radius (their nearest lattice
    # cells lie outside it), none inside
    added = cand[len(lattice):]
    rim = added[added[:, 0] != 25]
    rxy = nm.frame.to_world(rim)
    d = np.hypot(np.maximum(np.maximum(box.lo[0] - rxy[:, 0], 0), rxy[:, 0] - box.hi[0]),
                 np.maximum(np.maximum(box.lo[1] - rxy[:, 1], 0), rxy[:, 1] - box.hi[1]))
    assert np.all(d > 1.0 - 0.1)
