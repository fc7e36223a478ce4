"""Reading MJCF episode bundles: one folder per scene variant with its MJCF, episodes and navmap.

Layout read (exporters/mjcf_bundle writes it; the fixture builder in `tests/support/bundles.py` writes the same):

    <variant>/
      <name>.xml              scene + objects MJCF, loads from any cwd (asset paths relative to it)
      episodes.json           list of records.Episode (MuJoCo frame)
      oracle/                 the generator's artefacts: the environment and the gt detector read them,
                              agents only as declared oracles (`suite.boundary`)
        navmap*.json          records.NavMap (one per floor; floor 0 first)
        scene*.json           optional records.SceneAsset (instance labels, rooms)
        instance_labels.json  optional {"<instance id>": "<label>"} (used when no SceneAsset loads)
        object_labels.json    optional {"<segmentation id>": "<category>"} of every placed object
        relevance.json        optional records.Relevance (the table that drove placement)
        region_map*.json      optional records.RegionMap
(Bundles written before the oracle/ folder hold the same files beside episodes.json; they load too.)

Bundle version 4 (``bundle.json`` with ``"bundle_version": 4``) names its files instead: ``episodes.json`` holds
``EpisodeRef`` rows whose goals live once in ``goals.npz`` (`suite.goals`), and the scene-level oracle files
(``navmaps``, ``region_maps`` as records.save_npz shards, ``instance_labels``, ``relevance``) may live in the
dataset's ``../oracle/<scene>/``, shared by every variant of the scene; ``object_labels`` stays in the
bundle's ``oracle/``. Paths in bundle.json are relative to the bundle folder. Version 5 adds the dataset's
vocabulary to the dataset's ``index.json`` (its bundles are laid out as version 4's).

A dataset is a folder of such variant folders (or one variant folder itself).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..records import Episode, NavMap, RecordError, RegionMap, Relevance, SceneAsset, load_json, load_npz
from ..runview import RunLayout
from .goals import unpack_episodes

EPISODES = "episodes.json"
BUNDLE_VERSION = 5  # the newest bundle layout this reader knows (exporters/mjcf_bundle writes it)


@dataclass
class Bundle:
    """One loaded variant folder."""

    root: Path
    mjcf: Path
    episodes: list[Episode]
    navmaps: list[NavMap]
    scene: SceneAsset | None = None
    relevance: Relevance | None = None
    region_maps: list[RegionMap] = field(default_factory=list)
    labels: dict[int, str] = field(default_factory=dict)
    object_labels: dict[int, str] = field(default_factory=dict)
    # The episodes' visibility definition (bundle.json "visibility": segmentation width, height in px, eta_gt);
    # empty for bundles written before it was recorded (the suite then uses the episodes config's defaults).
    visibility: dict[str, float] = field(default_factory=dict)
    # A day of a chain of days (bundle.json "day" and "sequence": the scene's days in order, the one before and
    # after): None and empty for a variant.
    day: int | None = None
    sequence: dict[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        """Return the variant's folder name."""
        return self.root.name

    def navmap(self, floor: int = 0) -> NavMap:
        """Return the navmap of a floor (the first one if the floor is unknown)."""
        for nm in self.navmaps:
            if nm.floor == floor:
                return nm
        return self.navmaps[0]

    def region_map(self, floor: int = 0) -> RegionMap | None:
        """Return the region map of a floor, if the bundle has one."""
        for rm in self.region_maps:
            if rm.floor == floor:
                return rm
        return self.region_maps[0] if self.region_maps else None

    def instance_labels(self) -> dict[int, str]:
        """Return scene instance id -> label from the scene record (empty without one)."""
        if self.scene is not None:
            return {int(i.id): i.label for i in self.scene.instances}
        return dict(self.labels)

    def detector_labels(self) -> dict[int, str]:
        """Return segmentation id -> label of everything the gt detector reports: scene instances and placed objects.

        Bundles without ``object_labels.json`` name only their goal objects.
        """
        from ..sim.model import object_segment_id

        objects = dict(self.object_labels) or {object_segment_id(g.object_id): g.category
                                               for e in self.episodes for g in e.goals}
        return {**self.instance_labels(), **objects}

    def categories(self) -> list[str]:
        """Return the sorted goal categories of the episodes."""
        return sorted({e.object_category for e in self.episodes})


def find_bundles(root: str | Path) -> list[Path]:
    """Return the variant folders under a dataset folder (sorted), or the folder itself."""
    root = Path(root)
    if not root.is_dir():
        raise InputError(root, "dataset folder not found")
    if RunLayout.is_run(root):  # a run folder: its MJCF export
        if not (root / RunLayout.export_dir("mjcf")).is_dir():
            raise InputError(root, "is a run folder without an MJCF export (export/mjcf): run "
                                   f"`sdovon-mj export {root} --format mjcf --out DIR` and evaluate DIR")
        root = root / RunLayout.export_dir("mjcf")
    if (root / EPISODES).exists():
        return [root]
    found = sorted(p.parent for p in root.rglob(EPISODES))
    if not found:
        raise InputError(root, f"no {EPISODES} under this folder: not an MJCF episode bundle")
    return found


def _load(path: Path, cls: type):
    try:
        return load_json(path, cls)
    except (RecordError, json.JSONDecodeError) as e:
        raise InputError(path, f"not a valid {cls.__name__} file ({e})") from None


def _find_mjcf(root: Path) -> Path:
    xmls = sorted(p for p in root.glob("*.xml") if p.is_file())
    if not xmls:
        raise InputError(root, "no MJCF (*.xml) in this bundle folder")
    for pref in (f"{root.name}.xml", "scene.xml", "variant.xml", "model.xml"):
        for p in xmls:
            if p.name == pref:
                return p
    for p in xmls:
        head = p.read_text(encoding="utf-8", errors="replace")[:2000]
        if "<mujoco" in head and "<worldbody" in p.read_text(encoding="utf-8", errors="replace"):
            return p
    return xmls[0]


def _bundle_meta(root: Path) -> dict | None:
    """Return a bundle's bundle.json (None without one); InputError when malformed or newer than this reader."""
    path = root / "bundle.json"
    if not path.is_file():
        return None
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise InputError(path, f"not valid JSON ({e})") from None
    if not isinstance(meta, dict):
        raise InputError(path, "expected a JSON object")
    version = meta.get("bundle_version", 0)
    if not isinstance(version, int) or version > BUNDLE_VERSION:
        raise InputError(path, f"bundle_version {version!r} is newer than this reader knows ({BUNDLE_VERSION}): "
                               "update sdovon-mj or export the run again")
    return meta


def _named(root: Path, meta: dict, key: str, label: str = "") -> Path | None:
    """Return the file a v4 bundle.json names under `key` (relative to the bundle; None when absent or empty)."""
    rel = meta.get(key) or None
    if rel is None:
        return None
    p = (root / str(rel)).resolve()
    if not p.is_file():
        shared = "" if p.is_relative_to(root) else (
            " (a scene file shared by the dataset: keep the dataset folder together, or make the bundle "
            "self-contained with `sdovon-mj export BUNDLE --standalone` before copying it alone)")
        raise InputError(p, f"file named by {root / 'bundle.json'} ('{label or key}') not found{shared}")
    return p


def _load_maps(paths: list[Path], cls: type) -> list:
    """Load NavMap / RegionMap records from JSON files or save_npz shards."""
    out = []
    for p in paths:
        if p.suffix == ".npz":
            try:
                recs = load_npz(p)
            except RecordError as e:
                raise InputError(p, f"not a valid {cls.__name__} file ({e})") from None
            if not all(isinstance(r, cls) for r in recs):
                raise InputError(p, f"expected {cls.__name__} records")
        else:
            rec = _load(p, cls)
            recs = rec if isinstance(rec, list) else [rec]
        out.extend(recs)
    return sorted(out, key=lambda m: m.floor)


def _visibility(root: Path, meta: dict) -> dict[str, float]:
    """Return bundle.json's visibility definition (width, height, eta_gt), checked; empty when absent."""
    vis = meta.get("visibility")
    if vis is None:
        return {}
    ok = isinstance(vis, dict) and all(isinstance(vis.get(k), (int, float)) and vis[k] > 0 for k in ("width", "height", "eta_gt"))
    if not ok or vis["eta_gt"] > 1:
        raise InputError(root / "bundle.json", f"'visibility' must hold positive width, height (px) and eta_gt <= 1, got {vis!r}")
    return {"width": int(vis["width"]), "height": int(vis["height"]), "eta_gt": float(vis["eta_gt"])}


def _load_v4(root: Path, meta: dict) -> Bundle:
    """Load a version-4 bundle: the files its bundle.json names (some shared per scene in the dataset)."""
    goals = _named(root, meta, "goals")
    episodes = unpack_episodes(root / str(meta.get("episodes") or EPISODES), goals)
    navs = {}
    for key in ("navmaps", "region_maps"):
        table = meta.get(key) or {}
        if not isinstance(table, dict):
            raise InputError(root / "bundle.json", f"'{key}' must map floor -> file")
        navs[key] = [p for k in sorted(table, key=str) if (p := _named(root, table, k, f"{key}.{k}")) is not None]
    if not navs["navmaps"]:
        raise InputError(root / "bundle.json", "names no navmaps (records.NavMap, one per floor)")
    rel = _named(root, meta, "relevance")
    labels_p, objects_p = _named(root, meta, "instance_labels"), _named(root, meta, "object_labels")
    model = root / str(meta.get("model") or "")
    return Bundle(root, model if meta.get("model") and model.is_file() else _find_mjcf(root), episodes,
                  _load_maps(navs["navmaps"], NavMap), None,
                  _load(rel, Relevance) if rel is not None else None, _load_maps(navs["region_maps"], RegionMap),
                  _labels(labels_p) if labels_p else {}, _labels(objects_p) if objects_p else {},
                  _visibility(root, meta), int(meta["day"]) if meta.get("day") is not None else None,
                  dict(meta.get("sequence") or {}))


def load_bundle(path: str | Path) -> Bundle:
    """Load one variant folder: MJCF path, episodes, navmaps and optional semantics (every bundle version)."""
    root = Path(path).resolve()
    ep_path = root / EPISODES
    if not ep_path.exists():
        raise InputError(root, f"bundle folder lacks {EPISODES}")
    meta = _bundle_meta(root)
    if meta is not None and meta.get("bundle_version", 0) >= 4:
        return _load_v4(root, meta)
    episodes = _load(ep_path, Episode)
    if not isinstance(episodes, list):
        raise InputError(ep_path, "expected a list of Episode records")
    odir = root / "oracle" if (root / "oracle").is_dir() else root
    nav_paths = sorted(odir.glob("navmap*.json")) or sorted(odir.glob("*navmap*.json"))
    if not nav_paths:
        raise InputError(root, "bundle folder lacks an oracle/navmap*.json (records.NavMap)")
    navmaps = []
    for p in nav_paths:
        nm = _load(p, NavMap)
        navmaps.extend(nm if isinstance(nm, list) else [nm])
    navmaps.sort(key=lambda n: n.floor)
    scene = None
    for p in sorted(odir.glob("scene*.json")):
        try:
            scene = load_json(p, SceneAsset)
            break
        except (RecordError, json.JSONDecodeError, TypeError, ValueError):
            continue
    relevance = None
    for p in (odir / "relevance.json", root.parent / "relevance.json"):
        if p.exists():
            relevance = _load(p, Relevance)
            break
    region_maps: list[RegionMap] = []
    for p in sorted(odir.glob("region_map*.json")):
        rm = _load(p, RegionMap)
        region_maps.extend(rm if isinstance(rm, list) else [rm])
    labels, objects = _labels(odir / "instance_labels.json"), _labels(odir / "object_labels.json")
    return Bundle(root, _find_mjcf(root), episodes, navmaps, scene, relevance, region_maps, labels, objects)


def _labels(path: Path) -> dict[int, str]:
    """Read a {"<id>": "<label>"} file ({} when absent; InputError naming a malformed one)."""
    if not path.exists():
        return {}
    try:
        return {int(k): str(v) for k, v in json.loads(path.read_text(encoding="utf-8")).items()}
    except (json.JSONDecodeError, ValueError, AttributeError) as e:
        raise InputError(path, f"expected a JSON object of id -> label ({e})") from None
