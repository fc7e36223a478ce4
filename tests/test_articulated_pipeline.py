"""Articulated receptacles through observe, perceive, place and episodes (``world.articulated``, issue 17 items 3-5).

One tiny default-world run (apartment 0: kitchen with an articulated fridge, base cabinet and microwave) with every
part closed in the variants: perception (parts open) finds planes inside the pieces and names the joint closing
each; objects placed inside stay where they were put when the doors close (or are classified); the variant records
the parts' state first in its qpos; every goal hidden behind a closed part names it (or is seen through a gap),
and a full render from its first view point (at the episodes' visibility size, as the suite checks) shows the
object with the part open and not with it closed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mujoco

from sdovon_mj.config import load_config
from sdovon_mj.episodes.inside import part_opened, seen_fraction
from sdovon_mj.episodes.viewpoints import load_variant_model
from sdovon_mj.place.inside import DISPLACED, TUNNELLED
from sdovon_mj.records import Episode, ReceptaclePlane, SceneAsset, SceneVariant, load_json
from sdovon_mj.sim.articulation import part_instance, part_joints


CONFIG = """\
name: sdovon-articulated-tiny
seed: 0
world:
  scene_seeds: [0]
  floors: 1
  object_variants: 1
  object_categories: [can, remote, book, apple]
  articulated: true
observe:
  yaw_steps: 4
  pitch_angles: [-30.0, 0.0]
  width: 160
  height: 120
place:
  k_v: 1
  m: 2
  part_open_p: 0.0
  part_ajar_p: 0.0
  part_closed_p: 1.0
episodes:
  k_e: 2
"""


@pytest.fixture(scope="module")
def run(articulated_closed_run: Path) -> Path:
    """The tiny articulated run, to its episodes (shared with tests/test_articulated_suite.py: conftest)."""
    return articulated_closed_run / "run"


@pytest.mark.slow
def test_planes_inside_name_their_part(run: Path) -> None:
    scene = load_json(run / "scenes/apt_0000/scene.json", SceneAsset)
    planes = load_json(run / "scenes/apt_0000/semantics/planes.json", ReceptaclePlane)
    joints = {p.joint: fx for fx in scene.articulated for p in fx.parts}
    inside = [p for p in planes if p.part is not None]
    assert inside, "no plane inside an articulated piece"
    for p in inside:
        fx = joints[p.part]
        lo, hi = scene.instance(fx.instance_id).bounds  # closed box; a door-closed shelf lies in it
        c = np.asarray(p.polygon).mean(axis=0)
        assert lo[2] < p.height < hi[2] and np.all(c > lo[:2]) and np.all(c < hi[:2]), (p.label, p.part)
    # a piece's top (nothing closes over it) keeps part None
    tops = [p for p in planes if p.part is None and any(abs(p.height - scene.instance(fx.instance_id).bounds[1][2]) < 0.03
                                                          for fx in scene.articulated)]
    assert tops


@pytest.mark.slow
def test_variant_state_and_objects_inside_stay(run: Path) -> None:
    v = load_json(run / "scenes/apt_0000/variants/apt_0000_v000/variant.json", SceneVariant)
    planes = {p.id: p for p in load_json(run / "scenes/apt_0000/semantics/planes.json", ReceptaclePlane)}
    scene = load_json(run / "scenes/apt_0000/scene.json", SceneAsset)
    model, data = load_variant_model(v, run)  # raises on a qpos / model size mismatch
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in part_joints(model)]
    assert v.articulation is not None and sorted(v.articulation) == sorted(names)
    for j, n in zip(part_joints(model), names):  # every part closed (part_closed_p = 1), first in qpos
        assert v.articulation[n] == pytest.approx(model.jnt_range[j][0])
        assert data.qpos[model.jnt_qposadr[j]] == pytest.approx(v.articulation[n])
    inside = [p for p in v.placements if planes[p.plane_id].part is not None]
    assert inside
    for p in v.placements:
        if p.status in ("resting", DISPLACED, TUNNELLED):
            assert p.part == planes[p.plane_id].part, p.object_id
    resting = [p for p in inside if p.status == "resting"]
    assert len(resting) >= 0.95 * len([p for p in inside if p.status in ("resting", DISPLACED, TUNNELLED)])
    boxes = {fx.instance_id: scene.instance(fx.instance_id).bounds for fx in scene.articulated}
    for p in resting:  # behind the closed door, inside the piece's box
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.object_id)
        lo, hi = boxes[part_instance(p.part)]
        assert np.all(data.xpos[b] > lo) and np.all(data.xpos[b] < hi), p.object_id


@pytest.mark.slow
def test_hidden_goals_name_the_part_and_show_only_when_open(run: Path) -> None:
    cfg = load_config(run / "config.yaml")
    v = load_json(run / "scenes/apt_0000/variants/apt_0000_v000/variant.json", SceneVariant)
    episodes = load_json(run / "scenes/apt_0000/variants/apt_0000_v000/episodes.json", Episode)
    model, data = load_variant_model(v, run)
    by_obj = {p.object_id: p for p in v.placements}
    goals = {g.object_id: g for e in episodes for g in e.goals}
    vis = (cfg.episodes.vis_width, cfg.episodes.vis_height)  # the view points' definition (the suite checks so)
    # Every part is closed: an object inside one is a goal through its part, or seen through a gap between door and
    # carcass with the part closed (then no part is named, and a render of everything from its first view point must
    # see it).
    hidden = []
    for g in goals.values():
        part = by_obj[g.object_id].part
        if g.open_part is None and part:
            assert seen_fraction(model, data, g, g.view_points[0], cfg.agent, vis) >= cfg.agent.eta_gt, g.object_id
        else:
            assert g.open_part == part, g.object_id
            hidden += [g] if part else []
    checked = 0
    for g in hidden:
        closed = seen_fraction(model, data, g, g.view_points[0], cfg.agent, vis)
        with part_opened(model, data, g.open_part, g.object_id):
            opened = seen_fraction(model, data, g, g.view_points[0], cfg.agent, vis)
        assert opened >= cfg.agent.eta_gt > closed, (g.object_id, opened, closed)
        checked += 1
    assert checked > 0, "no goal hidden behind a closed part in the fixture run"
