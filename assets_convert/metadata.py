"""Per-file asset metadata: ``assets.yaml`` files beside objects and scenes, and ``<file>.yaml`` sidecars.

An ``assets.yaml`` applies to the files of its folder and every folder below; those of the file's folder and of
up to `MAX_LEVELS` parent folders are read, outermost first, so a nearer one wins, and a ``<file name>.yaml``
sidecar (``kettle.stl.yaml``) wins over all. Within one file, its top-level keys come first, then every
``files`` entry whose glob matches the path relative to that folder, in the order written::

    units: cm              # m, cm, mm, in, ft or metres per file unit
    up: +Z                 # +X -X +Y -Y +Z -Z
    scale: 1.0             # extra factor on the units
    category: kettle       # object category
    add_floor: false       # scenes: add a ground slab (convert.add_floor)
    receptacle: false      # scenes: force (true) or forbid (false) every instance of the file as a receptacle
    nodes:                 # scenes: per node-name glob (the instance's node name or its label), in order
      "Shelf_Wall*": {receptacle: true}
      "Upper_Cabinet*": {receptacle: false}
    multipart: true        # this folder's object files are one object, rigidly joined (its parts)
    name: kettle_01        # the multi-part object's name (default: the folder name)
    files:
      "*.glb": {up: +Y, units: m}
      "handle.stl": {units: mm}

The command line's ``--units`` / ``--up`` (``convert.units`` / ``convert.up``) stay the run-wide defaults: metadata
wins for the files it covers. An unknown key, or a value of the wrong kind, is an error naming the file and the key.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sdovon_mj.errors import InputError

from .load import UNIT_NAMES, display_path

FILE_NAME = "assets.yaml"
MAX_LEVELS = 3  # parent folders searched above a file's own folder
ENTRY_KEYS = ("units", "up", "scale", "category", "add_floor", "receptacle", "nodes")
NODE_KEYS = ("receptacle",)  # what a ``nodes`` glob may say about the matching scene instances
FOLDER_KEYS = ENTRY_KEYS + ("multipart", "name", "files")
UP_AXES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z", "X", "Y", "Z")


@dataclass
class AssetMeta:
    """What metadata says about one file (None: not said)."""

    units: str | None = None
    up: str | None = None
    scale: float = 1.0
    category: str | None = None
    add_floor: bool | None = None
    multipart: Path | None = None  # the folder whose files form one object
    name: str | None = None
    receptacle: bool | None = None  # scenes: every instance forced (True) / forbidden (False) as a receptacle
    nodes: list[tuple[str, bool]] = field(default_factory=list)  # scenes: (node-name glob, receptacle), in order
    sources: list[Path] = field(default_factory=list)  # the metadata files read (for cache keys)

    def units_value(self, default: str | float) -> str | float:
        """Return the units to load with: metadata's (times `scale`), else `default` (times `scale`)."""
        base = self.units if self.units is not None else default
        if self.scale == 1.0:
            return base
        if str(base).lower() == "auto":
            raise InputError(display_path(self.sources[-1]) if self.sources else "assets.yaml",
                             "'scale' needs 'units' (auto units cannot be scaled)")
        metres = UNIT_NAMES[str(base)] if str(base) in UNIT_NAMES else float(base)
        return metres * self.scale


def _load_yaml(path: Path) -> dict[str, Any]:
    """Read one metadata YAML file (a mapping) or raise InputError naming it."""
    import yaml

    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as e:
        raise InputError(display_path(path), f"cannot read YAML: {e}") from None
    if doc is None:
        return {}
    if not isinstance(doc, dict):
        raise InputError(display_path(path), "must be a mapping of keys (units, up, scale, category, ...)")
    return doc


def _check_entry(doc: dict[str, Any], allowed: tuple[str, ...], path: Path, where: str = "") -> None:
    """Raise InputError for an unknown key or a value of the wrong kind."""
    for key, value in doc.items():
        if key not in allowed:
            raise InputError(display_path(path), f"unknown key '{where}{key}' (known: {', '.join(allowed)})")
        bad = None
        if key == "units":
            ok = str(value).lower() in UNIT_NAMES or isinstance(value, (int, float)) and not isinstance(value, bool) \
                and value > 0
            bad = None if ok else "a unit (m, cm, mm, in, ft) or a positive number of metres per file unit"
        elif key == "up":
            bad = None if str(value).upper() in UP_AXES else "one of +X -X +Y -Y +Z -Z"
        elif key == "scale":
            ok = isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0
            bad = None if ok else "a positive number"
        elif key in ("add_floor", "multipart", "receptacle"):
            bad = None if isinstance(value, bool) else "true or false"
        elif key in ("category", "name"):
            bad = None if isinstance(value, str) and value.strip() else "a non-empty string"
        elif key == "nodes":
            if not (isinstance(value, dict) and all(isinstance(v, dict) for v in value.values())):
                bad = "a mapping of node-name glob -> {receptacle: true|false}"
            else:
                for pattern, entry in value.items():
                    _check_entry(entry, NODE_KEYS, path, f"{where}nodes.{pattern}.")
        elif key == "files":
            bad = None if isinstance(value, dict) and all(isinstance(v, dict) for v in value.values()) \
                else "a mapping of glob -> {key: value}"
        if bad:
            raise InputError(display_path(path), f"key '{where}{key}': {value!r} is not {bad}")


def _apply(meta: AssetMeta, entry: dict[str, Any]) -> None:
    """Set the entry's keys on `meta`."""
    if "units" in entry:
        u = entry["units"]
        meta.units = str(u).lower() if str(u).lower() in UNIT_NAMES else str(float(u))
    if "up" in entry:
        meta.up = str(entry["up"]).upper()
    if "scale" in entry:
        meta.scale = float(entry["scale"])
    if "category" in entry:
        meta.category = str(entry["category"]).strip()
    if "add_floor" in entry:
        meta.add_floor = bool(entry["add_floor"])
    if "receptacle" in entry:
        meta.receptacle = bool(entry["receptacle"])
    for pattern, node in (entry.get("nodes") or {}).items():
        if "receptacle" in node:
            meta.nodes.append((str(pattern), bool(node["receptacle"])))


def meta_for(path: str | Path) -> AssetMeta:
    """Return the metadata of one object or scene file (empty when no metadata file covers it)."""
    path = Path(path)
    folders = [path.parent, *path.parent.parents][: MAX_LEVELS + 1]
    meta = AssetMeta()
    for folder in reversed(folders):
        yml = folder / FILE_NAME
        if not yml.is_file():
            continue
        doc = _load_yaml(yml)
        _check_entry(doc, FOLDER_KEYS, yml)
        meta.sources.append(yml)
        _apply(meta, doc)
        if doc.get("multipart"):
            meta.multipart, meta.name = folder, str(doc.get("name") or folder.name)
        rel = path.relative_to(folder).as_posix()
        for pattern, entry in (doc.get("files") or {}).items():
            _check_entry(entry, ENTRY_KEYS, yml, f"files.{pattern}.")
            if fnmatch.fnmatch(rel, str(pattern)) or fnmatch.fnmatch(path.name, str(pattern)):
                _apply(meta, entry)
    side = path.with_name(path.name + ".yaml")
    if side.is_file():
        doc = _load_yaml(side)
        _check_entry(doc, ENTRY_KEYS, side)
        meta.sources.append(side)
        _apply(meta, doc)
    return meta


def receptacle_flag(meta: AssetMeta, node: str, label: str = "") -> bool | None:
    """Return what metadata says of one scene instance being a receptacle (None: nothing; labels decide).

    The file's ``receptacle`` first, then every ``nodes`` glob matching the instance's node name or its label
    (case ignored), the last match winning.
    """
    flag = meta.receptacle
    for pattern, value in meta.nodes:
        pat = pattern.lower()
        if fnmatch.fnmatchcase(str(node).lower(), pat) or (label and fnmatch.fnmatchcase(str(label).lower(), pat)):
            flag = value
    return flag


def combine_parts(files: list[Path], out_file: Path, units: str | float, up: str) -> Path:
    """Write the parts of a multi-part object (each file read with its own metadata) as one Z-up metre GLB.

    Parameters
    ----------
    files : list of Path
        The part files (OBJ, GLB/glTF, PLY, STL), in their shared frame once units and up axis are applied.
    out_file : Path
        The GLB to write.
    units : str or float
        Run-wide default units (a part's metadata wins).
    up : str
        Run-wide default up axis (a part's metadata wins).
    """
    import numpy as np
    import trimesh
    from trimesh.visual.material import PBRMaterial

    from .load import load_mesh

    scene = trimesh.Scene()
    for f in sorted(files):
        meta = meta_for(f)
        mesh = load_mesh(f, units=meta.units_value(units), up=meta.up or up, kind="object")
        for k, p in enumerate(mesh.parts):
            if p.material.image is not None and p.uv is not None:
                visual: Any = trimesh.visual.TextureVisuals(uv=p.uv, material=PBRMaterial(
                    baseColorTexture=p.material.image, baseColorFactor=[int(round(c * 255)) for c in p.material.rgba]))
            elif p.colors is not None:
                visual = trimesh.visual.ColorVisuals(vertex_colors=p.colors)
            else:
                visual = trimesh.visual.ColorVisuals(face_colors=np.tile(
                    [int(round(c * 255)) for c in p.material.rgba], (len(p.faces), 1)))
            tm = trimesh.Trimesh(p.vertices, p.faces, visual=visual, process=False)
            scene.add_geometry(tm, node_name=f"{f.stem}_{k}", geom_name=f"{f.stem}_{k}")
    out_file.parent.mkdir(parents=True, exist_ok=True)
    out_file.write_bytes(scene.export(file_type="glb"))
    return out_file


__all__ = ["AssetMeta", "FILE_NAME", "combine_parts", "meta_for", "receptacle_flag"]
