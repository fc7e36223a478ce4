"""A small two-room apartment written as MJCF episode bundles (for tests, benches and demos).

Bedroom (bed, nightstand, desk) and kitchen (counter, table, sofa) joined by a 1 m doorway; objects
are boxes ``obj_<n>`` placed on receptacles mostly where they belong (a seed decides which), goal
view points are navigable cells within 1 m that see the object (MuJoCo ray), start poses have a
geodesic distance of at least 1 m. Alongside: the NavMap, a SceneAsset with instance labels and
rooms, a RegionMap of the rooms and a Relevance table matching the placement priors.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

import mujoco

from sdovon_mj.geometry import yaw_quat
from sdovon_mj.grid import GridFrame, erode
from sdovon_mj.gridgraph import GeodesicField
from sdovon_mj.records import (Episode, Goal, NavMap, RegionMap, Relevance, Room, SceneAsset, SemanticInstance,
                       ViewPoint, save_json)
from sdovon_mj.sim.model import object_segment_id
from sdovon_mj.store import atomic_write_text, user_cache_dir
from .mjcf import corner_box_geom, outer_walls

CACHE_VERSION = "vp7"  # bump when the written bundles change (vp6: oracle/ folder, dense 0.1 m view points;
# vp7: the scene's source names tests/support)

RES = 0.05
ORIGIN = np.array([-0.2, -0.2])
SIZE = (8.0, 5.0)
WALL_H = 2.5
ROOMS = {"bedroom": (0.0, 4.0), "kitchen": (4.0, 8.0)}
# id: (label, room, xmin, ymin, xmax, ymax, top height, rgba)
FURNITURE = {
    10: ("bed", "bedroom", 0.3, 3.3, 2.3, 4.7, 0.5, "0.7 0.6 0.8 1"),
    11: ("nightstand", "bedroom", 2.6, 4.2, 3.1, 4.7, 0.55, "0.5 0.35 0.2 1"),
    12: ("desk", "bedroom", 0.3, 0.3, 1.5, 0.9, 0.75, "0.6 0.45 0.3 1"),
    13: ("counter", "kitchen", 5.2, 4.1, 7.7, 4.7, 0.9, "0.8 0.8 0.75 1"),
    14: ("table", "kitchen", 5.5, 1.8, 6.7, 2.6, 0.75, "0.55 0.4 0.25 1"),
    15: ("sofa", "kitchen", 4.5, 0.2, 6.5, 1.0, 0.45, "0.3 0.5 0.4 1"),
}
# category: (preferred receptacles, size xyz, rgba)
OBJECTS = {
    "pillow": (("bed",), (0.4, 0.3, 0.12), "0.9 0.9 0.95 1"),
    "book": (("desk", "nightstand"), (0.2, 0.15, 0.05), "0.8 0.1 0.1 1"),
    "laptop": (("desk",), (0.32, 0.22, 0.03), "0.2 0.2 0.2 1"),
    "mug": (("counter", "table"), (0.09, 0.09, 0.1), "0.1 0.3 0.8 1"),
    "plate": (("table", "counter"), (0.22, 0.22, 0.03), "0.95 0.95 0.9 1"),
    "remote": (("sofa",), (0.05, 0.18, 0.03), "0.1 0.1 0.1 1"),
    "toy": (("bed", "sofa"), (0.15, 0.15, 0.15), "0.9 0.7 0.1 1"),
}
RECEPTACLES = ("bed", "nightstand", "desk", "counter", "table", "sofa")
REGIONS = ("bedroom", "kitchen")


def _walls() -> list[tuple[float, float, float, float]]:
    """Return the wall footprints (xmin, ymin, xmax, ymax): the outer walls and the partition with its doorway."""
    t = 0.1
    h = SIZE[1]
    return outer_walls(SIZE, t) + [(4.0 - t / 2, 0.0, 4.0 + t / 2, 2.0), (4.0 - t / 2, 3.0, 4.0 + t / 2, h)]


def relevance_table() -> Relevance:
    """Return the fixture's P(obj|region) and P(obj|receptacle) tables (the placement priors)."""
    cats = sorted(OBJECTS)
    p_rec = np.full((len(cats), len(RECEPTACLES)), 0.02)
    p_rgn = np.full((len(cats), len(REGIONS)), 0.05)
    for i, c in enumerate(cats):
        for r in OBJECTS[c][0]:
            p_rec[i, RECEPTACLES.index(r)] = 1.0
            room = next(v[1] for v in FURNITURE.values() if v[0] == r)
            p_rgn[i, REGIONS.index(room)] = 1.0
    p_rec /= p_rec.sum(axis=0, keepdims=True)
    p_rgn /= p_rgn.sum(axis=0, keepdims=True)
    return Relevance(objects=cats, regions=list(REGIONS), receptacles=list(RECEPTACLES),
                     p_obj_region=p_rgn.astype(np.float32), p_obj_receptacle=p_rec.astype(np.float32), backend="fixture")


def navmap() -> NavMap:
    """Return the fixture apartment's navigable map (free floor eroded by the agent radius)."""
    h = int(round((SIZE[1] + 0.4) / RES))
    w = int(round((SIZE[0] + 0.4) / RES))
    frame = GridFrame(ORIGIN, RES, (h, w))
    rows, cols = np.mgrid[0:h, 0:w]
    xy = frame.to_world(np.stack([rows.ravel(), cols.ravel()], 1)).reshape(h, w, 2)
    x, y = xy[..., 0], xy[..., 1]
    free = (x > 0) & (x < SIZE[0]) & (y > 0) & (y < SIZE[1])
    for (x0, y0, x1, y1) in _walls() + [v[2:6] for v in FURNITURE.values()]:
        free &= ~((x > x0) & (x < x1) & (y > y0) & (y < y1))
    return NavMap(floor=0, height=0.0, origin=ORIGIN.copy(), resolution=RES, navigable=erode(free, 0.18, RES), free=free)


def region_map() -> RegionMap:
    """Return the ground-truth region map of the two rooms."""
    nm = navmap()
    h, w = nm.navigable.shape
    frame = nm.frame
    rows, cols = np.mgrid[0:h, 0:w]
    x = frame.to_world(np.stack([rows.ravel(), cols.ravel()], 1))[:, 0].reshape(h, w)
    lab = np.where(x < 4.0, 0, 1).astype(np.int16)
    scores = np.zeros((h, w, 2), np.float32)
    scores[..., 0] = lab == 0
    scores[..., 1] = lab == 1
    return RegionMap(floor=0, origin=nm.origin.copy(), resolution=RES, labels=list(REGIONS), label_map=lab, scores=scores)


def scene_asset(mjcf_name: str) -> SceneAsset:
    """Return the SceneAsset describing the fixture's instances and rooms."""
    insts = [SemanticInstance(1, "floor", ["inst_1"], kind="floor")]
    insts += [SemanticInstance(2 + i, "wall", [f"inst_{2 + i}"], kind="structure") for i in range(len(_walls()))]
    for k, v in sorted(FURNITURE.items()):
        insts.append(SemanticInstance(k, v[0], [f"inst_{k}"], room=REGIONS.index(v[1]), kind="receptacle",
                                      bounds=np.array([[v[2], v[3], 0.0], [v[4], v[5], v[6]]])))
    rooms = [Room(i, r, 0, np.array([[a, 0.0], [b, 0.0], [b, SIZE[1]], [a, SIZE[1]]])) for i, (r, (a, b)) in enumerate(ROOMS.items())]
    return SceneAsset(name="fixture_apartment", mjcf=mjcf_name, source="tests/support/bundles.py", instances=insts,
                      rooms=rooms, bounds=np.array([[0.0, 0.0, 0.0], [SIZE[0], SIZE[1], WALL_H]]))


def _place_objects(rng: np.random.Generator, misplace: float) -> list[tuple[str, str, np.ndarray, tuple]]:
    """Return (object id, category, centre, size) for one variant."""
    out = []
    n = 0
    used: dict[int, list[np.ndarray]] = {}
    for cat in sorted(OBJECTS):
        prefs, size, _rgba = OBJECTS[cat]
        count = 1 + int(rng.random() < 0.3)
        for _ in range(count):
            if rng.random() < misplace:
                rec = RECEPTACLES[int(rng.integers(len(RECEPTACLES)))]
            else:
                rec = prefs[int(rng.integers(len(prefs)))]
            fid = next(k for k, v in FURNITURE.items() if v[0] == rec)
            _l, _r, x0, y0, x1, y1, top, _c = FURNITURE[fid]
            for _try in range(50):
                p = np.array([rng.uniform(x0 + 0.15, x1 - 0.15), rng.uniform(y0 + 0.15, y1 - 0.15)])
                if all(np.linalg.norm(p - q) > 0.3 for q in used.get(fid, [])):
                    break
            used.setdefault(fid, []).append(p)
            out.append((f"obj_{n:03d}", cat, np.array([p[0], p[1], top + size[2] / 2]), size))
            n += 1
    return out


def _mjcf(objects: list[tuple[str, str, np.ndarray, tuple]]) -> str:
    """MJCF of one variant: floor, walls and furniture boxes (``inst_<k>``), one box body per object."""
    geoms = [corner_box_geom("inst_1", (-0.1, -0.1, -0.05), (SIZE[0] + 0.1, SIZE[1] + 0.1, 0.0), "0.75 0.72 0.68 1")]
    for i, (x0, y0, x1, y1) in enumerate(_walls()):
        geoms.append(corner_box_geom(f"inst_{2 + i}", (x0, y0, 0.0), (x1, y1, WALL_H), "0.92 0.9 0.85 1"))
    for k, v in sorted(FURNITURE.items()):
        geoms.append(corner_box_geom(f"inst_{k}", (v[2], v[3], 0.0), (v[4], v[5], v[6]), v[7]))
    bodies = []
    for oid, cat, c, size in objects:
        rgba = OBJECTS[cat][2]
        bodies.append(f'<body name="{oid}" pos="{c[0]:.4f} {c[1]:.4f} {c[2]:.4f}">'
                      f'<geom name="{oid}/visual" type="box" size="{size[0] / 2} {size[1] / 2} {size[2] / 2}" rgba="{rgba}" '
                      f'group="2" contype="0" conaffinity="0"/></body>')
    return ("<mujoco model=\"fixture_apartment\">\n<visual><global offwidth=\"640\" offheight=\"480\"/></visual>\n"
            "<statistic extent=\"10\" center=\"4 2.5 1\"/>\n<worldbody>\n"
            "<light name=\"sun\" directional=\"true\" pos=\"4 2.5 4\" dir=\"0.2 0.1 -1\" castshadow=\"false\"/>\n"
            + "\n".join(geoms) + "\n" + "\n".join(bodies) + "\n</worldbody>\n</mujoco>\n")


def _view_points(model: mujoco.MjModel, data: mujoco.MjData, nm: NavMap, oid: str, centre: np.ndarray,
                 rng: np.random.Generator, cap: int, half: np.ndarray | None = None) -> list[ViewPoint]:
    """Dense view points: navigable cells of a grid-anchored lattice at the success distance (0.1 m) within 1 m
    of the object's footprint, from which a ray at camera height reaches the object's centre or a corner
    (so stopping anywhere that sees the object, close by, lies within the success distance of one)."""
    frame = nm.frame
    stride = max(1, int(round(0.1 / nm.resolution)))
    rc = np.argwhere(nm.navigable)
    rc = rc[(rc[:, 0] % stride == 0) & (rc[:, 1] % stride == 0)]
    xy = frame.to_world(rc)
    hx, hy = (float(half[0]), float(half[1])) if half is not None else (0.0, 0.0)
    dx = np.maximum(np.abs(xy[:, 0] - centre[0]) - hx, 0.0)
    dy = np.maximum(np.abs(xy[:, 1] - centre[1]) - hy, 0.0)
    cand = xy[np.hypot(dx, dy) <= 1.0]
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, oid)
    groups = np.array([1, 0, 1, 0, 0, 0], np.uint8)
    geomid = np.zeros(1, np.int32)
    out = []
    hz = 0.0 if half is None else float(half[2])
    corners = [np.zeros(3)] + [0.9 * np.array([sx * hx, sy * hy, sz * hz]) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    for p in cand:
        cam = np.array([p[0], p[1], 0.88])
        for off in corners:  # like the generator's ray test: the centre or a corner of the box is reached first
            vec = centre + off - cam
            dist = mujoco.mj_ray(model, data, cam, vec / np.linalg.norm(vec), groups, 1, -1, geomid)
            if dist >= 0 and int(model.geom_bodyid[geomid[0]]) == bid:
                yaw = math.degrees(math.atan2(centre[1] - cam[1], centre[0] - cam[0]))
                out.append(ViewPoint(np.array([p[0], p[1], 0.0]), yaw_quat(yaw), 0.0))
                break
    if cap > 0 and len(out) > cap:
        keep = np.sort(rng.choice(len(out), cap, replace=False))
        out = [out[i] for i in keep]
    return out


def build_fixture(out_dir: str | Path, variants: int = 2, seed: int = 0, episodes_per_category: int = 3,
                  misplace: float = 0.1, max_viewpoints: int = 0) -> Path:
    """Write `variants` bundle folders of the fixture apartment under out_dir; return out_dir.

    Parameters
    ----------
    out_dir : str or Path
        Folder receiving ``fixture_apartment_v<k>/`` (MJCF, episodes, navmap, scene, region map, relevance).
    variants : int
        Number of object arrangements (bundles) to write.
    seed : int
        Seed of the arrangements and episodes (variant k uses ``default_rng([seed, k])``).
    episodes_per_category : int
        Episodes drawn per object category and variant.
    misplace : float
        Probability in [0, 1] that an object lands on a receptacle it does not prefer.
    max_viewpoints : int
        Most view points kept per goal object (0: all, the default: dense, as the episode generator's).
    """
    out = Path(out_dir)
    nm = navmap()
    frame = nm.frame
    nav_xy = frame.to_world(np.argwhere(nm.navigable))
    for v in range(variants):
        rng = np.random.default_rng([seed, v])
        name = f"fixture_apartment_v{v:03d}"
        root = out / name
        objects = _place_objects(rng, misplace)
        xml = _mjcf(objects)
        atomic_write_text(root / f"{name}.xml", xml)
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        goals_by_cat: dict[str, list[Goal]] = {}
        for oid, cat, c, size in objects:
            vps = _view_points(model, data, nm, oid, c, rng, max_viewpoints, np.array(size) / 2)
            if vps:
                half = np.array(size) / 2
                goals_by_cat.setdefault(cat, []).append(Goal(oid, cat, c.copy(), vps, np.stack([c - half, c + half])))
        episodes = []
        for cat in sorted(goals_by_cat):
            goals = goals_by_cat[cat]
            vp = np.array([p.position[:2] for g in goals for p in g.view_points])
            geo = GeodesicField(nm.navigable, frame, vp)
            for k in range(episodes_per_category):
                for _try in range(200):
                    s = nav_xy[int(rng.integers(len(nav_xy)))]
                    dg = geo.distance(s)
                    if 1.0 <= dg < math.inf:
                        break
                else:
                    continue
                eu = min(float(np.linalg.norm(g.position[:2] - s)) for g in goals)
                closest = min(goals, key=lambda g: float(np.linalg.norm(g.position[:2] - s))).object_id
                episodes.append(Episode(f"{name}_{cat}_{k}", "fixture_apartment", name, cat, np.array([s[0], s[1], 0.0]),
                                        yaw_quat(float(rng.uniform(-180, 180))), goals, float(dg), eu, closest, 0))
        save_json(episodes, root / "episodes.json")
        # generator artefacts go under oracle/, as the MJCF bundle exporter writes them
        save_json(nm, root / "oracle" / "navmap.json")
        scene = scene_asset(f"{name}.xml")
        save_json(scene, root / "oracle" / "scene.json")
        atomic_write_text(root / "oracle" / "instance_labels.json",
                          json.dumps({str(i.id): i.label for i in scene.instances}, indent=1, sort_keys=True) + "\n")
        atomic_write_text(root / "oracle" / "object_labels.json",
                          json.dumps({str(object_segment_id(oid)): cat for oid, cat, _c, _s in objects}, indent=1,
                                     sort_keys=True) + "\n")
        save_json(region_map(), root / "oracle" / "region_map.json")
        save_json(relevance_table(), root / "oracle" / "relevance.json")
    return out


def fixture_bundle(root: str | Path | None = None, variants: int = 2, seed: int = 0) -> Path:
    """Return the folder of the fixture dataset, writing it on first use.

    Without `root` the folder is ``fixture_s<seed>_v<variants>_<CACHE_VERSION>`` in the shared cache
    (``store.user_cache_dir("fixture")``; with SDOVON_CACHE=off, a per-user temporary folder).
    """
    if root is None:
        base = user_cache_dir("fixture") or Path(tempfile.gettempdir()) / f"sdovon-mj-fixture-{os.getuid()}"
        root = base / f"fixture_s{seed}_v{variants}_{CACHE_VERSION}"
    root = Path(root)
    if not all((root / f"fixture_apartment_v{v:03d}" / "episodes.json").exists() for v in range(variants)):
        build_fixture(root, variants=variants, seed=seed)
    return root
