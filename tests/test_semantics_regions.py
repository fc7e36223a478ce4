"""Region map: synthetic two-room floors, default-world apartments against true room types, caching."""

from __future__ import annotations


import numpy as np
import pytest

from sdovon_mj.config import SemanticsConfig
from sdovon_mj.records import Instance, NavMap, RegionMap, records_equal
from sdovon_mj.semantics import get_backend, region_map, region_picture

RES = 0.05


def box_instance(k: int, label: str, lo: tuple[float, float, float], hi: tuple[float, float, float]) -> Instance:
    """An instance whose points fill the surface grid of a box."""
    xs, ys, zs = (np.linspace(lo[i], hi[i], 6) for i in range(3))
    pts = np.stack(np.meshgrid(xs, ys, zs), axis=-1).reshape(-1, 3)
    c = pts.mean(axis=0)
    return Instance(id=k, label=label, points=(pts - c).astype(np.float32), center=c)


def two_rooms(door: bool = True) -> tuple[NavMap, list[Instance]]:
    """A 8 m x 3 m floor cut by a wall at x = 4 m (optional 1 m doorway): a bedroom west, a bathroom east."""
    w, h = int(8 / RES), int(3 / RES)
    free = np.ones((h, w), dtype=bool)
    free[:2], free[-2:], free[:, :2], free[:, -2:] = False, False, False, False
    wall = slice(int(3.95 / RES), int(4.05 / RES) + 1)
    free[:, wall] = False
    if door:
        free[int(1.0 / RES):int(2.0 / RES), wall] = True
    insts = [
        box_instance(0, "bed", (0.2, 0.2, 0.0), (2.2, 1.8, 0.5)),
        box_instance(1, "nightstand", (2.3, 0.2, 0.0), (2.8, 0.6, 0.55)),
        box_instance(2, "wardrobe", (0.2, 2.2, 0.0), (1.4, 2.8, 2.0)),
        box_instance(3, "toilet", (7.2, 0.2, 0.0), (7.8, 0.8, 0.45)),
        box_instance(4, "bathtub", (5.0, 2.1, 0.0), (7.8, 2.8, 0.55)),
        box_instance(5, "sink", (4.2, 0.2, 0.6), (4.8, 0.6, 0.85)),
        box_instance(6, "wall", (3.95, 0.0, 0.0), (4.05, 3.0, 2.5)),  # structure: ignored
    ]
    for inst in insts:
        rc = NavMap(0, 0.0, np.zeros(2), RES, free, free).frame.to_cell(inst.world_points[:, :2])
        rc = np.clip(rc, 0, [h - 1, w - 1])
        if inst.label != "wall":
            free[rc[:, 0], rc[:, 1]] = False
    from scipy import ndimage

    nav = ndimage.binary_erosion(free, iterations=3)
    return NavMap(floor=0, height=0.0, origin=np.zeros(2), resolution=RES, navigable=nav, free=free), insts


def test_two_rooms_labels_follow_the_wall(tmp_path):
    navmap, insts = two_rooms()
    b = get_backend(SemanticsConfig())
    rm = region_map(insts, navmap, b)
    assert rm.label_map.shape == navmap.navigable.shape and rm.scores.shape[:2] == navmap.navigable.shape
    assert rm.labels[:6] == list(SemanticsConfig().region_labels)
    assert rm.region_at(np.array([1.5, 1.5])) == "bedroom"
    assert rm.region_at(np.array([6.5, 1.5])) == "bathroom"
    nav = navmap.navigable
    xs = navmap.frame.to_world(np.argwhere(nav))[:, 0]
    lab = rm.label_map[nav]
    west = lab[xs < 3.9] == rm.labels.index("bedroom")
    east = lab[xs > 4.1] == rm.labels.index("bathroom")
    assert west.mean() > 0.9 and east.mean() > 0.9, (west.mean(), east.mean())  # some leak through the door
    assert rm.backend.startswith("offline:") and rm.fallbacks == []
    # picture: written, deterministic
    p1 = region_picture(rm, tmp_path / "a.png", navmap)
    p2 = region_picture(rm, tmp_path / "b.png", navmap)
    assert p1.read_bytes() == p2.read_bytes() and p1.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = RegionMap.from_json(rm.to_json())
    assert records_equal(again, rm)
    assert records_equal(region_map(insts, navmap, b), rm)


def test_paper_plain_disc_leaks_through_walls():
    """Without wall cutting (the paper's plain disc), labels cross the wall near it; with it they do not."""
    navmap, insts = two_rooms(door=False)
    b = get_backend(SemanticsConfig())
    cut = region_map(insts, navmap, b, SemanticsConfig(window_walls=True))
    disc = region_map(insts, navmap, b, SemanticsConfig(window_walls=False))

    def wrong(rm: RegionMap) -> int:
        cells = np.argwhere(navmap.navigable)
        xs = navmap.frame.to_world(cells)[:, 0]
        lab = rm.label_map[navmap.navigable]
        want = np.where(xs < 4.0, rm.labels.index("bedroom"), rm.labels.index("bathroom"))
        return int(np.sum(lab != want))

    assert wrong(cut) == 0
    assert wrong(disc) > wrong(cut)


def test_walking_votes_stop_labels_leaking_through_the_door():
    """A doorway joins the rooms: walking-distance votes label at least as many cells right as straight-line ones.

    Through a 1 m door the far room's cells are a longer walk than a straight line from a window centre
    near the door, so walking votes reach fewer of them and weigh those they reach less; walls still cut
    both (window_walls). Same instances, same backend: only the weighting differs.
    """
    navmap, insts = two_rooms(door=True)
    b = get_backend(SemanticsConfig())

    def right(rm: RegionMap) -> int:
        cells = np.argwhere(navmap.navigable)
        xs = navmap.frame.to_world(cells)[:, 0]
        lab = rm.label_map[navmap.navigable]
        want = np.where(xs < 4.0, rm.labels.index("bedroom"), rm.labels.index("bathroom"))
        return int(np.sum(lab == want))

    walk = region_map(insts, navmap, b, SemanticsConfig(region_votes="walking"))
    line = region_map(insts, navmap, b, SemanticsConfig(region_votes="euclidean"))
    assert SemanticsConfig().region_votes == "walking"
    assert right(walk) >= right(line)
    assert right(walk) > 0.9 * int(navmap.navigable.sum())


def test_no_instances_gives_unknown_map():
    navmap, _ = two_rooms()
    rm = region_map([], navmap, get_backend(SemanticsConfig()))
    assert (rm.label_map == -1).all() and rm.region_at(np.array([1.0, 1.0])) == ""


def test_bad_window_config():
    navmap, insts = two_rooms()
    with pytest.raises(ValueError, match="positive"):
        region_map(insts, navmap, get_backend(SemanticsConfig()), SemanticsConfig(window_step=0.0))


def test_region_map_cached_second_run_makes_no_request(tmp_path):
    """Through an LLM server: the second region map with the same inputs sends no request, same record."""
    from test_semantics_backends import FakeLLM, cfg_for

    navmap, insts = two_rooms()
    fake = FakeLLM("ollama", "good")
    try:
        cfg = cfg_for("ollama", fake.url)
        rm1 = region_map(insts, navmap, get_backend(cfg, cache_dir=tmp_path), cfg)
        n = len(fake.chat_requests)
        assert n >= 2  # one question per distinct window label set
        assert len({r["body"]["messages"][3]["content"] for r in fake.chat_requests}) == n  # each set asked once
        b2 = get_backend(cfg, cache_dir=tmp_path)
        rm2 = region_map(insts, navmap, b2, cfg)
        assert len(fake.chat_requests) == n and b2.requests == 0
        assert records_equal(rm1, rm2)
        assert rm1.backend.startswith("ollama:test-model")
        assert rm1.labels[0] == "kitchen"  # the fake proposes kitchen first everywhere
        assert (rm1.label_map[navmap.navigable] == 0).all()
    finally:
        fake.close()


# ------------------------------------------------------------------------------------------------
# default world


def _world():
    from sdovon_mj.world import generate_apartment

    return generate_apartment


def test_default_world_region_map_agrees_with_room_types():
    """Offline backend, ground-truth instances, 5 apartments: >= 80 % of navigable cells get the true room type."""
    from support.groundtruth import apartment_instances, apartment_navmap, region_accuracy

    generate_apartment = _world()
    b = get_backend(SemanticsConfig())
    hit = total = 0
    per_seed = []
    for seed in range(5):
        apt = generate_apartment(seed)
        insts = apartment_instances(apt)
        s_hit = s_tot = 0
        for fl in apt.floors:
            nav = apartment_navmap(apt, fl.index)
            acc = region_accuracy(region_map(insts, nav, b), apt, nav)
            s_hit += sum(a for a, _ in acc.values())
            s_tot += sum(n for _, n in acc.values())
        per_seed.append(s_hit / s_tot)
        hit, total = hit + s_hit, total + s_tot
    assert total > 10000
    assert hit / total >= 0.80, (hit / total, per_seed)
    assert min(per_seed) >= 0.6, per_seed
    assert b.fallbacks == []


def test_groundtruth_instances_and_navmap():
    from support.groundtruth import apartment_instances, apartment_navmap

    apt = _world()(0)
    insts = apartment_instances(apt)
    assert insts and all(i.label not in ("wall", "floor", "ceiling") for i in insts)
    assert all(len(i.points) >= 8 for i in insts)
    nav = apartment_navmap(apt, 0)
    assert nav.navigable.any() and not (nav.navigable & ~nav.free).any()
    # furniture blocks the map: the cell under a bed / sofa centre is not free
    big = [i for i in insts if i.label in ("bed", "sofa", "table")]
    assert big and not nav.is_navigable(np.asarray(big[0].center)[None, :2])[0]


@pytest.mark.parametrize("label, want", [
    ("HingeCabinet", "cabinet"), ("slidecabinet", "cabinet"), ("kitchen_cabinet_door_link", "kitchen cabinet"),
    ("Fridge_Body.001", "fridge"), ("left_nightstand_Cube", "nightstand"), ("BED_oak_02", "bed"),
    ("sofa/cushion", "sofa cushion"), ("toilet_seat_lid", "toilet"), ("shelf wall", "shelf"),
    ("Cube.012", ""), ("Plane", ""), ("mesh_3", ""), ("wall", "wall"), ("Wall_Panel.004", "wall"),
    ("side table", "side table"), ("floor lamp", "floor lamp"), ("microwave", "microwave"),
])
def test_room_label_takes_naming_noise_out(label: str, want: str) -> None:
    """Camel case, separators, numbering, run-together words, part / joint / link, primitive, position and material
    words go; a label the priors know as written stays as it is; a label of noise alone says nothing ('')."""
    from sdovon_mj.semantics.regions import room_label

    assert room_label(label) == want


def test_node_named_rooms_vote_like_their_names(tmp_path):
    """The two rooms of `two_rooms` with every label written as a node name (support.node_names) and the
    dividing wall as 'Cube.001': the same rooms as with the plain labels."""
    from support.node_names import node_named_instances

    navmap, insts = two_rooms()
    named = node_named_instances(insts, ["wall"])
    assert [i.label for i in named][:2] == ["Bed_Door.000", "nightstand_link"] and named[-1].label.startswith("Cube.")
    rm = region_map(named, navmap, get_backend(SemanticsConfig()))
    assert rm.region_at(np.array([1.5, 1.5])) == "bedroom" and rm.region_at(np.array([6.5, 1.5])) == "bathroom"


def test_one_room_is_one_region_and_a_door_makes_two():
    from sdovon_mj.semantics.regions import floor_space, room_count

    navmap, insts = two_rooms(door=True)
    furniture = [i for i in insts if i.label != "wall"]  # region_map leaves building pieces out of the floor space
    assert room_count(floor_space(furniture, navmap), RES) == 2  # a 1 m doorway parts them
    open_plan = np.asarray(navmap.free).copy()
    open_plan[:, int(3.95 / RES):int(4.05 / RES) + 1] = True  # no wall: one 8 m x 3 m room
    one = NavMap(floor=0, height=0.0, origin=np.zeros(2), resolution=RES, navigable=navmap.navigable | open_plan,
                 free=open_plan)
    assert room_count(floor_space(furniture, one), RES) == 1
    rm = region_map(insts, one, get_backend(SemanticsConfig()))
    assert len(set(rm.label_map[rm.label_map >= 0].tolist())) == 1  # bed and toilet in one room: one region
