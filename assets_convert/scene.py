"""convert_scene: a scene file -> visual-only MJCF that keeps semantic instances.

Output ``<out_dir>/scenes/<name>/``: ``scene.xml``, ``asset.json`` (SceneAsset), ``scene_mesh.npz``
(the merged Z-up metre mesh with per-face instance ids) and ``assets/``. Every geom is visual only
(contype = conaffinity = 0, mesh inertia shell); instance k's geoms are ``inst_<k>`` / ``inst_<k>_<j>``
(one per material), group 0, ceilings group 1.

Semantics, first found wins: the ``semantics`` argument (a sidecar path), ``<stem>.semantics.json``
beside the file (our default world), ``placements.json`` beside a glTF room (Drake-style furnished
room: shell nodes plus placed furniture), ScanNet's ``*.segs.json`` + ``*.aggregation.json``, else its
``.labels.ply`` (NYU40 classes), for PLY scans (`scannet`: ``<scene>.txt``'s axisAlignment applied too), else one
instance per mesh node labelled from its node name (a PLY scan then says in `SceneAsset.unused` which files it
looked for).
"""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import numpy as np

from sdovon_mj.errors import InputError
from sdovon_mj.naming import scene_name, scene_stem
from sdovon_mj.records import Floor, Room, SceneAsset, SemanticInstance, SupportSurface
from sdovon_mj.sim.model import instance_geom_name, save_scene_mesh
from sdovon_mj.store import atomic_write_text

from sdovon_mj.config import ConvertConfig

from . import articulated_scene, cache, habitat, scannet
from .metadata import AssetMeta, meta_for, receptacle_flag
from .load import Material, Part, display_path, gpu_texture_key, load_mesh, read_json as _read_json, referenced_files
from .naming import LABEL_RULES, PRIMITIVES, label_from_node, sanitize  # noqa: F401 (re-exported)
from .writer import AssetWriter, clean_part, fmt, render_template, xml_attr


FLOOR_MARGIN = 0.5  # m around the footprint of an added floor: an agent (radius ~0.2 m) can walk round the scene's edge
def _sidecar_for(path: Path) -> Path | None:
    """Return `<stem>.semantics.json` beside a scene file (`naming.scene_stem`: without ScanNet suffixes)."""
    p = path.parent / f"{scene_stem(path)}.semantics.json"
    return p if p.is_file() else None


def _rpy_matrix(rpy_deg: list[float]) -> np.ndarray:
    """Return R = Rz(yaw) Ry(pitch) Rx(roll) (Drake's rpy convention)."""
    r, p, y = np.radians(np.asarray(rpy_deg, dtype=float))
    rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    return rz @ ry @ rx


def _placements_parts(path: Path, placements: Path, units: str, up: str) -> tuple[list[tuple[Part, int]], list[dict], list[Path]]:
    """Load a Drake-style furnished room: every placed asset's parts, posed, with instance ids."""
    doc = _read_json(placements)
    items = doc.get("instances", [])
    # asset paths are relative to the assets root: find the ancestor that holds the first one
    root = None
    for anc in [placements.parent, *placements.parents]:
        if items and (anc / items[0].get("asset", "")).is_file():
            root = anc
            break
    if root is None:
        raise InputError(display_path(placements), "cannot resolve the asset paths it lists")
    out: list[tuple[Part, int]] = []
    insts: list[dict] = []
    files: list[Path] = [placements]
    for item in items:
        apath = root / item["asset"]
        mesh = load_mesh(apath, units=units, up=up, kind="scene")
        files.extend(mesh.files)
        rot = _rpy_matrix(item.get("rpy_deg", [0, 0, 0]))
        t = np.asarray(item.get("translation", [0, 0, 0]), dtype=float)
        structural = item.get("object_id") is None
        for p in mesh.parts:
            p.vertices = p.vertices @ rot.T + t
        if structural:  # room shell and curtains: one instance per node
            by_node: dict[str, list[Part]] = {}
            for p in mesh.parts:
                by_node.setdefault(p.node, []).append(p)
            for node in sorted(by_node):
                iid = len(insts)
                label = label_from_node(node)
                m = re.search(r"floor|ceiling|window|glass", by_node[node][0].material.name.lower())
                if m and re.search(r"_[0-9a-f]{6}$", node):  # a node split per material: its material names it
                    label = {"glass": "window"}.get(m.group(0), m.group(0))
                insts.append({"id": iid, "label": label, "kind": "structure", "name": f"{item['name']}/{node}"})
                out.extend((p, iid) for p in by_node[node])
        else:
            iid = len(insts)
            insts.append({"id": iid, "label": str(item.get("name", "object")).replace("_", " "), "kind": "furniture",
                          "name": item["name"], "object_id": item.get("object_id", "")})
            out.extend((p, iid) for p in mesh.parts)
    return out, insts, files


def _node_instance_id(node: str) -> int | None:
    """Return k for a node named 'instance_<k>'."""
    m = re.match(r"^instance_(\d+)(?:_[0-9a-f]{6})?$", node)  # trimesh suffixes multi-primitive nodes
    return int(m.group(1)) if m else None


def convert_scene(path: str | Path, out_dir: str | Path, name: str | None = None, units: str | float = "auto",
                  up: str = "auto", semantics: str | Path | None = None, texture_max_size: int = 1024,
                  cache_dir: str | Path | None = None, add_floor: bool = False) -> SceneAsset:
    """Convert a scene mesh to visual-only MJCF at `<out_dir>/scenes/<name>/scene.xml`; return its SceneAsset.

    Parameters
    ----------
    path : str or Path
        Scene mesh file (GLB/glTF, OBJ, PLY with optional ScanNet files).
    out_dir : str or Path
        Output root; the scene goes to ``<out_dir>/scenes/<name>/``.
    name : str, optional
        Scene name (default: `naming.scene_name` of the file: its stem without format and dataset suffixes).
    units : str or float
        "auto", a unit name or metres per file unit (the sidecar's when "auto").
    up : str
        The file's up axis (the sidecar's when "auto").
    semantics : str or Path, optional
        Semantics sidecar (default: ``<stem>.semantics.json`` beside the file).
    texture_max_size : int
        Largest texture side kept, pixels.
    cache_dir : str or Path, optional
        Conversion cache folder (default: the user cache).
    add_floor : bool
        Add a ground slab (instance labelled "floor") under the scene's footprint plus `FLOOR_MARGIN`, its top at
        the scene's lowest point: for scenes modelled without a floor (an artist kitchen, a furniture set).
    """
    path = Path(path)
    out_dir = Path(out_dir)
    layout = habitat.layout_of(path)
    files = habitat.input_files(path) if layout else referenced_files(path)
    meta = meta_for(path)  # assets.yaml / <file>.yaml: wins over run-wide defaults
    files += meta.sources
    if str(units) == "auto" and (meta.units is not None or meta.scale != 1.0):
        units = meta.units_value("auto" if meta.units is None else meta.units)
    if up == "auto" and meta.up is not None:
        up = meta.up
    if meta.add_floor is not None:
        add_floor = meta.add_floor
    name = sanitize(name) if name else scene_name(path)
    sidecar_path = Path(semantics) if semantics else (None if layout else _sidecar_for(path))
    placements = path.parent / "placements.json"
    sidecar = _read_json(sidecar_path) if sidecar_path else None
    if sidecar is not None:
        files.append(sidecar_path)  # type: ignore[arg-type]
        if up == "auto" and sidecar.get("up"):
            up = str(sidecar["up"])
        if str(units) == "auto" and sidecar.get("units"):
            units = str(sidecar["units"])
    scan = scannet.scan_files(path) if not layout else scannet.ScanFiles()
    art_sidecar = None if layout else articulated_scene.sidecar_for(path)  # world.articulated pieces (URDF)
    if art_sidecar is not None:
        files += articulated_scene.input_files(path)
    use_placements = sidecar is None and not layout and placements.is_file() and _lists_asset(placements, path)
    if use_placements:
        files.append(placements)
    files.extend(scan.inputs())
    params = {"kind": "scene", "name": name, "units": str(units), "up": up, "texture_max_size": texture_max_size,
              "placements": use_placements}
    if layout:
        params["layout"] = layout  # only then: the keys of other scenes stay as they were
    if add_floor:
        params["add_floor"] = FLOOR_MARGIN
    params.update(gpu_texture_key(files))
    if scan.labels is not None and scan.segments is None:
        params["nyu40"] = scannet.SPECK_AREA  # instances from the labels mesh: its rule's one parameter
    if scan.meta is not None:
        params["axis_alignment"] = True
    if sidecar is None and scan.segments is None:
        params["labels"] = LABEL_RULES  # node-name labels: a new rule must not hit a cached scene labelled by the old
    key = cache.cache_key(files if not use_placements else files + _placement_files(placements), params)
    root = cache.cache_root(cache_dir)
    target = out_dir / "scenes" / name
    hit = cache.lookup(root, key)
    if hit is not None:
        cache.link_tree(hit, target)
        return _relocate(SceneAsset.from_json((target / "asset.json").read_text(encoding="utf-8")), name)
    tmp = cache.scratch_dir(target)
    try:
        reading = None
        if layout == "hm3d":
            reading = habitat.read_hm3d(path, units, up)
        elif layout == "mp3d":
            reading = habitat.read_mp3d(path, units, up)
        elif layout == "habitat":
            reading = habitat.read_habitat(path)
        asset = _build_scene(path, tmp, name, units, up, sidecar, scan, placements if use_placements else None,
                             texture_max_size, reading, add_floor, meta, None if root is None else root / "textures")
        if art_sidecar is not None:
            asset = articulated_scene.add_articulated(tmp, path, asset, art_sidecar,
                                                      ConvertConfig(texture_max_size=texture_max_size), cache_dir)
        elif reading is not None and reading.articulated:  # a dataset's articulated objects (Habitat URDF furniture)
            asset = articulated_scene.add_articulated(tmp, path, asset, reading.articulated,
                                                      ConvertConfig(texture_max_size=texture_max_size), cache_dir)
        asset.content_hash = key
        atomic_write_text(tmp / "asset.json", asset.to_json())
        cache.store(root, key, tmp)
        cache.replace_dir(tmp, target)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return _relocate(asset, name)


CONVERTED_RECORDS = ("asset.json", "scene.json")  # what marks a converted scene's folder (convert output; a run's)
RUN_STAGE_DIRS = ("convert", "observe", "perceive", "semantics", "variants")  # a run's later stages, not the scene


def converted_record(folder: str | Path) -> Path | None:
    """Return the SceneAsset record that makes a folder a converted scene (``asset.json``, else a run's
    ``scene.json``), or None: the folder is recognised by that record, never by the files beside it."""
    for name in CONVERTED_RECORDS:
        p = Path(folder) / name
        if p.is_file():
            return p
    return None


def converted_scenes(folder: str | Path) -> list[Path]:
    """Return the converted scene folders a folder stands for: itself when it is one, the ``scenes/<name>/``
    folders of a convert output or run folder, else []."""
    folder = Path(folder)
    if converted_record(folder) is not None:
        return [folder]
    scenes = folder / "scenes"
    return sorted(d for d in scenes.iterdir() if d.is_dir() and converted_record(d) is not None) \
        if scenes.is_dir() else []


def read_converted(folder: str | Path) -> SceneAsset:
    """Return the SceneAsset of a converted scene folder; raise InputError naming what is missing or unreadable."""
    folder = Path(folder)
    record = converted_record(folder)
    if record is None:
        raise InputError(display_path(folder), "not a converted scene: no asset.json or scene.json in it")
    try:
        asset = SceneAsset.from_json(record.read_text(encoding="utf-8"))
    except Exception as e:  # noqa: BLE001 - a damaged or foreign record is a bad input
        raise InputError(display_path(record), f"not a SceneAsset record: {type(e).__name__}: {e}") from None
    for rel in (asset.mjcf, asset.mesh):
        p = folder / Path(rel).name
        if not p.is_file():
            raise InputError(display_path(folder), f"converted scene is incomplete: {Path(rel).name} is missing")
    return asset


def converted_files(folder: str | Path) -> list[Path]:
    """Return the files that identify a converted scene (record, MJCF, mesh sidecar) for fingerprints; the record's
    ``content_hash`` is the conversion's cache key, which covers its inputs (textures and meshes under assets/)."""
    folder = Path(folder)
    asset = read_converted(folder)
    return [p for p in (converted_record(folder), folder / Path(asset.mjcf).name, folder / Path(asset.mesh).name) if p]


def link_converted(folder: str | Path, out_dir: str | Path, name: str) -> SceneAsset:
    """Use a converted scene folder as it is: hard-link (else copy) its conversion files into
    ``<out_dir>/scenes/<name>/`` (a run's later stage folders left out) and return its SceneAsset there."""
    folder = Path(folder)
    asset = read_converted(folder)
    target = Path(out_dir) / "scenes" / name
    if folder.resolve() != target.resolve():
        tmp = cache.scratch_dir(target)

        def _link(s: str, d: str) -> None:
            try:
                os.link(s, d)
            except OSError:
                shutil.copy2(s, d)

        try:
            shutil.copytree(folder, tmp, copy_function=_link, dirs_exist_ok=True,
                            ignore=shutil.ignore_patterns(cache.ENTRY, "scene.json", ".*", *RUN_STAGE_DIRS))
            cache.replace_dir(tmp, target)
        finally:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)
    asset.name = name
    return _relocate(asset, name)


def check_scene(path: str | Path) -> None:
    """Check a scene input before any conversion: every file it references exists and parses as its format (JSON,
    glTF headers and buffers, HM3D ``.semantic.txt``, Matterport ``.house``, a ScanNet scan's segments, labels
    header and axisAlignment); raise InputError naming the first
    file that does not. A converted scene folder must hold its record, MJCF and mesh sidecar. Mesh contents are
    read by the conversion itself (a corrupt triangle list fails that scene's task, not the run)."""
    path = Path(path)
    if path.is_dir():
        read_converted(path)
        return
    layout = habitat.layout_of(path)
    if layout == "habitat":
        habitat.scene_files(path)
    elif layout == "hm3d":
        base = habitat._hm3d_base(path)
        referenced_files(path)
        sem = Path(f"{base}.semantic.glb")
        if not sem.is_file():
            raise InputError(display_path(sem), "missing: an HM3D scene needs its .semantic.glb beside the .glb")
        referenced_files(sem)
        habitat.read_semantic_txt(Path(f"{base}.semantic.txt"))
    elif layout == "mp3d":
        base = path.parent / path.stem
        referenced_files(path)
        if not Path(f"{base}_semantic.ply").is_file():
            raise InputError(display_path(Path(f"{base}_semantic.ply")), "missing: a Matterport3D scene needs its "
                                                                         "_semantic.ply beside the .glb")
        habitat.read_house(Path(f"{base}.house"))
    else:
        referenced_files(path)
        sidecar = _sidecar_for(path)
        if sidecar is not None:
            _read_json(sidecar)
        if articulated_scene.sidecar_for(path) is not None:
            articulated_scene.input_files(path)
        scannet.check(scannet.scan_files(path))  # a ScanNet scan's segments, labels header, axisAlignment
    meta_for(path)  # assets.yaml / <file>.yaml parse


def floor_slab(vertices: np.ndarray, margin: float | None = None, thickness: float = 0.05) -> Part:
    """Return a box slab under the XY footprint of `vertices` grown by `margin` (default `FLOOR_MARGIN`), top at their lowest z."""
    margin = FLOOR_MARGIN if margin is None else margin
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    x0, y0, x1, y1 = lo[0] - margin, lo[1] - margin, hi[0] + margin, hi[1] + margin
    z1, z0 = lo[2], lo[2] - thickness
    v = np.array([[x, y, z] for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)], dtype=np.float64)
    f = np.array([[4, 5, 7], [4, 7, 6], [0, 2, 3], [0, 3, 1], [0, 1, 5], [0, 5, 4], [2, 6, 7], [2, 7, 3],
                  [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]], dtype=np.int64)
    return Part(v, f, Material("added_floor", (0.55, 0.53, 0.5, 1.0), None, "added_floor"), None, None, "added_floor")


def _relocate(asset: SceneAsset, name: str) -> SceneAsset:
    """Make the asset's paths relative to the output folder."""
    asset.mjcf = f"scenes/{name}/scene.xml"
    asset.mesh = f"scenes/{name}/scene_mesh.npz"
    for fx in asset.articulated:  # world.articulated pieces: converted under the scene's folder
        fx.model = f"scenes/{name}/articulated/objects/art_{fx.instance_id}/model.xml"
    return asset


def _lists_asset(placements: Path, path: Path) -> bool:
    """Return whether a placements.json lists this file as its first (room) asset."""
    try:
        items = json.loads(placements.read_text(encoding="utf-8")).get("instances", [])
    except (OSError, json.JSONDecodeError, AttributeError):
        return False
    return bool(items) and Path(items[0].get("asset", "")).name == path.name


def _placement_files(placements: Path) -> list[Path]:
    """Return every file a placements.json pulls in (for the cache key)."""
    try:
        _parts, _insts, files = _placements_parts_files_only(placements)
    except InputError:
        return []
    return files


def _placements_parts_files_only(placements: Path) -> tuple[None, None, list[Path]]:
    """Return the referenced files of a placements.json without loading meshes."""
    doc = _read_json(placements)
    items = doc.get("instances", [])
    for anc in [placements.parent, *placements.parents]:
        if items and (anc / items[0].get("asset", "")).is_file():
            files: list[Path] = []
            for it in items:
                files.extend(referenced_files(anc / it["asset"]))
            return None, None, files
    raise InputError(display_path(placements), "cannot resolve the asset paths it lists")


def _build_scene(path: Path, work: Path, name: str, units: str | float, up: str, sidecar: dict | None,
                 scan: scannet.ScanFiles, placements: Path | None, texture_max_size: int,
                 reading: habitat.Reading | None = None, add_floor: bool = False,
                 asset_meta: AssetMeta | None = None, texture_cache: Path | None = None) -> SceneAsset:
    """Load, group by instance and material, and write one scene into folder `work` (`reading`: a dataset reader's).

    `asset_meta` (the file's assets.yaml metadata) may force or forbid instances as receptacles (`receptacle`, `nodes`).
    """
    inst_meta: dict[int, dict] = {}
    pairs: list[tuple[Part, int]] = []
    unused: list[str] = []
    if reading is not None:
        pairs, inst_meta = reading.pairs, dict(reading.meta)
    elif placements is not None:
        pairs, insts, _files = _placements_parts(path, placements, str(units), up)
        inst_meta = {d["id"]: d for d in insts}
    else:
        mesh = load_mesh(path, units=units, up=up, kind="scene")
        scan_pairs, inst_meta, unused = scannet.read_scan(mesh, scan)
        if scan_pairs is not None:
            pairs = scan_pairs
        else:
            if sidecar is None and path.suffix.lower() == ".ply":  # a scan without labels: say what was looked for
                unused.append(scannet.looked_for(path))
            node_ids: dict[str, int] = {}
            for p in mesh.parts:
                iid = _node_instance_id(p.node)
                if iid is None:
                    iid = node_ids.setdefault(p.node, 10**6 + len(node_ids))
                pairs.append((p, iid))
            # nodes without ids get the next free ids in node order
            taken = {i for _p, i in pairs if i < 10**6}
            nxt = (max(taken) + 1) if taken else 0
            remap = {}
            for node, tmp_id in sorted(node_ids.items(), key=lambda kv: kv[1]):
                remap[tmp_id] = nxt
                inst_meta[nxt] = {"id": nxt, "label": label_from_node(node), "kind": "", "name": node}
                nxt += 1
            pairs = [(p, remap.get(i, i)) for p, i in pairs]
            for p, i in pairs:
                inst_meta.setdefault(i, {"id": i, "label": label_from_node(p.node), "kind": "", "name": p.node})
    if sidecar is not None:
        for d in sidecar.get("instances", []):
            inst_meta[int(d["id"])] = {**inst_meta.get(int(d["id"]), {}), **d}
    if not pairs:
        raise InputError(display_path(path), "no triangles in the scene")
    if add_floor:
        slab = floor_slab(np.concatenate([p.vertices for p, _i in pairs]))
        iid = max(max(i for _p, i in pairs), max(inst_meta, default=-1)) + 1
        inst_meta[iid] = {"id": iid, "label": "floor", "kind": "structure", "name": "added_floor"}
        pairs = [*pairs, (slab, iid)]

    writer = AssetWriter(work / "assets", texture_max_size, texture_cache)
    geoms: list[str] = []
    by_inst: dict[int, list[Part]] = {}
    for p, iid in pairs:
        by_inst.setdefault(iid, []).append(p)
    all_v: list[np.ndarray] = []
    all_f: list[np.ndarray] = []
    all_i: list[np.ndarray] = []
    nv = 0
    instances: list[SemanticInstance] = []
    for iid in sorted(by_inst):
        groups: dict[str, list[Part]] = {}
        for p in by_inst[iid]:
            groups.setdefault(p.material.key, []).append(p)
        parts = []
        for items in groups.values():
            from .writer import merge_parts

            merged = merge_parts(items)[0] if len(items) > 1 else items[0]
            cp = clean_part(merged)
            if cp is not None:
                parts.append(cp)
        if not parts:
            continue
        meta = inst_meta.get(iid, {})
        label = str(meta.get("label", "object"))
        ceiling = "ceiling" in label.lower() or meta.get("kind") == "ceiling"
        cls = "ceiling" if ceiling else "scene"
        gnames = []
        for j, p in enumerate(parts):
            gname = instance_geom_name(iid) if len(parts) == 1 else instance_geom_name(iid, j)
            textured = p.material.image is not None and p.uv is not None
            mat = writer.material(p.material, textured)
            vm, uvm = p.vertices, p.uv
            if len(vm) < 4:  # MuJoCo compiles no mesh of under 4 vertices (a scan instance of one triangle): the
                vm = np.concatenate([vm, vm[:4 - len(vm)]])  # MJCF mesh repeats its first vertex, no face uses it
                uvm = None if uvm is None else np.concatenate([uvm, uvm[:4 - len(uvm)]])
            writer.mesh(gname, vm, p.faces, uvm if textured else None, ' inertia="shell"')
            geoms.append(f'    <geom name="{gname}" class="{cls}" mesh="{gname}" material="{mat}"/>')
            gnames.append(gname)
            all_v.append(p.vertices)
            all_f.append(p.faces + nv)
            all_i.append(np.full(len(p.faces), iid, dtype=np.int64))
            nv += len(p.vertices)
        v = np.concatenate([p.vertices for p in parts])
        flag = None if asset_meta is None or meta.get("name") == "added_floor" else \
            receptacle_flag(asset_meta, str(meta.get("name", "")), label)
        instances.append(SemanticInstance(id=int(iid), label=label, geoms=gnames, room=int(meta.get("room", -1)),
                                          floor=int(meta.get("floor", -1)), kind=str(meta.get("kind", "")),
                                          bounds=np.stack([v.min(axis=0), v.max(axis=0)]), receptacle=flag))
    V = np.concatenate(all_v)
    F = np.concatenate(all_f)
    FI = np.concatenate(all_i)
    lo, hi = V.min(axis=0), V.max(axis=0)
    centre = (lo + hi) / 2
    extent = float(np.linalg.norm(hi - lo) / 2)
    znear = max(0.01 / max(extent, 1e-6), 1e-4)
    zfar = max(50.0, 4.0 * float(np.linalg.norm(hi - lo)) / max(extent, 1e-6))
    lights = _lights(lo, hi)
    render_template("scene.xml", work / "scene.xml", name=name, extent=fmt([extent]), center=fmt(centre),
                    znear=fmt([znear]), zfar=fmt([zfar]), assets=writer.xml, lights=lights, geoms="\n".join(geoms))
    _check_compiles(work / "scene.xml", display_path(path))
    save_scene_mesh(work / "scene_mesh.npz", V, F, FI)
    floors: list[Floor] = []
    rooms: list[Room] = []
    supports: list[SupportSurface] = []
    if sidecar is not None:
        floors = [Floor(index=int(f["index"]), height=float(f["height"]), area=float(f.get("area", 0.0)))
                  for f in sidecar.get("floors", [])]
        rooms = [Room(id=int(r["id"]), type=str(r["type"]), floor=int(r.get("floor", 0)),
                      polygon=np.asarray(r["polygon"], dtype=np.float64)) for r in sidecar.get("rooms", [])]
        for d in sidecar.get("instances", []):
            for s in d.get("support_surfaces", []):
                supports.append(SupportSurface(instance_id=int(d["id"]), height=float(s["height"]),
                                               polygon=np.asarray(s["polygon"], dtype=np.float64)))
        for s in sidecar.get("support_surfaces", []):
            supports.append(SupportSurface(instance_id=int(s["instance_id"]), height=float(s["height"]),
                                           polygon=np.asarray(s["polygon"], dtype=np.float64)))
    if reading is not None:
        rooms = list(reading.rooms)
        unused = list(reading.unused)
    return SceneAsset(name=name, mjcf="scene.xml", source=display_path(path), floors=floors, instances=instances,
                      bounds=np.stack([lo, hi]), rooms=rooms, support_surfaces=supports, mesh="scene_mesh.npz",
                      unused=unused)


def _lights(lo: np.ndarray, hi: np.ndarray) -> str:
    """Return two directional lights (no shadows) for a scene box, so renders are lit."""
    c = (lo + hi) / 2
    z = hi[2] + 1.0
    return (f'    <light name="sun" directional="true" pos="{fmt([c[0], c[1], z])}" dir="-0.3 -0.2 -1" '
            f'diffuse="0.55 0.55 0.55" specular="0.1 0.1 0.1" castshadow="false"/>\n'
            f'    <light name="fill" directional="true" pos="{fmt([c[0], c[1], z])}" dir="0.3 0.3 -1" '
            f'diffuse="0.25 0.25 0.25" specular="0 0 0" castshadow="false"/>')


def _check_compiles(xml: Path, where: str) -> None:
    """Compile the written scene once; raise InputError naming the input when MuJoCo refuses it."""
    import mujoco

    try:
        mujoco.MjModel.from_xml_path(str(xml))
    except Exception as e:  # noqa: BLE001
        raise InputError(where, f"converted scene does not compile in MuJoCo: {e}") from None


__all__ = ["check_scene", "convert_scene", "converted_files", "converted_record", "converted_scenes", "label_from_node", "link_converted",
           "read_converted", "xml_attr"]
