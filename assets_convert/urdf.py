"""URDF -> MJCF: articulated objects (cabinets, drawers, fridges) as MuJoCo bodies nested along the kinematic tree.

What is read (every error names the URDF file and the link or joint):

- ``<link>``: ``<visual>`` and ``<collision>`` with ``<origin xyz rpy>`` and a ``<geometry>`` of ``<mesh filename
  scale>`` (OBJ, STL, PLY, GLB/glTF; DAE when trimesh can read it), ``<box size>``, ``<cylinder radius length>`` or
  ``<sphere radius>``; ``<material>`` colours (inline or named at the robot level); ``<inertial>`` (origin, mass,
  inertia).
- ``<joint>`` of type revolute, continuous, prismatic or fixed: parent, child, ``<origin xyz rpy>``, ``<axis>``,
  ``<limit lower upper effort velocity>``, ``<dynamics damping friction>``.
- mesh paths relative to the URDF, absolute, or ``package://<pkg>/<path>`` (``<pkg>`` is searched in the URDF's
  folder and its parents, then in ``ROS_PACKAGE_PATH``).
- Habitat's ``<stem>.ao_config.json`` beside the URDF: ``render_asset`` (drawn as the root link's visual in place
  of the root link's own visuals: a skinned render asset is not split per link), ``semantic_id`` (kept on the
  ObjectAsset), ``uniform_scale`` (scales every length; masses are kept, inertias scale with its square) and
  ``mass_scale``.

What is written (``objects/<name>/model.xml`` + ``assets/``), in the URDF's root-link frame (metres, Z up; not
recentred, so joint states and exports match the URDF): the root link is body ``object`` (no joint: the object is
fixed where it is put), every other link a body named after it, nested under its parent link with the joint origin
as its pose; revolute -> hinge with ``range``, continuous -> unlimited hinge, prismatic -> slide with ``range``,
fixed -> no joint (welded); damping, frictionloss, ``armature`` (`ARMATURE`), stiffer stops (`SOLREF_LIMIT`) and
``actuatorfrcrange`` (the URDF
effort). Visual geoms are class ``visual`` (group 2, contype 0, density 0) as the mesh converter writes them;
collision geoms class ``collision`` (group 3): URDF collision primitives as they are, collision meshes as their
convex hulls, and for a link with visual geometry but no collision, its visual primitives and CoACD hulls of its
visual meshes (a single hull when the mesh is nearly convex). Links with an ``<inertial>`` keep it; others get
their mass from the collision geoms at the category density. The conversion is cached like the mesh converter's.
"""

from __future__ import annotations

import json
import math
import os
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sdovon_mj.config import ConvertConfig
from sdovon_mj.errors import InputError
from sdovon_mj.records import ArticulatedPart, ObjectAsset
from sdovon_mj.store import atomic_write_text

from .load import Material, Part, display_path, gpu_texture_key, load_mesh, referenced_files

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")
ARMATURE = 0.01  # kg m^2 (hinge) / kg (slide): rotor inertia added on every joint, steadies stiff position control
SOLREF_LIMIT = "0.01 1"  # joint stops twice as stiff as MuJoCo's default (0.02): a pushed door stays at its stop
FRICTION = "1 0.005 0.0001"  # as the mesh converter's collision class
AO_CONFIG = ".ao_config.json"
DEFAULT_RGBA = (0.6, 0.6, 0.6, 1.0)
MIN_MASS = 1e-3  # kg: a moving link with no inertial and no collision geometry gets this (and a warning)


@dataclass
class Geometry:
    """One visual or collision element of a link (link frame, metres after the URDF scales)."""

    kind: str  # mesh | box | cylinder | sphere
    origin: np.ndarray  # (4, 4) element frame in the link frame
    size: tuple[float, ...] = ()  # box: full sizes; cylinder: radius, length; sphere: radius
    mesh: Path | None = None
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    rgba: tuple[float, float, float, float] | None = None  # URDF material colour, if any


@dataclass
class Inertial:
    """A link's URDF inertial: mass (kg), frame in the link frame, inertia tensor (kg m^2) in that frame."""

    mass: float
    origin: np.ndarray
    inertia: np.ndarray  # (3, 3)


@dataclass
class Link:
    """A URDF link."""

    name: str
    visuals: list[Geometry] = field(default_factory=list)
    collisions: list[Geometry] = field(default_factory=list)
    inertial: Inertial | None = None


@dataclass
class Joint:
    """A URDF joint (limits in radians or metres; None when the URDF gives none)."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray  # (4, 4) child link frame in the parent link frame
    axis: np.ndarray  # (3,) unit axis in the child link frame
    lower: float | None = None
    upper: float | None = None
    effort: float | None = None
    velocity: float | None = None
    damping: float = 0.0
    friction: float = 0.0


@dataclass
class Robot:
    """A parsed URDF: links (file order), joints (file order), the root link and Habitat extras."""

    path: Path
    name: str
    links: dict[str, Link]
    joints: list[Joint]
    root: str
    render_asset: Path | None = None
    semantic_id: int | None = None
    scale: float = 1.0
    mass_scale: float = 1.0
    ao_config: Path | None = None
    unused: list[str] = field(default_factory=list)  # elements read past (transmissions, mimic joints, ...), named

    def children(self, link: str) -> list[Joint]:
        """Return the joints whose parent is `link` (file order)."""
        return [j for j in self.joints if j.parent == link]

    def files(self) -> list[Path]:
        """Return the URDF, its ao_config, render asset and every mesh file (each once, with MTL/textures)."""
        out = [self.path] + ([self.ao_config] if self.ao_config else [])
        meshes = [g.mesh for lk in self.links.values() for g in lk.visuals + lk.collisions if g.mesh is not None]
        if self.render_asset is not None:
            meshes.append(self.render_asset)
        for m in meshes:
            for f in _mesh_files(m):
                if f not in out:
                    out.append(f)
        return out


# ----------------------------------------------------------------------------------------------
# reading


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """Return the 3x3 rotation of URDF roll-pitch-yaw (fixed axes X, Y, Z: R = Rz(yaw) Ry(pitch) Rx(roll))."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def mat_to_quat(R: np.ndarray) -> np.ndarray:
    """Return the MuJoCo quaternion (w, x, y, z, w >= 0) of a rotation matrix."""
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=np.float64).ravel())
    return -q if q[0] < 0 else q


def _floats(text: str | None, n: int, where: str, what: str, default: tuple[float, ...] | None = None) -> np.ndarray:
    """Parse `n` numbers from an attribute; raise InputError naming the element when malformed."""
    if text is None:
        if default is None:
            raise InputError(where, f"{what} is missing")
        return np.asarray(default, dtype=np.float64)
    try:
        vals = [float(t) for t in text.split()]
    except ValueError:
        raise InputError(where, f"{what} is not a list of numbers: {text!r}") from None
    if len(vals) != n or not np.isfinite(vals).all():
        raise InputError(where, f"{what} needs {n} finite numbers, got {text!r}")
    return np.asarray(vals, dtype=np.float64)


def _origin(el: ET.Element | None, where: str, what: str) -> np.ndarray:
    """Return the 4x4 transform of an ``<origin xyz rpy>`` child (identity when absent)."""
    T = np.eye(4)
    o = el.find("origin") if el is not None else None
    if o is None:
        return T
    T[:3, :3] = rpy_matrix(_floats(o.get("rpy"), 3, where, f"{what} origin rpy", (0.0, 0.0, 0.0)))
    T[:3, 3] = _floats(o.get("xyz"), 3, where, f"{what} origin xyz", (0.0, 0.0, 0.0))
    return T


def resolve_mesh(filename: str, urdf: Path) -> Path:
    """Return the file a URDF mesh ``filename`` names (relative, absolute, ``file://`` or ``package://``).

    A ``package://<pkg>/<rest>`` is looked up as ``<dir>/<pkg>/<rest>`` and ``<dir>/<rest>`` where ``<dir>`` is
    named ``<pkg>``, for the URDF's folder and its parents, then for the folders of ``ROS_PACKAGE_PATH``, and
    finally as ``<rest>`` relative to the URDF. The first that exists wins; else the plain relative guess is
    returned (the caller reports it missing).
    """
    if filename.startswith("file://"):
        return Path(filename[len("file://"):])
    if filename.startswith("package://"):
        pkg, _, rest = filename[len("package://"):].partition("/")
        roots = [urdf.parent.resolve(), *urdf.parent.resolve().parents]
        roots += [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
        for d in roots:
            for cand in ((d / rest) if d.name == pkg else None, d / pkg / rest):
                if cand is not None and cand.is_file():
                    return cand
        return urdf.parent / rest
    p = Path(filename)
    return p if p.is_absolute() else urdf.parent / p


def _geometry(el: ET.Element, urdf: Path, where: str, what: str,
              materials: dict[str, tuple[float, float, float, float]]) -> Geometry:
    """Parse one ``<visual>`` / ``<collision>`` element."""
    g = el.find("geometry")
    if g is None or len(g) == 0:
        raise InputError(where, f"{what} has no <geometry>")
    shape = g[0]
    T = _origin(el, where, what)
    rgba = None
    mat = el.find("material")
    if mat is not None:
        col = mat.find("color")
        if col is not None:
            rgba = tuple(_floats(col.get("rgba"), 4, where, f"{what} material colour"))
        elif mat.get("name") in materials:
            rgba = materials[mat.get("name")]
    if shape.tag == "box":
        size = _floats(shape.get("size"), 3, where, f"{what} box size")
        if (size <= 0).any():
            raise InputError(where, f"{what} box size must be positive, got {shape.get('size')!r}")
        return Geometry("box", T, tuple(size), rgba=rgba)
    if shape.tag == "cylinder":
        r = _floats(shape.get("radius"), 1, where, f"{what} cylinder radius")[0]
        h = _floats(shape.get("length"), 1, where, f"{what} cylinder length")[0]
        if r <= 0 or h <= 0:
            raise InputError(where, f"{what} cylinder radius and length must be positive")
        return Geometry("cylinder", T, (r, h), rgba=rgba)
    if shape.tag == "sphere":
        r = _floats(shape.get("radius"), 1, where, f"{what} sphere radius")[0]
        if r <= 0:
            raise InputError(where, f"{what} sphere radius must be positive")
        return Geometry("sphere", T, (r,), rgba=rgba)
    if shape.tag == "mesh":
        fn = shape.get("filename")
        if not fn:
            raise InputError(where, f"{what} mesh has no filename")
        path = resolve_mesh(fn, urdf)
        if not path.is_file():
            raise InputError(where, f"{what}: mesh file '{fn}' not found (looked at {display_path(path)})")
        sc = shape.get("scale")
        if sc is not None and len(sc.split()) not in (1, 3):
            raise InputError(where, f"{what} mesh scale needs 1 or 3 numbers, got {sc!r}")
        scale = _floats(sc, 3, where, f"{what} mesh scale") if sc is not None and len(sc.split()) == 3 else \
            np.full(3, _floats(sc, 1, where, f"{what} mesh scale", (1.0,))[0])
        if (scale == 0).any():
            raise InputError(where, f"{what} mesh scale must not be zero, got {sc!r}")
        return Geometry("mesh", T, (), path, scale, rgba)
    raise InputError(where, f"{what}: unknown geometry <{shape.tag}> (use mesh, box, cylinder or sphere)")


def _ao_config(urdf: Path) -> tuple[Path | None, dict[str, Any]]:
    """Return Habitat's ``<stem>.ao_config.json`` beside a URDF and its contents (None, {} when absent)."""
    p = urdf.with_name(urdf.stem + AO_CONFIG)
    if not p.is_file():
        return None, {}
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(display_path(p), f"cannot read the articulated-object config: {e}") from None
    if not isinstance(doc, dict):
        raise InputError(display_path(p), "an articulated-object config must be a JSON object")
    return p, doc


def read_urdf(path: str | Path) -> Robot:
    """Parse a URDF (and a Habitat ``.ao_config.json`` beside it); raise InputError naming the file and link/joint."""
    path = Path(path)
    where = display_path(path)
    if not path.is_file():
        raise InputError(where, "file not found")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        raise InputError(where, f"not a readable URDF (XML error: {e})") from None
    if root.tag != "robot":
        raise InputError(where, f"not a URDF: the root element is <{root.tag}>, not <robot>")
    materials: dict[str, tuple[float, float, float, float]] = {}
    for m in root.findall("material"):
        col = m.find("color")
        if m.get("name") and col is not None:
            materials[m.get("name")] = tuple(_floats(col.get("rgba"), 4, where, f"material '{m.get('name')}' colour"))
    links: dict[str, Link] = {}
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            raise InputError(where, "a <link> has no name")
        if name in links:
            raise InputError(where, f"link '{name}' is defined twice")
        lk = Link(name)
        for i, v in enumerate(el.findall("visual")):
            lk.visuals.append(_geometry(v, path, where, f"link '{name}' visual {i}", materials))
        for i, c in enumerate(el.findall("collision")):
            lk.collisions.append(_geometry(c, path, where, f"link '{name}' collision {i}", materials))
        ine = el.find("inertial")
        if ine is not None:
            m = ine.find("mass")
            mass = _floats(m.get("value") if m is not None else None, 1, where, f"link '{name}' inertial mass")[0]
            if mass < 0:
                raise InputError(where, f"link '{name}': negative mass {mass:g}")
            i_el = ine.find("inertia")
            vals = {k: float(i_el.get(k, 0.0)) if i_el is not None else 0.0
                    for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
            inertia = np.array([[vals["ixx"], vals["ixy"], vals["ixz"]], [vals["ixy"], vals["iyy"], vals["iyz"]],
                                [vals["ixz"], vals["iyz"], vals["izz"]]])
            lk.inertial = Inertial(float(mass), _origin(ine, where, f"link '{name}' inertial"), inertia)
        links[name] = lk
    if not links:
        raise InputError(where, "the URDF has no <link>")
    joints: list[Joint] = []
    parent_of: dict[str, str] = {}
    for el in root.findall("joint"):
        name = el.get("name") or ""
        what = f"joint '{name}'"
        if not name:
            raise InputError(where, "a <joint> has no name")
        if any(j.name == name for j in joints):
            raise InputError(where, f"{what} is defined twice")
        jtype = el.get("type") or ""
        if jtype not in JOINT_TYPES:
            raise InputError(where, f"{what}: unknown or unsupported joint type '{jtype}' (supported: {', '.join(JOINT_TYPES)})")
        p_el, c_el = el.find("parent"), el.find("child")
        parent = p_el.get("link") if p_el is not None else None
        child = c_el.get("link") if c_el is not None else None
        for role, lname in (("parent", parent), ("child", child)):
            if not lname:
                raise InputError(where, f"{what} has no {role} link")
            if lname not in links:
                raise InputError(where, f"{what}: {role} link '{lname}' does not exist")
        if child in parent_of:
            raise InputError(where, f"{what}: link '{child}' is already the child of joint '{parent_of[child]}' "
                                    "(a link has one parent joint)")
        parent_of[child] = name
        axis = _floats((el.find("axis").get("xyz") if el.find("axis") is not None else None), 3, where,
                       f"{what} axis", (1.0, 0.0, 0.0))
        if jtype != "fixed":
            n = float(np.linalg.norm(axis))
            if n < 1e-9:
                raise InputError(where, f"{what}: axis is zero")
            axis = axis / n
        j = Joint(name, jtype, parent, child, _origin(el, where, what), axis)  # type: ignore[arg-type]
        lim = el.find("limit")
        if lim is not None:
            get = (lambda k: _floats(lim.get(k), 1, where, f"{what} limit {k}")[0] if lim.get(k) is not None else None)
            j.lower, j.upper, j.effort, j.velocity = get("lower"), get("upper"), get("effort"), get("velocity")
        if jtype in ("revolute", "prismatic"):
            if lim is None:
                raise InputError(where, f"{what}: a {jtype} joint needs a <limit lower upper>")
            j.lower = 0.0 if j.lower is None else j.lower
            j.upper = 0.0 if j.upper is None else j.upper
            if j.lower > j.upper:
                raise InputError(where, f"{what}: limit lower {j.lower:g} > upper {j.upper:g}")
        dyn = el.find("dynamics")
        if dyn is not None:
            j.damping = float(_floats(dyn.get("damping"), 1, where, f"{what} dynamics damping", (0.0,))[0])
            j.friction = float(_floats(dyn.get("friction"), 1, where, f"{what} dynamics friction", (0.0,))[0])
            if j.damping < 0 or j.friction < 0:
                raise InputError(where, f"{what}: negative damping or friction")
        joints.append(j)
    roots = [n for n in links if n not in parent_of]
    if len(roots) > 1:
        raise InputError(where, f"the URDF has {len(roots)} root links ({', '.join(repr(r) for r in roots)}); "
                                "a URDF is one tree: join them with a joint")
    if not roots:
        raise InputError(where, f"the joints form a cycle: {_cycle(parent_of, joints)}")
    robot = Robot(path, root.get("name") or path.stem, links, joints, roots[0])
    robot.unused = _unread_elements(root)
    seen = {robot.root}
    stack = [robot.root]
    while stack:
        for j in robot.children(stack.pop()):
            seen.add(j.child)
            stack.append(j.child)
    if len(seen) != len(links):
        raise InputError(where, f"the joints form a cycle: {_cycle(parent_of, joints, set(links) - seen)}")
    cfg_path, ao = _ao_config(path)
    if cfg_path is not None:
        _apply_ao_config(robot, cfg_path, ao)
    return robot


READ_TAGS = {"robot": {"link", "joint", "material"}, "link": {"visual", "collision", "inertial"},
             "joint": {"parent", "child", "origin", "axis", "limit", "dynamics"}}  # what `read_urdf` reads


def _unread_elements(root: ET.Element) -> list[str]:
    """Return one line per kind of URDF element `read_urdf` reads past (``<transmission>``, ``<gazebo>``, a joint's
    ``<mimic>`` or ``<safety_controller>``, ...), with how many there are."""
    counts: dict[str, int] = {}
    for el in root:
        if el.tag not in READ_TAGS["robot"]:
            counts[f"<{el.tag}>"] = counts.get(f"<{el.tag}>", 0) + 1
        elif el.tag in READ_TAGS:
            for sub in el:
                if sub.tag not in READ_TAGS[el.tag]:
                    key = f"<{el.tag}><{sub.tag}>"
                    counts[key] = counts.get(key, 0) + 1
    return [f"{n} {tag} not converted" for tag, n in sorted(counts.items())]


def _cycle(parent_of: dict[str, str], joints: list[Joint], within: set[str] | None = None) -> str:
    """Return a cycle of links as 'a -> b -> a' (joint names in brackets)."""
    by_name = {j.name: j for j in joints}
    start = sorted(within)[0] if within else sorted(parent_of)[0]
    path = [start]
    cur = start
    while True:
        j = by_name[parent_of[cur]]
        cur = j.parent
        if cur in path:
            path.append(cur)
            return " <- ".join(f"'{n}'" for n in path[path.index(cur):]) + " (link <- parent link)"
        path.append(cur)


def _apply_ao_config(robot: Robot, cfg_path: Path, ao: dict[str, Any]) -> None:
    """Take render_asset, semantic_id, uniform_scale and mass_scale from a Habitat ao_config."""
    where = display_path(cfg_path)
    robot.ao_config = cfg_path
    ra = ao.get("render_asset")
    if ra:
        p = Path(str(ra))
        p = p if p.is_absolute() else cfg_path.parent / p
        if not p.is_file():
            raise InputError(where, f"render_asset '{ra}' not found (looked at {display_path(p)})")
        robot.render_asset = p
    if ao.get("semantic_id") is not None:
        try:
            robot.semantic_id = int(ao["semantic_id"])
        except (TypeError, ValueError):
            raise InputError(where, f"semantic_id must be an integer, got {ao['semantic_id']!r}") from None
    for key in ("uniform_scale", "mass_scale"):
        if ao.get(key) is not None:
            try:
                v = float(ao[key])
            except (TypeError, ValueError):
                v = float("nan")
            if not (np.isfinite(v) and v > 0):
                raise InputError(where, f"{key} must be a positive number, got {ao[key]!r}")
            setattr(robot, "scale" if key == "uniform_scale" else "mass_scale", v)


def _mesh_files(path: Path) -> list[Path]:
    """Return a mesh file and what it references (MTL, textures, buffers)."""
    if path.suffix.lower() == ".dae":
        return [path]
    return referenced_files(path)


def urdf_mesh_files(path: str | Path) -> list[Path]:
    """Return every mesh file a URDF references (resolved; [] when the URDF cannot be read)."""
    try:
        robot = read_urdf(path)
    except InputError:
        return []
    out = [g.mesh for lk in robot.links.values() for g in lk.visuals + lk.collisions if g.mesh is not None]
    return out + ([robot.render_asset] if robot.render_asset else [])


# ----------------------------------------------------------------------------------------------
# geometry


def _load_parts(mesh: Path, scale: np.ndarray, T: np.ndarray, where: str, what: str) -> list[Part]:
    """Load a mesh file as parts, scaled per axis and moved by T (4x4) into the link frame."""
    import trimesh

    try:
        if mesh.suffix.lower() == ".dae":
            try:
                scene = trimesh.load(str(mesh), force="scene", process=False)
            except Exception as e:  # noqa: BLE001 - pycollada missing or a bad file
                raise InputError(display_path(mesh), f"cannot read DAE file ({type(e).__name__}: {e}); "
                                                     "install pycollada or convert it to OBJ/GLB") from None
            geom = scene.to_mesh()  # one mesh in the file's frame, node transforms applied (colour: the URDF's)
            if len(geom.faces) == 0:
                raise InputError(display_path(mesh), "no triangles in the file")
            parts = [Part(np.asarray(geom.vertices, float), np.asarray(geom.faces, np.int64),
                          Material(mesh.stem, DEFAULT_RGBA, None, f"dae|{mesh}"))]
        else:
            u = float(np.abs(scale).max())  # size checks see metres; a non-uniform scale is applied after
            parts = load_mesh(mesh, units=u, up="+Z", kind="object").parts
            scale = scale / u
    except InputError as e:
        raise InputError(where, f"{what}: {e}") from None
    for p in parts:
        p.vertices = (p.vertices * scale) @ T[:3, :3].T + T[:3, 3]
        if np.linalg.det(np.diag(scale)) < 0:  # a mirroring scale flips the winding
            p.faces = p.faces[:, ::-1].copy()
    return parts


def inertia_problem(I: np.ndarray) -> str | None:
    """Return why a 3x3 inertia tensor (kg m^2) is not physical for MuJoCo, or None when it is.

    MuJoCo's compiler needs positive principal moments that satisfy the triangle inequality (A + B >= C);
    PyBullet accepts URDFs without either (e.g. ``izz="0"``).
    """
    from .writer import fmt

    I = np.asarray(I, dtype=np.float64)
    if not np.isfinite(I).all():
        return "has non-finite entries"
    ev = np.sort(np.linalg.eigvalsh(0.5 * (I + I.T)))
    scale = max(float(np.abs(ev).max()), 1e-300)
    if ev[0] <= 1e-9 * scale or ev[0] <= 1e-14:
        return f"has principal moments {fmt(ev, 6)} (not all positive)"
    if ev[0] + ev[1] < ev[2] * (1.0 - 1e-9):
        return f"has principal moments {fmt(ev, 6)} (A + B < C: no rigid body has them)"
    return None


def box_inertia(mass: float, points: np.ndarray | None, fallback: float = 0.05) -> np.ndarray:
    """Return the principal moments (kg m^2) of a solid box of `mass` spanning `points` (N, 3), axis-aligned.

    A side under 1 mm counts as 1 mm; without points the box is a cube of side `fallback` metres.
    """
    if points is None or len(points) == 0:
        ext = np.full(3, float(fallback))
    else:
        ext = np.maximum(np.ptp(np.asarray(points, dtype=np.float64), axis=0), 1e-3)
    a, b, c = ext
    return mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def _primitive_corners(g: Geometry) -> np.ndarray:
    """Return points bounding a primitive in the link frame (box corners; cylinder/sphere bounding-box corners)."""
    if g.kind == "box":
        h = np.asarray(g.size) / 2
    elif g.kind == "cylinder":
        h = np.array([g.size[0], g.size[0], g.size[1] / 2])
    else:
        h = np.full(3, g.size[0])
    c = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
    return c @ g.origin[:3, :3].T + g.origin[:3, 3]


def _primitive_volume(g: Geometry) -> float:
    """Return a primitive's volume, m^3."""
    if g.kind == "box":
        return float(np.prod(g.size))
    if g.kind == "cylinder":
        return float(math.pi * g.size[0] ** 2 * g.size[1])
    return float(4.0 / 3.0 * math.pi * g.size[0] ** 3)


def _scaled(g: Geometry, s: float) -> Geometry:
    """Return a geometry with every length multiplied by s (the ao_config uniform_scale)."""
    if s == 1.0:
        return g
    T = g.origin.copy()
    T[:3, 3] *= s
    return Geometry(g.kind, T, tuple(x * s for x in g.size), g.mesh, g.scale * s, g.rgba)


def _pose_attrs(T: np.ndarray) -> str:
    """Return ` pos=".." quat=".."` attributes of a 4x4 transform (omitted parts when identity)."""
    from .writer import fmt

    out = ""
    if np.abs(T[:3, 3]).max() > 0:
        out += f' pos="{fmt(T[:3, 3])}"'
    if np.abs(T[:3, :3] - np.eye(3)).max() > 1e-12:
        out += f' quat="{fmt(mat_to_quat(T[:3, :3]))}"'
    return out


def _primitive_attrs(g: Geometry) -> str:
    """Return MJCF type/size attributes of a primitive (half sizes; cylinder radius, half length)."""
    from .writer import fmt

    if g.kind == "box":
        return f'type="box" size="{fmt(np.asarray(g.size) / 2)}"'
    if g.kind == "cylinder":
        return f'type="cylinder" size="{fmt([g.size[0], g.size[1] / 2])}"'
    return f'type="sphere" size="{fmt([g.size[0]])}"'


# ----------------------------------------------------------------------------------------------
# writing


def _unique(name: str, used: set[str]) -> str:
    """Return a sanitized MJCF name not yet in `used` (and record it)."""
    from .naming import sanitize

    base = sanitize(name)
    out, k = base, 1
    while out in used:
        k += 1
        out = f"{base}_{k}"
    used.add(out)
    return out


def write_mjcf(robot: Robot, work: Path, name: str, density: float, cfg: ConvertConfig) -> tuple[ObjectAsset, dict[str, Any]]:
    """Write `robot` as ``work/model.xml`` + ``work/assets/``; return its ObjectAsset (mjcf relative) and report figures.

    Parameters
    ----------
    robot : Robot
        The parsed URDF.
    work : Path
        Output folder (the object's folder).
    name : str
        Model name.
    density : float
        Collision-geom density, kg/m^3 (links without ``<inertial>`` get their mass from it).
    cfg : ConvertConfig
        CoACD and texture settings.
    """
    import trimesh

    from .hulls import clean_hulls, decompose, hull_volume, nearly_convex
    from .writer import AssetWriter, clean_part, fmt, merge_parts

    where = display_path(robot.path)
    s = robot.scale
    writer = AssetWriter(work / "assets", cfg.texture_max_size)
    maxv = max(int(cfg.coacd_max_hull_vertices), 4)
    used: set[str] = set()
    body_names = {robot.root: _unique("object", used)}
    for lk in robot.links:
        if lk != robot.root:
            body_names[lk] = _unique(lk, used)
    joint_used: set[str] = set()
    points: dict[str, list[np.ndarray]] = {lk: [] for lk in robot.links}
    volume = 0.0
    hull_count, coacd_links, warnings = 0, [], []
    hull_t = 0.0
    body_xml: dict[str, list[str]] = {}
    for lname, link in robot.links.items():
        b = body_names[lname]
        lines: list[str] = []
        vis = [_scaled(g, s) for g in link.visuals]
        col = [_scaled(g, s) for g in link.collisions]
        render = robot.render_asset if lname == robot.root else None
        prims = [g for g in vis if g.kind != "mesh"]  # collision stand-ins when the link has no <collision>
        if render is not None:  # Habitat draws the render asset instead of the link's visuals
            vis = [Geometry("mesh", np.eye(4), (), render, np.full(3, s))]
        vis_meshes: list[Part] = []
        for i, g in enumerate(vis):
            what = "render_asset" if render is not None else f"link '{lname}' visual {i}"
            if g.kind == "mesh":
                parts = [p for p in (clean_part(q) for q in merge_parts(_load_parts(g.mesh, g.scale, g.origin, where, what)))
                         if p is not None]
                for k, p in enumerate(parts):
                    textured = p.material.image is not None and p.uv is not None
                    mat = p.material
                    if g.rgba is not None and not textured:
                        mat = Material(mat.name, g.rgba, None, f"urdf|{fmt(g.rgba, 4)}")
                    mname = writer.material(mat, textured)
                    mesh_name = f"{b}_visual_{i}_{k}"
                    writer.mesh(mesh_name, p.vertices, p.faces, p.uv if textured else None, ' inertia="shell"')
                    lines.append(f'<geom name="{b}/visual_{i}_{k}" class="visual" mesh="{mesh_name}" material="{mname}"/>')
                    points[lname].append(p.vertices)
                vis_meshes += parts
            else:
                rgba = g.rgba or DEFAULT_RGBA
                mname = writer.material(Material("urdf", rgba, None, f"urdf|{fmt(rgba, 4)}"), False)
                lines.append(f'<geom name="{b}/visual_{i}" class="visual" {_primitive_attrs(g)}{_pose_attrs(g.origin)} '
                             f'material="{mname}"/>')
                points[lname].append(_primitive_corners(g))
        colls: list[tuple[str, Geometry | None, tuple[np.ndarray, np.ndarray] | None]] = []
        if col:
            for i, g in enumerate(col):
                if g.kind == "mesh":
                    parts = _load_parts(g.mesh, g.scale, g.origin, where, f"link '{lname}' collision {i}")
                    v = np.concatenate([p.vertices for p in parts])
                    hulls = clean_hulls([(v, np.zeros((0, 3), np.int64))], maxv)
                    if not hulls:
                        raise InputError(where, f"link '{lname}' collision {i}: the mesh is flat (no convex hull)")
                    colls += [("hull", None, h) for h in hulls]
                else:
                    colls.append(("prim", g, None))
        else:
            colls += [("prim", g, None) for g in prims]
            if vis_meshes:
                offs = np.cumsum([0] + [len(p.vertices) for p in vis_meshes[:-1]])
                tm = trimesh.Trimesh(np.concatenate([p.vertices for p in vis_meshes]),
                                     np.concatenate([p.faces + o for p, o in zip(vis_meshes, offs)]), process=True)
                t0 = time.perf_counter()
                chull = tm.convex_hull
                if float(chull.volume) <= 1e-12:
                    raise InputError(where, f"link '{lname}': its visual mesh is flat and it has no <collision>")
                if nearly_convex(tm, chull, float(cfg.coacd_threshold)):
                    hulls = clean_hulls([(np.asarray(chull.vertices), np.asarray(chull.faces))], maxv)
                else:
                    hulls = decompose(tm.vertices, tm.faces, cfg)
                    coacd_links.append(lname)
                hull_t += time.perf_counter() - t0
                colls += [("hull", None, h) for h in hulls]
        for k, (kind, g, h) in enumerate(colls):
            if kind == "prim":
                assert g is not None
                lines.append(f'<geom name="{b}/collision_{k}" class="collision" {_primitive_attrs(g)}{_pose_attrs(g.origin)}/>')
                points[lname].append(_primitive_corners(g))
                volume += _primitive_volume(g)
            else:
                assert h is not None
                mesh_name = f"{b}_collision_{k}"
                writer.mesh(mesh_name, h[0], h[1], None, f' inertia="convex" maxhullvert="{maxv}"')
                lines.append(f'<geom name="{b}/collision_{k}" class="collision" type="mesh" mesh="{mesh_name}"/>')
                points[lname].append(h[0])
                volume += hull_volume([h])
                hull_count += 1
        if link.inertial is not None and link.inertial.mass > 0:
            ine = link.inertial
            R = ine.origin[:3, :3]
            I = R @ ine.inertia @ R.T * s * s  # in the link frame
            pos = ine.origin[:3, 3] * s
            mass = ine.mass * robot.mass_scale
            why = inertia_problem(I)
            if why is None:
                full = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
                lines.insert(0, f'<inertial pos="{fmt(pos)}" mass="{fmt([mass])}" fullinertia="{fmt(full, 8)}"/>')
            else:
                # PyBullet runs such links; MuJoCo refuses to compile them. Keep the URDF's mass and centre of
                # mass, take the inertia of a solid box spanning the link's geometry (SolidWorks exports, random
                # objects with izz=0).
                diag = box_inertia(mass, np.concatenate(points[lname]) if points[lname] else None)
                warnings.append(f"link '{lname}': URDF inertia {why}; used a solid box of the link's geometry "
                                f"with its mass ({fmt(diag, 8)} kg m^2)")
                lines.insert(0, f'<inertial pos="{fmt(pos)}" mass="{fmt([mass])}" diaginertia="{fmt(diag, 8)}"/>')
        elif not colls and lname != robot.root and _moves(robot, lname):
            warnings.append(f"link '{lname}' moves but has no inertial and no collision geometry: given {MIN_MASS:g} kg")
            lines.insert(0, f'<inertial pos="0 0 0" mass="{MIN_MASS:g}" diaginertia="1e-6 1e-6 1e-6"/>')
        body_xml[lname] = lines

    parts_out: list[ArticulatedPart] = []

    def emit(lname: str, depth: int, T_world: np.ndarray, out: list[str], joint: Joint | None) -> None:
        ind = "  " * depth
        b = body_names[lname]
        pose = "" if joint is None else _pose_attrs(_scaled_T(joint.origin, s))
        out.append(f'{ind}<body name="{b}"{pose}>')
        if joint is not None and joint.type != "fixed":
            jname = _unique(joint.name, joint_used)
            kind = "slide" if joint.type == "prismatic" else "hinge"
            lim = joint.type != "continuous"
            lo = (joint.lower or 0.0) * (s if kind == "slide" else 1.0)
            hi = (joint.upper or 0.0) * (s if kind == "slide" else 1.0)
            attrs = f'name="{jname}" class="articulation" type="{kind}" axis="{fmt(joint.axis)}"'
            attrs += f' range="{fmt([lo, hi])}" limited="true"' if lim else ' limited="false"'
            if joint.damping:
                attrs += f' damping="{fmt([joint.damping])}"'
            if joint.friction:
                attrs += f' frictionloss="{fmt([joint.friction])}"'
            if joint.effort:
                attrs += f' actuatorfrcrange="{fmt([-joint.effort, joint.effort])}"'
            out.append(f"{ind}  <joint {attrs}/>")
            parts_out.append(ArticulatedPart(joint=jname, kind=kind, range=(float(lo), float(hi)) if lim else None,
                                             body=b, axis=tuple(float(x) for x in joint.axis), link=lname))
        out += [f"{ind}  {ln}" for ln in body_xml[lname]]
        for pts in points[lname]:
            world_pts.append(pts @ T_world[:3, :3].T + T_world[:3, 3])
        for j in robot.children(lname):
            emit(j.child, depth + 1, T_world @ _scaled_T(j.origin, s), out, j)
        out.append(f"{ind}</body>")

    world_pts: list[np.ndarray] = []
    tree: list[str] = []
    emit(robot.root, 2, np.eye(4), tree, None)
    if not world_pts:
        raise InputError(where, "the URDF has no visual or collision geometry")
    allp = np.concatenate(world_pts)
    bbox = np.stack([allp.min(axis=0), allp.max(axis=0)])
    xml = f"""<mujoco model="{name}">
  <!-- sdovon-mj articulated object from URDF {robot.path.name} (assets_convert.urdf): links are bodies nested
       along the kinematic tree in the URDF root-link frame; visual geoms class "visual" (group 2, no contacts,
       no mass), collision geoms class "collision" (group 3). The root body has no joint. -->
  <compiler angle="radian" meshdir="assets" texturedir="assets" autolimits="true"/>

  <default>
    <default class="visual">
      <geom type="mesh" group="2" contype="0" conaffinity="0" density="0"/>
    </default>
    <default class="collision">
      <geom group="3" density="{fmt([density])}" friction="{FRICTION}"/>
    </default>
    <default class="articulation">
      <joint armature="{ARMATURE:g}" solreflimit="{SOLREF_LIMIT}"/>
    </default>
  </default>

  <asset>
{writer.xml}
  </asset>

  <worldbody>
{chr(10).join(tree)}
  </worldbody>
</mujoco>
"""
    atomic_write_text(work / "model.xml", xml)
    import mujoco

    try:
        model = mujoco.MjModel.from_xml_path(str(work / "model.xml"))
    except Exception as e:  # noqa: BLE001
        raise InputError(where, f"converted model does not compile in MuJoCo: {e}") from None
    mass = float(model.body_mass[1:].sum())
    asset = ObjectAsset(name=name, category="", mjcf="model.xml", bbox=bbox, mass=mass, hull_count=hull_count,
                        volume=float(volume), volume_ratio=0.0, parts=parts_out, semantic_id=robot.semantic_id)
    info = {"links": len(robot.links), "joints": len(robot.joints), "movable": len(parts_out),
            "hulls": hull_count, "coacd_links": coacd_links, "hull_seconds": round(hull_t, 3), "mass": mass,
            "density": density, "scale": s, "warnings": warnings,
            "render_asset": display_path(robot.render_asset) if robot.render_asset else None}
    if robot.unused:  # only then: reports of URDFs read in full keep their bytes
        info["unused"] = list(robot.unused)
    return asset, info


def _scaled_T(T: np.ndarray, s: float) -> np.ndarray:
    """Return a transform with its translation multiplied by s."""
    if s == 1.0:
        return T
    out = T.copy()
    out[:3, 3] *= s
    return out


def _moves(robot: Robot, link: str) -> bool:
    """Return whether a link's own joint is movable (fixed chains to a moving parent do not count)."""
    return any(j.child == link and j.type != "fixed" for j in robot.joints)


# ----------------------------------------------------------------------------------------------
# conversion (cached)


def convert_urdf_report(path: str | Path, out_dir: str | Path, category: str | None = None,
                        density: float | None = None, name: str | None = None, config: ConvertConfig | None = None,
                        cache_dir: str | Path | None = None, source: str | None = None,
                        scale: float = 1.0) -> tuple[ObjectAsset, dict[str, Any]]:
    """Convert one URDF to ``<out_dir>/objects/<name>/model.xml`` (cached); return its ObjectAsset and report figures.

    Parameters
    ----------
    path : str or Path
        The URDF file (a Habitat ``<stem>.ao_config.json`` beside it is read too).
    out_dir : str or Path
        Output root; the object goes to ``<out_dir>/objects/<name>/``.
    category : str, optional
        Object category (default: ``assets.yaml`` metadata, ``meta.json`` beside the file (its ``category`` or
        PartNet-Mobility's ``model_cat``), else the object's name: `object.default_category` with the URDF's folder as
        the library; the robot name is not used, URDFs copy it about).
    density : float, optional
        Collision-geom density for links without ``<inertial>``, kg/m^3 (default: the category's).
    name : str, optional
        Asset name (default: the URDF file stem; its folder's name for a generic stem like ``mobility``).
    config : ConvertConfig, optional
        Conversion settings (CoACD, textures; units and up axis do not apply: a URDF is metres, Z up).
    cache_dir : str or Path, optional
        Conversion cache folder (default: the user cache).
    source : str, optional
        The source recorded in the asset (default: `path`).
    scale : float
        Uniform scale applied on top of the ao_config's ``uniform_scale`` (a Habitat scene instance's
        ``uniform_scale``): every length, as habitat-sim scales a URDF.
    """
    from . import cache
    from .metadata import meta_for
    from .naming import default_category, density_for, object_name
    from .objcache import cached_object

    t0 = time.perf_counter()
    cfg = config or ConvertConfig()
    path, out_dir = Path(path), Path(out_dir)
    robot = read_urdf(path)
    if not (np.isfinite(scale) and scale > 0):
        raise InputError(display_path(path), f"scale must be a positive number, got {scale!r}")
    robot.scale *= float(scale)
    meta = meta_for(path)
    name = object_name(path, name)
    # the URDF's robot name is no category (pybullet_data's duck_vhacd.urdf names its robot 'cube.urdf')
    category = category or meta.category or default_category(path, path.parent)
    dens = float(density) if density else density_for(category, cfg.default_density)
    params = {"kind": "urdf", "name": name, "category": category, "density": dens,
              **({"source": source} if source else {}), **({"scale": float(scale)} if scale != 1.0 else {}),
              "config": {k: getattr(cfg, k) for k in sorted(cfg.__dataclass_fields__)
                         if k not in ("jobs", "timeout_s", "add_floor", "units", "up", "target_size")},
              **gpu_texture_key(robot.files())}
    key = cache.cache_key(robot.files() + meta.sources, params)

    def build(tmp: Path) -> tuple[ObjectAsset, dict[str, Any]]:
        asset, info = write_mjcf(robot, tmp, name, dens, cfg)
        asset.category = category
        return asset, info

    return cached_object(out_dir, name, key, cache_dir, source or display_path(path), t0, build)


__all__ = ["Geometry", "Inertial", "Joint", "Link", "Robot", "box_inertia", "convert_urdf_report", "inertia_problem", "read_urdf", "resolve_mesh",
           "urdf_mesh_files", "write_mjcf"]
