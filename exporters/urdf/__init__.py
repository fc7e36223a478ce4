"""URDF exporter (PyBullet, SAPIEN / ManiSkill): per variant a static scene URDF, one URDF per object, poses in JSON.

Layout under ``<out>/<name>/`` (Z up, metres, kilograms)::

    meshes/<digest>.obj (+ .mtl)   every mesh once (content digest names): visual meshes with their colour and
                                   texture (MTL ``Kd``/``d``/``map_Kd``), collision hulls, scene collision pieces
    textures/<digest>.png          textures, once
    <variant>/scene.urdf           the static scene: link ``scene`` fixed to a root ``world`` (``concave="yes"``: PyBullet builds
                                   triangle-mesh colliders for it) with the scene's visual meshes, its structure
                                   (MJCF group 0) split into connected pieces as collision meshes (loaders that
                                   take a mesh's convex hull, such as SAPIEN, get one hull per piece), and the
                                   support geometry the objects were settled on
    <variant>/<obj_n>.urdf         one rigid object: link ``<obj_n>`` with its inertial (mass, centre of mass,
                                   principal axes as ``rpy``, principal moments), visual meshes and its convex
                                   hulls as collision meshes, in the body frame
    <variant>/scene.json           gravity, the scene URDF, and per object its URDF, settled pose of the link
                                   frame (position, quaternion wxyz and xyzw) and inertial (mass, centre of
                                   mass, principal moments and axes, body frame)
    <variant>/episodes.json        the variant's ObjectNav episodes (records; goal ``object_id`` = object URDF name)
    index.json                     dataset, split, the variants

Load with PyBullet: ``loadURDF(scene.urdf, useFixedBase=True)`` then each object at its pose; with SAPIEN:
``URDFLoader`` (``fix_root_link=True`` for the scene, ``False`` for objects) and ``set_pose``.
Variants without episodes are skipped and reported, like the other exporters.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from sdovon_mj.records import dumps
from sdovon_mj.store import atomic_write_bytes, atomic_write_text
from sdovon_mj.export import ExportOptions, ExportReport, Exporter, RunView, exportable_variants, finish_export

from exporters.simparts import MeshPart, RigidBody, VariantParts, obj_text, texture_png, variant_parts


def _f(v, digits: int = 9) -> str:
    return " ".join(f"{float(x):.{digits}g}" for x in np.ravel(v))


def _pieces(part: MeshPart) -> list[MeshPart]:
    """Split a collision part into its connected pieces (one convex hull each for convex-only loaders)."""
    tm = trimesh.Trimesh(part.vertices, part.faces, process=False)
    tm.merge_vertices()
    comps = tm.split(only_watertight=False)
    if len(comps) <= 1:
        return [part]
    comps = sorted(comps, key=lambda c: tuple(np.round(c.vertices.min(axis=0), 6)))
    return [MeshPart(name=f"{part.name}_{i}", vertices=np.asarray(c.vertices, float), faces=np.asarray(c.faces, np.int64),
                     rgba=part.rgba, collides=True) for i, c in enumerate(comps)]


class _Meshes:
    """Writes mesh (and MTL, texture) files once, by content digest."""

    def __init__(self, root: Path, written: list[Path]) -> None:
        self.root, self.written = root, written

    def _write(self, path: Path, data: bytes) -> None:
        if not path.exists():
            atomic_write_bytes(path, data)
        self.written.append(path)

    def collision(self, part: MeshPart) -> str:
        """Write a collision mesh (geometry only); return its path relative to the dataset root."""
        d = part.digest()
        self._write(self.root / "meshes" / f"c{d}.obj", obj_text(part).encode())
        return f"meshes/c{d}.obj"

    def visual(self, part: MeshPart) -> str:
        """Write a visual mesh with its MTL (colour, texture); return its path relative to the dataset root."""
        d = part.digest()
        r, g, b, a = (float(x) for x in part.rgba)
        mtl = [f"newmtl m{d}", f"Kd {r:.6g} {g:.6g} {b:.6g}", "Ka 0 0 0", "Ks 0.1 0.1 0.1", f"d {a:.6g}"]
        if part.texture >= 0:
            png = texture_png(part.image)
            t = hashlib.sha256(png).hexdigest()[:16]
            self._write(self.root / "textures" / f"{t}.png", png)
            mtl.append(f"map_Kd ../textures/{t}.png")
        self._write(self.root / "meshes" / f"v{d}.mtl", ("\n".join(mtl) + "\n").encode())
        self._write(self.root / "meshes" / f"v{d}.obj", obj_text(part, mtl=f"v{d}.mtl", material=f"m{d}").encode())
        return f"meshes/v{d}.obj"


def _visual_xml(meshes: _Meshes, part: MeshPart, i: int) -> str:
    color = "" if part.texture >= 0 else (f'\n      <material name="c{i}"><color rgba="{_f(part.rgba)}"/></material>')
    return (f'    <visual name={quoteattr(part.name)}>\n      <origin xyz="0 0 0" rpy="0 0 0"/>\n'
            f'      <geometry><mesh filename="../{meshes.visual(part)}"/></geometry>{color}\n    </visual>\n')


def _collision_xml(meshes: _Meshes, part: MeshPart) -> str:
    return (f'    <collision name={quoteattr(part.name)}>\n      <origin xyz="0 0 0" rpy="0 0 0"/>\n'
            f'      <geometry><mesh filename="../{meshes.collision(part)}"/></geometry>\n    </collision>\n')


def object_urdf(meshes: _Meshes, body: RigidBody) -> str:
    """Return the URDF text of one rigid object (link frame = the MuJoCo body frame)."""
    q = np.asarray(body.principal_quat, dtype=float)
    rpy = Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_euler("xyz")  # URDF rpy: fixed axes x, y, z
    ixx, iyy, izz = (repr(float(x)) for x in body.inertia)
    out = [f'<?xml version="1.0"?>\n<robot name={quoteattr(body.object_id)}>\n  <link name={quoteattr(body.object_id)}>\n',
           # Inertial values at full precision (17 digits): the tensor reads back exactly.
           f'    <inertial>\n      <origin xyz="{_f(body.com, 17)}" rpy="{_f(rpy, 17)}"/>\n      <mass value="{body.mass!r}"/>\n'
           f'      <inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/>\n    </inertial>\n']
    out += [_visual_xml(meshes, p, i) for i, p in enumerate(body.visuals)]
    out += [_collision_xml(meshes, p) for p in body.collisions]
    out.append("  </link>\n</robot>\n")
    return "".join(out)


def scene_urdf(meshes: _Meshes, parts: VariantParts) -> str:
    """Return the URDF text of the static scene (visual meshes, structure pieces and support as collision)."""
    # A root link "world" fixed to "scene": loaders that make single-link URDFs free bodies (SAPIEN) keep it fixed.
    out = [f'<?xml version="1.0"?>\n<robot name={quoteattr(parts.variant.scene)}>\n  <link name="world"/>\n'
           '  <joint name="world_to_scene" type="fixed">\n    <parent link="world"/>\n    <child link="scene"/>\n'
           '    <origin xyz="0 0 0" rpy="0 0 0"/>\n  </joint>\n  <link name="scene" concave="yes">\n',
           '    <inertial>\n      <origin xyz="0 0 0" rpy="0 0 0"/>\n      <mass value="0"/>\n'
           '      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>\n    </inertial>\n']
    out += [_visual_xml(meshes, p, i) for i, p in enumerate(parts.scene)]
    for p in parts.scene:
        if p.collides:
            out += [_collision_xml(meshes, piece) for piece in _pieces(p)]
    out += [_collision_xml(meshes, p) for p in parts.support]
    out.append("  </link>\n</robot>\n")
    return "".join(out)


class UrdfExporter(Exporter):
    """Writes per variant a static scene URDF, one URDF per object and scene.json of settled poses."""

    name = "urdf"

    def export(self, run: RunView, out_dir: Path, options: ExportOptions) -> ExportReport:
        """Write every variant with episodes as URDF files under out_dir/<name>/ (layout: module docstring)."""
        root = Path(out_dir) / options.name
        report = ExportReport(format=self.name, out_dir=str(out_dir), name=options.name)
        written: list[Path] = []
        index = []
        for variant, eps in exportable_variants(run, report):
            parts = variant_parts(run, variant)
            meshes = _Meshes(root, written)
            vdir = root / variant.name
            atomic_write_text(vdir / "scene.urdf", scene_urdf(meshes, parts))
            written.append(vdir / "scene.urdf")
            objects = []
            for body in parts.bodies:
                atomic_write_text(vdir / f"{body.object_id}.urdf", object_urdf(meshes, body))
                written.append(vdir / f"{body.object_id}.urdf")
                q = [float(x) for x in body.quat]
                objects.append({"object_id": body.object_id, "asset": body.asset, "category": body.category,
                                "urdf": f"{body.object_id}.urdf", "position": [float(x) for x in body.pos],
                                "quaternion_wxyz": q, "quaternion_xyzw": q[1:] + q[:1], "mass": float(body.mass),
                                "center_of_mass": [float(x) for x in body.com],
                                "inertia_principal": [float(x) for x in body.inertia],
                                "inertia_principal_axes_wxyz": [float(x) for x in body.principal_quat]})
            atomic_write_text(vdir / "scene.json", json.dumps({
                "variant": variant.name, "scene": variant.scene, "scene_urdf": "scene.urdf",
                "gravity": [float(x) for x in parts.gravity], "objects": objects,
                "frame": "Z up, metres; poses are the object link frames (the MuJoCo body frames), settled"},
                indent=1, sort_keys=True) + "\n")
            atomic_write_text(vdir / "episodes.json", dumps([e.to_dict() for e in eps]))
            written += [vdir / "scene.json", vdir / "episodes.json"]
            index.append({"variant": variant.name, "path": variant.name, "n_objects": len(objects), "n_episodes": len(eps)})
            report.variants.append(variant.name)
            report.episodes += len(eps)
        return finish_export(report, root, options, index, written)


__all__ = ["UrdfExporter", "object_urdf", "scene_urdf"]
