"""The exporter interface: a read-only view over a run folder, an export report, and the output-folder policy.

Run folder layout (paths inside records are relative to the run root)::

    <run>/scenes/<scene>/scene.json                            SceneAsset (+ its asset files)
    <run>/scenes/<scene>/observe/navmap_<floor>.json           NavMap, one per floor
    <run>/scenes/<scene>/semantics/relevance.json              Relevance (optional)
    <run>/scenes/<scene>/semantics/regions_<floor>.json        RegionMap, one per floor (optional)
    <run>/scenes/<scene>/variants/<variant>/variant.json       SceneVariant (its .mjcf: composed MJCF)
    <run>/scenes/<scene>/variants/<variant>/episodes.json      list[Episode]
    <run>/objects/<name>/object.json                           ObjectAsset (+ its asset files)

Output-folder policy (applied by ``prepare_out_dir`` for every exporter, built-in or plugin):
every export records itself in ``<out>/sdovon_export.json`` as {format, name, split, run_id}.

- an empty or missing folder: export;
- a non-empty folder without that manifest: **refuse** (it holds something we did not write);
- the manifest already lists the same format and dataset name from the **same run** (same
  ``run_id``, a digest of the run's records): re-export, replacing that dataset's files;
- the same format and dataset name from **another run**: **refuse** (that would mix two datasets);
- only other datasets (other names or formats): refuse unless ``merge=True``; with merge, the new
  dataset is added next to them under its own name (Habitat: its own ``data/scene_datasets/<name>``
  and ``data/datasets/objectnav/<name>``; MJCF: its own ``<out>/<name>/``). Nothing is ever mixed.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sdovon_mj.errors import InputError, SdovonError
from sdovon_mj.records import (Episode, NavMap, ObjectAsset, RecordError, RegionMap, Relevance, SceneAsset, SceneVariant,
                               load_json)
from sdovon_mj.store import atomic_write_text

MANIFEST = "sdovon_export.json"


class ExportError(SdovonError):
    """An export that cannot be written (e.g. the output folder holds another dataset)."""


@dataclass
class ExportOptions:
    """Options every exporter understands."""

    name: str = "sdovon"
    split: str = "val"
    merge: bool = False
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class ExportReport:
    """What an export wrote and what it skipped (with reasons)."""

    format: str
    out_dir: str
    name: str
    variants: list[str] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)  # variant -> reason
    episodes: int = 0
    files: list[str] = field(default_factory=list)  # relative to out_dir

    def summary(self) -> str:
        """Return a one-paragraph human summary."""
        lines = [f"{self.format}: {len(self.variants)} variants, {self.episodes} episodes, {len(self.files)} files -> {self.out_dir}"]
        for v, why in sorted(self.skipped.items()):
            lines.append(f"  skipped {v}: {why}")
        return "\n".join(lines)


def _load(path: Path, cls: type) -> Any:
    """Load a record file or raise InputError naming it."""
    if not path.exists():
        raise InputError(path, "missing")
    try:
        return load_json(path, cls)
    except RecordError as e:
        raise InputError(path, str(e)) from None


class RunView:
    """Read-only view of a run folder (layout in this module's docstring)."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root).resolve()
        if not (self.root / "scenes").is_dir():
            raise InputError(self.root, "not a run folder (no scenes/ inside)")

    def path(self, rel: str | Path) -> Path:
        """Return the absolute path of a run-relative path."""
        return self.root / Path(rel)

    def scene_names(self) -> list[str]:
        """Return the scene names (sorted)."""
        return sorted(p.parent.name for p in (self.root / "scenes").glob("*/scene.json"))

    def scenes(self) -> list[SceneAsset]:
        """Return every SceneAsset (sorted by name)."""
        return [self.scene(n) for n in self.scene_names()]

    def scene(self, name: str) -> SceneAsset:
        """Return one SceneAsset."""
        return _load(self.root / "scenes" / name / "scene.json", SceneAsset)

    def navmaps(self, scene: str) -> list[NavMap]:
        """Return a scene's NavMaps sorted by floor."""
        maps = [_load(p, NavMap) for p in sorted((self.root / "scenes" / scene / "observe").glob("navmap_*.json"))]
        return sorted(maps, key=lambda m: m.floor)

    def relevance(self, scene: str) -> Relevance | None:
        """Return a scene's relevance tables (None when the run has none)."""
        p = self.root / "scenes" / scene / "semantics" / "relevance.json"
        return _load(p, Relevance) if p.exists() else None

    def region_maps(self, scene: str) -> list[RegionMap]:
        """Return a scene's region maps sorted by floor ([] when the run has none)."""
        maps = [_load(p, RegionMap) for p in sorted((self.root / "scenes" / scene / "semantics").glob("regions_*.json"))]
        return sorted(maps, key=lambda m: m.floor)

    def variants(self, scene: str) -> list[SceneVariant]:
        """Return a scene's SceneVariants sorted by index."""
        vs = [_load(p, SceneVariant) for p in sorted((self.root / "scenes" / scene / "variants").glob("*/variant.json"))]
        return sorted(vs, key=lambda v: v.index)

    def all_variants(self) -> list[SceneVariant]:
        """Return every variant of every scene."""
        return [v for s in self.scene_names() for v in self.variants(s)]

    def variant_dir(self, variant: SceneVariant) -> Path:
        """Return the folder of a variant's records."""
        return self.root / "scenes" / variant.scene / "variants" / variant.name

    def episodes(self, variant: SceneVariant) -> list[Episode]:
        """Return a variant's episodes ([] when it has none or no episodes.json)."""
        p = self.variant_dir(variant) / "episodes.json"
        return _load(p, Episode) if p.exists() else []

    def objects(self) -> dict[str, ObjectAsset]:
        """Return every ObjectAsset by name."""
        return {p.parent.name: _load(p, ObjectAsset) for p in sorted((self.root / "objects").glob("*/object.json"))}

    def run_id(self) -> str:
        """Return a digest of the run's record files (identifies the run across exports)."""
        h = hashlib.sha256()
        for p in sorted(self.root.glob("scenes/*/scene.json")) + sorted(self.root.glob("scenes/*/variants/*/*.json")) + sorted(self.root.glob("objects/*/object.json")):
            h.update(p.relative_to(self.root).as_posix().encode())
            h.update(p.read_bytes())
        return h.hexdigest()[:20]


class Exporter:
    """Base of exporter plugins: sees records and the run folder only."""

    name: str = "base"

    def export(self, run: RunView, out_dir: Path, options: ExportOptions) -> ExportReport:
        """Write the run in this exporter's format under out_dir and report what was written."""
        raise NotImplementedError


def read_manifest(out_dir: Path) -> list[dict[str, str]] | None:
    """Return the export manifest entries of a folder (None when it has none)."""
    p = Path(out_dir) / MANIFEST
    if not p.exists():
        return None
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
        return list(data["exports"])
    except (json.JSONDecodeError, KeyError, TypeError) as e:
        raise InputError(p, f"corrupt export manifest ({e})") from None


def prepare_out_dir(out_dir: Path, fmt: str, name: str, split: str, run_id: str, merge: bool = False) -> None:
    """Apply the output-folder policy (module docstring); raise ExportError when the export must not go there."""
    out_dir = Path(out_dir)
    if not out_dir.exists() or not any(out_dir.iterdir()):
        return
    entries = read_manifest(out_dir)
    if entries is None:
        raise ExportError(f"{out_dir}: folder is not empty and holds no {MANIFEST}; refusing to mix an export into it")
    for e in entries:
        if e.get("format") == fmt and e.get("name") == name:
            if e.get("run_id") == run_id:
                return
            raise ExportError(f"{out_dir}: already holds {fmt} dataset '{name}' from another run "
                              f"(run {e.get('run_id')}); export under another --name or into another folder")
    if not merge:
        others = ", ".join(f"{e.get('format')}:{e.get('name')}" for e in entries)
        raise ExportError(f"{out_dir}: already holds other datasets ({others}); pass --merge to add '{name}' next to them")


def record_export(out_dir: Path, fmt: str, name: str, split: str, run_id: str) -> None:
    """Add (or refresh) this export's entry in the folder's manifest."""
    entries = [e for e in (read_manifest(out_dir) or []) if not (e.get("format") == fmt and e.get("name") == name)]
    entries.append({"format": fmt, "name": name, "split": split, "run_id": run_id})
    entries.sort(key=lambda e: (e["format"], e["name"]))
    atomic_write_text(Path(out_dir) / MANIFEST, json.dumps({"exports": entries}, indent=1, sort_keys=True) + "\n")


def run_export(exporter: Exporter, run: RunView, out_dir: Path, options: ExportOptions) -> ExportReport:
    """Check the output-folder policy, run an exporter, and record it in the manifest."""
    fmt = getattr(exporter, "name", type(exporter).__name__)
    run_id = run.run_id()
    prepare_out_dir(out_dir, fmt, options.name, options.split, run_id, options.merge)
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    report = exporter.export(run, Path(out_dir), options)
    record_export(out_dir, fmt, options.name, options.split, run_id)
    return report
