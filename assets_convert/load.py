"""Mesh loading: OBJ(+MTL), GLB/glTF, PLY, STL -> parts in metres, Z up, one material each.

Units (``units="auto"``), by the largest bounding-box extent E of the file in file units:

- objects: E <= 5 -> metres; 5 < E <= 500 -> centimetres; 500 < E <= 5000 -> millimetres;
  larger -> error (no household object is that big in any of these units).
- scenes: E <= 200 -> metres; <= 20 000 -> centimetres; <= 200 000 -> millimetres; larger -> error.

Explicit units: ``"m"``, ``"cm"``, ``"mm"``, ``"in"`` or a number (metres per file unit). A converted
object larger than 20 m (scene: 2 km) or smaller than 1 mm is rejected. ``target_size > 0``
rescales an object so its largest extent equals it (for files whose units are unknown).

Up axis (``up="auto"``): glTF/GLB -> +Y (the glTF convention), every other format -> +Z.
Explicit: ``"+X" "-X" "+Y" "-Y" "+Z" "-Z"`` (also ``"y"``, ``"z"``). The file is rotated so its
up axis becomes +Z; +Y up maps (x, y, z) -> (x, -z, y) (+90 deg about X, as Drake and robocasa do).
"""

from __future__ import annotations

import json
import os
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sdovon_mj.errors import InputError

SUPPORTED = (".obj", ".glb", ".gltf", ".ply", ".stl")
UNIT_NAMES = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
OBJECT_AUTO = ((5.0, 1.0), (500.0, 0.01), (5000.0, 0.001))
SCENE_AUTO = ((200.0, 1.0), (20000.0, 0.01), (200000.0, 0.001))
OBJECT_MAX_SIZE = 20.0
SCENE_MAX_SIZE = 2000.0
MIN_SIZE = 1e-3
FLAT_TOL = 1e-5  # m: thinner than this is a flat (zero-volume) object


def display_path(path: str | os.PathLike[str]) -> str:
    """Return a printable path (undecodable bytes of non-UTF-8 names shown as \\xNN)."""
    return os.fsencode(os.fspath(path)).decode("utf-8", "backslashreplace")


def check_name(path: Path) -> None:
    """Raise InputError when a file name is not valid UTF-8 (it cannot go into MJCF or JSON)."""
    try:
        os.fspath(path).encode("utf-8")
    except UnicodeEncodeError:
        raise InputError(display_path(path), "file name is not valid UTF-8; rename the file") from None


@dataclass
class Material:
    """One render material: colour factor and an optional base-colour image (PIL)."""

    name: str
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)
    image: Any = None  # PIL.Image or None
    key: str = ""  # identity for merging parts that share a material


@dataclass
class Part:
    """A triangle mesh with one material, already in metres and Z up."""

    vertices: np.ndarray  # (N, 3) float64
    faces: np.ndarray  # (M, 3) int64
    material: Material
    uv: np.ndarray | None = None  # (N, 2), OBJ convention (v = 0 at the image bottom)
    colors: np.ndarray | None = None  # (N, 4) uint8 vertex colours (scans)
    node: str = ""


@dataclass
class LoadedMesh:
    """A loaded file: its parts and how units and up axis were resolved."""

    path: Path
    parts: list[Part]
    scale: float
    units_rule: str
    up: str
    files: list[Path] = field(default_factory=list)  # the file and every file it references

    @property
    def bounds(self) -> np.ndarray:
        """Return the (2, 3) min/max of all parts."""
        v = np.concatenate([p.vertices for p in self.parts])
        return np.stack([v.min(axis=0), v.max(axis=0)])

    @property
    def face_count(self) -> int:
        """Return the number of triangles over all parts."""
        return int(sum(len(p.faces) for p in self.parts))


# ----------------------------------------------------------------------------------------------
# referenced files (for missing-file errors and cache keys)


def _obj_references(path: Path) -> list[Path]:
    """Return the MTL files and textures an OBJ references; raise on missing ones."""
    refs: list[Path] = []
    try:
        text = path.read_bytes().decode("utf-8", "replace")
    except OSError as e:
        raise InputError(display_path(path), f"cannot read file: {e}") from None
    for m in re.finditer(r"^\s*mtllib\s+(.+?)\s*$", text, flags=re.M):
        mtl = path.parent / m.group(1)
        if not mtl.is_file():
            raise InputError(display_path(path), f"material library '{m.group(1)}' not found (looked at {display_path(mtl)})")
        refs.append(mtl)
        mtext = mtl.read_bytes().decode("utf-8", "replace")
        for t in re.finditer(r"^\s*map_\w+\s+(.+?)\s*$", mtext, flags=re.M):
            tokens = t.group(1).split()
            # options like "-s 1 1 1" precede the file name; the name is the last token(s)
            name = tokens[-1]
            tex = mtl.parent / name
            if not tex.is_file():
                raise InputError(display_path(path), f"texture file '{name}' referenced by {mtl.name} not found")
            if tex.stat().st_size == 0:  # trimesh would drop it silently and the object would lose its texture
                raise InputError(display_path(path), f"texture file '{name}' referenced by {mtl.name} is empty (0 bytes)")
            refs.append(tex)
    return refs


def read_json(path: str | os.PathLike[str]) -> Any:
    """Read a JSON file or raise InputError naming it."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(display_path(path), f"cannot read JSON: {e}") from None


def _gltf_json(path: Path) -> dict[str, Any]:
    """Return the JSON chunk of a glTF or GLB; raise on truncated or corrupt files."""
    if path.suffix.lower() == ".glb":  # the header and the JSON chunk only: a scan's binary chunk is not read here
        size = path.stat().st_size
        with open(path, "rb") as fh:
            head = fh.read(20)
            if len(head) < 20:
                raise InputError(display_path(path), f"truncated GLB: {len(head)} bytes, shorter than the 20-byte header")
            magic, _version, length = struct.unpack("<4sII", head[:12])
            if magic != b"glTF":
                raise InputError(display_path(path), "not a GLB file (bad magic bytes)")
            if length > size:
                raise InputError(display_path(path), f"truncated GLB: header says {length} bytes, file has {size}")
            clen, ctype = struct.unpack("<II", head[12:20])
            if ctype != 0x4E4F534A or 20 + clen > size:
                raise InputError(display_path(path), "corrupt GLB: bad JSON chunk")
            raw = fh.read(clen)
    else:
        raw = path.read_bytes()
    try:
        return json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(display_path(path), f"glTF JSON is not readable: {e}") from None


def _check_gltf_extensions(path: Path, doc: dict[str, Any]) -> None:
    """Raise InputError when a glTF's geometry is compressed in a way the loader cannot decode here.

    trimesh decodes ``KHR_draco_mesh_compression`` through DracoPy when it is installed (without it the vertices
    are silently zeros) and does not decode ``EXT_meshopt_compression`` at all.
    """
    import importlib.util

    used = set(doc.get("extensionsUsed", [])) | set(doc.get("extensionsRequired", []))
    if "KHR_draco_mesh_compression" in used and importlib.util.find_spec("DracoPy") is None:
        raise InputError(display_path(path), "the geometry is Draco-compressed (KHR_draco_mesh_compression) and "
                         "DracoPy is not installed: `pip install DracoPy`, or write the file without Draco compression")
    meshopt = sorted(used & {"EXT_meshopt_compression", "KHR_meshopt_compression"})
    if meshopt:
        raise InputError(display_path(path), f"the geometry is meshopt-compressed ({meshopt[0]}), which cannot be "
                         "read here: write the file without it (e.g. `gltf-transform copy IN OUT` after "
                         "`gltf-transform meshopt --decode`, or re-export from the source)")


# Texture encodings Pillow (and so trimesh) cannot decode: a base-colour texture in one of them would be dropped
GPU_TEXTURE_MIMES = ("image/ktx2", "image/ktx", "image/x-basis", "image/basis")
GPU_TEXTURE_SUFFIXES = (".ktx2", ".ktx", ".basis")
GPU_TEXTURE_EXTENSIONS = ("KHR_texture_basisu", "GOOGLE_texture_basis", "EXT_texture_astc", "MSFT_texture_dds")


def _check_colour_textures(path: Path, doc: dict[str, Any]) -> None:
    """Raise InputError when a base-colour texture is in a GPU encoding that cannot be decoded here.

    trimesh reads images through Pillow; a KTX2 or Basis texture would be dropped without a word and the model
    would come out untextured (a scene's renders then feed the detectors grey surfaces). KTX2 (Basis Universal or
    plain 8-bit pixels) and ``.basis`` images are decoded (`gputex`); their headers are checked here, before any
    loading. Other GPU encodings (DDS, ASTC, KTX1) are refused.
    """
    from . import gputex

    textures, images = doc.get("textures", []), doc.get("images", [])
    decodable = gputex.gpu_colour_images(doc)
    binary: Any = b""
    for mat in doc.get("materials", []):
        idx = mat.get("pbrMetallicRoughness", {}).get("baseColorTexture", {}).get("index")
        if idx is None or not 0 <= idx < len(textures):
            continue
        if idx in decodable:
            if not binary and path.suffix.lower() == ".glb":
                binary = _GlbBinary(path)
            head = gputex.image_bytes(doc, binary, decodable[idx], path.parent, display_path(path), limit=80)
            why = gputex.header_problem(head)
            if why:
                raise InputError(display_path(path), f"material '{mat.get('name', '')}' has a base-colour texture "
                                 f"that cannot be decoded here ({why}), so the model would lose its look: use a copy "
                                 "with PNG/JPEG textures (HM3D: the plain <id>.glb of the glb package)")
            continue
        tex = textures[idx]
        src = tex.get("source")
        ext = sorted(set(tex.get("extensions", {})) & set(GPU_TEXTURE_EXTENSIONS))
        img = images[src] if src is not None and 0 <= src < len(images) else {}
        gpu = (src is None and ext) or img.get("mimeType", "").lower() in GPU_TEXTURE_MIMES \
            or str(img.get("uri", "")).lower().endswith(GPU_TEXTURE_SUFFIXES)
        if gpu:
            how = ext[0] if ext else (img.get("mimeType") or Path(str(img.get("uri", ""))).suffix)
            raise InputError(display_path(path), f"material '{mat.get('name', '')}' has its base-colour texture in a GPU "
                             f"encoding ({how}) that cannot be decoded here, so the model would lose its look: use a "
                             "copy with PNG/JPEG textures (KTX2 and Basis Universal images are read; DDS, ASTC and "
                             "KTX1 are not)")


GPU_ORIENTATION_RULE = 1  # version of gputex's row order (1: .basis Y-flip and KTXorientation honoured)


def gpu_texture_key(files: list[Path]) -> dict[str, int]:
    """Return the cache-key parameters that the decoding of GPU-encoded textures adds for a conversion reading
    `files`: ``{"gpu_orientation": GPU_ORIENTATION_RULE}`` when a glTF/GLB among them has a KTX2 / Basis base-colour
    image (a conversion cached before the orientation rule held its textures upside down), else {} (the keys of all
    other conversions stay as they were)."""
    from . import gputex

    for f in files:
        if Path(f).suffix.lower() in (".glb", ".gltf") and Path(f).is_file():
            try:
                if gputex.gpu_colour_images(_gltf_json(Path(f))):
                    return {"gpu_orientation": GPU_ORIENTATION_RULE}
            except InputError:
                continue  # a damaged file: its loading names it
    return {}


class _GlbBinary:
    """The BIN chunk of a GLB, read by slices from the file (a header check reads a few bytes of a large scan)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        with open(path, "rb") as fh:
            fh.seek(12)
            clen = struct.unpack("<I", fh.read(4))[0]
            fh.seek(20 + clen)
            head = fh.read(8)
        self.start = 20 + clen + 8 if len(head) == 8 and struct.unpack("<II", head)[1] == 0x004E4942 else -1
        self.size = struct.unpack("<II", head)[0] if self.start >= 0 else 0

    def __bool__(self) -> bool:
        return True

    def __getitem__(self, sl: slice) -> bytes:
        if self.start < 0:
            return b""
        a, b = max(0, sl.start or 0), min(self.size, self.size if sl.stop is None else sl.stop)
        with open(self.path, "rb") as fh:
            fh.seek(self.start + a)
            return fh.read(max(0, b - a))


def _gltf_references(path: Path) -> list[Path]:
    """Return the buffers and images a glTF references; raise on missing ones or undecodable compression."""
    doc = _gltf_json(path)
    _check_gltf_extensions(path, doc)
    _check_colour_textures(path, doc)
    from urllib.parse import unquote

    refs: list[Path] = []
    # base-colour images are required; normal/roughness maps are not used and may be missing
    textures = doc.get("textures", [])
    colour_images = set()
    for mat in doc.get("materials", []):
        idx = mat.get("pbrMetallicRoughness", {}).get("baseColorTexture", {}).get("index")
        if idx is not None and 0 <= idx < len(textures):
            colour_images.add(textures[idx].get("source"))
    for kind in ("buffers", "images"):
        for i, item in enumerate(doc.get(kind, [])):
            uri = item.get("uri")
            if not uri or uri.startswith("data:"):
                continue
            p = path.parent / unquote(uri)
            if not p.is_file():
                if kind == "images" and i not in colour_images:
                    continue
                what = "texture file" if kind == "images" else "buffer file"
                raise InputError(display_path(path), f"{what} '{uri}' not found")
            if p.stat().st_size == 0 and (kind == "buffers" or i in colour_images):
                what = "texture file" if kind == "images" else "buffer file"
                raise InputError(display_path(path), f"{what} '{uri}' is empty (0 bytes)")
            refs.append(p)
    if path.suffix.lower() == ".glb":
        size = path.stat().st_size
        for buf in doc.get("buffers", []):
            if "uri" not in buf:
                need = int(buf.get("byteLength", 0))
                if size < 20 + need:
                    raise InputError(display_path(path), f"truncated GLB: binary chunk needs {need} bytes")
    return refs


def referenced_files(path: Path) -> list[Path]:
    """Return `path` plus every file it references (MTL, textures, buffers), checking they exist."""
    path = Path(path)
    check_name(path)
    if not path.exists():
        raise InputError(display_path(path), "file not found")
    if not path.is_file():
        raise InputError(display_path(path), "not a regular file")
    if path.stat().st_size == 0:
        raise InputError(display_path(path), "empty file (0 bytes)")
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED:
        raise InputError(display_path(path), f"unsupported format '{suffix}' (supported: {', '.join(SUPPORTED)})")
    refs: list[Path] = []
    if suffix == ".obj":
        refs = _obj_references(path)
    elif suffix in (".gltf", ".glb"):
        refs = _gltf_references(path)
    out = [path]
    for r in refs:
        if r not in out:
            out.append(r)
    return out


# ----------------------------------------------------------------------------------------------
# units and up axis


def up_rotation(up: str, path: Path) -> tuple[np.ndarray, str]:
    """Return the 3x3 rotation taking the file's up axis to +Z, and the axis name."""
    key = up.strip().upper()
    if key == "AUTO":
        key = "+Y" if path.suffix.lower() in (".glb", ".gltf") else "+Z"
    if key in ("X", "Y", "Z"):
        key = "+" + key
    rots = {
        "+Z": np.eye(3),
        "-Z": np.diag([1.0, -1.0, -1.0]),
        "+Y": np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]]),
        "-Y": np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]]),
        "+X": np.array([[0, 0, -1.0], [0, 1.0, 0], [1.0, 0, 0]]),
        "-X": np.array([[0, 0, 1.0], [0, 1.0, 0], [-1.0, 0, 0]]),
    }
    if key not in rots:
        raise InputError(display_path(path), f"unknown up axis '{up}' (use auto, +X, -X, +Y, -Y, +Z or -Z)")
    return rots[key], key


def resolve_scale(units: str | float, extent: float, path: Path, kind: str, target_size: float = 0.0) -> tuple[float, str]:
    """Return metres per file unit and the rule that chose it (see the module docstring).

    Parameters
    ----------
    units : str or float
        "auto", a unit name ("m", "cm", "mm", "in") or metres per file unit.
    extent : float
        Largest bounding-box extent of the mesh, in file units.
    path : Path
        The mesh file (named in errors).
    kind : str
        "object" or "scene" (chooses the auto table).
    target_size : float
        When > 0, the largest extent wanted, metres (overrides `units`).
    """
    where = display_path(path)
    if target_size and target_size > 0:
        if extent <= 0:
            raise InputError(where, "mesh has zero size; cannot rescale to target_size")
        return target_size / extent, f"target_size {target_size} m"
    u = str(units).strip().lower()
    if u == "auto":
        table = OBJECT_AUTO if kind == "object" else SCENE_AUTO
        for limit, scale in table:
            if extent <= limit:
                name = {1.0: "m", 0.01: "cm", 0.001: "mm"}[scale]
                return scale, f"auto: largest extent {extent:.4g} units -> {name}"
        raise InputError(where, f"largest extent {extent:.4g} file units is implausible for an {kind} in m, cm or mm "
                                f"(auto limit {table[-1][0]:g}); pass units explicitly")
    if u in UNIT_NAMES:
        return UNIT_NAMES[u], f"explicit {u}"
    try:
        s = float(u)
    except ValueError:
        raise InputError(where, f"unknown units '{units}' (use auto, m, cm, mm, in or a number)") from None
    if not np.isfinite(s) or s <= 0:
        raise InputError(where, f"units scale must be a positive number, got {units}")
    return s, f"explicit scale {s:g}"


# ----------------------------------------------------------------------------------------------
# loading


def _rgba(c: Any, default: tuple[float, ...] = (0.6, 0.6, 0.6, 1.0)) -> tuple[float, float, float, float]:
    """Return an RGBA float tuple from a trimesh colour (0-255 or 0-1)."""
    if c is None:
        return tuple(default)  # type: ignore[return-value]
    a = np.asarray(c, dtype=float).ravel()
    if a.size == 3:
        a = np.append(a, 1.0 if a.max() <= 1.0 else 255.0)
    if a.size != 4:
        return tuple(default)  # type: ignore[return-value]
    if a.max() > 1.0:
        a = a / 255.0
    return tuple(float(x) for x in np.clip(a, 0.0, 1.0))  # type: ignore[return-value]


def _material_of(geom: Any, gname: str, suffix: str) -> tuple[Material, np.ndarray | None, np.ndarray | None]:
    """Return (material, uv, vertex colours) of a trimesh geometry."""
    visual = getattr(geom, "visual", None)
    kind = getattr(visual, "kind", None)
    if kind == "texture" or type(visual).__name__ == "TextureVisuals":
        mat = visual.material
        uv = None if visual.uv is None else np.asarray(visual.uv, dtype=np.float64)
        name = getattr(mat, "name", None) or gname
        image = None
        rgba: tuple[float, float, float, float]
        if hasattr(mat, "baseColorTexture"):  # PBR (glTF)
            image = mat.baseColorTexture
            rgba = _rgba(mat.baseColorFactor, (1.0, 1.0, 1.0, 1.0))
        else:  # SimpleMaterial (OBJ/MTL)
            image = getattr(mat, "image", None)
            if image is not None:
                rgba = (1.0, 1.0, 1.0, 1.0)  # obj2mjcf semantics: a textured OBJ material shows its texture
            else:
                rgba = _rgba(getattr(mat, "diffuse", None))
        if uv is None or len(uv) != len(geom.vertices):
            image, uv = None, None
        key = f"{name}|{id(mat)}"
        return Material(str(name), rgba, image, key), uv, None
    colors = None
    rgba = (0.6, 0.6, 0.6, 1.0)
    if kind == "vertex":
        colors = np.asarray(visual.vertex_colors, dtype=np.uint8)
        rgba = _rgba(colors[:, :4].mean(axis=0))
    elif kind == "face":
        fc = np.asarray(visual.face_colors, dtype=float)
        rgba = _rgba(fc.mean(axis=0))
    elif visual is not None and hasattr(visual, "main_color"):
        try:
            rgba = _rgba(visual.main_color)
        except Exception:  # noqa: BLE001 - a colourless mesh keeps the default grey
            pass
    key = f"colour|{gname}|{','.join(f'{x:.3f}' for x in rgba)}" if colors is None else f"vertex|{gname}"
    return Material(f"{gname}", rgba, None, key), None, colors


def load_mesh(path: str | Path, units: str | float = "auto", up: str = "auto", kind: str = "object",
              target_size: float = 0.0) -> LoadedMesh:
    """Load a mesh file as parts (one material each) in metres, Z up; raise InputError on bad input.

    Parameters
    ----------
    path : str or Path
        Mesh file (OBJ, GLB/glTF, PLY or STL).
    units : str or float
        "auto", a unit name or metres per file unit (see the module docstring).
    up : str
        The file's up axis: "auto", "+X", "-X", "+Y", "-Y", "+Z" or "-Z".
    kind : str
        "object" or "scene" (auto-units table and size limits).
    target_size : float
        When > 0, rescale so the largest extent is this many metres.
    """
    import trimesh

    path = Path(path)
    files = referenced_files(path)
    where = display_path(path)
    try:
        decoded = None
        if path.suffix.lower() in (".glb", ".gltf"):
            from .gputex import decoded_gltf

            decoded = decoded_gltf(path)  # KTX2 / Basis base-colour images -> PNG (HM3D's *.basis.glb)
        if decoded is not None:
            from trimesh.resolvers import FilePathResolver

            scene = trimesh.load(decoded[0], file_type=decoded[1], force="scene", process=False,
                                 resolver=FilePathResolver(str(path)))
        else:
            scene = trimesh.load(str(path), force="scene", process=False)
    except InputError:
        raise
    except Exception as e:  # noqa: BLE001 - any parser failure is a bad input
        msg = str(e).strip().splitlines()[0] if str(e).strip() else ""
        raise InputError(where, f"cannot parse {path.suffix.lower()[1:].upper()} file: {type(e).__name__}{': ' + msg if msg else ''}") from None
    rot, up_name = up_rotation(up, path)
    parts: list[Part] = []
    nan_count = 0
    # trimesh names the nodes of a multi-primitive glTF mesh '<node>_<6 random hex>': sort by the node name without
    # it, then by the geometry's load order (the primitive order), so parts come in the same order in every process
    order = {g: k for k, g in enumerate(scene.geometry)}

    def node_key(node: str) -> tuple[str, int, str]:
        return re.sub(r"_[0-9a-f]{6}$", "", node), order.get(scene.graph[node][1], -1), node

    for node in sorted(scene.graph.nodes_geometry, key=node_key):
        transform, gname = scene.graph[node]
        geom = scene.geometry.get(gname)
        if geom is None or not hasattr(geom, "faces") or geom.faces is None or len(geom.faces) == 0:
            continue
        v = np.asarray(geom.vertices, dtype=np.float64)
        f = np.asarray(geom.faces, dtype=np.int64)
        bad = ~np.isfinite(v).all(axis=1)
        if bad.any():
            nan_count += int(bad.sum())
            continue
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise InputError(where, f"node '{node}': face indices out of range")
        v = v @ np.asarray(transform, dtype=np.float64)[:3, :3].T + np.asarray(transform, dtype=np.float64)[:3, 3]
        material, uv, colors = _material_of(geom, str(gname), path.suffix.lower())
        parts.append(Part(v @ rot.T, f, material, uv, colors, str(node)))
    if nan_count:
        raise InputError(where, f"{nan_count} vertex coordinate rows are NaN or infinite")
    if not parts:
        raise InputError(where, "no triangles in the file (empty mesh or point cloud)")
    allv = np.concatenate([p.vertices for p in parts])
    ext_file = float((allv.max(axis=0) - allv.min(axis=0)).max())
    scale, rule = resolve_scale(units, ext_file, path, kind, target_size)
    for p in parts:
        p.vertices = p.vertices * scale
    size = ext_file * scale
    limit = OBJECT_MAX_SIZE if kind == "object" else SCENE_MAX_SIZE
    if size > limit:
        raise InputError(where, f"mesh is {size:,.6g} m across ({rule}), larger than the {limit:g} m limit for an {kind}; "
                                "check the units")
    if size < MIN_SIZE:
        raise InputError(where, f"mesh is only {size:.3g} m across ({rule}); check the units")
    return LoadedMesh(path, parts, scale, rule, up_name, files)
