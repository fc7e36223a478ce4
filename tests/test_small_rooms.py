"""Small rooms: the coverage sampler's stall rules, and the hints (sdovon_mj/hints.py) followed to a run with episodes.

A 2 x 2 m cluttered room (tests/support/small_room.py, written here) with furniture whose labels are no
receptacle label and no name the offline semantics backend gives a receptacle ("otherfurniture", as ScanNet's
NYU40 classes have it). At the defaults the observe stage refuses it (its navigable component is under 1 m^2) and
says what to set; each run below follows the hint the last one printed and gets past the outcome it named:
the refusal, no receptacle plane, no episode (no start lies 1 m from a goal in a room this small).
"""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.commands.generate import empty_warnings
from sdovon_mj.config import ObserveConfig, load_config
from sdovon_mj.observe import coverage_viewpoints, scene_floors_and_maps
from sdovon_mj.observe.coverage import STOP_BOUND, STOP_DRAWS, STOP_NO_GAIN, viewpoint_bound
from sdovon_mj.pipeline import generate
from sdovon_mj.records import NavMap
from sdovon_mj.sim.model import load_scene_mesh
from support.small_room import write_small_room

# Small settings (a cheap run, the same claims): four quick object categories, one variant, small images, coverage
# views only, exact label matching (no sentence-embedding model to load).
SMALL = ["world.object_categories=[can,remote,book,apple]", "world.object_variants=1", "observe.width=160",
         "observe.height=120", "observe.yaw_steps=4", "observe.camera_heights=[]", "observe.targeted_views=0",
         "perceive.label_similarity=exact", "place.k_v=1", "episodes.k_e=1"]
LABELS = {"table": "otherfurniture", "sofa": "daybed", "chair": "box"}


def _hint(text: str) -> str:
    """Return the one ``--set KEY=VALUE`` a hint names (the test fails when there is none or several)."""
    found = re.findall(r"--set (\S+=\S+)", text)
    assert len(found) == 1, text
    return found[0]


def _run(run: Path, room: Path, sets: list[str]):
    """Run generate on the room with the small settings and `sets`; return the summary."""
    return generate(run, load_config(None, SMALL + sets), scenes=[str(room)], progress=False)


@pytest.mark.slow
def test_a_small_cluttered_room_follows_its_hints_to_episodes(tmp_path: Path) -> None:
    room = write_small_room(tmp_path / "small_room.glb", size=2.0, labels=LABELS)
    run = tmp_path / "run"
    sets: list[str] = []

    # 1. defaults: the observe stage refuses the room and names observe.min_component_area (not convert.add_floor:
    # the room has a floor)
    s = _run(run, room, sets)
    err = next(f.error for f in s.failures if f.spec.label == "small_room")
    print(err)
    assert "no navigable area" in err and "add_floor" not in err, err
    sets.append(_hint(err))
    key, value = sets[-1].split("=")
    assert key == "observe.min_component_area" and 0 < float(value) < ObserveConfig().min_component_area, sets

    # 2. following it, the room gets past observe; its sampler stops early (the goal is out of reach on this floor)
    # and the run logs the coverage reached; nothing is a receptacle: the warning names the labels to take
    s = _run(run, room, sets)
    assert not s.failures, [f.error for f in s.failures]
    obs = json.loads((run / "scenes/small_room/observe/summary.json").read_text())
    (floor,) = obs["maps"]
    cov = floor["coverage"]
    assert not cov["reached"] and cov["stopped"] in (STOP_NO_GAIN, STOP_BOUND), cov
    assert cov["accepted"] <= cov["viewpoint_bound"] and cov["iterations"] < load_config(None, SMALL).observe.max_iterations
    notes = [n for r in s.results for n in r.notes if n.startswith("observe: floor 0")]
    assert len(notes) == 1 and f"coverage {cov['coverage']:.3f} of goal 0.95 with {cov['accepted']} view points" in notes[0]
    warn = empty_warnings(str(run))
    print("\n".join(warn))
    assert warn[0].startswith("scene small_room: no receptacle plane found"), warn
    sets.append(_hint(warn[0]))
    assert sets[-1].startswith("receptacles.labels=[") and "otherfurniture" in sets[-1], sets
    assert warn[-1].startswith("the run has 0 episodes"), warn

    # 3. following it, receptacle planes appear; no start lies min_start_distance from a goal: the warning says so
    s = _run(run, room, sets)
    planes = json.loads((run / "scenes/small_room/perceive/planes.json").read_text())
    assert planes, "the hinted receptacle labels gave no plane"
    warn = empty_warnings(str(run))
    print("\n".join(warn))
    assert warn and "0 episodes" in warn[0] and "min_start_distance" in warn[0], warn
    sets.append(_hint(warn[0]))

    # 4. following it, the run ends with episodes and no warning
    s = _run(run, room, sets)
    assert not s.failures
    episodes = [e for v in (run / "scenes/small_room/variants").iterdir() for e in json.loads((v / "episodes.json").read_text())]
    assert episodes and empty_warnings(str(run)) == []

    # the stall rules are what stopped the sampler: without them it draws until max_iterations on this floor
    v, f, _fi = load_scene_mesh(run / "scenes/small_room/scene_mesh.npz")
    cfg = load_config(None, SMALL + sets[:1]).observe
    _floors, (nm,), _sk = scene_floors_and_maps(v, f, cfg, "small_room")
    _vps, _mp, on = coverage_viewpoints(nm, cfg, seed=3)
    _vps, _mp, off = coverage_viewpoints(nm, dataclasses.replace(cfg, coverage_min_gain=0.0, max_viewpoints_per_disc=0.0), seed=3)
    assert not off.reached and off.stopped == STOP_DRAWS and on.stopped in (STOP_NO_GAIN, STOP_BOUND)
    assert on.accepted < off.accepted and on.coverage <= off.coverage


def _open_floor(side_m: float, res: float = 0.05) -> NavMap:
    """Return the navmap of an empty square floor `side_m` on a side (every cell navigable and free)."""
    n = int(round(side_m / res))
    grid = np.ones((n, n), dtype=bool)
    return NavMap(floor=0, height=0.0, origin=np.zeros(2), resolution=res, navigable=grid, free=grid)


def test_the_view_point_bound_grows_with_the_floor_area() -> None:
    """ceil(max_viewpoints_per_disc * ceil(area / (pi r_max^2))): 8 on anything up to one disc (7.07 m^2 at r_max
    1.5), then 8 more per disc; 0 turns the bound off."""
    cfg = ObserveConfig()
    bounds = [viewpoint_bound(_open_floor(side), cfg) for side in (0.8, 2.0, 2.7, 6.0, 12.0)]
    assert bounds[0] == bounds[1] == 8 and bounds[2] == 16  # 0.64 and 4 m^2: one disc; 7.29 m^2: two
    assert bounds == sorted(bounds) and bounds[-1] == 8 * int(np.ceil(144 / (np.pi * 1.5 ** 2)))
    assert viewpoint_bound(_open_floor(6.0), dataclasses.replace(cfg, max_viewpoints_per_disc=0.0)) == 0


def test_the_stall_rules_leave_a_reachable_goal_alone() -> None:
    """On an open 6 x 6 m floor the goal is reached at the defaults, with the same view points as with the stall
    rules off: they bite only where the sampler is stuck."""
    cfg = ObserveConfig()
    nm = _open_floor(6.0)
    a = coverage_viewpoints(nm, cfg, seed=1)
    b = coverage_viewpoints(nm, dataclasses.replace(cfg, coverage_min_gain=0.0, max_viewpoints_per_disc=0.0), seed=1)
    assert a[2].reached and a[2].to_dict() == b[2].to_dict() and "stopped" not in a[2].to_dict()
    np.testing.assert_array_equal(np.array([p.position for p in a[0]]), np.array([p.position for p in b[0]]))


@pytest.mark.parametrize("figures, expect", [
    # (largest_m2, widest_m, free_m2, floor_m2, below_m) -> the setting named
    ((0.74, 0.4, 1.5, 4.5, 0.1), "observe.min_component_area=0.74"),
    ((0.0, 0.15, 0.8, 4.5, 0.1), "agent.radius=0.14"),
    ((0.0, 0.0, 0.0, 0.0, 0.1), "convert.add_floor=true"),
    ((0.96, 0.5, 3.9, 4.8, 0.86), "convert.add_floor=true"),  # the floor found is a worktop 0.86 m up
])
def test_the_navigable_area_hint_names_what_the_figures_point_to(figures, expect) -> None:
    from sdovon_mj.hints import FloorFigures, no_navigable_area

    largest, widest, free, floor, below = figures
    fig = FloorFigures(floor=0, floor_m2=floor, free_m2=free, eroded_m2=largest, largest_m2=largest, widest_m=widest,
                       below_m=below)
    assert _hint(no_navigable_area([fig], 1.0, 0.18)) == expect


def test_a_corridor_narrower_than_the_agent_follows_its_hints(tmp_path: Path) -> None:
    """A 4 m corridor 0.3 m wide between two blocks: no agent of radius 0.18 m fits. The refusal names agent.radius
    (not add_floor, not min_component_area); following each hint the refusal changes, then the floor is mapped."""
    import trimesh

    from sdovon_mj.config import AgentConfig
    from sdovon_mj.errors import InputError

    parts = [((0.0, 0.0, -0.1), (1.0, 4.0, 0.0)), ((0.0, 0.0, 0.0), (0.35, 4.0, 1.0)), ((0.65, 0.0, 0.0), (1.0, 4.0, 1.0))]
    boxes = []
    for lo, hi in parts:
        b = trimesh.creation.box(extents=np.subtract(hi, lo))
        b.apply_translation(np.add(lo, hi) / 2)
        boxes.append(b)
    mesh = trimesh.util.concatenate(boxes)
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    cfg, agent = ObserveConfig(), AgentConfig()
    seen = []
    for _ in range(3):
        try:
            _floors, maps, _sk = scene_floors_and_maps(v, f, cfg, "corridor", agent)
            break
        except InputError as e:
            key, value = _hint(str(e)).split("=")
            seen.append(key)
            if key == "agent.radius":
                assert float(value) < AgentConfig().radius
                agent = dataclasses.replace(agent, radius=float(value))
            else:
                assert key == "observe.min_component_area", str(e)
                cfg = dataclasses.replace(cfg, min_component_area=float(value))
    else:
        pytest.fail(f"still refused after following {seen}")
    assert seen[0] == "agent.radius" and maps[0].navigable.any(), seen


def test_a_floor_under_min_floor_area_follows_its_hint(tmp_path: Path) -> None:
    """A 1.2 x 1.2 m scan of a floor with a low box on it (1.44 m^2 < min_floor_area 2 m^2): no storey is found and
    the refusal names observe.min_floor_area; following it, the floor is found."""
    import trimesh

    from sdovon_mj.errors import InputError
    from sdovon_mj.observe import find_floors

    floor = trimesh.creation.box(extents=(1.2, 1.2, 0.05))
    floor.apply_translation((0.6, 0.6, -0.025))
    box = trimesh.creation.box(extents=(0.3, 0.3, 0.3))
    box.apply_translation((0.6, 0.6, 0.15))
    mesh = trimesh.util.concatenate([floor, box])
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    with pytest.raises(InputError) as err:
        scene_floors_and_maps(v, f, ObserveConfig(), "scan")
    key, value = _hint(str(err.value)).split("=")
    assert key == "observe.min_floor_area" and float(value) < ObserveConfig().min_floor_area, str(err.value)
    floors = find_floors(v, f, dataclasses.replace(ObserveConfig(), min_floor_area=float(value)))
    assert [fl.height for fl in floors] == [0.0]
