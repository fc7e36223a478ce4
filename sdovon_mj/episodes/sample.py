"""A small synthetic run folder (room, table, cabinet, three objects) in the documented run layout.

For tests, benches and demos of the episode and export stages without the upstream stages. Layout
(see exporters/base.py): ``scenes/<scene>/scene.json``, ``scenes/<scene>/observe/navmap_<floor>.json``,
``scenes/<scene>/variants/<variant>/variant.json`` (+ ``episodes.json``), ``objects/<name>/object.json``.

Variant ``room_v000`` holds a mug on the table (``obj_000``, a mesh, yaw 90 deg), a ball on the floor
(``obj_001``) and a second mug shut inside the cabinet (``obj_002``, invisible: dropped from the goals);
variant ``room_v001`` holds only the shut-in mug (zero valid goals).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import trimesh
from scipy import ndimage

from ..config import EpisodeConfig
from ..records import Floor, NavMap, ObjectAsset, Placement, SceneAsset, SceneVariant, SemanticInstance, save_json
from ..store import atomic_write_bytes, atomic_write_text

SCENE = "room"
ROOM = (6.0, 5.0)
TABLE = ((1.5, 1.2), (0.5, 0.3), 0.75)  # centre, half extents, top height
PARTITION = ((2.95, 3.05), (0.0, 3.2))
CABINET = ((5.0, 4.2), 0.25)  # centre, outer half size (cube standing on the floor)
MUG_POSE = (np.array([1.5, 1.2, 0.75]), 90.0)
BALL_POSE = (np.array([4.5, 1.0, 0.12]), 0.0)
HIDDEN_POSE = (np.array([5.0, 4.2, 0.02]), 0.0)


def _box(name: str, pos, size, rgba="0.8 0.8 0.8 1", group=0) -> str:
    p = " ".join(f"{v:g}" for v in pos)
    s = " ".join(f"{v:g}" for v in size)
    return f'    <geom name="{name}" type="box" pos="{p}" size="{s}" rgba="{rgba}" group="{group}" contype="0" conaffinity="0"/>\n'


def scene_geoms() -> str:
    """Return the worldbody geoms of the room (instances inst_0..inst_8)."""
    w, h = ROOM
    (tx, ty), (thx, thy), tz = TABLE
    (cx, cy), cs = CABINET
    t = 0.02
    g = _box("inst_0", (w / 2, h / 2, -0.05), (w / 2 + 0.1, h / 2 + 0.1, 0.05), "0.6 0.5 0.4 1")
    g += _box("inst_1", (w / 2, -0.05, 1.3), (w / 2 + 0.1, 0.05, 1.3), "0.9 0.9 0.85 1")
    g += _box("inst_2", (w / 2, h + 0.05, 1.3), (w / 2 + 0.1, 0.05, 1.3), "0.9 0.9 0.85 1")
    g += _box("inst_3", (-0.05, h / 2, 1.3), (0.05, h / 2 + 0.1, 1.3), "0.9 0.9 0.85 1")
    g += _box("inst_4", (w + 0.05, h / 2, 1.3), (0.05, h / 2 + 0.1, 1.3), "0.9 0.9 0.85 1")
    g += _box("inst_5", (tx, ty, tz / 2), (thx, thy, tz / 2), "0.5 0.3 0.1 1")
    (px0, px1), (py0, py1) = PARTITION
    g += _box("inst_6", ((px0 + px1) / 2, (py0 + py1) / 2, 1.3), ((px1 - px0) / 2, (py1 - py0) / 2, 1.3), "0.85 0.85 0.9 1")
    # Closed cabinet: six panels around a hollow inside.
    for j, (pos, size) in enumerate([
        ((cx, cy, t / 2), (cs, cs, t / 2)), ((cx, cy, 2 * cs - t / 2), (cs, cs, t / 2)),
        ((cx - cs + t / 2, cy, cs), (t / 2, cs, cs)), ((cx + cs - t / 2, cy, cs), (t / 2, cs, cs)),
        ((cx, cy - cs + t / 2, cs), (cs, t / 2, cs)), ((cx, cy + cs - t / 2, cs), (cs, t / 2, cs))]):
        g += _box(f"inst_7_{j}", pos, size, "0.3 0.3 0.6 1")
    g += _box("inst_8", (w / 2, h / 2, 2.65), (w / 2 + 0.1, h / 2 + 0.1, 0.05), "1 1 1 1", group=1)
    return g


def _quat_yaw(yaw_deg: float) -> np.ndarray:
    h = math.radians(yaw_deg) / 2
    return np.array([math.cos(h), 0.0, 0.0, math.sin(h)])


def _fmt(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def _object_body(oid: str, kind: str, pos: np.ndarray, quat: np.ndarray, mesh_name: str) -> str:
    if kind == "mug":
        vis = f'<geom name="{oid}/visual" type="mesh" mesh="{mesh_name}" group="2" contype="0" conaffinity="0" rgba="0.9 0.1 0.1 1"/>'
        col = f'<geom name="{oid}/collision" type="cylinder" size="0.05 0.05" pos="0 0 0.05" group="3"/>'
    else:
        vis = f'<geom name="{oid}/visual" type="sphere" size="0.12" group="2" contype="0" conaffinity="0" rgba="0.1 0.7 0.1 1"/>'
        col = f'<geom name="{oid}/collision" type="sphere" size="0.12" group="3"/>'
    return (f'    <body name="{oid}" pos="{_fmt(pos)}" quat="{_fmt(quat)}">\n      <freejoint name="{oid}/joint"/>\n'
            f'      {vis}\n      {col}\n    </body>\n')


def _navmap(agent_radius: float = 0.18, res: float = 0.05) -> NavMap:
    w, h = ROOM
    H, W = int(round(h / res)), int(round(w / res))
    xs = (np.arange(W) + 0.5) * res
    ys = (np.arange(H) + 0.5) * res
    X, Y = np.meshgrid(xs, ys)
    free = np.ones((H, W), dtype=bool)
    (tx, ty), (thx, thy), _ = TABLE
    free &= ~((abs(X - tx) <= thx) & (abs(Y - ty) <= thy))
    (px0, px1), (py0, py1) = PARTITION
    free &= ~((X >= px0) & (X <= px1) & (Y >= py0) & (Y <= py1))
    (cx, cy), cs = CABINET
    free &= ~((abs(X - cx) <= cs) & (abs(Y - cy) <= cs))
    bp = BALL_POSE[0]
    free &= ~(np.hypot(X - bp[0], Y - bp[1]) <= 0.12)
    r = int(math.ceil(agent_radius / res))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    nav = ndimage.binary_erosion(free, structure=(xx ** 2 + yy ** 2) <= r * r, border_value=0)
    return NavMap(floor=0, height=0.0, origin=np.zeros(2), resolution=res, navigable=nav, free=free)


def build_sample_run(root: str | Path, episodes: bool = False, cfg: EpisodeConfig | None = None, seed: int = 0) -> Path:
    """Write the sample run folder under `root` (optionally with episodes) and return root."""
    root = Path(root)
    scene_dir = root / "scenes" / SCENE
    # Object asset: a mug mesh (OBJ, base at z=0) with a Menagerie-style model.xml.
    mug = trimesh.creation.cylinder(radius=0.05, height=0.1, sections=24)
    mug.apply_translation([0, 0, 0.05])
    atomic_write_bytes(root / "objects" / "mug_a" / "mug.obj", mug.export(file_type="obj").encode())
    atomic_write_text(root / "objects" / "mug_a" / "model.xml", (
        '<mujoco model="mug_a">\n  <asset>\n    <mesh name="mug" file="mug.obj"/>\n  </asset>\n  <worldbody>\n'
        '    <body name="object">\n      <geom type="mesh" mesh="mug" group="2" contype="0" conaffinity="0"/>\n'
        '      <geom type="cylinder" size="0.05 0.05" pos="0 0 0.05" group="3"/>\n    </body>\n  </worldbody>\n</mujoco>\n'))
    save_json(ObjectAsset(name="mug_a", category="mug", mjcf="objects/mug_a/model.xml",
                          bbox=np.array([[-0.05, -0.05, 0.0], [0.05, 0.05, 0.1]]), mass=0.3, hull_count=1),
              root / "objects" / "mug_a" / "object.json")
    atomic_write_text(root / "objects" / "ball_a" / "model.xml", (
        '<mujoco model="ball_a">\n  <worldbody>\n    <body name="object">\n'
        '      <geom type="sphere" size="0.12" group="2" contype="0" conaffinity="0"/>\n'
        '      <geom type="sphere" size="0.12" group="3"/>\n    </body>\n  </worldbody>\n</mujoco>\n'))
    save_json(ObjectAsset(name="ball_a", category="ball", mjcf="objects/ball_a/model.xml",
                          bbox=np.array([[-0.12, -0.12, -0.12], [0.12, 0.12, 0.12]]), mass=0.4, hull_count=1),
              root / "objects" / "ball_a" / "object.json")
    # Scene asset.
    atomic_write_text(scene_dir / "scene.xml", f'<mujoco model="{SCENE}">\n  <worldbody>\n{scene_geoms()}  </worldbody>\n</mujoco>\n')
    # No SemanticInstance list: its `kind` field collides with the record tag in records.py (reported).
    insts: list[SemanticInstance] = []
    save_json(SceneAsset(name=SCENE, mjcf=f"scenes/{SCENE}/scene.xml", floors=[Floor(0, 0.0, ROOM[0] * ROOM[1])],
                         instances=insts, bounds=np.array([[0.0, 0.0, 0.0], [ROOM[0], ROOM[1], 2.7]])),
              scene_dir / "scene.json")
    nm = _navmap()
    save_json(nm, scene_dir / "observe" / "navmap_0.json")
    specs = {0: [("obj_000", "mug", "mug_a", MUG_POSE), ("obj_001", "ball", "ball_a", BALL_POSE),
                 ("obj_002", "mug", "mug_a", HIDDEN_POSE)],
             1: [("obj_002", "mug", "mug_a", HIDDEN_POSE)]}
    for index, objs in specs.items():
        vname = f"{SCENE}_v{index:03d}"
        vdir = scene_dir / "variants" / vname
        mesh_rel = Path("../../../../objects/mug_a/mug.obj").as_posix()
        bodies, placements, qpos = "", [], []
        for oid, cat, asset, (pos, yaw) in objs:
            q = _quat_yaw(yaw)
            bodies += _object_body(oid, cat, pos, q, "mug_a_mesh")
            placements.append(Placement(object_id=oid, asset=asset, category=cat, plane_id=0, receptacle_instance=5,
                                        region="living room", spawn_pos=pos + [0, 0, 0.3], spawn_quat=q,
                                        settled_pos=pos.copy(), settled_quat=q.copy(), status="resting"))
            qpos += [*pos, *q]
        xml = (f'<mujoco model="{vname}">\n  <asset>\n    <mesh name="mug_a_mesh" file="{mesh_rel}"/>\n  </asset>\n'
               f'  <worldbody>\n    <light pos="3 2.5 2.5" dir="0 0 -1" directional="false"/>\n{scene_geoms()}{bodies}  </worldbody>\n</mujoco>\n')
        atomic_write_text(vdir / "variant.xml", xml)
        variant = SceneVariant(scene=SCENE, index=index, seed=index, placements=placements, qpos=np.array(qpos),
                               mjcf=f"scenes/{SCENE}/variants/{vname}/variant.xml")
        save_json(variant, vdir / "variant.json")
        if episodes:
            from .generate import generate_episodes

            eps = generate_episodes(variant, [nm], root, cfg or EpisodeConfig(), seed + index)
            save_json(eps, vdir / "episodes.json")
    return root
