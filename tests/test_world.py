"""The embedded default world: procedural apartments (clean GLB / scan PLY) and household objects."""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy import ndimage

from sdovon_mj.world import (
    RECEPTACLE_LABELS,
    ROOM_TYPES,
    generate_apartment,
    write_apartment,
)
from sdovon_mj.world.scan import make_scan

SEEDS = range(10)


@lru_cache(maxsize=None)
def apartment(seed: int, floors: int | None = None):
    """Generate (once per test session) the apartment of a seed."""
    return generate_apartment(seed, floors)


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


# ------------------------------------------------------------------------------------------------
# apartments


def test_same_seed_same_bytes_clean_and_scan(tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        apt = generate_apartment(3)  # fresh generation each time, not the cache
        assert write_apartment(apt, out, "clean").name == "apartment_0003.glb"
        assert write_apartment(apt, out, "scan").name == "apartment_0003_vh_clean.ply"
    fa, fb = _files(a), _files(b)
    assert sorted(fa) == ["apartment_0003.aggregation.json", "apartment_0003.glb", "apartment_0003.semantics.json",
                          "apartment_0003_vh_clean.ply", "apartment_0003_vh_clean.segs.json"]
    assert fa == fb


def test_different_seeds_different_layouts() -> None:
    layouts = set()
    for s in SEEDS:
        apt = apartment(s)
        layouts.add(tuple((r.type, tuple(np.round(r.polygon, 3).ravel())) for r in apt.rooms))
    assert len(layouts) == len(SEEDS)
    assert not np.array_equal(apartment(0).mesh.vertices[:100], apartment(1).mesh.vertices[:100])


def test_coverage_over_first_ten_seeds() -> None:
    room_types, labels, storeys = set(), set(), []
    for s in SEEDS:
        apt = apartment(s)
        assert 3 <= len(apt.rooms) <= 6
        assert 2.5 <= apt.wall_height <= 2.8
        room_types |= {r.type for r in apt.rooms}
        labels |= {i.label for i in apt.instances}
        storeys.append(len(apt.floors))
        # measured wall height from the mesh agrees
        walls = [i.id for i in apt.instances if i.label == "wall" and i.floor == 0]
        wz = apt.mesh.vertices[apt.mesh.faces[np.isin(apt.mesh.face_instance, walls)]][..., 2]
        assert 2.5 <= wz.max() - wz.min() <= 2.8 + 1e-9
    assert room_types == set(ROOM_TYPES)
    assert set(RECEPTACLE_LABELS) <= labels
    assert {"chair", "wardrobe", "toilet", "fridge", "floor", "wall", "ceiling", "door frame"} <= labels
    assert 1 in storeys and 2 in storeys


def test_two_storeys() -> None:
    apt = apartment(0, 2)
    assert [f.index for f in apt.floors] == [0, 1]
    assert apt.floors[0].height == 0.0 and abs(apt.floors[1].height - 3.0) < 1e-9
    for f in (0, 1):
        assert any(r.floor == f for r in apt.rooms)
        floor_ids = [i.id for i in apt.instances if i.label == "floor" and i.floor == f]
        top = apt.mesh.vertices[apt.mesh.faces[np.isin(apt.mesh.face_instance, floor_ids)]][..., 2].max()
        assert abs(top - apt.floors[f].height) < 1e-9
    one = apartment(0, 1)
    assert len(one.floors) == 1 and all(r.floor == 0 for r in one.rooms)


def test_every_face_and_instance_is_labelled() -> None:
    for s in SEEDS:
        apt = apartment(s)
        m = apt.mesh
        assert m.vertices.dtype == np.float64 and m.vertices.shape[1] == 3
        assert len(m.face_instance) == len(m.faces) == len(m.face_color)
        assert m.face_color.dtype == np.uint8 and m.face_color.shape[1] == 4
        assert m.face_instance.min() >= 0 and m.face_instance.max() < len(apt.instances)
        assert set(np.unique(m.face_instance)) == set(range(len(apt.instances)))  # no empty instance
        room_ids = {r.id for r in apt.rooms}
        for inst in apt.instances:
            assert inst.label and inst.kind in ("structure", "receptacle", "furniture")
            assert inst.room in room_ids
            assert apt.rooms[inst.room].floor == inst.floor
            assert bool(inst.support_surfaces) == (inst.kind == "receptacle")
        assert 3000 <= len(m.faces) <= 60000


def test_rooms_are_ccw_and_furniture_inside_its_room() -> None:
    for s in SEEDS:
        apt = apartment(s)
        m = apt.mesh
        for r in apt.rooms:
            p = r.polygon
            area = 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
            assert area > 3.0
        for inst in apt.instances:
            if inst.kind == "structure":
                continue
            v = m.vertices[m.faces[m.face_instance == inst.id]].reshape(-1, 3)
            r = apt.rooms[inst.room].polygon
            lo, hi = r.min(0) + 0.05 - 1e-6, r.max(0) - 0.05 + 1e-6  # inside the walls
            assert np.all(v[:, :2] >= lo) and np.all(v[:, :2] <= hi), (s, inst)
            z0 = apt.floors[inst.floor].height
            assert v[:, 2].min() >= z0 - 1e-6 and v[:, 2].max() <= z0 + apt.wall_height


def test_furniture_does_not_overlap() -> None:
    """3D boxes of furniture pieces are disjoint, except pieces designed to nest (a chair pushed under
    its table, a sink or hob in its counter, a TV on its stand)."""
    nested = {frozenset(p) for p in (("chair", "table"), ("chair", "desk"), ("sink", "counter"), ("stove", "counter"),
                                     ("tv", "tv stand"), ("rug", "coffee table"))}
    for s in SEEDS:
        apt = apartment(s)
        m = apt.mesh
        items = [i for i in apt.instances if i.kind != "structure"]
        boxes = {}
        for inst in items:
            v = m.vertices[m.faces[m.face_instance == inst.id]].reshape(-1, 3)
            boxes[inst.id] = (v.min(0), v.max(0))
        for k, a in enumerate(items):
            for b in items[k + 1:]:
                (alo, ahi), (blo, bhi) = boxes[a.id], boxes[b.id]
                overlap = np.minimum(ahi, bhi) - np.maximum(alo, blo)
                if np.all(overlap > 1e-3):
                    assert frozenset((a.label, b.label)) in nested, (s, a.label, b.label, overlap)


def _polygon_samples(poly: np.ndarray) -> np.ndarray:
    """The centroid and the vertices pulled 60 % towards it (inside a convex polygon)."""
    c = poly.mean(axis=0)
    return np.vstack([c[None], c + 0.4 * (poly - c)])


def test_support_surfaces_are_real_top_faces() -> None:
    for s in SEEDS:
        apt = apartment(s)
        mesh = trimesh.Trimesh(apt.mesh.vertices, apt.mesh.faces, process=False)
        origins, expect = [], []
        for inst in apt.receptacles:
            for sup in inst.support_surfaces:
                p = sup.polygon
                area = 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
                assert area > 0.02, (s, inst.label)  # CCW and not degenerate
                for xy in _polygon_samples(p):
                    origins.append([xy[0], xy[1], sup.height + 0.05])
                    expect.append((inst.id, sup.height))
        origins = np.array(origins)
        dirs = np.tile([0.0, 0.0, -1.0], (len(origins), 1))
        locs, ray_idx, tri_idx = mesh.ray.intersects_location(origins, dirs, multiple_hits=False)
        assert len(ray_idx) == len(origins)
        for loc, ri, ti in zip(locs, ray_idx, tri_idx):
            inst_id, h = expect[ri]
            assert abs(loc[2] - h) <= 1e-3, (s, apt.instances[inst_id].label, loc, h)
            assert apt.mesh.face_instance[ti] == inst_id


def test_bookshelves_have_levels_and_sizes_are_realistic() -> None:
    tops: dict[str, list[float]] = {}
    for s in SEEDS:
        apt = apartment(s)
        for inst in apt.receptacles:
            z0 = apt.floors[inst.floor].height
            hs = sorted(sup.height - z0 for sup in inst.support_surfaces)
            tops.setdefault(inst.label, []).append(hs[-1])
            if inst.label == "bookshelf":
                assert len(hs) in (4, 5) and min(np.diff(hs)) > 0.28
            if inst.label == "shelf":
                assert 1.0 - 1e-9 <= hs[0] and hs[-1] <= 1.6 + 1e-9
    ranges = {"table": (0.72, 0.78), "desk": (0.72, 0.78), "counter": (0.8, 0.93), "coffee table": (0.38, 0.47),
              "nightstand": (0.48, 0.62), "dresser": (0.78, 1.02), "bed": (0.5, 0.65), "sofa": (0.42, 0.48)}
    for label, (lo, hi) in ranges.items():
        assert all(lo <= h <= hi for h in tops[label]), (label, tops[label])


def _nav_grid(apt, floor: int, res: float = 0.05):
    """Walkable cells of a storey from the mesh: no geometry between 2 cm and 1 m above the floor,
    eroded by the agent radius (0.18 m)."""
    m = apt.mesh
    z0 = apt.floors[floor].height
    v = m.vertices
    lo = v[:, :2].min(0) - 0.2
    shape = np.ceil((v[:, :2].max(0) + 0.2 - lo) / res).astype(int)
    occ = np.zeros(shape, dtype=bool)
    floor_cells = np.zeros(shape, dtype=bool)
    tri = v[m.faces]
    tz0, tz1 = tri[..., 2].min(1), tri[..., 2].max(1)
    # cells whose centres lie inside a face's XY box (all walls are >= 0.1 m thick)
    t0 = np.ceil((tri[..., :2].min(1) - lo) / res - 0.5).astype(int)
    t1 = np.floor((tri[..., :2].max(1) - lo) / res - 0.5).astype(int) + 1
    labels = np.array([i.label for i in apt.instances])[m.face_instance]
    for k in np.flatnonzero((tz1 > z0 + 0.02) & (tz0 < z0 + 1.0) & (labels != "ceiling")):
        occ[t0[k, 0]:t1[k, 0], t0[k, 1]:t1[k, 1]] = True
    for k in np.flatnonzero((labels == "floor") & (np.abs(tz1 - z0) < 1e-6)):
        floor_cells[t0[k, 0]:t1[k, 0], t0[k, 1]:t1[k, 1]] = True
    free = floor_cells & ~occ
    nav = ndimage.distance_transform_edt(free) * res > 0.18 + 0.5 * res
    return nav, lo


def test_doors_connect_every_room_and_receptacles_are_reachable() -> None:
    for s in SEEDS:
        apt = apartment(s)
        for f in apt.floors:
            nav, lo = _nav_grid(apt, f.index)
            lab, _ = ndimage.label(nav)
            comps = set()
            for d in apt.doors:
                if d.floor != f.index:
                    continue
                assert d.width >= 0.85 and d.height >= 2.0
                c = np.floor((d.centre[:2] - lo) / 0.05).astype(int)
                comps.add(int(lab[c[0], c[1]]))
            assert len(comps) == 1 and 0 not in comps, (s, f.index, comps)
            main = lab == comps.pop()
            for r in apt.rooms:
                if r.floor != f.index:
                    continue
                a = np.floor((r.polygon.min(0) - lo) / 0.05).astype(int)
                b = np.ceil((r.polygon.max(0) - lo) / 0.05).astype(int)
                assert main[a[0]:b[0], a[1]:b[1]].sum() * 0.0025 > 1.0, (s, r.type)
            for inst in apt.receptacles:
                if inst.floor != f.index:
                    continue
                v = apt.mesh.vertices[apt.mesh.faces[apt.mesh.face_instance == inst.id]].reshape(-1, 3)
                a = np.maximum(0, np.floor((v[:, :2].min(0) - 0.6 - lo) / 0.05).astype(int))
                b = np.ceil((v[:, :2].max(0) + 0.6 - lo) / 0.05).astype(int)
                assert main[a[0]:b[0], a[1]:b[1]].any(), (s, inst.label)


def test_glb_is_y_up_with_named_instance_nodes(tmp_path: Path) -> None:
    apt = apartment(1)
    path = write_apartment(apt, tmp_path, "clean", name="flat")
    assert path.name == "flat.glb" and path.stat().st_size < 2_000_000
    scene = trimesh.load(path)
    ext = scene.bounds[1] - scene.bounds[0]
    assert abs(ext[1] - (apt.wall_height + 0.1 + 0.02)) < 0.01  # slab + walls + ceiling along +Y
    raw = json.loads(path.read_bytes()[20:20 + int.from_bytes(path.read_bytes()[12:16], "little")])
    names = [n["name"] for n in raw["nodes"]]
    assert names == [f"instance_{i.id}" for i in apt.instances]
    assert all(n["extras"]["label"] == apt.instances[k].label for k, n in enumerate(raw["nodes"]))
    assert len(raw["materials"]) >= len(apt.instances) and raw["images"]
    # back to Z up, the GLB geometry is the apartment mesh
    mesh = scene.dump(concatenate=True)
    v = np.asarray(mesh.vertices)
    zup = np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1)
    assert np.allclose(zup.min(0), apt.mesh.vertices.min(0), atol=1e-5)
    assert np.allclose(zup.max(0), apt.mesh.vertices.max(0), atol=1e-5)
    assert len(mesh.faces) == len(apt.mesh.faces)


def test_sidecar_shape(tmp_path: Path) -> None:
    apt = apartment(2)
    write_apartment(apt, tmp_path, "clean")
    text = (tmp_path / "apartment_0002.semantics.json").read_text()
    data = json.loads(text)
    assert text == json.dumps(data, sort_keys=True, indent=1) + "\n"
    assert set(data) == {"format", "name", "seed", "mode", "units", "up", "mesh", "floors", "rooms", "instances"}
    assert data["format"] == "sdovon-world/1" and data["mode"] == "clean" and data["up"] == "+Y"
    assert data["units"] == "m" and data["mesh"] == "apartment_0002.glb" and data["seed"] == 2
    assert all(set(f) == {"index", "height"} for f in data["floors"])
    assert all(set(r) == {"id", "type", "floor", "polygon"} for r in data["rooms"])
    assert [i["id"] for i in data["instances"]] == list(range(len(apt.instances)))
    for i in data["instances"]:
        assert set(i) == {"id", "label", "room", "floor", "kind", "support_surfaces"}
        for s in i["support_surfaces"]:
            assert set(s) == {"height", "polygon"} and len(s["polygon"]) >= 3


def test_scan_mode_ply_segments_noise_and_holes(tmp_path: Path) -> None:
    apt = apartment(5)
    path = write_apartment(apt, tmp_path, "scan")
    name = "apartment_0005"
    ply = trimesh.load(path, process=False)
    segs = json.loads((tmp_path / f"{name}_vh_clean.segs.json").read_text())
    agg = json.loads((tmp_path / f"{name}.aggregation.json").read_text())
    side = json.loads((tmp_path / f"{name}.semantics.json").read_text())
    assert side["mode"] == "scan" and side["up"] == "+Z" and side["mesh"] == path.name
    assert segs["sceneId"] == name and agg["sceneId"] == name
    assert len(segs["segIndices"]) == len(ply.vertices)
    assert 100_000 <= len(ply.faces) <= 330_000
    assert ply.visual.vertex_colors.shape == (len(ply.vertices), 4)
    # Z up, metres: the same extent as the clean apartment
    assert len(apt.floors) == 1
    clean_xy = np.stack([apt.mesh.vertices[:, :2].min(0), apt.mesh.vertices[:, :2].max(0)])
    assert np.allclose(ply.bounds[:, :2], clean_xy, atol=0.03)
    assert abs(ply.bounds[0, 2]) < 0.03 and abs(ply.bounds[1, 2] - apt.wall_height) < 0.03
    # ScanNet aggregation: every segment belongs to exactly one group whose label matches the sidecar
    seg_ids = np.asarray(segs["segIndices"])
    grouped = np.concatenate([g["segments"] for g in agg["segGroups"]])
    assert len(grouped) == len(np.unique(grouped)) == len(np.unique(seg_ids))
    labels = {i["id"]: i["label"] for i in side["instances"]}
    assert all(g["label"] == labels[g["objectId"]] for g in agg["segGroups"])
    # noise: vertices sit a few millimetres off the clean surface
    clean = trimesh.Trimesh(apt.mesh.vertices, apt.mesh.faces, process=False)
    sample = np.asarray(ply.vertices)[:: max(1, len(ply.vertices) // 1500)]
    _, dist, _ = trimesh.proximity.closest_point(clean, sample)
    assert 0.0015 < float(np.median(dist)) < 0.006
    # holes: about 1 % of the faces were cut out in small patches
    scan = make_scan(apt)
    assert np.array_equal(scan.faces, np.asarray(ply.faces))
    assert 0.005 < scan.holes_faces / (scan.holes_faces + len(scan.faces)) < 0.05
    edges = np.sort(np.asarray(ply.faces)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, count = np.unique(edges, axis=0, return_counts=True)
    assert np.sum(count == 1) > 0.01 * len(ply.faces)  # open boundaries (holes, cut hidden faces)


# ------------------------------------------------------------------------------------------------
# household objects

from sdovon_mj.world.objects import OBJECT_CATEGORIES, generate_object, sorted_dims, write_object_library  # noqa: E402


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """The whole object library (3 variants per category), written once."""
    return write_object_library(0, tmp_path_factory.mktemp("objects"), variants=3)


def test_object_catalogue() -> None:
    assert len(OBJECT_CATEGORIES) >= 25
    required = {"mug", "cup", "bowl", "plate", "book", "bottle", "can", "cereal_box", "laptop", "remote", "pillow",
                "stuffed_toy", "vase", "potted_plant", "lamp", "shoe", "toothbrush", "soap_dispenser", "towel", "spoon",
                "knife", "apple", "banana", "keyboard", "phone"}
    assert required <= set(OBJECT_CATEGORIES)
    for c in OBJECT_CATEGORIES.values():
        assert all(0 < a <= b for a, b in zip(c.size_min, c.size_max))


def test_object_library_files(library: list[Path]) -> None:
    assert len(library) == 3 * len(OBJECT_CATEGORIES)
    for cat in OBJECT_CATEGORIES:
        assert sorted(p.parent.name for p in library if p.parent.parent.name == cat) == [f"{cat}_{k}" for k in range(3)]
    for p in library:
        assert p.name == "model.obj" and (p.parent / "model.mtl").exists()
        meta = json.loads((p.parent / "meta.json").read_text())
        assert set(meta) == {"category", "name", "dims_m", "seed", "license", "units", "up"}
        assert meta["units"] == "m" and meta["up"] == "+Z" and meta["license"].startswith("CC0-1.0")
        assert meta["category"] == p.parent.parent.name and meta["name"] == p.parent.name


def test_objects_load_watertight_resting_and_plausible(library: list[Path]) -> None:
    shapes = {}
    for p in library:
        meta = json.loads((p.parent / "meta.json").read_text())
        cat = OBJECT_CATEGORIES[meta["category"]]
        mesh = trimesh.load(p, force="mesh")
        assert mesh.is_watertight, p
        assert 200 <= len(mesh.faces) <= 3000, (p, len(mesh.faces))
        lo, hi = mesh.bounds
        assert abs(lo[2]) <= 1e-6, p  # resting on z = 0
        assert np.all(np.abs(0.5 * (lo[:2] + hi[:2])) <= 1e-5), p  # centred in XY
        dims = sorted_dims(hi - lo)
        assert np.all(dims >= np.array(cat.size_min) - 1e-4) and np.all(dims <= np.array(cat.size_max) + 1e-4), (p, dims)
        assert np.allclose(hi - lo, meta["dims_m"], atol=2e-4)
        shapes.setdefault(meta["category"], set()).add(tuple(np.round(dims, 3)))
    assert all(len(v) == 3 for v in shapes.values())  # the variants differ
    mug = trimesh.load([p for p in library if p.parent.name == "mug_0"][0], force="mesh")
    assert 0.08 <= mug.extents[2] <= 0.105


def test_object_bytes_are_deterministic(tmp_path: Path) -> None:
    cats = ["mug", "book", "potted_plant", "laptop", "teapot"]
    a = write_object_library(7, tmp_path / "a", variants=2, categories=cats)
    b = write_object_library(7, tmp_path / "b", variants=2, categories=cats)
    for pa, pb in zip(a, b):
        for f in ("model.obj", "model.mtl", "meta.json"):
            assert (pa.parent / f).read_bytes() == (pb.parent / f).read_bytes()
    # a category does not depend on which other categories are written
    alone = write_object_library(7, tmp_path / "c", variants=2, categories=["teapot"])
    assert alone[0].read_bytes() == [p for p in a if p.parent.name == "teapot_0"][0].read_bytes()
    # another seed gives other shapes
    assert not np.allclose(generate_object("mug", 0, 7).dims, generate_object("mug", 0, 8).dims)


# ------------------------------------------------------------------------------------------------
# the world's modules


def _world_imports() -> dict[str, set[str]]:
    """Return world module -> the world modules it imports, lazy imports inside functions included.

    Modules are named relative to the package (``io.glb``; a package's ``__init__`` by the package: ``io``, ``""``).
    ``from . import x`` and ``from .io import glb`` name the module x / io.glb when it is one, else its package.
    """
    import ast

    root = Path(__file__).resolve().parents[1] / "sdovon_mj" / "world"
    mods = {}
    for p in root.rglob("*.py"):
        parts = p.relative_to(root).with_suffix("").parts
        mods[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    out: dict[str, set[str]] = {m: set() for m in mods}
    for name, path in mods.items():
        pkg = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = [x for x in pkg.split(".") if x]
                base = base[: len(base) - (node.level - 1)] if node.level > 1 else base
                if node.level - 1 > len([x for x in pkg.split(".") if x]):
                    continue  # above the world package
                target = ".".join(base + ([node.module] if node.module else []))
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("sdovon_mj.world"):
                target = node.module[len("sdovon_mj.world"):].lstrip(".")
            else:
                continue
            for a in node.names:
                sub = f"{target}.{a.name}".lstrip(".")
                hit = sub if sub in mods else target
                if hit in mods and hit != name:
                    out[name].add(hit)
    return out


def test_world_modules_import_no_circle() -> None:
    g = _world_imports()
    assert {"model", "layout", "structure", "placement", "programs", "assembly", "io", "io.glb"} <= set(g)
    # depth-first search for a path back to the start (lazy imports count: they are edges too)
    for start in sorted(g):
        stack, seen = [(start, (start,))], set()
        while stack:
            node, path = stack.pop()
            for nxt in sorted(g[node]):
                assert nxt != start, f"import circle: {' -> '.join(path + (nxt,))}"
                if nxt not in seen:
                    seen.add(nxt)
                    stack.append((nxt, path + (nxt,)))
