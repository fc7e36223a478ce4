"""Readers of Habitat-native scene datasets: HM3D-Semantics scans and Habitat scene-dataset configs (HSSD, ReplicaCAD).

Both return a `Reading`: (part, instance id) pairs in MuJoCo's frame (metres, Z up), per-instance metadata
(label, room, kind, name) and the input's region annotations as `Room` records; `scene.convert_scene` turns it
into the visual-only MJCF as for any other scene.

**HM3D** (`<id>.glb` or `<id>.basis.glb`, `<id>.semantic.glb`, `<id>.semantic.txt`): the txt lists
``<instance id>,<RRGGBB>,"<category>",<region id>`` (after an optional ``HM3D Semantic Annotations`` line); the
semantic GLB paints every triangle with its instance colour (per-vertex COLOR_0 or a texture, sampled at the
triangle's centroid). Each visual triangle takes the instance of the nearest semantic triangle (centroids), so a
visual mesh triangulated differently from its semantic mesh still splits into instances. The raw GLBs are Z up
(habitat-sim's convention for raw scan GLBs), so ``up="auto"`` means +Z here. Black (000000) is unannotated
surface; any other colour missing from the txt is an error naming both files.

**Habitat scene datasets** (`*.scene_instance.json`, or a `*.scene_dataset_config.json` holding exactly one
scene instance): the dataset config beside the scene instance or in a parent folder registers stage, object and
semantic configs (``paths`` folders and globs, ``configs`` entries with ``original_file``, ``template_handle`` and
``attributes`` overrides, ``default_attributes``). A ``template_name`` resolves as habitat-sim does it: an exact
handle, else the first registered handle (sorted) that contains it. Asset frames come from ``up``/``front``
(default Y up, front -Z), then ``scale`` and ``units_to_meters``, then a stage config's ``origin`` (habitat-sim's
"origin of the stage in the world frame, for alignment": the asset's origin is put there); instances apply ``non_uniform_scale``,
``uniform_scale``, ``rotation`` (wxyz) and ``translation`` with ``translation_origin`` (``asset_local``: the
translation places the asset origin; ``COM``: it places the centre of mass, ``COM`` of the template or its
bounding-box centre). Habitat's Y-up world becomes MuJoCo's Z up: (x, y, z) -> (x, -z, y). The stage's nodes become
instances labelled by their glTF node extras ``label`` or their node name; each object instance is one instance,
labelled by the dataset's semantic lexicon (``classes``, through the template's ``semantic_id``), else by its
template name. ``region_annotations`` of the scene's semantic config become `Room` records (label = type) and
assign each instance whose centre lies inside one its room. ``articulated_object_instances`` (URDF templates under the
config's ``articulated_objects.paths``) become `Reading.articulated` pieces posed as habitat-sim poses them
(`_read_articulated`), built into the scene by `articulated_scene.add_articulated`. What the scene instance holds
and is not imported (a template the dataset lacks, a light setup, fields not read) is named in `Reading.unused`.
"""

from __future__ import annotations

import csv
import glob
from collections import OrderedDict
import io
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sdovon_mj.errors import InputError
from sdovon_mj.geometry import points_in_polygon
from sdovon_mj.records import Room

from .naming import label_from_node
from .load import LoadedMesh, Part, _gltf_json, display_path, load_mesh, read_json as _read_json, referenced_files, up_rotation

SCENE_INSTANCE = ".scene_instance.json"
DATASET_CONFIG = ".scene_dataset_config.json"
HAB_TO_MJ = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # (x, y, z)_hab -> (x, -z, y)
UNANNOTATED = "000000"


@dataclass
class Reading:
    """What a dataset reader found: parts with instance ids, instance metadata, regions and the files read."""

    pairs: list[tuple[Part, int]]
    meta: dict[int, dict[str, Any]]
    rooms: list[Room] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    unused: list[str] = field(default_factory=list)  # what the input held and the reader did not use (SceneAsset.unused)
    # articulated pieces to build into the scene (`articulated_scene.add_articulated`'s piece dicts: URDF, MuJoCo pose)
    articulated: list[dict[str, Any]] = field(default_factory=list)


# ----------------------------------------------------------------------------------------------
# detection


def _hm3d_base(path: Path) -> Path | None:
    """Return the HM3D stem path (folder / id) of `<id>.glb` / `<id>.basis.glb`, or None for other files."""
    name = path.name
    if not name.lower().endswith(".glb") or name.lower().endswith(".semantic.glb"):
        return None
    stem = re.sub(r"(\.basis)?\.glb$", "", name, flags=re.IGNORECASE)
    return path.parent / stem


def layout_of(path: str | Path) -> str | None:
    """Return "hm3d", "mp3d", "habitat" or None (another reader) for a scene input path."""
    path = Path(path)
    low = path.name.lower()
    if low.endswith((SCENE_INSTANCE, DATASET_CONFIG, STAGE_CONFIG)):
        return "habitat"
    base = _hm3d_base(path)
    if base is not None and (Path(f"{base}.semantic.glb").is_file() or Path(f"{base}.semantic.txt").is_file()):
        return "hm3d"
    if _mp3d_base(path) is not None:
        return "mp3d"
    if is_stage_member(path):  # a stage of a stage-only dataset (its config's frame and units apply)
        return "habitat"
    return None


def is_companion(path: str | Path) -> bool:
    """Return whether a file is a companion of another input (HM3D / MP3D semantic mesh), not a scene of its own."""
    name = Path(path).name.lower()
    return name.endswith(".semantic.glb") or name.endswith("_semantic.ply")


def input_files(path: str | Path) -> list[Path]:
    """Return every file a dataset-layout scene reads (for the conversion cache key)."""
    path = Path(path)
    layout = layout_of(path)
    if layout == "hm3d":
        base = _hm3d_base(path)
        files = referenced_files(path)
        for suffix in (".semantic.glb", ".semantic.txt"):
            p = Path(f"{base}{suffix}")
            if p.is_file():
                files.append(p)
        return files
    if layout == "mp3d":
        base = path.parent / path.stem
        return referenced_files(path) + [p for p in (Path(f"{base}_semantic.ply"), Path(f"{base}.house")) if p.is_file()]
    if layout == "habitat":
        return scene_files(path)
    return referenced_files(path)


# ----------------------------------------------------------------------------------------------
# HM3D


def read_semantic_txt(path: Path) -> dict[str, dict[str, Any]]:
    """Parse an HM3D ``.semantic.txt``: hex colour -> {id, label, region}; raise InputError naming the line."""
    if not path.is_file():
        raise InputError(display_path(path), "missing: an HM3D scene needs its .semantic.txt (instance ids, "
                                             "categories, regions) beside the .semantic.glb")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(display_path(path), f"cannot read: {e}") from None
    out: dict[str, dict[str, Any]] = {}
    for n, row in enumerate(csv.reader(io.StringIO(text)), start=1):
        if not row or (n == 1 and len(row) == 1 and not row[0].strip()[:1].isdigit()):
            continue  # the header line
        if len(row) < 4:
            raise InputError(display_path(path), f"line {n}: expected id,RRGGBB,\"category\",region, got {','.join(row)!r}")
        try:
            iid, hexcol, label, region = int(row[0]), row[1].strip().upper(), row[2].strip(), int(row[3])
        except ValueError:
            raise InputError(display_path(path), f"line {n}: id and region must be integers: {','.join(row)!r}") from None
        if not re.fullmatch(r"[0-9A-F]{6}", hexcol):
            raise InputError(display_path(path), f"line {n}: colour {row[1]!r} is not RRGGBB hex")
        if hexcol in out:
            raise InputError(display_path(path), f"line {n}: colour {hexcol} already names instance {out[hexcol]['id']}")
        out[hexcol] = {"id": iid, "label": label or "object", "room": region}
    return out


def _face_colours(part: Part) -> np.ndarray:
    """Return (F, 3) uint8 colours of a semantic part's faces (vertex colour of the first corner, else texture at the centroid)."""
    if part.colors is not None:
        return np.asarray(part.colors, dtype=np.uint8)[part.faces[:, 0], :3]
    if part.material.image is not None and part.uv is not None:
        img = np.asarray(part.material.image.convert("RGB"))
        h, w = img.shape[:2]
        uv = part.uv[part.faces].mean(axis=1)
        col = np.clip(np.floor((uv[:, 0] % 1.0) * w), 0, w - 1).astype(np.int64)
        row = np.clip(np.floor((1.0 - uv[:, 1] % 1.0) * h), 0, h - 1).astype(np.int64)
        return img[row, col]
    rgb = np.round(np.asarray(part.material.rgba[:3]) * 255).astype(np.uint8)
    return np.tile(rgb, (len(part.faces), 1))


def split_by_face_instance(part: Part, finst: np.ndarray) -> list[tuple[Part, int]]:
    """Split a part by per-face instance ids, keeping material, UVs and vertex colours."""
    out = []
    finst = np.asarray(finst)
    order = np.argsort(finst, kind="stable")  # each instance's faces in one run, in their original order
    ids, starts = np.unique(finst[order], return_index=True)
    for iid, a, b in zip(ids.tolist(), starts.tolist(), starts[1:].tolist() + [len(order)]):
        sel = part.faces[order[a:b]]
        used = np.unique(sel)
        local = np.searchsorted(used, sel)  # vertex index within the piece (no array the size of the whole part)
        out.append((Part(part.vertices[used], local, part.material,
                         None if part.uv is None else part.uv[used],
                         None if part.colors is None else part.colors[used], part.node), int(iid)))
    return out


def read_hm3d(path: str | Path, units: str | float = "auto", up: str = "auto") -> Reading:
    """Read an HM3D-Semantics scene (visual GLB + ``.semantic.glb`` + ``.semantic.txt``) into instances and regions."""
    from scipy.spatial import cKDTree

    path = Path(path)
    base = _hm3d_base(path)
    sem_glb, sem_txt = Path(f"{base}.semantic.glb"), Path(f"{base}.semantic.txt")
    if not sem_glb.is_file():
        raise InputError(display_path(sem_glb), "missing: an HM3D scene needs its .semantic.glb beside the .glb")
    table = read_semantic_txt(sem_txt)
    up = "+Z" if str(up).lower() == "auto" else up
    visual = load_mesh(path, units=units, up=up, kind="scene")
    semantic = load_mesh(sem_glb, units=visual.scale, up=up, kind="scene")
    cents, ids = [], []
    missing: dict[str, int] = {}
    unlabeled = max((d["id"] for d in table.values()), default=0) + 1
    for sp in semantic.parts:
        cols = _face_colours(sp).astype(np.int64)
        keys = (cols[:, 0] << 16) | (cols[:, 1] << 8) | cols[:, 2]  # RRGGBB as an integer: one lookup per colour
        uniq, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
        lut = np.empty(len(uniq), dtype=np.int64)
        for j, key in enumerate(uniq.tolist()):
            h = f"{key:06X}"
            if h not in table and h != UNANNOTATED:
                missing[h] = missing.get(h, 0) + int(counts[j])
            lut[j] = table[h]["id"] if h in table else unlabeled
        ids.append(lut[inverse.ravel()])
        cents.append(sp.vertices[sp.faces].mean(axis=1))
    if missing:
        shown = ", ".join(f"{h} ({n} triangles)" for h, n in sorted(missing.items())[:5])
        raise InputError(display_path(sem_glb), f"{len(missing)} instance colour(s) absent from {sem_txt.name}: {shown}")
    tree = cKDTree(np.concatenate(cents))
    face_ids = np.concatenate(ids)
    pairs: list[tuple[Part, int]] = []
    for vp in visual.parts:
        pairs.extend(split_by_face_instance(vp, _match_faces(vp, tree, face_ids)))
    meta = {d["id"]: {"id": d["id"], "label": d["label"], "room": d["room"], "kind": "", "name": f"{h}"}
            for h, d in table.items()}
    meta[unlabeled] = {"id": unlabeled, "label": "unlabeled", "room": -1, "kind": "", "name": UNANNOTATED}
    return Reading(pairs, meta, [], [path, sem_glb, sem_txt])


def _match_faces(part: Part, tree: Any, face_ids: np.ndarray, k: int = 8) -> np.ndarray:
    """Return the instance of each of a visual part's faces: that of the nearest semantic face (centroids).

    Ties (coincident triangles of two instances, e.g. a wall face behind a window pane) go to the instance most of
    the part's unambiguous faces have, and pieces too small for a MuJoCo mesh (< 4 vertices) join that instance too.
    """
    cent = part.vertices[part.faces].mean(axis=1)
    k = min(k, len(face_ids))
    dist, idx = tree.query(cent, k=k)
    dist, idx = dist.reshape(len(cent), k), idx.reshape(len(cent), k)
    cand = face_ids[idx]
    tie = (dist <= dist[:, :1] + 1e-9) & (cand != cand[:, :1])
    ambiguous = tie.any(axis=1)
    ids = cand[:, 0].copy()
    clear = ids[~ambiguous] if (~ambiguous).any() else ids
    vals, counts = np.unique(clear, return_counts=True)
    major = int(vals[np.argmax(counts)])
    for f in np.flatnonzero(ambiguous):
        options = cand[f][dist[f] <= dist[f, 0] + 1e-9]
        ids[f] = major if major in options else int(options.min())
    for iid in np.unique(ids):
        if iid != major and len(np.unique(part.faces[ids == iid])) < 4:
            ids[ids == iid] = major
    return ids


# ----------------------------------------------------------------------------------------------
# Matterport3D

# Matterport3D's one-letter region labels (its README's table)
MP3D_REGIONS = {"a": "bathroom", "b": "bedroom", "c": "closet", "d": "dining room", "e": "entryway", "f": "family room",
                "g": "garage", "h": "hallway", "i": "library", "j": "laundry room", "k": "kitchen", "l": "living room",
                "m": "meeting room", "n": "lounge", "o": "office", "p": "porch", "r": "game room", "s": "stairs",
                "t": "toilet", "u": "utility room", "v": "tv room", "w": "gym", "x": "outdoor", "y": "balcony",
                "z": "other room", "B": "bar", "C": "classroom", "D": "dining booth", "S": "spa", "Z": "junk"}


def _mp3d_base(path: Path) -> Path | None:
    """Return the MP3D stem path of `<id>.glb` when `<id>_semantic.ply` or `<id>.house` lies beside it."""
    if path.suffix.lower() != ".glb":
        return None
    base = path.parent / path.stem
    return base if Path(f"{base}_semantic.ply").is_file() or Path(f"{base}.house").is_file() else None


HOUSE_COUNTS = {"L": 12, "R": 10, "S": 6, "V": 5, "C": 9, "O": 8}  # record -> its count's field on the H line


def read_house(path: Path) -> tuple[dict[int, dict[str, Any]], dict[int, str], dict[int, dict[str, Any]]]:
    """Parse a Matterport3D ``.house`` file: (regions, categories, objects) by index; raise InputError naming the line.

    The layout of Matterport's ``data_organization.md`` (house_segmentations): an ``ASCII 1.1`` line, then
    ``H name label #images #panoramas #vertices #surfaces #segments #objects #categories #regions #portals #levels
    0 0 0 0 0 xlo ylo zlo xhi yhi zhi 0 0 0 0 0``, ``L level_index #regions label px py pz xlo .. zhi ..``,
    ``R region_index level_index 0 0 label px py pz xlo ylo zlo xhi yhi zhi height 0 0 0 0``,
    ``S surface_index region_index 0 label px py pz nx ny nz xlo .. zhi ..``,
    ``V vertex_index surface_index label px py pz nx ny nz 0 0 0``,
    ``C category_index category_mapping_index category_mapping_name mpcat40_index mpcat40_name ..``,
    ``O object_index region_index category_index px py pz a0x a0y a0z a1x a1y a1z r0 r1 r2 ..`` (``P``, ``I``, ``E``
    lines are read past). A region's extent is the counter-clockwise polygon of the ``V`` vertices of its ``S``
    surfaces (the largest when it has several), else its box (``polygon`` None). The H line's counts of levels,
    regions, surfaces, vertices, categories and objects must match the lines that follow (a cut file is an error).
    """
    if not path.is_file():
        raise InputError(display_path(path), "missing: a Matterport3D scene needs its .house file (regions, "
                                             "object categories) beside the .glb")
    regions: dict[int, dict[str, Any]] = {}
    cats: dict[int, str] = {}
    objects: dict[int, dict[str, Any]] = {}
    surfaces: dict[int, int] = {}
    verts: dict[int, list[tuple[float, float]]] = {}
    seen = {k: 0 for k in HOUSE_COUNTS}
    header: list[str] | None = None
    for n, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), start=1):
        f = line.split()
        try:
            if f[:1] == ["H"]:
                header = f
                for pos in HOUSE_COUNTS.values():
                    int(f[pos])  # the counts must be integers
            elif f[:1] == ["R"]:
                box = [float(x) for x in f[9:15]]
                if len(box) != 6:
                    raise IndexError
                regions[int(f[1])] = {"level": int(f[2]), "label": MP3D_REGIONS.get(f[5], "other room"),
                                      "box": box, "polygon": None}
            elif f[:1] == ["S"]:
                surfaces[int(f[1])] = int(f[2])
            elif f[:1] == ["V"]:
                verts.setdefault(int(f[2]), []).append((float(f[4]), float(f[5])))
            elif f[:1] == ["C"]:
                raw, coarse = f[3], f[5] if len(f) > 5 else f[3]
                name = raw if raw not in ("", "-", "unknown") else coarse
                cats[int(f[1])] = re.sub(r"[_#]+", " ", name).strip() or "object"
            elif f[:1] == ["O"]:
                objects[int(f[1])] = {"region": int(f[2]), "category": int(f[3])}
        except (IndexError, ValueError):
            raise InputError(display_path(path), f"line {n}: malformed {f[0] if f else ''} record: {line.strip()!r}") \
                from None
        if f[:1] and f[0] in seen:
            seen[f[0]] += 1
    if header is not None:
        names = {"L": "levels", "R": "regions", "S": "surfaces", "V": "vertices", "C": "categories", "O": "objects"}
        for rec, pos in HOUSE_COUNTS.items():
            if int(header[pos]) != seen[rec]:
                raise InputError(display_path(path), f"the H line says {header[pos]} {names[rec]}, the file has "
                                                     f"{seen[rec]} {rec} lines (a cut or edited file?)")
    for sid, rid in sorted(surfaces.items()):
        poly = np.asarray(verts.get(sid, []), dtype=float)
        if rid in regions and len(poly) >= 3:
            area = 0.5 * abs(float(np.dot(poly[:, 0], np.roll(poly[:, 1], -1)) - np.dot(np.roll(poly[:, 0], -1), poly[:, 1])))
            old = regions[rid]["polygon"]
            if old is None or area > old[1]:
                regions[rid]["polygon"] = (poly, area)
    for r in regions.values():
        r["polygon"] = None if r["polygon"] is None else r["polygon"][0]
    return regions, cats, objects


def read_mp3d(path: str | Path, units: str | float = "auto", up: str = "auto") -> Reading:
    """Read a Matterport3D scene (``<id>.glb`` + ``<id>_semantic.ply`` + ``<id>.house``) into instances and regions."""
    import trimesh
    from scipy.spatial import cKDTree

    path = Path(path)
    base = path.parent / path.stem
    sem_ply, house = Path(f"{base}_semantic.ply"), Path(f"{base}.house")
    if not sem_ply.is_file():
        raise InputError(display_path(sem_ply), "missing: a Matterport3D scene needs its _semantic.ply beside the .glb")
    regions, cats, objects = read_house(house)
    up = "+Z" if str(up).lower() == "auto" else up
    visual = load_mesh(path, units=units, up=up, kind="scene")
    try:
        ply = trimesh.load(str(sem_ply), process=False)
        raw = ply.metadata["_ply_raw"]["face"]["data"]
        face_obj = np.asarray(raw["object_id"], dtype=np.int64).ravel()
    except Exception as e:  # noqa: BLE001 - any parser failure is a bad input
        raise InputError(display_path(sem_ply), f"cannot read per-face object_id: {type(e).__name__}: {e}") from None
    missing = sorted(set(np.unique(face_obj).tolist()) - set(objects) - {-1})
    if missing:
        raise InputError(display_path(sem_ply), f"{len(missing)} object id(s) absent from {house.name}: "
                                                f"{', '.join(map(str, missing[:8]))}")
    rot, _name = up_rotation(up, sem_ply)
    sv = np.asarray(ply.vertices, dtype=np.float64) @ rot.T * visual.scale
    tree = cKDTree(sv[np.asarray(ply.faces)].mean(axis=1))
    pairs: list[tuple[Part, int]] = []
    for vp in visual.parts:
        pairs.extend(split_by_face_instance(vp, _match_faces(vp, tree, face_obj)))
    meta = {k: {"id": k, "label": cats.get(o["category"], "object"), "room": o["region"],
                "floor": regions.get(o["region"], {}).get("level", -1), "kind": "", "name": f"object {k}"}
            for k, o in objects.items()}
    meta[-1] = {"id": -1, "label": "unlabeled", "room": -1, "kind": "", "name": "unlabeled"}
    rooms = []
    for k in sorted(regions):
        x0, y0, _z0, x1, y1, _z1 = (v * visual.scale for v in regions[k]["box"])
        poly = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) if regions[k]["polygon"] is None \
            else regions[k]["polygon"] * visual.scale
        if float(np.dot(poly[:, 0], np.roll(poly[:, 1], -1)) - np.dot(np.roll(poly[:, 0], -1), poly[:, 1])) < 0:
            poly = poly[::-1]
        rooms.append(Room(id=k, type=regions[k]["label"], floor=regions[k]["level"], polygon=poly))
    return Reading(pairs, meta, rooms, [path, sem_ply, house])


# ----------------------------------------------------------------------------------------------
# Habitat scene datasets

STAGE_CONFIG = ".stage_config.json"
OBJECT_CONFIG = ".object_config.json"
AO_CONFIG = ".ao_config.json"
ASSET_SUFFIXES = (".glb", ".gltf", ".obj", ".ply")  # render assets a ``paths`` entry may register directly
ANCESTORS = 4  # how many folders up from a scene file a dataset config is looked for


@dataclass
class _Dataset:
    """A scene dataset config (path None: a scene instance without one)."""

    path: Path | None
    doc: dict[str, Any]

    @property
    def root(self) -> Path:
        """The folder its relative paths start from."""
        return self.path.parent if self.path else Path(".")


_REGISTRIES: dict[tuple[str, int, int], "_Registry"] = {}


def _stat_key(path: Path) -> tuple[int, int]:
    """Return (mtime_ns, size) of a file ((0, -1) when it is gone)."""
    try:
        st = path.stat()
    except OSError:
        return 0, -1
    return st.st_mtime_ns, st.st_size


def _registry(config: Path | None) -> "_Registry":
    """Return the (per-process, memoised) registry of a dataset config: read again when the config or any template
    config it read has changed since (files added under its ``paths`` are seen by a new process)."""
    if config is None:
        return _Registry(_Dataset(None, {}))
    key = (str(config.resolve()), *_stat_key(config))
    reg = _REGISTRIES.get(key)
    if reg is not None and any(_stat_key(f) != k for f, k in reg.read.items()):
        reg = None
    if reg is None:
        doc = _read_json(config)
        if not isinstance(doc, dict):
            raise InputError(display_path(config), "not a JSON object: not a Habitat scene dataset config")
        reg = _REGISTRIES[key] = _Registry(_Dataset(config, doc))
    return reg


def dataset_members(config: str | Path) -> list[Path]:
    """Return the scenes a scene dataset config holds, sorted: its scene instances; with none, its stages.

    Datasets whose scenes are stages (HM3D's and MP3D's configs register ``<id>.basis.glb`` stages by glob and no
    scene instance; Gibson's likewise) give one scene per stage: a registered render asset, or a ``*.stage_config.json``.
    """
    reg = _registry(Path(config))
    scenes = reg.files("scene_instances", SCENE_INSTANCE)
    if scenes:
        return scenes
    return sorted({p for p in reg.files("stages", STAGE_CONFIG) + reg.asset_files("stages")})


def _registers(reg: "_Registry", path: Path) -> bool:
    """Return whether a dataset registers `path` as a scene instance or a stage."""
    rp = path.resolve()
    return any(p.resolve() == rp for p in reg.files("scene_instances", SCENE_INSTANCE) + reg.files("stages", STAGE_CONFIG)
               + reg.asset_files("stages"))


def dataset_of(path: str | Path) -> Path | None:
    """Return the scene dataset config a scene file belongs to, or None.

    The config beside the file or in one of the `ANCESTORS` folders above it, nearest first, that registers it (a
    folder with several, such as HSSD's ``hssd-hab`` and ``hssd-hab-uncluttered`` configs: the first in name order
    that registers it); a scene instance that no config registers takes the nearest config (its templates may still
    resolve there), a stage file none.
    """
    path = Path(path)
    nearest = None
    for anc in [path.parent, *path.parent.parents][:ANCESTORS]:
        for cand in sorted(anc.glob(f"*{DATASET_CONFIG}")):
            if nearest is None:
                nearest = cand
            try:
                if _registers(_registry(cand), path):
                    return cand
            except InputError:
                continue
    return nearest if path.name.lower().endswith(SCENE_INSTANCE) else None


def is_stage_member(path: str | Path) -> bool:
    """Return whether a file is a stage that a dataset config above it registers (a scene of a stage-only dataset)."""
    path = Path(path)
    low = path.name.lower()
    if not (low.endswith(STAGE_CONFIG) or path.suffix.lower() in ASSET_SUFFIXES) or low.endswith(".semantic.glb"):
        return False
    return dataset_of(path) is not None


def _scene_and_dataset(path: Path) -> tuple[Path, _Dataset]:
    """Return (scene file, its dataset config) for a scene-instance, stage or dataset-config input."""
    if path.name.lower().endswith(DATASET_CONFIG):
        scenes = dataset_members(path)
        if len(scenes) != 1:
            listing = ", ".join(display_path(s.relative_to(path.parent)) for s in scenes[:12]) or "none"
            raise InputError(display_path(path), f"holds {len(scenes)} scenes ({listing}"
                                                 f"{' ...' if len(scenes) > 12 else ''}); convert each of them (a "
                                                 "folder or the config given to `generate --scenes` is expanded)")
        return scenes[0], _registry(path).ds
    config = dataset_of(path)
    return path, _registry(config).ds


class _Registry:
    """The templates a dataset config registers (stages, objects, semantic configs) by handle (memoised)."""

    SUFFIX = {"stages": STAGE_CONFIG, "objects": OBJECT_CONFIG, "articulated_objects": AO_CONFIG,
              "semantic_scene_descriptor_instances": ".semantic_config.json"}

    def __init__(self, ds: _Dataset) -> None:
        self.ds = ds
        self._files: dict[tuple[str, str], list[Path]] = {}
        self._handles: dict[str, list[tuple[str, dict[str, Any], Path]]] = {}
        self._resolved: dict[tuple[str, str], tuple[dict[str, Any], Path, Path | None] | None] = {}
        self._urdfs: list[tuple[str, Path]] | None = None  # articulated-object templates (urdf_handles)
        self.read: dict[Path, tuple[int, int]] = {}  # template config files read -> (mtime_ns, size) when read

    def _json(self, f: Path) -> Any:
        """Read a template config file, recording its state (a later change makes `_registry` read again)."""
        self.read[f] = _stat_key(f)
        return _read_json(f)

    def _entries(self, section: str, ext: str) -> list[str]:
        sec = self.ds.doc.get(section) or {}
        paths = sec.get("paths") if isinstance(sec, dict) else None
        return [str(e) for e in (paths or {}).get(ext, [])] if isinstance(paths, dict) else []

    def files(self, section: str, suffix: str) -> list[Path]:
        """Return the config files a section's ``paths`` register (folders searched recursively, globs expanded)."""
        key = (section, suffix)
        if key not in self._files:
            out: set[Path] = set()
            for entry in self._entries(section, ".json"):
                for hit in sorted(glob.glob(str(self.ds.root / entry))):
                    p = Path(hit)
                    if p.is_dir():
                        out.update(q for q in p.rglob(f"*{suffix}") if q.is_file())
                    elif p.name.lower().endswith(suffix):
                        out.add(p)
            self._files[key] = sorted(out)
        return self._files[key]

    def asset_files(self, section: str) -> list[Path]:
        """Return the render assets a section's ``paths`` register directly (``".glb": ["*/*.basis.glb"]``)."""
        key = (section, "assets")
        if key not in self._files:
            out: set[Path] = set()
            for ext in ASSET_SUFFIXES:
                for entry in self._entries(section, ext):
                    for hit in sorted(glob.glob(str(self.ds.root / entry))):
                        p = Path(hit)
                        found = p.rglob(f"*{ext}") if p.is_dir() else [p]
                        out.update(q for q in found if q.is_file() and q.suffix.lower() == ext
                                   and not q.name.lower().endswith((".semantic.glb", "_semantic.ply")))
            self._files[key] = sorted(out)
        return self._files[key]

    def config_files(self) -> list[Path]:
        """Return every registered config file."""
        out: list[Path] = []
        for sec, suf in self.SUFFIX.items():
            out += self.files(sec, suf)
        return out

    def handles(self, section: str) -> list[tuple[str, dict[str, Any], Path]]:
        """Return (handle, attributes, folder of relative paths) of a section's templates, in registration order."""
        if section in self._handles:
            return self._handles[section]
        sec = self.ds.doc.get(section) or {}
        defaults = dict(sec.get("default_attributes") or {}) if isinstance(sec, dict) else {}
        out = []
        for f in self.files(section, self.SUFFIX[section]):
            attrs = {**defaults, **self._json(f), "__file__": f}
            out.append((f.relative_to(self.ds.root).as_posix(), attrs, f.parent))
        if section == "stages":  # render assets registered as stages: the defaults with the file as render asset
            for f in self.asset_files(section):
                out.append((f.relative_to(self.ds.root).as_posix(), {**defaults, "render_asset": f.name}, f.parent))
        for cfg in (sec.get("configs") or []) if isinstance(sec, dict) else []:
            handle = str(cfg.get("template_handle", ""))
            attrs, base = dict(defaults), self.ds.root
            if cfg.get("original_file"):
                orig = self.ds.root / str(cfg["original_file"])
                attrs.update(self._json(orig))
                attrs["__file__"] = orig
                base = orig.parent
            attrs.update(cfg.get("attributes") or {})
            if "render_asset" in (cfg.get("attributes") or {}):
                base = self.ds.root
            out.append((handle, attrs, base))
        self._handles[section] = out
        return out

    def resolve(self, section: str, name: str, where: Path) -> tuple[dict[str, Any], Path]:
        """Return (attributes, folder) of the template `name`: an exact handle, else the first handle containing it.

        The attributes carry ``__file__``, the config file they were read from (absent for a registered render asset).
        Raise InputError naming the scene (`where`) and the dataset when no template matches.
        """
        found = self.lookup(section, name)
        if found is None:
            raise InputError(display_path(where), self.missing(section, name))
        return found

    def lookup(self, section: str, name: str) -> tuple[dict[str, Any], Path] | None:
        """Return (attributes, folder) of the template `name` as `resolve` finds it, or None when none matches."""
        key = (section, name)
        if key not in self._resolved:
            self._resolved[key] = self._resolve(section, name)
        hit = self._resolved[key]
        return None if hit is None else (hit[0], hit[1])

    def missing(self, section: str, name: str) -> str:
        """Return the sentence saying that template `name` is not in the dataset (with the first handles it has)."""
        kind = {"stages": "stage", "objects": "object", "articulated_objects": "articulated object"}.get(section, section)
        handles = [h for h, _p in self.urdf_handles()] if section == "articulated_objects" else \
            [h for h, _a, _b in self.handles(section)]
        known = ", ".join(sorted(handles)[:8]) or "none"
        return (f"{kind} template '{name}' is not in the dataset "
                f"({display_path(self.ds.path) if self.ds.path else 'no dataset config'}; registered: {known})")

    def _resolve(self, section: str, name: str) -> tuple[dict[str, Any], Path, Path | None] | None:
        entries = self.handles(section)
        for handle, attrs, base in entries:
            if handle == name:
                return attrs, base, None
        for handle, attrs, base in sorted(entries, key=lambda e: e[0]):
            if name in handle:
                return attrs, base, None
        direct = self.ds.root / name
        if direct.is_file() and direct.name.lower().endswith(self.SUFFIX[section]):
            return {**self._json(direct), "__file__": direct}, direct.parent, None
        return None

    def urdf_handles(self) -> list[tuple[str, Path]]:
        """Return (handle, URDF file) of the articulated-object templates the config registers, sorted by handle.

        ``articulated_objects.paths``: ``".urdf"`` entries are folders (searched recursively), globs or files, as
        ReplicaCAD's ``{".urdf": ["urdf/*/"]}``; ``".json"`` entries name ``*.ao_config.json`` files whose
        ``urdf_filepath`` (relative to the config file) is the URDF. The handle is the file's path relative to the
        dataset config (the config's, for an ao_config).
        """
        if self._urdfs is None:
            out: dict[str, Path] = {}
            for entry in self._entries("articulated_objects", ".urdf"):
                for hit in sorted(glob.glob(str(self.ds.root / entry))):
                    p = Path(hit)
                    for q in (sorted(p.rglob("*.urdf")) if p.is_dir() else [p]):
                        if q.is_file() and q.suffix.lower() == ".urdf":
                            out[q.relative_to(self.ds.root).as_posix()] = q
            for f in self.files("articulated_objects", AO_CONFIG):
                doc = self._json(f)
                rel = doc.get("urdf_filepath") if isinstance(doc, dict) else None
                if rel and (f.parent / str(rel)).is_file():
                    out[f.relative_to(self.ds.root).as_posix()] = f.parent / str(rel)
            self._urdfs = sorted(out.items())
        return self._urdfs

    def lookup_urdf(self, name: str) -> Path | None:
        """Return the URDF of articulated-object template `name`, or None: a handle equal to it, else one whose file
        stem is it (ReplicaCAD's ``fridge`` for ``urdf/fridge/fridge.urdf``), else the first handle containing it
        (habitat-sim's substring rule), else a URDF at that path under the dataset folder."""
        entries = self.urdf_handles()
        for handle, urdf in entries:
            if handle == name:
                return urdf
        for handle, urdf in entries:
            if Path(handle).name.split(".")[0] == name or urdf.stem == name:
                return urdf
        for handle, urdf in entries:
            if name in handle:
                return urdf
        direct = self.ds.root / name
        return direct if direct.is_file() and direct.suffix.lower() == ".urdf" else None


def _scene_doc(scene: Path, reg: _Registry) -> dict[str, Any]:
    """Return a scene instance's JSON; a stage member (stage config or registered render asset) as a scene holding
    only that stage, as habitat-sim synthesises one around a stage."""
    low = scene.name.lower()
    if low.endswith(SCENE_INSTANCE):
        doc = _read_json(scene)
        if not isinstance(doc, dict) or not isinstance(doc.get("stage_instance"), dict):
            raise InputError(display_path(scene), "no 'stage_instance' object: not a Habitat scene instance")
        return doc
    if reg.ds.path is None:
        raise InputError(display_path(scene), "a stage file is a scene only inside the scene dataset config that "
                                              "registers it (none found beside it or above)")
    return {"stage_instance": {"template_name": scene.resolve().relative_to(reg.ds.root.resolve()).as_posix()}}


def _template_files(attrs: dict[str, Any], base: Path) -> list[Path]:
    """Return a resolved template's config file and its render asset with every file it references."""
    out = [attrs["__file__"]] if attrs.get("__file__") else []
    if attrs.get("render_asset"):
        asset = base / str(attrs["render_asset"])
        out += referenced_files(asset) if asset.is_file() else []
    return out


def scene_files(path: str | Path) -> list[Path]:
    """Return every file a Habitat scene reads: the scene file, its dataset config, the stage and object templates it
    uses with their render assets (and what those reference) and its semantic config; raise InputError on the first
    that is missing, unreadable or not of its format (the up-front input check and the conversion cache key)."""
    scene, ds = _scene_and_dataset(Path(path))
    reg = _registry(ds.path)
    doc = _scene_doc(scene, reg)
    files = [scene] + ([ds.path] if ds.path else [])
    stage = doc["stage_instance"]
    insts = [("stages", stage)] + [("objects", o) for o in (doc.get("object_instances") or [])]
    for k, (section, inst) in enumerate(insts):
        name = str(inst.get("template_name", "")) if isinstance(inst, dict) else ""
        if not name:
            raise InputError(display_path(scene), f"object_instances[{k - 1}] has no template_name" if k else
                                                  "stage_instance has no template_name")
        if section == "objects" and reg.lookup(section, name) is None:
            continue  # not imported: the conversion names it (Reading.unused)
        attrs, base = reg.resolve(section, name, scene)
        if not attrs.get("render_asset") or not (base / str(attrs["render_asset"])).is_file():
            raise InputError(display_path(scene), f"render asset '{attrs.get('render_asset', '')}' of template "
                                                  f"'{name}' not found (looked at "
                                                  f"{display_path(base / str(attrs.get('render_asset', '')))})")
        files += _template_files(attrs, base)
    for inst in _articulated_entries(doc, scene):
        urdf = reg.lookup_urdf(str(inst.get("template_name", "")))
        if urdf is not None:
            files += _urdf_files(urdf)
    sem = _semantic_config_path(doc, scene, ds, reg)
    if sem is not None:
        _read_json(sem)
        files.append(sem)
    return sorted(set(files), key=lambda p: os.fsencode(str(p)))


TEMPLATE_MEMO_FACES = 3_000_000  # triangles of loaded templates a process keeps (about 0.3 GB of arrays)
_TEMPLATES: "OrderedDict[tuple[str, int, int, float], LoadedMesh]" = OrderedDict()
TEMPLATE_LOADS: list[str] = []  # render assets parsed by this process, in order (what `load_template` did not reuse)


def load_template(asset: Path, units: float) -> LoadedMesh:
    """Return a template's render asset loaded in its own frame (metres by `units`, no axis change: `_frame` turns
    it), parsed once per process: scenes of a dataset share stages and object templates, and a scene places one
    template many times. The memo keeps the last-used templates up to `TEMPLATE_MEMO_FACES` triangles; callers
    never modify the parts (placing makes new arrays)."""
    st = asset.stat()
    key = (str(asset.resolve()), st.st_mtime_ns, st.st_size, float(units))
    hit = _TEMPLATES.get(key)
    if hit is not None:
        _TEMPLATES.move_to_end(key)
        return hit
    mesh = load_mesh(asset, units=units, up="+Z", kind="scene")  # +Z: no axis change here; the frame is below
    TEMPLATE_LOADS.append(key[0])
    _TEMPLATES[key] = mesh
    total = sum(m.face_count for m in _TEMPLATES.values())
    while total > TEMPLATE_MEMO_FACES and len(_TEMPLATES) > 1:
        _k, old = _TEMPLATES.popitem(last=False)
        total -= old.face_count
    return mesh


def _frame(attrs: dict[str, Any], where: Path) -> np.ndarray:
    """Return the rotation taking an asset's (up, front) to Habitat's (+Y, -Z)."""
    up = np.asarray(attrs.get("up", [0.0, 1.0, 0.0]), dtype=float)
    front = np.asarray(attrs.get("front", [0.0, 0.0, -1.0]), dtype=float)
    if up.shape != (3,) or front.shape != (3,) or np.linalg.norm(up) == 0 or np.linalg.norm(front) == 0:
        raise InputError(display_path(where), "'up' and 'front' must be non-zero 3-vectors")
    up, front = up / np.linalg.norm(up), front / np.linalg.norm(front)
    if abs(float(up @ front)) > 1e-6:
        raise InputError(display_path(where), f"'up' {up.tolist()} and 'front' {front.tolist()} are not orthogonal")
    right = np.cross(front, up)
    return np.stack([right, up, -front])


def _quat_wxyz(q: Any, where: Path) -> np.ndarray:
    """Return the rotation matrix of a Habitat wxyz quaternion."""
    a = np.asarray(q if q is not None else [1.0, 0.0, 0.0, 0.0], dtype=float)
    if a.shape != (4,) or not np.isfinite(a).all() or np.linalg.norm(a) == 0:
        raise InputError(display_path(where), f"'rotation' must be a wxyz quaternion, got {q!r}")
    w, x, y, z = a / np.linalg.norm(a)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _placed_parts(attrs: dict[str, Any], base: Path, inst: dict[str, Any], origin: str, where: Path) -> list[Part]:
    """Load a template's render asset and place it as the instance says; parts in MuJoCo's frame."""
    asset = base / str(attrs.get("render_asset", ""))
    if not attrs.get("render_asset") or not asset.is_file():
        raise InputError(display_path(where), f"render asset '{attrs.get('render_asset', '')}' of template "
                                              f"'{inst.get('template_name')}' not found (looked at {display_path(asset)})")
    units = float(attrs.get("units_to_meters", 1.0))
    mesh = load_template(asset, units)
    frame = _frame(attrs, asset)
    scale = np.asarray(attrs.get("scale", [1.0, 1.0, 1.0]), dtype=float) * np.asarray(
        inst.get("non_uniform_scale", [1.0, 1.0, 1.0]), dtype=float) * float(inst.get("uniform_scale", 1.0))
    shift = np.asarray(attrs.get("origin", [0.0, 0.0, 0.0]), dtype=float)  # a stage config's origin (world frame)
    if shift.shape != (3,) or not np.isfinite(shift).all():
        raise InputError(display_path(where), f"'origin' of template '{inst.get('template_name')}' must be a 3-vector, "
                                              f"got {attrs.get('origin')!r}")
    local = [(p.vertices @ frame.T) * scale + shift for p in mesh.parts]
    allv = np.concatenate(local)
    if str(inst.get("translation_origin", origin)).lower() == "com":
        com = (np.asarray(attrs["COM"], dtype=float) * scale + shift if "COM" in attrs
               else (allv.min(axis=0) + allv.max(axis=0)) / 2)
    else:
        com = np.zeros(3)
    R = _quat_wxyz(inst.get("rotation"), where)
    t = np.asarray(inst.get("translation", [0.0, 0.0, 0.0]), dtype=float)
    out = []
    for p, v in zip(mesh.parts, local):
        world = (v - com) @ R.T + t
        out.append(Part(world @ HAB_TO_MJ.T, p.faces, p.material, p.uv, p.colors, p.node))
    return out


def _node_extras(asset: Path) -> dict[str, dict[str, Any]]:
    """Return glTF node name -> extras of a GLB/glTF (empty when it has none)."""
    try:
        doc = _gltf_json(asset)
    except InputError:
        return {}
    return {str(n.get("name", "")): n.get("extras") or {} for n in doc.get("nodes", []) if isinstance(n, dict)}


def _semantic_config_path(scene_doc: dict[str, Any], scene: Path, ds: _Dataset, reg: _Registry) -> Path | None:
    """Return the scene's semantic config file (lexicon, region annotations), or None when it names none that exists."""
    handle = scene_doc.get("semantic_scene_instance")
    sec = ds.doc.get("scene_instances") or {}
    if not handle and isinstance(sec, dict):
        handle = (sec.get("default_attributes") or {}).get("semantic_scene_instance")
    if not handle:
        return None
    stem = scene.name[: -len(SCENE_INSTANCE)] if scene.name.lower().endswith(SCENE_INSTANCE) else scene.stem
    handle = str(handle).replace("%%CONFIG_NAME_AS_ASSET_FILENAME%%", stem)
    ssd = ds.doc.get("semantic_scene_descriptor_instances") or {}
    target = str(ssd.get(handle, handle)) if isinstance(ssd, dict) else str(handle)
    direct = ds.root / target
    if direct.is_file():
        return direct
    for f in reg.files("semantic_scene_descriptor_instances", ".semantic_config.json"):
        if Path(target).name in f.name:
            return f
    return None


def _semantic_config(scene_doc: dict[str, Any], scene: Path, ds: _Dataset, reg: _Registry) -> dict[str, Any]:
    """Return the scene's semantic config (lexicon, region annotations), or {} when it names none that exists."""
    path = _semantic_config_path(scene_doc, scene, ds, reg)
    return _read_json(path) if path is not None else {}


def _rooms(semantic: dict[str, Any], where: Path) -> list[Room]:
    """Return the region annotations of a semantic config as Rooms (MuJoCo frame, CCW polygons)."""
    rooms = []
    regions = semantic.get("region_annotations") or []
    heights = sorted({round(float(r.get("floor_height", 0.0)), 3) for r in regions})
    for k, r in enumerate(regions):
        loop = np.asarray(r.get("poly_loop", []), dtype=float)
        if loop.ndim != 2 or loop.shape[1] != 3 or len(loop) < 3:
            raise InputError(display_path(where), f"region_annotations[{k}] ('{r.get('name', '')}'): poly_loop must "
                                                  "list at least 3 [x, y, z] points")
        poly = (loop @ HAB_TO_MJ.T)[:, :2]
        x, y = poly[:, 0], poly[:, 1]
        if float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) < 0:
            poly = poly[::-1]
        rooms.append(Room(id=k, type=str(r.get("label") or r.get("name") or "region"),
                          floor=heights.index(round(float(r.get("floor_height", 0.0)), 3)), polygon=poly))
    return rooms


def read_habitat(path: str | Path) -> Reading:
    """Read a Habitat scene dataset's scene instance (stage + placed objects, semantics, regions)."""
    scene, ds = _scene_and_dataset(Path(path))
    reg = _registry(ds.path)
    doc = _scene_doc(scene, reg)
    origin = str(doc.get("translation_origin", "asset_local"))
    semantic = _semantic_config(doc, scene, ds, reg)
    lexicon = {int(c["id"]): str(c["name"]) for c in semantic.get("classes", []) if "id" in c and "name" in c}
    rooms = _rooms(semantic, scene)
    pairs: list[tuple[Part, int]] = []
    meta: dict[int, dict[str, Any]] = {}
    stage_inst = doc["stage_instance"]
    attrs, base = reg.resolve("stages", str(stage_inst.get("template_name", "")), scene)
    stage_parts = _placed_parts(attrs, base, stage_inst, origin, scene)
    extras = _node_extras(base / str(attrs["render_asset"]))
    node_ids: dict[str, int] = {}
    for p in stage_parts:
        m = re.match(r"^(.*?)(?:_[0-9a-f]{6})?$", p.node)
        ex = extras.get(p.node) or extras.get(m.group(1) if m else p.node) or {}
        if "instance_id" in ex:
            iid = int(ex["instance_id"])
        else:
            iid = node_ids.setdefault(p.node, 10**6 + len(node_ids))
        entry = {"id": iid, "label": str(ex.get("label") or label_from_node(p.node)),
                 "kind": str(ex.get("kind", "structure")), "name": p.node}
        entry.update({k: int(ex[k]) for k in ("room", "floor") if k in ex})
        meta.setdefault(iid, entry)
        pairs.append((p, iid))
    nxt = max([i for _p, i in pairs if i < 10**6], default=-1) + 1
    renum = {}
    for tmp in sorted(set(node_ids.values())):
        renum[tmp] = nxt
        meta[nxt] = {**meta.pop(tmp), "id": nxt}
        nxt += 1
    pairs = [(p, renum.get(i, i)) for p, i in pairs]
    unused = _scene_unused(doc, scene, reg)
    for k, inst in enumerate(doc.get("object_instances") or []):
        name = str(inst.get("template_name", ""))
        if not name:
            raise InputError(display_path(scene), f"object_instances[{k}] has no template_name")
        if reg.lookup("objects", name) is None:
            unused.append(f"{display_path(scene)}: object_instances[{k}] not imported: {reg.missing('objects', name)}")
            continue
        attrs, base = reg.resolve("objects", name, scene)
        parts = _placed_parts(attrs, base, inst, origin, scene)
        sid = attrs.get("semantic_id", inst.get("semantic_id"))
        stem = Path(name).name
        stem = stem[: -len(".object_config.json")] if stem.endswith(".object_config.json") else stem
        label = lexicon.get(int(sid)) if sid is not None and int(sid) in lexicon else label_from_node(stem)
        meta[nxt] = {"id": nxt, "label": label, "kind": "furniture", "name": name}
        pairs.extend((p, nxt) for p in parts)
        nxt += 1
    if rooms:
        _assign_rooms(pairs, meta, rooms, semantic)
    pieces = _read_articulated(doc, scene, reg, lexicon, nxt, unused)
    return Reading(pairs, meta, rooms, [scene] + ([ds.path] if ds.path else []), unused, pieces)


# ----------------------------------------------------------------------------------------------
# Habitat articulated objects (URDF furniture: ReplicaCAD's fridge, counter, cupboards, drawers, doors)

AO_KEYS = {"template_name", "translation", "rotation", "uniform_scale", "non_uniform_scale", "translation_origin",
           "fixed_base", "motion_type", "auto_clamp_joint_limits", "initial_joint_pose", "initial_joint_velocities",
           "user_defined"}  # articulated_object_instances fields this reader reads (any other is named unused)
SCENE_KEYS = {"stage_instance", "object_instances", "articulated_object_instances", "translation_origin",
              "semantic_scene_instance", "default_lighting"}  # scene-instance keys read (others are named)


def _articulated_entries(doc: dict[str, Any], scene: Path) -> list[dict[str, Any]]:
    """Return a scene instance's ``articulated_object_instances`` (InputError naming the scene when malformed)."""
    entries = doc.get("articulated_object_instances") or []
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise InputError(display_path(scene), "'articulated_object_instances' must be a list of objects")
    return entries


def _urdf_files(urdf: Path) -> list[Path]:
    """Return a URDF with its ao_config and meshes (the URDF alone when it does not parse: its conversion says why)."""
    from .urdf import read_urdf

    try:
        return read_urdf(urdf).files()
    except InputError:
        return [urdf]


def _scene_unused(doc: dict[str, Any], scene: Path, reg: "_Registry") -> list[str]:
    """Return what a scene instance holds at its top level that the conversion does not use (lights, navmesh, ...)."""
    where = display_path(scene)
    out = []
    light = doc.get("default_lighting")
    if light not in (None, "", "no_lights"):
        sec = reg.ds.doc.get("light_setups")
        sec = sec if isinstance(sec, dict) else {}
        handles = [f.name for f in reg.files("light_setups", ".lighting_config.json")] + \
            [str(c.get("template_handle", "")) for c in (sec.get("configs") or []) if isinstance(c, dict)]
        setups = [h for h in handles if str(light) in h]
        out.append(f"{where}: default_lighting '{light}' (a light setup{'' if setups else ', not in the dataset'}) "
                   "not used: a converted scene is lit by its own two directional lights")
    for key in sorted(set(doc) - SCENE_KEYS):
        out.append(f"{where}: '{key}' not used (the converter reads {', '.join(sorted(SCENE_KEYS))})")
    return out


def _ao_label(name: str, semantic_id: int | None, lexicon: dict[int, str]) -> str:
    """Return an articulated object's label: its semantic class, else its template name (``kitchenCupboard_01`` ->
    "kitchen cupboard")."""
    if semantic_id is not None and semantic_id in lexicon:
        return lexicon[semantic_id]
    stem = Path(name).name.split(".")[0]
    return label_from_node(re.sub(r"(?<=[a-z0-9])(?=[A-Z])", " ", stem))


def _joint_pose(inst: dict[str, Any], movable: list[str], where: str) -> dict[str, float]:
    """Return joint name -> initial position of an instance: ``initial_joint_pose`` (a list in the URDF's movable
    joint order, or a dict by name), else ``user_defined.joint_states`` (by name, as our Habitat export writes it)."""
    pose = inst.get("initial_joint_pose")
    if pose is None:
        pose = (inst.get("user_defined") or {}).get("joint_states") if isinstance(inst.get("user_defined"), dict) else None
    if pose is None:
        return {}
    if isinstance(pose, list):
        if len(pose) > len(movable):
            raise InputError(where, f"initial_joint_pose has {len(pose)} values; the URDF has {len(movable)} movable joints")
        pose = dict(zip(movable, pose))
    if not isinstance(pose, dict):
        raise InputError(where, "initial_joint_pose must be a list or an object (joint name -> position)")
    unknown = sorted(set(map(str, pose)) - set(movable))
    if unknown:
        raise InputError(where, f"initial_joint_pose names joints the URDF has not: {', '.join(unknown)}")
    try:
        return {str(k): float(v) for k, v in pose.items()}
    except (TypeError, ValueError):
        raise InputError(where, f"initial_joint_pose values must be numbers, got {pose!r}") from None


def _read_articulated(doc: dict[str, Any], scene: Path, reg: "_Registry", lexicon: dict[int, str], first_id: int,
                      unused: list[str]) -> list[dict[str, Any]]:
    """Return the scene instance's articulated objects as `articulated_scene` pieces; what is not imported goes to
    `unused` (a template the dataset lacks, a URDF that does not convert, fields not read).

    Pose as habitat-sim sets it (``BulletArticulatedObject::resetStateFromSceneInstanceAttr``): the instance's
    rotation and translation become the multibody's base transform, which is the root link's inertial frame (the
    URDF root ``<inertial><origin>``, scaled; identity without one). ``translation_origin`` gets no COM correction
    for articulated objects there (its ``defaultCOMCorrection`` is unused), so ``"COM"`` and ``"asset_local"`` both
    place that frame. The URDF's coordinates are taken in Habitat's Y-up world as they are (no up/front for
    URDFs); the root link's frame then goes to MuJoCo's Z-up world: (x, y, z) -> (x, -z, y).
    """
    from .urdf import mat_to_quat, read_urdf

    pieces = []
    iid = first_id
    for k, inst in enumerate(_articulated_entries(doc, scene)):
        name = str(inst.get("template_name", ""))
        what = f"{display_path(scene)}: articulated_object_instances[{k}] '{name}'"
        if not name:
            raise InputError(display_path(scene), f"articulated_object_instances[{k}] has no template_name")
        urdf = reg.lookup_urdf(name)
        if urdf is None:
            unused.append(f"{display_path(scene)}: articulated_object_instances[{k}] not imported: "
                          f"{reg.missing('articulated_objects', name)}")
            continue
        try:
            robot = read_urdf(urdf)
        except InputError as e:
            unused.append(f"{what} not imported: its URDF does not convert: {e}")
            continue
        origin = str(inst.get("translation_origin", doc.get("translation_origin", "asset_local"))).lower()
        if origin not in ("asset_local", "com"):
            raise InputError(display_path(scene), f"articulated_object_instances[{k}]: translation_origin must be "
                                                  f"'asset_local' or 'COM', got {origin!r}")
        scale = float(inst.get("uniform_scale", 1.0))
        nus = np.asarray(inst.get("non_uniform_scale", [1.0, 1.0, 1.0]), dtype=float)
        if not (np.isfinite(scale) and scale > 0) or nus.shape != (3,) or not (nus > 0).all():
            raise InputError(display_path(scene), f"articulated_object_instances[{k}]: uniform_scale must be positive "
                                                  "and non_uniform_scale 3 positive numbers")
        if np.ptp(nus) > 1e-9:
            unused.append(f"{what}: non_uniform_scale {nus.tolist()} not applied (a URDF scales uniformly): "
                          f"scaled by {float(nus.mean()):g}")
        scale *= float(nus.mean())
        movable = [j.name for j in robot.joints if j.type != "fixed"]
        try:
            pose = _joint_pose(inst, movable, what)
        except InputError as e:  # habitat-sim warns and skips such values; so does this reader, naming them
            unused.append(f"{what}: initial joint state not read: {e.cause}")
            pose = {}
        if any(abs(v) > 1e-9 for v in pose.values()):
            unused.append(f"{what}: initial joint state {pose} not kept: each variant draws its parts' states "
                          "(place.part_open_p / part_closed_p / part_ajar_p)")
        if any(abs(float(v)) > 1e-9 for v in (inst.get("initial_joint_velocities") or [])):
            unused.append(f"{what}: initial_joint_velocities not used (parts start at rest)")
        motion = str(inst.get("motion_type", "DYNAMIC")).upper()
        if motion not in ("DYNAMIC", "KINEMATIC", "UNDEFINED"):
            unused.append(f"{what}: motion_type {motion} not kept: its doors and drawers move here like any piece's")
        if inst.get("fixed_base") is False:
            unused.append(f"{what}: fixed_base false not kept: imported with its base fixed where the scene puts it")
        extra = sorted(set(inst) - AO_KEYS)
        if extra:
            unused.append(f"{what}: fields not used: {', '.join(extra)}")
        # habitat-sim: base (root inertial frame) = instance transform; root link frame = base * inertial^-1
        T_i = np.eye(4)
        ine = robot.links[robot.root].inertial
        if ine is not None:
            T_i = ine.origin.copy()
            T_i[:3, 3] *= robot.scale * scale
        T = np.eye(4)
        T[:3, :3] = _quat_wxyz(inst.get("rotation"), scene)
        T[:3, 3] = np.asarray(inst.get("translation", [0.0, 0.0, 0.0]), dtype=float)
        root = T @ np.linalg.inv(T_i)
        sid = robot.semantic_id
        pieces.append({"id": iid, "label": _ao_label(name, sid, lexicon), "urdf": urdf, "name": name,
                       "position": (HAB_TO_MJ @ root[:3, 3]).tolist(),
                       "quat": mat_to_quat(HAB_TO_MJ @ root[:3, :3]).tolist(), "scale": scale})
        iid += 1
    return pieces


def _assign_rooms(pairs: list[tuple[Part, int]], meta: dict[int, dict[str, Any]], rooms: list[Room],
                  semantic: dict[str, Any]) -> None:
    """Set each instance's room (and floor) to the region containing its bounding-box centre (XY, within the extrusion)."""
    regions = semantic.get("region_annotations") or []
    by: dict[int, list[np.ndarray]] = {}
    for p, i in pairs:
        by.setdefault(i, []).append(p.vertices)
    for i, vs in by.items():
        v = np.concatenate(vs)
        c = (v.min(axis=0) + v.max(axis=0)) / 2
        if "room" in meta[i]:
            continue  # the input said it (glTF node extras)
        for room, r in zip(rooms, regions):
            h0 = float(r.get("floor_height", -np.inf))
            h1 = h0 + float(r.get("extrusion_height", np.inf))
            if h0 - 0.5 <= c[2] <= h1 + 0.5 and points_in_polygon(room.polygon, c[None, :2])[0]:
                meta[i]["room"], meta[i]["floor"] = room.id, room.floor
                break


__all__ = ["Reading", "dataset_members", "dataset_of", "input_files", "is_companion", "layout_of", "read_habitat",
           "scene_files", "read_house", "read_hm3d", "read_mp3d",
           "read_semantic_txt",
           "split_by_face_instance"]
