"""Small real inputs for placement without the other stages: primitive Menagerie-style objects,
a visual-only table scene with its receptacle planes, and a hand-filled relevance table.

Used by the place tests and bench (and handy for trying the stage alone). Objects follow the
converter's layout: ``<out>/<name>/model.xml`` + ``assets/``, class ``visual`` (group 2, no
contacts, density 0) and class ``collision`` (group 3), an explicit inertial, no freejoint.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from sdovon_mj.geometry import yaw_quat
from sdovon_mj.records import Floor, ObjectAsset, ReceptaclePlane, Relevance, Room, SceneAsset, SemanticInstance, SupportSurface
from sdovon_mj.store import atomic_write_text
from .mjcf import box_geom

_HEAD = """<mujoco model="{name}">
  <compiler angle="radian" meshdir="assets" autolimits="true"/>
  <default>
    <default class="visual">
      <geom contype="0" conaffinity="0" group="2" density="0"/>
    </default>
    <default class="collision">
      <geom group="3" rgba="0.6 0.6 0.6 1"/>
    </default>
  </default>
"""

KINDS = ("box", "mug", "ball", "can")  # also "cube": an 8 cm cube (bench: the same boxes as scene-synthesizer's)


def write_primitive_object(out_dir: str | Path, store_root: str | Path, kind: str, name: str,
                           scale: float = 1.0, category: str | None = None) -> ObjectAsset:
    """Write a primitive object model (box, mug, ball or can) and return its ObjectAsset.

    Parameters
    ----------
    out_dir : str or Path
        Folder receiving ``<name>/model.xml`` (+ ``assets/``).
    store_root : str or Path
        Folder the ObjectAsset's ``mjcf`` path is relative to (an ancestor of out_dir).
    kind : str
        One of `KINDS`, or ``"cube"`` (an 8 cm cube).
    name : str
        Object (and folder) name.
    scale : float
        Uniform scale of the base size (box 8 x 5 x 12 cm, mug r 4 cm h 9 cm, ball r 3.5 cm, can r 3.3 cm h 12 cm).
    category : str or None
        Category recorded on the asset (default: `kind`).
    """
    out = Path(out_dir) / name
    (out / "assets").mkdir(parents=True, exist_ok=True)
    s = float(scale)
    body: list[str] = []
    assets = ""
    if kind in ("box", "cube"):
        hx, hy, hz = (0.04 * s, 0.025 * s, 0.06 * s) if kind == "box" else (0.04 * s, 0.04 * s, 0.04 * s)
        mass = 0.2 * s**3
        inertia = mass / 3.0 * np.array([hy**2 + hz**2, hx**2 + hz**2, hx**2 + hy**2])
        body.append(f'<geom class="visual" type="box" size="{hx} {hy} {hz}" pos="0 0 {hz}" rgba="0.8 0.3 0.2 1"/>')
        body.append(f'<geom class="collision" type="box" size="{hx} {hy} {hz}" pos="0 0 {hz}"/>')
        com, bbox = (0, 0, hz), np.array([[-hx, -hy, 0], [hx, hy, 2 * hz]])
        volume = 8 * hx * hy * hz
    elif kind == "mug":
        import trimesh

        r, h, t = 0.04 * s, 0.09 * s, 0.005 * s
        mesh = trimesh.creation.annulus(r - t, r, h)
        mesh.apply_translation([0, 0, h / 2])
        atomic_write_text(out / "assets" / "visual_0.obj", mesh.export(file_type="obj"))
        assets = '  <asset>\n    <mesh name="visual_0" file="visual_0.obj"/>\n  </asset>\n'
        body.append('<geom class="visual" type="mesh" mesh="visual_0" rgba="0.2 0.4 0.8 1"/>')
        body.append(f'<geom class="visual" type="cylinder" size="{r} {t / 2}" pos="0 0 {t / 2}" rgba="0.2 0.4 0.8 1"/>')
        body.append(f'<geom class="visual" type="box" size="{t} {t} {h * 0.3}" pos="{r + 0.015 * s} 0 {h / 2}" rgba="0.2 0.4 0.8 1"/>')
        body.append(f'<geom class="collision" type="cylinder" size="{r} {t / 2}" pos="0 0 {t / 2}"/>')
        n = 10
        for k in range(n):
            a = 2 * math.pi * k / n
            q = yaw_quat(360.0 * k / n)
            body.append(f'<geom class="collision" type="box" size="{t / 2} {r * math.sin(math.pi / n) + t / 2} {h / 2}" '
                        f'pos="{(r - t / 2) * math.cos(a):.6f} {(r - t / 2) * math.sin(a):.6f} {h / 2}" '
                        f'quat="{q[0]:.6f} 0 0 {q[3]:.6f}"/>')
        body.append(f'<geom class="collision" type="box" size="{0.015 * s} {t} {h * 0.3}" pos="{r + 0.015 * s} 0 {h / 2}"/>')
        mass = 0.3 * s**3
        inertia = mass * np.array([(r**2) / 2 + h**2 / 12, (r**2) / 2 + h**2 / 12, r**2])
        com, bbox = (0, 0, h / 2), np.array([[-r, -r, 0], [r + 0.03 * s, r, h]])
        volume = math.pi * r * r * h
    elif kind == "ball":
        r = 0.035 * s
        mass = 0.1 * s**3
        inertia = np.full(3, 0.4 * mass * r * r)
        body.append(f'<geom class="visual" type="sphere" size="{r}" pos="0 0 {r}" rgba="0.9 0.8 0.1 1"/>')
        body.append(f'<geom class="collision" type="sphere" size="{r}" pos="0 0 {r}"/>')
        com, bbox = (0, 0, r), np.array([[-r, -r, 0], [r, r, 2 * r]])
        volume = 4 / 3 * math.pi * r**3
    elif kind == "can":
        r, hz = 0.033 * s, 0.06 * s
        mass = 0.35 * s**3
        inertia = mass * np.array([r * r / 4 + (2 * hz) ** 2 / 12, r * r / 4 + (2 * hz) ** 2 / 12, r * r / 2])
        body.append(f'<geom class="visual" type="cylinder" size="{r} {hz}" pos="0 0 {hz}" rgba="0.7 0.7 0.75 1"/>')
        body.append(f'<geom class="collision" type="cylinder" size="{r} {hz}" pos="0 0 {hz}"/>')
        com, bbox = (0, 0, hz), np.array([[-r, -r, 0], [r, r, 2 * hz]])
        volume = math.pi * r * r * 2 * hz
    else:
        raise ValueError(f"unknown primitive kind {kind!r} (known: {', '.join(KINDS)})")
    ix, iy, iz = (float(v) for v in inertia)
    lines = [_HEAD.format(name=name), assets, "  <worldbody>\n", f'    <body name="{name}">\n',
             f'      <inertial pos="{com[0]} {com[1]} {com[2]}" mass="{mass:.6f}" diaginertia="{ix:.3e} {iy:.3e} {iz:.3e}"/>\n']
    lines += [f"      {g}\n" for g in body]
    lines += ["    </body>\n", "  </worldbody>\n", "</mujoco>\n"]
    atomic_write_text(out / "model.xml", "".join(lines))
    rel = (out / "model.xml").resolve().relative_to(Path(store_root).resolve()).as_posix()
    return ObjectAsset(name=name, category=category or kind, mjcf=rel, bbox=bbox.astype(float), mass=float(mass),
                       hull_count=sum(1 for g in body if 'class="collision"' in g), volume=float(volume), volume_ratio=1.0,
                       source="synthetic primitive", license="CC0-1.0")


def write_primitive_library(out_dir: str | Path, store_root: str | Path, per_kind: int = 2,
                            kinds: tuple[str, ...] = KINDS, seed: int = 0) -> list[ObjectAsset]:
    """Write `per_kind` scaled variants of each primitive kind; return their ObjectAssets.

    Parameters
    ----------
    out_dir : str or Path
        Folder receiving one ``<kind>_<i>/`` folder per object.
    store_root : str or Path
        Folder the ObjectAssets' ``mjcf`` paths are relative to.
    per_kind : int
        Variants written per kind.
    kinds : tuple of str
        Primitive kinds (see `write_primitive_object`).
    seed : int
        Seed of the scales, uniform in [0.85, 1.15].
    """
    rng = np.random.default_rng(seed)
    out = []
    for kind in kinds:
        for i in range(per_kind):
            out.append(write_primitive_object(out_dir, store_root, kind, f"{kind}_{i}", scale=float(rng.uniform(0.85, 1.15))))
    return out


# A small two-room flat: a kitchen with a counter and a table, a living room with a coffee table and a
# shelf. (label, room, centre xy, half size xy, top height)
_FURNITURE = (
    ("counter", 0, (1.0, 0.4), (0.9, 0.3), 0.9),
    ("table", 0, (1.5, 2.2), (0.6, 0.45), 0.75),
    ("coffee table", 1, (5.0, 1.5), (0.5, 0.3), 0.45),
    ("shelf", 1, (6.5, 3.6), (0.5, 0.2), 1.2),
)
_ROOMS = ((0, "kitchen", (0.0, 0.0, 4.0, 4.0)), (1, "living room", (4.0, 0.0, 8.0, 4.0)))


def write_table_scene(out_dir: str | Path, store_root: str | Path, name: str = "flat", furniture: tuple = _FURNITURE,
                      rooms_spec: tuple = _ROOMS) -> tuple[SceneAsset, list[ReceptaclePlane]]:
    """Write a visual-only scene of box-top receptacles (default: two rooms, four receptacles); return it and its planes.

    Parameters
    ----------
    out_dir : str or Path
        Folder receiving ``<name>.xml``.
    store_root : str or Path
        Folder the SceneAsset's ``mjcf`` path is relative to.
    name : str
        Scene (and MJCF model) name.
    furniture : tuple
        ``(label, room index, centre xy (m), half size xy (m), top height (m))`` per receptacle.
    rooms_spec : tuple
        ``(room id, room type, (xmin, ymin, xmax, ymax) in m)`` per room.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    x0 = min(r[2][0] for r in rooms_spec)
    y0 = min(r[2][1] for r in rooms_spec)
    x1 = max(r[2][2] for r in rooms_spec)
    y1 = max(r[2][3] for r in rooms_spec)
    geoms = [box_geom("inst_0", ((x0 + x1) / 2, (y0 + y1) / 2, -0.05), ((x1 - x0) / 2, (y1 - y0) / 2, 0.05), "0.75 0.7 0.6 1")]
    instances = [SemanticInstance(id=0, label="floor", geoms=["inst_0"], room=-1, floor=0, kind="structure")]
    planes, surfaces = [], []
    for k, (label, room, (cx, cy), (hx, hy), top) in enumerate(furniture, start=1):
        geoms.append(box_geom(f"inst_{k}_0", (cx, cy, top - 0.02), (hx, hy, 0.02), "0.55 0.35 0.2 1"))
        lh = (top - 0.04) / 2
        for j, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1)), start=1):
            geoms.append(box_geom(f"inst_{k}_{j}", (cx + sx * (hx - 0.04), cy + sy * (hy - 0.04), lh), (0.03, 0.03, lh),
                                  "0.45 0.3 0.2 1"))
        poly = np.array([[cx - hx, cy - hy], [cx + hx, cy - hy], [cx + hx, cy + hy], [cx - hx, cy + hy]])
        instances.append(SemanticInstance(id=k, label=label, geoms=[f"inst_{k}_{j}" for j in range(5)], room=room, floor=0,
                                          kind="receptacle", bounds=np.array([[cx - hx, cy - hy, 0.0], [cx + hx, cy + hy, top]])))
        surfaces.append(SupportSurface(instance_id=k, height=float(top), polygon=poly))
        planes.append(ReceptaclePlane(id=k - 1, instance_id=k, label=label, height=float(top), polygon=poly,
                                      normal=np.array([0.0, 0.0, 1.0]), region=rooms_spec[room][1], floor=0))
    xml = ("<mujoco model=\"%s\">\n  <default>\n    <geom contype=\"0\" conaffinity=\"0\" group=\"0\"/>\n  </default>\n"
           "  <worldbody>\n    <light pos=\"%g %g 3\" dir=\"0 0 -1\" directional=\"true\"/>\n%s\n  </worldbody>\n</mujoco>\n") % (
        name, (x0 + x1) / 2, (y0 + y1) / 2, "\n".join("    " + g for g in geoms))
    atomic_write_text(out / f"{name}.xml", xml)
    rel = (out / f"{name}.xml").resolve().relative_to(Path(store_root).resolve()).as_posix()
    rooms = [Room(id=i, type=t, floor=0, polygon=np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float))
             for i, t, (x0, y0, x1, y1) in rooms_spec]
    scene = SceneAsset(name=name, mjcf=rel, source="synthetic", floors=[Floor(index=0, height=0.0, area=float((x1 - x0) * (y1 - y0)))],
                       instances=instances, bounds=np.array([[x0, y0, -0.1], [x1, y1, 2.5]]), rooms=rooms,
                       support_surfaces=surfaces)
    return scene, planes


def hand_relevance() -> Relevance:
    """Return a hand-filled relevance table over the primitive kinds, two regions and four receptacles."""
    objects = ["box", "mug", "ball", "can", "plant"]
    regions = ["kitchen", "living room"]
    receptacles = ["counter", "table", "coffee table", "shelf"]
    p_rgn = np.array([[0.35, 0.15], [0.40, 0.10], [0.05, 0.40], [0.15, 0.05], [0.05, 0.30]])
    p_rec = np.array([[0.40, 0.20, 0.10, 0.40], [0.35, 0.40, 0.30, 0.10], [0.05, 0.05, 0.40, 0.20],
                      [0.15, 0.30, 0.10, 0.10], [0.05, 0.05, 0.10, 0.20]])
    return Relevance(objects=objects, regions=regions, receptacles=receptacles, p_obj_region=p_rgn / p_rgn.sum(0),
                     p_obj_receptacle=p_rec / p_rec.sum(0), backend="hand", model="")
