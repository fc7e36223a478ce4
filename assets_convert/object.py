"""convert_object: one mesh file -> Menagerie-style MJCF object with CoACD collision hulls.

Output ``<out_dir>/objects/<name>/``: ``model.xml``, ``asset.json`` (the ObjectAsset record) and
``assets/`` (``visual_<i>.obj`` one per material, ``texture_<k>.png``, ``collision_<k>.obj``).
The object frame: metres, Z up, base at z = 0, bounding box centred in X and Y. The body is named
``object``; it has no joint (the scene composer adds a freejoint).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from sdovon_mj.config import ConvertConfig
from sdovon_mj.errors import InputError
from sdovon_mj.records import ObjectAsset

from . import cache
from .hulls import clean_hulls, decompose, hull_volume, mass_properties, nearly_convex
from .naming import (DENSITIES, GENERIC_DIRS, GENERIC_STEMS, category_label, default_category, default_name,  # noqa: F401
                     density_for, library_category, meta_json_category, object_name, sanitize)
from .objcache import cached_object, load_converted  # noqa: F401 (re-exported)
from .load import FLAT_TOL, display_path, gpu_texture_key, load_mesh
from .writer import AssetWriter, clean_part, fmt, merge_parts, render_template

MAX_RATIO_WARN = 1.5


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
                                          if k not in ("jobs", "timeout_s", "add_floor")},
              **gpu_texture_key(files)}
    key = cache.cache_key(files, params)
    return cached_object(out_dir, name, key, cache_dir, source or display_path(path), t0,
                         lambda tmp: _build(path, tmp, name, category, u, a, t, dens, cfg))


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
    if nearly_convex(tm, chull, float(cfg.coacd_threshold)) or (vol_method == "exact" and mvol >= (1.0 - tol) * ch_vol):
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


def _check_compiles(xml: Path, where: str) -> None:
    """Compile the written MJCF once; raise InputError naming the input when MuJoCo refuses it."""
    import mujoco

    try:
        mujoco.MjModel.from_xml_path(str(xml))
    except Exception as e:  # noqa: BLE001
        raise InputError(where, f"converted model does not compile in MuJoCo: {e}") from None
