"""The default world's house preset: its design bounds, its geometry (stairs, openings), clutter labels, writers."""

from __future__ import annotations

import json
from collections import Counter
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import trimesh

from sdovon_mj.world import OBJECT_CATEGORIES, generate_apartment, generate_house, write_apartment
from sdovon_mj.world.houseplan import GOING, HOUSE_ROOM_TYPES, LANE, REQUIRED, RISERS, ROOMS, plan_house
from sdovon_mj.world.layout import STOREY_HEIGHT, WALL_T

PLAN_SEEDS = range(40)


@lru_cache(maxsize=None)
def house(seed: int, floors: int | None = None):
    """Generate (once per test session) the house of a seed."""
    return generate_house(seed, floors)


def _rect(r) -> tuple[float, float, float, float]:
    return r.x0, r.y0, r.x1, r.y1


def _overlap(a, b) -> float:
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return max(w, 0.0) * max(h, 0.0)


def test_house_plans_keep_the_design_bounds() -> None:
    """Bounds that follow from the preset's definition (houseplan.py), on 40 seeded plans: 8-16 rooms (drawn again
    otherwise), 1-3 storeys, the required room types, disjoint rooms, a ground floor that is not one rectangle (an
    arm or garage always leaves the main wing), every room of a storey reachable through doors, doorways at least
    0.9 m clear, hallways at least 1.25 m wide, and with several storeys one stairwell per storey, stacked, holding
    one flight per pair of storeys that climbs a storey in RISERS steps."""
    shapes = Counter()
    for s in PLAN_SEEDS:
        p = plan_house(s)
        shapes[p.shape] += 1
        assert ROOMS[0] <= len(p.rooms) <= ROOMS[1], s
        assert 1 <= p.storeys <= 3 and {r.floor for r in p.rooms} == set(range(p.storeys))
        types = [r.type for r in p.rooms]
        assert set(REQUIRED) <= set(types) and set(types) <= set(HOUSE_ROOM_TYPES), s
        assert [r.id for r in p.rooms] == list(range(len(p.rooms)))
        for fl in range(p.storeys):
            rooms = [r for r in p.rooms if r.floor == fl]
            for i, a in enumerate(rooms):
                assert all(_overlap(_rect(a), _rect(b)) < 1e-9 for b in rooms[i + 1:]), (s, a, rooms)
            # doors join the storey's rooms into one graph
            seen, todo = {rooms[0].id}, [rooms[0].id]
            while todo:
                k = todo.pop()
                for d in p.doors:
                    if d.floor == fl and k in (d.room_a, d.room_b):
                        o = d.room_b if d.room_a == k else d.room_a
                        if o not in seen:
                            seen.add(o)
                            todo.append(o)
            assert seen == {r.id for r in rooms}, (s, fl)
        ground = [r for r in p.rooms if r.floor == 0]
        x0, y0 = min(r.x0 for r in ground), min(r.y0 for r in ground)
        x1, y1 = max(r.x1 for r in ground), max(r.y1 for r in ground)
        assert sum((r.x1 - r.x0) * (r.y1 - r.y0) for r in ground) < (x1 - x0) * (y1 - y0) - 1.0, s
        assert all(d.width - 0.1 >= 0.9 - 1e-9 for d in p.doors)
        assert all(min(r.x1 - r.x0, r.y1 - r.y0) >= 1.25 - 1e-9 for r in p.rooms if r.type == "hallway")
        wells = [r for r in p.rooms if r.type == "stairwell"]
        assert len(p.flights) == p.storeys - 1
        if p.storeys > 1:
            assert len(wells) == p.storeys and len({_rect(w) for w in wells}) == 1
            for f in p.flights:
                well = p.rooms[f.room]
                assert well.type == "stairwell" and p.rooms[f.arrives].floor == f.floor + 1
                assert well.x0 < f.lane[0] < f.lane[2] < well.x1 and well.y0 < f.lane[1] < f.lane[3] < well.y1
                run = (f.lane[2] - f.lane[0]) if f.rises in ("E", "W") else (f.lane[3] - f.lane[1])
                width = (f.lane[3] - f.lane[1]) if f.rises in ("E", "W") else (f.lane[2] - f.lane[0])
                assert abs(run - (RISERS - 1) * GOING) < 1e-6 and abs(width - LANE) < 1e-6
        else:
            assert not wells
    assert len(shapes) >= 3, shapes  # L, T, U and courtyard footprints all come up


def test_houses_are_seeded_and_not_apartments(tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        h = generate_house(1)  # fresh generation each time, not the cache
        assert write_apartment(h, out, "clean").name == "house_0001.glb"
    assert {p.name: p.read_bytes() for p in a.iterdir()} == {p.name: p.read_bytes() for p in b.iterdir()}
    assert not np.array_equal(house(1).mesh.vertices[:200], house(2).mesh.vertices[:200])
    assert len(json.loads((a / "house_0001.semantics.json").read_text())["rooms"]) > len(generate_apartment(1).rooms)


@pytest.mark.parametrize("seed,floors", [(0, 1), (2, 3)])
def test_house_geometry_labels_and_stairs(seed: int, floors: int) -> None:
    h = house(seed, floors)
    m = h.mesh
    assert len(h.floors) == floors and h.preset == "house"
    assert set(np.unique(m.face_instance)) == set(range(len(h.instances)))  # no empty instance
    for inst in h.instances:
        assert h.rooms[inst.room].floor == inst.floor
        assert bool(inst.support_surfaces) == (inst.kind == "receptacle")
        if inst.kind != "structure":  # inside its room's walls, within its storey
            v = m.vertices[m.faces[m.face_instance == inst.id]].reshape(-1, 3)
            r = h.rooms[inst.room].polygon
            assert np.all(v[:, :2] >= r.min(0) + 0.5 * WALL_T - 1e-6) and np.all(v[:, :2] <= r.max(0) - 0.5 * WALL_T + 1e-6)
            z0 = h.floors[inst.floor].height
            assert v[:, 2].min() >= z0 - 1e-6, inst
            if inst.label != "stairs":
                assert v[:, 2].max() <= z0 + h.wall_height + 1e-6, inst
    # clutter labels: never an object-library category (a goal names only placed objects); all in the semantic
    # priors' table (no embedding look-up while the semantics stage reads a house)
    from sdovon_mj.semantics.priors import default_priors

    cats = {c.replace("_", " ") for c in OBJECT_CATEGORIES}
    labels = {i.label for i in h.instances}
    assert not labels & cats
    pri = default_priors()
    assert not {lab for lab in labels if pri.resolve(lab, embed=False) is None}
    # stairs: a flight rises a storey in steps; the storey above has no floor over it
    stairs = [i for i in h.instances if i.label == "stairs"]
    assert len(stairs) == 2 * (floors - 1)  # the flight and, a storey up, its railing
    for i in stairs:
        z = m.vertices[m.faces[m.face_instance == i.id]][..., 2]
        z0 = h.floors[i.floor].height
        if z.max() > z0 + 1.5:  # the flight
            assert abs(z.max() - (z0 + STOREY_HEIGHT * (RISERS - 1) / RISERS)) < 1e-6
            assert z.min() >= z0 - 1e-6
            xy = m.vertices[m.faces[m.face_instance == i.id]][..., :2].reshape(-1, 2)
            centre = 0.5 * (xy.min(0) + xy.max(0))
            above = [j.id for j in h.instances if j.label == "floor" and j.floor == i.floor + 1]
            tri = m.vertices[m.faces[np.isin(m.face_instance, above)]]
            hit = [t for t in tri if abs(t[:, 2].max() - h.floors[i.floor + 1].height) < 1e-6
                   and t[:, 0].min() <= centre[0] <= t[:, 0].max() and t[:, 1].min() <= centre[1] <= t[:, 1].max()]
            assert not hit  # an opening in the floor above
        else:  # the railing round that opening
            assert 0.9 <= z.max() - z0 <= 1.0


@pytest.mark.slow
def test_house_writers_hm3d_mp3d_habitat_scan(tmp_path: Path) -> None:
    h = house(0, 1)
    n_rooms = len(h.rooms)
    write_apartment(h, tmp_path / "hm3d", "hm3d", name="h")
    lines = (tmp_path / "hm3d" / "h.semantic.txt").read_text().splitlines()
    assert lines[0] == "HM3D Semantic Annotations" and len(lines) - 1 == len(h.instances)
    assert {int(x.rsplit(",", 1)[1]) for x in lines[1:]} == set(range(n_rooms))
    write_apartment(h, tmp_path / "mp3d", "mp3d", name="h")
    house_file = (tmp_path / "mp3d" / "h.house").read_text().splitlines()
    assert sum(x.startswith("R ") for x in house_file) == n_rooms and sum(x.startswith("L ") for x in house_file) == 1
    codes = {x.split()[5] for x in house_file if x.startswith("R ")}
    assert {"h", "e"} <= codes  # hallway, entryway (Matterport's region codes)
    write_apartment(h, tmp_path / "hab", "habitat", name="h")
    sem = json.loads((tmp_path / "hab" / "semantics" / "h.semantic_config.json").read_text())
    assert len(sem["region_annotations"]) == n_rooms
    path = write_apartment(h, tmp_path / "scan", "scan", name="h", max_faces=40_000)
    ply = trimesh.load(path, process=False)
    agg = json.loads((tmp_path / "scan" / "h.aggregation.json").read_text())
    segs = json.loads((tmp_path / "scan" / "h_vh_clean.segs.json").read_text())["segIndices"]
    assert len(segs) == len(ply.vertices) and len(ply.faces) > 0
    label = {i.id: i.label for i in h.instances}
    assert all(g["label"] == label[g["id"]] for g in agg["segGroups"])
    grouped = {g["id"] for g in agg["segGroups"]}
    assert {i.id for i in h.instances if i.label in ("floor", "wall")} <= grouped  # large surfaces survive the scan
