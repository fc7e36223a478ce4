"""A Habitat scene dataset in the ReplicaCAD layout, written by the tests (a fixture, not shipped data).

`write_replicacad` writes ``<root>/rc.scene_dataset_config.json`` registering ``stages/`` (a box room: a floor and
four walls, Y up, as a baked ReplicaCAD stage), ``urdf/*/`` (ReplicaCAD's ``{".urdf": ["urdf/*/"]}``: a fridge
with a hinged door and a kitchen counter with a drawer, their root links' centre of mass above their floor point;
the fridge's URDF in Habitat's Y-up frame, the counter's Z up as ReplicaCAD's are) and ``scenes/``. The scene
instance places both with ``translation_origin: "COM"``, a rotation (about +Y; the counter first -90 degrees about
+X, as ReplicaCAD's scenes turn their Z-up URDFs upright) and a ``uniform_scale``; `EXTRA` adds what a conversion
must name and skip (a template the dataset lacks, a light setup).

`expected_root` gives where habitat-sim puts a piece's root link (its base is the root link's inertial frame at
the instance transform), in Habitat's frame, computed here independently of the reader.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

__all__ = ["COUNTER", "FRIDGE", "EXTRA", "expected_root", "expected_link", "write_replicacad"]

WALL = 0.1  # m, wall thickness
ROOM = (5.0, 4.0, 2.5)  # m: x extent, z extent, height (Habitat frame)


def _box(size: tuple[float, float, float], centre: tuple[float, float, float], rgba: str = "0.8 0.8 0.8 1") -> str:
    """Return a URDF visual + collision box (Y-up link frame)."""
    s = " ".join(f"{v:g}" for v in size)
    c = " ".join(f"{v:g}" for v in centre)
    return (f'<visual><origin xyz="{c}"/><geometry><box size="{s}"/></geometry><material name="m">'
            f'<color rgba="{rgba}"/></material></visual>'
            f'<collision><origin xyz="{c}"/><geometry><box size="{s}"/></geometry></collision>')


# Fridge: 0.7 wide (x), 1.6 high (y), 0.6 deep (z), front +z; the root link's origin at the middle of its floor
# footprint, its centre of mass 0.8 m up. A middle shelf; the door hinges at the front-left edge about -y (it swings
# out to +z as its joint opens, range 0..2 rad).
FRIDGE_COM = (0.0, 0.8, 0.0)
FRIDGE = {
    "name": "fridge",
    "urdf": f"""<?xml version="1.0"?>
<robot name="fridge">
  <link name="body">
    <inertial><origin xyz="{FRIDGE_COM[0]} {FRIDGE_COM[1]} {FRIDGE_COM[2]}"/><mass value="60"/>
      <inertia ixx="10" ixy="0" ixz="0" iyy="5" iyz="0" izz="10"/></inertial>
    {_box((0.7, 0.05, 0.6), (0, 0.025, 0))}
    {_box((0.7, 0.05, 0.6), (0, 1.575, 0))}
    {_box((0.05, 1.5, 0.6), (-0.325, 0.8, 0))}
    {_box((0.05, 1.5, 0.6), (0.325, 0.8, 0))}
    {_box((0.6, 1.5, 0.05), (0, 0.8, -0.275))}
    {_box((0.6, 0.02, 0.5), (0, 0.8, 0.0))}
  </link>
  <link name="door">
    <inertial><origin xyz="0.35 0.8 0.02"/><mass value="8"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    {_box((0.7, 1.6, 0.04), (0.35, 0.8, 0.02), "0.9 0.9 0.95 1")}
  </link>
  <joint name="door_hinge" type="revolute">
    <parent link="body"/><child link="door"/>
    <origin xyz="-0.35 0 0.3"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="2.0" effort="50" velocity="1"/>
  </joint>
</robot>
""",
}

# Kitchen counter: 1.2 wide, 0.9 high, 0.6 deep, front +z; a drawer (slides out along +z, 0..0.4 m) under the top,
# a fixed divider and lower front close the compartment below it. Its centre of mass is off the vertical through the
# root link's origin, so the instance rotation moves it. Written Z up, as ReplicaCAD's own URDFs are (their scene
# instances turn them upright with a rotation of -90 degrees about +X): a Y-up point (x, y, z) is (x, -z, y) here.


def _zup(size: tuple[float, float, float], centre: tuple[float, float, float], rgba: str = "0.8 0.8 0.8 1") -> str:
    """Return `_box` of a Y-up box written in a Z-up link frame."""
    return _box((size[0], size[2], size[1]), (centre[0], -centre[2], centre[1]), rgba)


COUNTER_COM = (0.1, 0.05, 0.45)  # Z-up: 0.45 m up, 0.05 m behind the root link's origin, 0.1 m to the side
COUNTER = {
    "name": "kitchen_counter",
    "urdf": f"""<?xml version="1.0"?>
<robot name="kitchen_counter">
  <link name="carcass">
    <inertial><origin xyz="{COUNTER_COM[0]} {COUNTER_COM[1]} {COUNTER_COM[2]}"/><mass value="80"/>
      <inertia ixx="10" ixy="0" ixz="0" iyy="10" iyz="0" izz="10"/></inertial>
    {_zup((1.2, 0.05, 0.6), (0, 0.025, 0))}
    {_zup((1.24, 0.05, 0.64), (0, 0.875, 0.01), "0.3 0.3 0.3 1")}
    {_zup((0.05, 0.8, 0.6), (-0.575, 0.45, 0))}
    {_zup((0.05, 0.8, 0.6), (0.575, 0.45, 0))}
    {_zup((1.1, 0.8, 0.05), (0, 0.45, -0.275))}
    {_zup((1.1, 0.03, 0.55), (0, 0.415, 0.0))}
    {_zup((1.1, 0.38, 0.03), (0, 0.24, 0.285))}
  </link>
  <link name="drawer">
    <inertial><origin xyz="0 0 0.6"/><mass value="4"/>
      <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>
    {_zup((1.06, 0.02, 0.5), (0, 0.45, 0.0))}
    {_zup((1.1, 0.38, 0.03), (0, 0.63, 0.285), "0.7 0.5 0.3 1")}
    {_zup((0.02, 0.2, 0.5), (-0.52, 0.55, 0.0))}
    {_zup((0.02, 0.2, 0.5), (0.52, 0.55, 0.0))}
    {_zup((1.06, 0.2, 0.02), (0, 0.55, -0.24))}
  </link>
  <joint name="drawer_slide" type="prismatic">
    <parent link="carcass"/><child link="drawer"/>
    <origin xyz="0 0 0"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.4" effort="50" velocity="1"/>
  </joint>
</robot>
""",
}

# The instances (Habitat frame): the fridge against the left wall facing +x, the counter against the right wall
# facing -x (rotations about +Y), each at its centre of mass (translation_origin COM).
FRIDGE_YAW, FRIDGE_SCALE = 90.0, 1.05
COUNTER_YAW, COUNTER_SCALE = -90.0, 0.98
EXTRA = {"missing": "no_such_cupboard", "light": "rc_lights"}


def _rot_y(deg: float) -> np.ndarray:
    """Return the rotation about Habitat's +Y by `deg` degrees."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _quat_y(deg: float) -> list[float]:
    """Return the wxyz quaternion of a rotation about +Y (a scene instance's ``rotation``)."""
    h = math.radians(deg) / 2
    return [math.cos(h), 0.0, math.sin(h), 0.0]


def _floor_points() -> dict[str, np.ndarray]:
    """Return each piece's root-link origin (middle of its floor footprint) in Habitat's frame."""
    x0, z0 = ROOM[0] / 2, ROOM[1] / 2
    return {"fridge": np.array([-x0 + WALL / 2 + 0.3 * FRIDGE_SCALE + 0.03, 0.0, -0.8]),
            "kitchen_counter": np.array([x0 - WALL / 2 - 0.32 * COUNTER_SCALE - 0.03, 0.0, 0.6])}


def _rotation(name: str) -> tuple[np.ndarray, list[float]]:
    """Return a piece's instance rotation (matrix, wxyz): about +Y; the Z-up counter first -90 degrees about +X."""
    if name == "fridge":
        return _rot_y(FRIDGE_YAW), _quat_y(FRIDGE_YAW)
    h = math.radians(-90.0) / 2
    qx = np.array([math.cos(h), math.sin(h), 0.0, 0.0])
    qy = np.asarray(_quat_y(COUNTER_YAW))
    w1, x1, y1, z1 = qy  # q = q_y * q_x (Hamilton product)
    w2, x2, y2, z2 = qx
    q = [w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2]
    c, s = math.cos(math.radians(-90.0)), math.sin(math.radians(-90.0))
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    return _rot_y(COUNTER_YAW) @ Rx, [float(v) for v in q]


def _instance(name: str) -> dict:
    """Return the scene instance entry of a piece: its COM as translation (ReplicaCAD style)."""
    scale, com = (FRIDGE_SCALE, FRIDGE_COM) if name == "fridge" else (COUNTER_SCALE, COUNTER_COM)
    R, q = _rotation(name)
    t = _floor_points()[name] + R @ (np.asarray(com) * scale)
    return {"template_name": name, "fixed_base": True, "auto_clamp_joint_limits": True, "translation_origin": "COM",
            "motion_type": "DYNAMIC", "translation": [float(v) for v in t], "rotation": q, "uniform_scale": scale}


def expected_root(name: str) -> np.ndarray:
    """Return the 4x4 pose (Habitat frame) habitat-sim gives a piece's root link: base = instance transform, the
    base being the root link's inertial frame (scaled), so root = T_instance * inertial^-1."""
    inst = _instance(name)
    com = FRIDGE_COM if name == "fridge" else COUNTER_COM
    T = np.eye(4)
    T[:3, :3] = _rotation(name)[0]
    T[:3, 3] = inst["translation"]
    Ti = np.eye(4)
    Ti[:3, 3] = np.asarray(com) * inst["uniform_scale"]
    return T @ np.linalg.inv(Ti)


def expected_link(name: str) -> np.ndarray:
    """Return the 4x4 Habitat-frame pose of the moving link (door / drawer) at joint position 0."""
    T = expected_root(name)
    J = np.eye(4)
    if name == "fridge":
        J[:3, 3] = np.array([-0.35, 0.0, 0.3]) * FRIDGE_SCALE
    return T @ J


def _stage(path: Path) -> None:
    """Write the box room GLB (Y up): a floor slab and four walls, node names ``floor`` and ``wall_<k>``."""
    import trimesh

    x, z, h = ROOM
    scene = trimesh.Scene()
    floor = trimesh.creation.box(extents=(x, 0.1, z))
    floor.apply_translation((0, -0.05, 0))
    scene.add_geometry(floor, node_name="floor", geom_name="floor")
    walls = [((WALL, h, z), (-x / 2, h / 2, 0)), ((WALL, h, z), (x / 2, h / 2, 0)),
             ((x, h, WALL), (0, h / 2, -z / 2)), ((x, h, WALL), (0, h / 2, z / 2))]
    for k, (ext, c) in enumerate(walls):
        w = trimesh.creation.box(extents=ext)
        w.apply_translation(c)
        scene.add_geometry(w, node_name=f"wall_{k}", geom_name=f"wall_{k}")
    path.parent.mkdir(parents=True, exist_ok=True)
    scene.export(str(path), file_type="glb")


def write_replicacad(root: Path, extra: bool = False) -> Path:
    """Write the dataset under `root`; return its scene instance file.

    `extra` adds a third articulated instance whose template the dataset lacks (`EXTRA["missing"]`), an object
    instance likewise, and ``default_lighting`` naming a light setup the config registers (`EXTRA["light"]`).
    """
    root = Path(root)
    _stage(root / "stages" / "box_room.glb")
    (root / "stages" / "box_room.stage_config.json").write_text(json.dumps(
        {"render_asset": "box_room.glb", "up": [0, 1, 0], "front": [0, 0, -1]}), encoding="utf-8")
    for piece in (FRIDGE, COUNTER):
        d = root / "urdf" / piece["name"]
        d.mkdir(parents=True, exist_ok=True)
        (d / f"{piece['name']}.urdf").write_text(piece["urdf"], encoding="utf-8")
    config = {"stages": {"paths": {".json": ["stages"]}}, "objects": {"paths": {".json": ["objects"]}},
              "articulated_objects": {"paths": {".urdf": ["urdf/*/"]}}, "scene_instances": {"paths": {".json": ["scenes"]}}}
    scene = {"stage_instance": {"template_name": "stages/box_room"}, "translation_origin": "asset_local",
             "articulated_object_instances": [_instance("fridge"), _instance("kitchen_counter")]}
    if extra:
        config["light_setups"] = {"paths": {".json": ["lights"]}}
        (root / "lights").mkdir(parents=True, exist_ok=True)
        (root / "lights" / f"{EXTRA['light']}.lighting_config.json").write_text(json.dumps(
            {"lights": {"0": {"position": [0, 2.2, 0], "intensity": 3.0, "color": [1, 1, 1], "type": "point"}}}),
            encoding="utf-8")
        scene["default_lighting"] = EXTRA["light"]
        scene["articulated_object_instances"].append({**_instance("fridge"), "template_name": EXTRA["missing"]})
        scene["object_instances"] = [{"template_name": "no_such_chair", "translation": [0, 0, 0]}]
    (root / "rc.scene_dataset_config.json").write_text(json.dumps(config, indent=1), encoding="utf-8")
    path = root / "scenes" / "apt_kitchen.scene_instance.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(scene, indent=1), encoding="utf-8")
    return path
