"""convert_object: one mesh file -> Menagerie-style MJCF object with CoACD collision hulls.

Output ``<out_dir>/objects/<name>/``: ``model.xml``, ``asset.json`` (the ObjectAsset record) and
``assets/`` (``visual_<i>.obj`` one per material, ``texture_<k>.png``, ``collision_<k>.obj``).
The object frame: metres, Z up, base at z = 0, bounding box centred in X and Y. The body is named
``object``; it has no joint (the scene composer adds a freejoint).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
import unicodedata
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from sdovon_mj.config import ConvertConfig
from sdovon_mj.errors import InputError
from sdovon_mj.records import ObjectAsset, dumps
from sdovon_mj.store import atomic_write_text

from . import cache
from .hulls import clean_hulls, decompose, hull_volume, mass_properties
from .load import FLAT_TOL, display_path, load_mesh
from .writer import AssetWriter, clean_part, fmt, merge_parts, render_template

if TYPE_CHECKING:
    from .metadata import AssetMeta

# Bulk densities (kg/m^3) of the solid hull volume: hollow things (boxes, bins, furniture) are light.
DENSITIES: dict[str, float] = {
    "apple": 800, "ball": 150, "banana": 900, "bin": 150, "book": 700, "bottle": 800, "bowl": 700,
    "bread": 250, "cabinet": 350, "can": 900, "chair": 250, "cup": 700, "cushion": 60, "donut": 400,
    "food_box": 250, "fruit": 900, "keyboard": 600, "lamp": 300, "laptop": 1200, "mug": 700,
    "pillow": 60, "plant": 400, "plate": 1500, "power_drill": 900, "remote": 900, "shelf": 300,
    "shoe": 400, "sofa": 120, "stool": 350, "table": 350, "tea_set": 700, "teddy_bear": 80,
    "toy": 300, "toy_block": 80, "vase": 900,
}
GENERIC_STEMS = {"textured", "model", "mesh", "object", "untitled", "scene", "visual", "model_normalized",
                 "mobility"}  # PartNet-Mobility: <id>/mobility.urdf
MAX_RATIO_WARN = 1.5


def density_for(category: str, default: float = 500.0) -> float:
    """Return the bulk density (kg/m^3) of a category (default when unknown)."""
    key = re.sub(r"[\s\-]+", "_", category.strip().lower())
    if key in DENSITIES:
        return float(DENSITIES[key])
    last = key.split("_")[-1]
    return float(DENSITIES.get(last, default))


# Latin letters that Unicode does not decompose into an ASCII letter and a mark
_LATIN = str.maketrans({"ß": "ss", "æ": "ae", "Æ": "AE", "ø": "o", "Ø": "O", "œ": "oe", "Œ": "OE", "ł": "l", "Ł": "L",
                        "đ": "d", "Đ": "D", "þ": "th", "Þ": "Th", "ð": "d", "Ð": "D", "ı": "i"})


def sanitize(name: str) -> str:
    """Return a name safe for MJCF and file names ([A-Za-z0-9_-]): accented Latin letters lose their marks
    (``Café`` -> ``Cafe``, ``groß`` -> ``gross``), other characters become ``_``; ``object`` when none is left."""
    s = unicodedata.normalize("NFKD", str(name).translate(_LATIN)).encode("ascii", "ignore").decode("ascii")
    s = re.sub(r"[^A-Za-z0-9_\-]+", "_", s).strip("_")
    return s or "object"


# Folders that hold a model's files rather than name it (YCB <name>/google_16k/textured.obj, Google Scanned Objects
# <name>/meshes/model.obj): a generic file stem takes its name from the first folder above them
GENERIC_DIRS = {"meshes", "mesh", "models", "model", "obj", "objs", "geometry", "visual", "visuals", "textured",
                "google_16k", "google_64k", "google_512k", "poisson", "tsdf", "normalized", "glb", "gltf"}


def default_name(path: Path) -> str:
    """Return an object name from a file path (the folder name for generic stems like textured.obj).

    The folder is the first one up that is not a container like ``meshes/`` or ``google_16k/`` (`GENERIC_DIRS`), so
    ``Panda/meshes/model.obj`` is ``Panda`` and ``002_master_chef_can/google_16k/textured.obj`` is
    ``002_master_chef_can``; two inputs that still end with one name are told apart by `convert_tree`.
    """
    return sanitize(_name_text(Path(path)))


def _name_text(path: Path) -> str:
    """Return the text `default_name` makes a name of, as the file system spells it (not yet `sanitize`d)."""
    stem = path.stem
    if stem.lower() in GENERIC_STEMS:
        for anc in list(path.parents)[:3]:
            if anc.name and anc.name.lower() not in GENERIC_DIRS:
                return anc.name
        return path.parent.name
    if stem.lower().endswith("_1k"):
        return re.sub(r"_1k$", "", stem)
    return stem


def category_label(text: str) -> str:
    """Return a category guessed from a file or folder name as goal text is written: lower case, words joined by one
    underscore, letters of every script kept (``Coffee Mug`` and ``coffee-mug`` -> ``coffee_mug``, ``PowerDrill`` ->
    ``power_drill``, ``Tasse groß`` -> ``tasse_groß``; empty when the text has no letter or digit).

    A word boundary inside a name written in camel case counts where two lower-case letters meet an upper-case one
    followed by a lower-case one (``PowerDrill``; not ``iPad`` or ``USBStick``). Case variants of one category in a
    library (``Mug.obj``, ``mug_2.glb``) so become one category.
    """
    s = unicodedata.normalize("NFC", str(text))
    s = re.sub(r"(?<=[a-z]{2})(?=[A-Z][a-z])", "_", s)
    return re.sub(r"[\W_]+", "_", s.lower()).strip("_")


def object_name(path: str | Path, name: str | None = None) -> str:
    """Return the name a conversion of `path` gives its object (its folder under objects/): `name` when given,
    else `default_name` (a URDF's file stem, or its folder's name for a generic stem such as PartNet-Mobility's
    ``<id>/mobility.urdf``)."""
    path = Path(path)
    if name:
        return sanitize(name)
    return default_name(path)


def meta_json_category(path: str | Path) -> str | None:
    """Return the category a ``meta.json`` beside an object file names: its ``category``, else PartNet-Mobility's
    ``model_cat`` in snake case (``StorageFurniture`` -> ``storage_furniture``); None when there is none."""
    meta = Path(path).parent / "meta.json"
    if not meta.is_file():
        return None
    try:
        doc = json.loads(meta.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError, UnicodeDecodeError):
        return None
    if not isinstance(doc, dict):
        return None
    if doc.get("category"):
        return str(doc["category"])
    if isinstance(doc.get("model_cat"), str) and doc["model_cat"].strip():
        return re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", doc["model_cat"].strip()).replace(" ", "_").lower()
    return None


def default_category(path: Path, root: str | Path | None = None) -> str:
    """Return a category guess for an object file: the category ``meta.json`` beside it names
    (`meta_json_category`), else its grandparent folder's name (``<category>/<name>/<file>``; YCB
    ``<name>/google_16k/textured.obj`` and GSO ``<name>/meshes/model.obj`` give the object's name), a leading numeric
    id such as YCB's '002_' dropped.

    ``root``: the library folder the file was found in (default: the file's own folder, as for one file converted
    alone). The grandparent counts only when it lies inside that folder; otherwise (a flat library ``lib/mug.obj``,
    one folder per object ``lib/mug/model.obj``, a single file) the guess is the object's own name (`default_name`'s
    text) without a numeric id before it or an instance number after it (``chair_01`` -> ``chair``): the library
    folder (or a folder above it) names no category. A guessed name is written as `category_label` writes it
    (``Coffee Mug`` -> ``coffee_mug``); a category ``meta.json`` names is kept as written.
    """
    path = Path(path)
    cat = meta_json_category(path)
    if cat:
        return cat
    folder = path.parent.parent
    root = path.parent if root is None else root
    inside = os.path.abspath(folder).startswith(os.path.abspath(root).rstrip(os.sep) + os.sep)
    name = (folder.name or path.parent.name) if inside else _name_text(path)
    name = re.sub(r"^\d+[\W_]+(?=[^\W\d_])", "", name) or name
    if not inside:
        name = re.sub(r"(?<=[^\W\d_])[\W_]*\d+[\W_]*$", "", name) or name  # chair_01, mug (2)
    return category_label(name) or "object"


def library_category(path: str | Path, library: str | Path | None = None, meta: AssetMeta | None = None) -> str | None:
    """Return the category converting an object file gives it when none is named: ``assets.yaml`` metadata (`meta`,
    `metadata.meta_for`'s answer when the caller has it), else `default_category` with the library folder it was found
    in; None for a part of a multi-part object (its group's category applies)."""
    from .metadata import meta_for

    meta = meta if meta is not None else meta_for(Path(path))
    if meta.multipart is not None:
        return None
    return meta.category or default_category(Path(path), library)


def mesh_volume(vertices: np.ndarray, faces: np.ndarray) -> tuple[float, str]:
    """Return the enclosed volume of a mesh (exact when watertight, else a filled-voxel estimate)."""
    import trimesh

    tm = trimesh.Trimesh(vertices, faces, process=True)
    if tm.is_watertight and tm.is_winding_consistent:
        return float(abs(tm.volume)), "exact"
    ext = float(tm.extents.max())
    if ext <= 0:
        return 0.0, "empty"
    pitch = ext / 64.0
    try:
        vox = tm.voxelized(pitch).fill()
        # the filled grid includes the surface shell: remove half a voxel layer of it
        vol = float(vox.volume) - 0.5 * pitch * float(tm.area)
        return max(vol, 0.0), "voxel"
    except Exception:  # noqa: BLE001 - odd geometry: fall back to the convex hull volume
        return float(tm.convex_hull.volume), "convex hull"


def _resolve(cfg: ConvertConfig, units: str | float, up: str, target_size: float) -> tuple[str, str, float]:
    """Return (units, up, target_size): explicit arguments win over the config."""
    u = str(units) if str(units) != "auto" else cfg.units
    a = up if up != "auto" else cfg.up
    t = float(target_size) if target_size else float(cfg.target_size)
    return u, a, t


def convert_object(path: str | Path, out_dir: str | Path, category: str | None = None, units: str | float = "auto",
                   up: str = "auto", target_size: float = 0.0, density: float | None = None, name: str | None = None,
                   config: ConvertConfig | None = None, cache_dir: str | Path | None = None) -> ObjectAsset:
    """Convert one object mesh to `<out_dir>/objects/<name>/model.xml` (cached); return its ObjectAsset.

    Parameters are those of `convert_object_report`.
    """
    asset, _info = convert_object_report(path, out_dir, category, units, up, target_size, density, name, config, cache_dir)
    return asset


def convert_object_report(path: str | Path, out_dir: str | Path, category: str | None = None,
                          units: str | float = "auto", up: str = "auto", target_size: float = 0.0,
                          density: float | None = None, name: str | None = None,
                          config: ConvertConfig | None = None,
                          cache_dir: str | Path | None = None,
                          source: str | None = None) -> tuple[ObjectAsset, dict[str, Any]]:
    """Convert one object and also return report figures (faces, hulls, seconds, cache hit, warnings).

    Parameters
    ----------
    path : str or Path
        Object mesh file.
    out_dir : str or Path
        Output root; the object goes to ``<out_dir>/objects/<name>/``.
    category : str, optional
        Object category (default: ``assets.yaml`` metadata, ``meta.json`` beside the file, else the grandparent
        folder name).
    units : str or float
        "auto", a unit name or metres per file unit ("auto": ``assets.yaml`` metadata, else the config's).
    up : str
        The file's up axis ("auto": ``assets.yaml`` metadata, else the config's).
    target_size : float
        When > 0, rescale so the largest extent is this many metres (0: the config's).
    density : float, optional
        Bulk density, kg/m^3 (default: the category's).
    name : str, optional
        Asset name (default: from the file name).
    config : ConvertConfig, optional
        Conversion settings (default: ``ConvertConfig()``).
    cache_dir : str or Path, optional
        Conversion cache folder (default: the user cache).
    source : str, optional
        The source recorded in the asset (default: `path`; a multi-part object names its folder, not its scratch GLB).
    """
    from .load import referenced_files
    from .metadata import meta_for

    if Path(path).suffix.lower() == ".urdf":  # an articulated object: links and joints (assets_convert.urdf)
        from .urdf import convert_urdf_report

        return convert_urdf_report(path, out_dir, category, density, name, config, cache_dir, source)
    t0 = time.perf_counter()
    cfg = config or ConvertConfig()
    path = Path(path)
    out_dir = Path(out_dir)
    meta = meta_for(path)  # assets.yaml / <file>.yaml: wins over the run-wide config, not over explicit arguments
    files = referenced_files(path) + meta.sources
    name = object_name(path, name)
    category = category or meta.category or default_category(path)
    if str(units) == "auto" and (meta.units is not None or meta.scale != 1.0):
        units = meta.units_value(cfg.units)
    if up == "auto" and meta.up is not None:
        up = meta.up
    u, a, t = _resolve(cfg, units, up, target_size)
    dens = float(density) if density else density_for(category, cfg.default_density)
    params = {"kind": "object", "name": name, "category": category, "units": u, "up": a, "target_size": t,
              **({"source": source} if source else {}),
              "density": dens, "config": {k: getattr(cfg, k) for k in sorted(cfg.__dataclass_fields__)
                                          if k not in ("jobs", "timeout_s", "add_floor")}}
    key = cache.cache_key(files, params)
    return cached_object(out_dir, name, key, cache_dir, source or display_path(path), t0,
                         lambda tmp: _build(path, tmp, name, category, u, a, t, dens, cfg))


def cached_object(out_dir: Path, name: str, key: str, cache_dir: str | Path | None, source: str, t0: float,
                  build: Callable[[Path], tuple[ObjectAsset, dict[str, Any]]]) -> tuple[ObjectAsset, dict[str, Any]]:
    """Return a converted object from the conversion cache, or build it into a temp folder, store and place it.

    Parameters
    ----------
    out_dir : Path
        The conversion output folder (the object lands in ``objects/<name>``).
    name : str
        The object's folder name.
    key : str
        Its cache key (`cache.cache_key` of its input files and parameters).
    cache_dir : str, Path or None
        The cache root (None: the default `cache.cache_root`).
    source : str
        The source recorded in the asset (run-relative where possible).
    t0 : float
        `time.perf_counter()` at the start of the conversion (the returned info's seconds).
    build : callable
        ``build(work_dir) -> (asset, info)`` writes the object's files into work_dir.
    """
    root = cache.cache_root(cache_dir)
    target = out_dir / "objects" / name
    hit = cache.lookup(root, key)
    if hit is not None:
        cache.link_tree(hit, target)
        asset = load_converted(out_dir, name)
        info = dict(_read_info(target))
        info.update(cache_hit=True, seconds=time.perf_counter() - t0)
        return asset, info
    tmp = cache.scratch_dir(_mkdir(out_dir / "objects") / name)
    try:
        asset, info = build(tmp)
        asset.content_hash = key
        asset.source = source
        atomic_write_text(tmp / "asset.json", dumps(asset.to_dict()))
        # the stored report holds figures of the object only: wall seconds stay in the returned info (a run
        # folder's bytes must not depend on how long CoACD took)
        atomic_write_text(tmp / "report.json", dumps({k: v for k, v in info.items() if k != "hull_seconds"}))
        cache.store(root, key, tmp)
        cache.replace_dir(tmp, target)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    asset.mjcf = (Path("objects") / name / "model.xml").as_posix()
    return asset, dict(info, cache_hit=False, seconds=time.perf_counter() - t0)


def load_converted(out_dir: str | Path, name: str) -> ObjectAsset:
    """Return the ObjectAsset of an object converted into `out_dir` (its mjcf relative to out_dir)."""
    stored = json.loads((Path(out_dir) / "objects" / name / "asset.json").read_text(encoding="utf-8"))
    asset = ObjectAsset.from_dict(stored)
    asset.mjcf = (Path("objects") / name / "model.xml").as_posix()
    return asset


def _read_info(folder: Path) -> dict[str, Any]:
    """Return the stored report figures of a converted object folder."""
    p = folder / "report.json"
    return json.loads(p.read_text(encoding="utf-8")) if p.is_file() else {}


def _mkdir(p: Path) -> Path:
    """Create a folder (and parents) and return it."""
    p.mkdir(parents=True, exist_ok=True)
    return p


def _build(path: Path, work: Path, name: str, category: str, units: str, up: str, target_size: float,
           density: float, cfg: ConvertConfig) -> tuple[ObjectAsset, dict[str, Any]]:
    """Load, recentre, decompose and write one object into folder `work`."""
    import trimesh

    where = display_path(path)
    mesh = load_mesh(path, units=units, up=up, kind="object", target_size=target_size)
    parts = [p for p in (clean_part(q) for q in merge_parts(mesh.parts)) if p is not None]
    if not parts:
        raise InputError(where, "all triangles are degenerate (zero area)")
    allv = np.concatenate([p.vertices for p in parts])
    lo, hi = allv.min(axis=0), allv.max(axis=0)
    offset = np.array([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    for p in parts:
        p.vertices = p.vertices + offset
    lo, hi = lo + offset, hi + offset
    ext = hi - lo
    if ext.min() < FLAT_TOL:
        raise InputError(where, f"flat mesh: {ext.min():.2g} m thick along its thinnest axis, it encloses no volume "
                                "(an object needs a solid shape for collision and mass)")
    offs = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
    cv = np.concatenate([p.vertices for p in parts])
    cf = np.concatenate([p.faces + o for p, o in zip(parts, offs)])
    tm = trimesh.Trimesh(cv, cf, process=True)
    mvol, vol_method = mesh_volume(tm.vertices, tm.faces)
    try:
        chull = tm.convex_hull
        ch_vol = float(chull.volume)
    except Exception:  # noqa: BLE001
        ch_vol = 0.0
    if ch_vol <= 1e-12:
        raise InputError(where, "flat mesh: its convex hull has zero volume")
    if mvol <= 1e-12 and vol_method == "exact":
        raise InputError(where, "zero-volume mesh: its surfaces enclose no volume")
    tol = float(getattr(cfg, "convex_tolerance", 0.03))
    t_hull = time.perf_counter()
    if _nearly_convex(tm, chull, float(cfg.coacd_threshold)) or (vol_method == "exact" and mvol >= (1.0 - tol) * ch_vol):
        hulls = clean_hulls([(np.asarray(chull.vertices), np.asarray(chull.faces))], int(cfg.coacd_max_hull_vertices))
        method = "convex"
    else:
        hulls = decompose(tm.vertices, tm.faces, cfg)
        method = "coacd"
    hull_seconds = time.perf_counter() - t_hull
    if not hulls:
        raise InputError(where, "no usable collision hulls (the mesh encloses no volume)")
    hvol = hull_volume(hulls)
    ratio = hvol / mvol if mvol > 0 else 0.0
    warnings = []
    if ratio > MAX_RATIO_WARN:
        warnings.append(f"hull volume is {ratio:.2f}x the mesh volume: a cavity was probably filled")
    mass, com, inertia = mass_properties(hulls, density)
    if mass <= 0:
        raise InputError(where, "collision hulls have no mass")

    writer = AssetWriter(work / "assets", cfg.texture_max_size)
    geoms: list[str] = []
    for i, p in enumerate(parts):
        textured = p.material.image is not None and p.uv is not None
        mat = writer.material(p.material, textured)
        writer.mesh(f"visual_{i}", p.vertices, p.faces, p.uv if textured else None, ' inertia="shell"')
        geoms.append(f'      <geom name="visual_{i}" class="visual" mesh="visual_{i}" material="{mat}"/>')
    maxv = int(cfg.coacd_max_hull_vertices)
    for k, (hv, hf) in enumerate(hulls):
        writer.mesh(f"collision_{k}", hv, hf, None, f' inertia="convex" maxhullvert="{max(maxv, 4)}"')
        geoms.append(f'      <geom name="collision_{k}" class="collision" mesh="collision_{k}"/>')
    full = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    render_template("object.xml", work / "model.xml", name=name, density=fmt([density]), friction="1 0.005 0.0001",
                    assets=writer.xml, com=fmt(com), mass=fmt([mass]), inertia=fmt(full, 8), geoms="\n".join(geoms))
    _check_compiles(work / "model.xml", where)
    asset = ObjectAsset(name=name, category=category, mjcf="model.xml", bbox=np.stack([lo, hi]), mass=float(mass),
                        hull_count=len(hulls), volume=float(hvol), volume_ratio=float(ratio))
    info = {"faces": mesh.face_count, "parts": len(parts), "hulls": len(hulls), "hull_method": method,
            "hull_seconds": round(hull_seconds, 3), "volume_ratio": round(float(ratio), 4), "mesh_volume": mvol,
            "volume_method": vol_method, "mass": float(mass), "density": density, "units": mesh.units_rule,
            "up": mesh.up, "scale": mesh.scale, "warnings": warnings}
    return asset, info


def _nearly_convex(tm: Any, chull: Any, threshold: float, samples: int = 2000) -> bool:
    """Return whether the convex hull stays within CoACD's concavity threshold of the surface.

    A hull whose surface lies within threshold x half the largest extent of the mesh (CoACD normalises
    to [-1, 1]) everywhere (a can's
    recessed lid, a box's rounded edges) becomes the single collision hull without running CoACD.
    """
    import trimesh

    pts, _ = trimesh.sample.sample_surface(chull, samples, seed=0)
    pts = np.concatenate([pts, np.asarray(chull.vertices)])
    _closest, dist, _tri = trimesh.proximity.closest_point(tm, pts)
    return float(np.max(dist)) <= threshold * 0.5 * float(tm.extents.max())


def _check_compiles(xml: Path, where: str) -> None:
    """Compile the written MJCF once; raise InputError naming the input when MuJoCo refuses it."""
    import mujoco

    try:
        mujoco.MjModel.from_xml_path(str(xml))
    except Exception as e:  # noqa: BLE001
        raise InputError(where, f"converted model does not compile in MuJoCo: {e}") from None
