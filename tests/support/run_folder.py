"""A small synthetic run folder (room, table, cabinet, three objects) in the documented run layout.

For tests, benches and demos of the episode and export stages without the upstream stages. Layout
(see sdovon_mj/runview.py): ``scenes/<scene>/scene.json``, ``scenes/<scene>/observe/navmap_<floor>.json``,
``scenes/<scene>/variants/<variant>/variant.json`` (+ ``episodes.json``), ``objects/<name>/object.json``.

Variant ``room_v000`` holds a mug on the table (``obj_000``, a mesh, yaw 90 deg), a ball on the floor
(``obj_001``) and a second mug shut inside the cabinet (``obj_002``, invisible: dropped from the goals);
variant ``room_v001`` holds only the shut-in mug (zero valid goals).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy import ndimage

from sdovon_mj.config import EpisodeConfig
from sdovon_mj.geometry import yaw_quat
from sdovon_mj.records import Floor, NavMap, ObjectAsset, Placement, SceneAsset, SceneVariant, SemanticInstance, save_json
from sdovon_mj.store import atomic_write_text
from sdovon_mj.world.shapes import cylinder
from .mjcf import box_geom, corner_box_geom, obj_text, outer_walls

SCENE = "room"
ROOM = (6.0, 5.0)
TABLE = ((1.5, 1.2), (0.5, 0.3), 0.75)  # centre, half extents, top height
PARTITION = ((2.95, 3.05), (0.0, 3.2))
CABINET = ((5.0, 4.2), 0.25)  # centre, outer half size (cube standing on the floor)
MUG_POSE = (np.array([1.5, 1.2, 0.75]), 90.0)
BALL_POSE = (np.array([4.5, 1.0, 0.12]), 0.0)
HIDDEN_POSE = (np.array([5.0, 4.2, 0.02]), 0.0)


def scene_geoms() -> str:
    """Return the worldbody geoms of the room (instances inst_0..inst_8)."""
    w, h = ROOM
    (tx, ty), (thx, thy), tz = TABLE
    (cx, cy), cs = CABINET
    t = 0.02
    g = [box_geom("inst_0", (w / 2, h / 2, -0.05), (w / 2 + 0.1, h / 2 + 0.1, 0.05), "0.6 0.5 0.4 1")]
    g += [corner_box_geom(f"inst_{1 + i}", (x0, y0, 0.0), (x1, y1, 2.6), "0.9 0.9 0.85 1")
          for i, (x0, y0, x1, y1) in enumerate(outer_walls(ROOM))]
    g.append(box_geom("inst_5", (tx, ty, tz / 2), (thx, thy, tz / 2), "0.5 0.3 0.1 1"))
    (px0, px1), (py0, py1) = PARTITION
    g.append(corner_box_geom("inst_6", (px0, py0, 0.0), (px1, py1, 2.6), "0.85 0.85 0.9 1"))
    # Closed cabinet: six panels around a hollow inside.
    for j, (pos, size) in enumerate([
        ((cx, cy, t / 2), (cs, cs, t / 2)), ((cx, cy, 2 * cs - t / 2), (cs, cs, t / 2)),
        ((cx - cs + t / 2, cy, cs), (t / 2, cs, cs)), ((cx + cs - t / 2, cy, cs), (t / 2, cs, cs)),
        ((cx, cy - cs + t / 2, cs), (cs, t / 2, cs)), ((cx, cy + cs - t / 2, cs), (cs, t / 2, cs))]):
        g.append(box_geom(f"inst_7_{j}", pos, size, "0.3 0.3 0.6 1"))
    g.append(box_geom("inst_8", (w / 2, h / 2, 2.65), (w / 2 + 0.1, h / 2 + 0.1, 0.05), "1 1 1 1", group=1))
    return "".join(f"    {line}\n" for line in g)


def _fmt(v: np.ndarray) -> str:
    """Numbers exactly (shortest repr), so the MJCF poses equal the recorded ones."""
    return " ".join(repr(float(x)) for x in v)


def _object_body(oid: str, kind: str, pos: np.ndarray, quat: np.ndarray, mesh_name: str) -> str:
    """MJCF body of one free object: a mesh mug or a sphere ball (visual group 2, collision group 3)."""
    if kind == "mug":
        vis = f'<geom name="{oid}/visual" type="mesh" mesh="{mesh_name}" group="2" contype="0" conaffinity="0" rgba="0.9 0.1 0.1 1"/>'
        col = f'<geom name="{oid}/collision" type="cylinder" size="0.05 0.05" pos="0 0 0.05" group="3"/>'
    else:
        vis = f'<geom name="{oid}/visual" type="sphere" size="0.12" group="2" contype="0" conaffinity="0" rgba="0.1 0.7 0.1 1"/>'
        col = f'<geom name="{oid}/collision" type="sphere" size="0.12" group="3"/>'
    return (f'    <body name="{oid}" pos="{_fmt(pos)}" quat="{_fmt(quat)}">\n      <freejoint name="{oid}/joint"/>\n'
            f'      {vis}\n      {col}\n    </body>\n')


def _navmap(agent_radius: float = 0.18, res: float = 0.05) -> NavMap:
    """The room's NavMap: floor minus table, partition, cabinet and ball, eroded by a disc of the agent radius."""
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
    atomic_write_text(root / "objects" / "mug_a" / "mug.obj", obj_text(*cylinder(0.05, 0.0, 0.1, segments=24)))
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
            q = yaw_quat(yaw)
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
            from sdovon_mj.episodes.generate import generate_episodes

            eps = generate_episodes(variant, [nm], root, cfg or EpisodeConfig(), seed + index)
            save_json(eps, vdir / "episodes.json")
    return root
