"""A third-party artist's kitchen (Blender-style GLB: Y up, nested transformed nodes, node names such as
'Cabinet_Base.001', 'Countertop_Marble', 'Cube.012', no semantic sidecar) goes through convert and generate.

The default receptacle list matches none of its labels, so receptacle identification asks the semantics
backend (prompt C.1) among the instance labels (`receptacles.llm_share`); a scene whose labels match the list
enough is not asked. The end-to-end test runs `generate --scenes kitchen.glb` with the default config and
the default object library, smaller only where the point does not depend on it (see `SMALL`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from assets_convert.scene import convert_scene
from sdovon_mj.config import RunConfig, load_config
from sdovon_mj.errors import InputError
from sdovon_mj.perceive.surfaces import receptacle_labels
from sdovon_mj.receptacles import receptacle_instances
from sdovon_mj.records import Instance, SceneAsset
from sdovon_mj.sim.model import load_scene_mesh
from support.artist_kitchen import write_artist_kitchen

from test_generate import cli


@pytest.fixture(scope="module")
def kitchen(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, SceneAsset, Path]:
    """The kitchen GLB, its converted SceneAsset and the conversion's output root."""
    root = tmp_path_factory.mktemp("kitchen")
    glb = write_artist_kitchen(root / "in" / "kitchen.glb")
    asset = convert_scene(glb, root / "out", cache_dir="off")
    return glb, asset, root / "out"


def gt_instances(asset: SceneAsset, out: Path) -> list[Instance]:
    """One fused-like Instance per scene instance (its mesh vertices), carrying its ground-truth id."""
    v, f, fi = load_scene_mesh(out / asset.mesh)
    insts = []
    for s in asset.instances:
        pts = v[np.unique(f[fi == s.id])]
        c = pts.mean(axis=0)
        insts.append(Instance(id=len(insts), label=s.label, points=(pts - c).astype(np.float32), center=c, gt_id=s.id))
    return insts


class CountingBackend:
    """The offline backend, counting the receptacle questions (prompt C.1) it is asked.

    Both offline modes answer C.1 from the same table; the table mode is built here as it loads no relevance model.
    """

    def __init__(self) -> None:
        from dataclasses import replace

        from sdovon_mj.semantics import get_backend

        self.inner = get_backend(replace(RunConfig().semantics, offline_model="table"))
        self.asked: list[list[str]] = []

    def receptacles(self, labels: list[str]) -> list[str]:
        self.asked.append(list(labels))
        return self.inner.receptacles(labels)


def test_kitchen_converts_z_up_with_nested_transforms_and_clean_labels(kitchen) -> None:
    _glb, asset, _out = kitchen
    by = {}
    for s in asset.instances:
        by.setdefault(s.label, []).append(s.bounds)
    # labels as a person names the pieces: Blender duplicate suffixes and numbers gone, no sidecar needed
    assert {"cabinet base", "countertop marble", "fridge body", "upper cabinet", "kitchen island", "bar stool",
            "shelf wall", "sink", "oven", "dining table"} <= set(by)
    assert not [lab for lab in by if any(ch.isdigit() for ch in lab) or "." in lab]
    # Y up became Z up: the floor plane is flat at z = 0 and the fridge (1.8 m tall in its node's scale) stands on it
    (plane,) = by["plane"]
    assert plane[0, 2] == pytest.approx(0.0, abs=1e-6) and plane[1, 2] == pytest.approx(0.0, abs=1e-6)
    (fridge,) = by["fridge body"]
    assert fridge[1, 2] - fridge[0, 2] == pytest.approx(1.8, abs=1e-6)
    # the island's node turns it 90 degrees about up: its 1.8 m side runs along world Y, its 0.8 m side along X
    (island,) = by["kitchen island"]
    np.testing.assert_allclose(island[1] - island[0], [0.8, 1.8, 0.86], atol=1e-6)
    # the counter run is nested twice (Kitchen -> Counter_Run): its worktop top at 0.9 m, against the back wall
    (top,) = by["countertop marble"]
    assert top[1, 2] == pytest.approx(0.9, abs=1e-6)
    wall = max(by["cube"], key=lambda b: b[1, 0] - b[0, 0])  # the back wall: the widest cube
    assert top[1, 1] == pytest.approx(wall[0, 1], abs=0.06)
    # the fridge door is the body's child: placed in the body's scaled frame, in front of it (-Y after Y-up -> Z-up)
    (door,) = by["fridge door"]
    assert door[1, 1] <= fridge[0, 1] + 1e-6 and door[1, 2] - door[0, 2] == pytest.approx(0.98 * 1.8, abs=1e-6)


def test_floorless_kitchen_names_add_floor_and_walks_with_it(tmp_path: Path) -> None:
    from sdovon_mj.config import ObserveConfig
    from sdovon_mj.observe.stage import scene_floors_and_maps

    glb = write_artist_kitchen(tmp_path / "bare" / "kitchen.glb", floor=False)
    plain = convert_scene(glb, tmp_path / "a", cache_dir="off")
    v, f, _fi = load_scene_mesh(tmp_path / "a" / plain.mesh)
    with pytest.raises(InputError, match="convert.add_floor=true"):
        scene_floors_and_maps(v, f, ObserveConfig(), "kitchen")
    floored = convert_scene(glb, tmp_path / "b", cache_dir="off", add_floor=True)
    v, f, _fi = load_scene_mesh(tmp_path / "b" / floored.mesh)
    floors, maps, _skipped = scene_floors_and_maps(v, f, ObserveConfig(), "kitchen")
    assert len(floors) == 1 and maps[0].navigable.any()


def test_receptacles_named_by_the_backend_when_the_list_matches_little(kitchen) -> None:
    _glb, asset, out = kitchen
    insts = gt_instances(asset, out)
    cfg = RunConfig()
    # the prespecified list alone finds no receptacle in the artist's names (the 0-episode run)
    assert receptacle_instances(insts, cfg.receptacles.labels) == []
    off = load_config(overrides=["receptacles.llm_share=0"])
    backend = CountingBackend()
    assert list(receptacle_labels(insts, off, backend, asset)) == list(cfg.receptacles.labels)
    assert backend.asked == []
    # with the default share the backend names receptacles among the instance labels, once
    labels = receptacle_labels(insts, cfg, backend, asset)
    assert len(backend.asked) == 1 and set(backend.asked[0]) == {i.label for i in insts}
    found = {i.label for i in receptacle_instances(insts, labels)}
    assert {"countertop marble", "kitchen island", "dining table"} <= found
    # walls, the floor plane, the fridge and the oven are no place to put things
    assert not found & {"cube", "plane", "fridge body", "fridge door", "oven"}


def test_a_list_that_matches_enough_is_not_sent_to_the_backend(kitchen) -> None:
    _glb, asset, out = kitchen
    clean = {"countertop marble": "counter", "kitchen island": "table", "dining table": "table"}
    insts = [Instance(id=i.id, label=clean.get(i.label, i.label), points=i.points, center=i.center, gt_id=i.gt_id)
             for i in gt_instances(asset, out)]
    cfg = RunConfig()
    share = len(receptacle_instances(insts, cfg.receptacles.labels)) / len(insts)
    assert share >= cfg.receptacles.llm_share  # the premise: these labels match the list enough
    backend = CountingBackend()
    assert list(receptacle_labels(insts, cfg, backend, asset)) == list(cfg.receptacles.labels)
    assert backend.asked == []
    # and the threshold is what decides: above this scene's share the backend is asked
    above = load_config(overrides=[f"receptacles.llm_share={min(1.0, share + 0.01)}"])
    receptacle_labels(insts, above, backend, asset)
    assert len(backend.asked) == 1


def test_assets_yaml_receptacle_flags_win_over_labels(kitchen, tmp_path: Path) -> None:
    glb, _asset, _out = kitchen
    folder = tmp_path / "flagged"
    folder.mkdir()
    flagged_glb = folder / "kitchen.glb"
    flagged_glb.write_bytes(glb.read_bytes())
    (folder / "assets.yaml").write_text('nodes:\n  "Shelf_Wall*": {receptacle: true}\n'
                                        '  "upper cabinet": {receptacle: false}\n')
    asset = convert_scene(flagged_glb, tmp_path / "out", cache_dir="off")
    flags = {s.label: s.receptacle for s in asset.instances}
    assert flags["shelf wall"] is True and flags["upper cabinet"] is False and flags["oven"] is None
    # an instance the metadata says nothing of keeps the bytes it had (no 'receptacle' key)
    oven = next(s for s in asset.instances if s.label == "oven")
    assert "receptacle" not in json.loads(oven.to_json())
    insts = gt_instances(asset, tmp_path / "out")
    labels = receptacle_labels(insts, RunConfig(), CountingBackend(), asset)
    found = {i.label for i in receptacle_instances(insts, labels)}
    # the backend calls a 'shelf wall' a wall and an 'upper cabinet' a receptacle: the metadata overrules both
    assert "shelf wall" in found and "upper cabinet" not in found and "countertop marble" in found


def test_kitchen_named_by_its_parts_is_one_kitchen_region(kitchen) -> None:
    """Node names (Cabinet_Base.001, Countertop_Marble, Fridge_Body, Island_Top, Shelf_Wall.002, Cube.012 walls,
    the Plane floor) go to the region question without their naming noise, and the one-room kitchen is one region:
    every receptacle's plane lies in the kitchen (it lay in 'office' and 'dining room' before)."""
    from sdovon_mj.config import ObserveConfig, SemanticsConfig
    from sdovon_mj.observe.stage import scene_floors_and_maps
    from sdovon_mj.records import ReceptaclePlane
    from sdovon_mj.semantics import annotate_planes, get_backend, region_map
    from sdovon_mj.semantics.regions import room_count, floor_space, room_label

    _glb, asset, out = kitchen
    assert [room_label(x) for x in ("Cube.012", "fridge body", "countertop marble", "shelf wall", "island top")] == \
        ["", "fridge", "countertop", "shelf", "island"]
    v, f, _fi = load_scene_mesh(out / asset.mesh)
    _floors, maps, _skipped = scene_floors_and_maps(v, f, ObserveConfig(), "kitchen")
    insts = gt_instances(asset, out)
    cfg = SemanticsConfig()
    rm = region_map(insts, maps[0], get_backend(cfg), cfg)
    pieces = [i for i in insts if room_label(i.label) not in ("", "wall", "floor")]  # as region_map takes them
    assert room_count(floor_space(pieces, maps[0]), maps[0].resolution) == 1
    assert {rm.labels[k] for k in np.unique(rm.label_map[rm.label_map >= 0])} == {"kitchen"}
    receptacles = [s for s in asset.instances if s.label in {"countertop marble", "island top", "dining table",
                                                             "shelf wall", "cabinet base"}]
    planes = [ReceptaclePlane(id=k, instance_id=s.id, label=s.label, height=float(s.bounds[1, 2]),
                              polygon=np.array([[s.bounds[0, 0], s.bounds[0, 1]], [s.bounds[1, 0], s.bounds[0, 1]],
                                                [s.bounds[1, 0], s.bounds[1, 1]], [s.bounds[0, 0], s.bounds[1, 1]]]),
                              normal=np.array([0.0, 0.0, 1.0])) for k, s in enumerate(receptacles)]
    assert {p.region for p in annotate_planes(planes, {0: (maps[0], rm)})} == {"kitchen"}


# Smaller than the defaults only where the point (artist names -> receptacles -> episodes) does not depend on it:
# the demo's 12 object categories with one shape variant each (a cold conversion cache converts 12 objects, not
# the whole library), 160x120 coverage images, no targeted views (our addition: more views of surfaces already
# found), one scene variant. Receptacles, semantics, placement and episodes run with their defaults.
DEMO_CATEGORIES = "[mug, bowl, plate, book, bottle, apple, pillow, laptop, toothbrush, towel, vase, remote]"
SMALL = ["--set", f"world.object_categories={DEMO_CATEGORIES}", "--set", "world.object_variants=1",
         "--set", "observe.width=160", "--set", "observe.height=120", "--set", "observe.targeted_views=0",
         "--set", "place.k_v=1"]


@pytest.mark.slow
def test_generate_on_the_artist_kitchen_gives_episodes(kitchen, tmp_path: Path) -> None:
    glb, _asset, _out = kitchen
    run = tmp_path / "run"
    proc = cli("generate", "--out", str(run), "--scenes", str(glb), *SMALL, "--quiet")
    assert proc.returncode == 0, proc.stderr[-3000:]
    episodes = [e for f in sorted((run / "scenes" / "kitchen" / "variants").glob("*/episodes.json"))
                for e in json.loads(f.read_text())]
    cats = {e["object_category"] for e in episodes}
    assert len(episodes) >= 10 and len(cats) >= 3, (len(episodes), sorted(cats))
    planes = json.loads((run / "scenes" / "kitchen" / "semantics" / "planes.json").read_text())
    assert planes and {p["region"] for p in planes} == {"kitchen"}, [(p["label"], p["region"]) for p in planes]
