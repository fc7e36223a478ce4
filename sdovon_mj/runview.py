"""The run view: read access to a run folder's records, the one home of the run-folder layout for readers.

Run folder layout (paths inside records are relative to the run root; writers: the stage declarations of
``sdovon_mj.stages``)::

    <run>/scenes/<scene>/scene.json                            SceneAsset (+ its asset files)
    <run>/scenes/<scene>/observe/navmap_<floor>.json           NavMap, one per floor
    <run>/scenes/<scene>/semantics/relevance.json              Relevance (optional)
    <run>/scenes/<scene>/semantics/regions_<floor>.json        RegionMap, one per floor (optional)
    <run>/scenes/<scene>/perceive/planes.json                  list[ReceptaclePlane] as perceive found them
    <run>/scenes/<scene>/semantics/planes.json                 the same with floor and region (optional)
    <run>/scenes/<scene>/variants/<variant>/variant.json       SceneVariant (its .mjcf: composed MJCF)
    <run>/scenes/<scene>/variants/<variant>/episodes.json      list[Episode]
    <run>/scenes/<scene>/days/<scene>_d<day>/variant.json      a day of the scene's chain (place.days): SceneVariant
    <run>/scenes/<scene>/days/<scene>_d<day>/day.json          DayChange (what stayed, moved, left, arrived)
    <run>/scenes/<scene>/days/<scene>_d<day>/episodes.json     list[Episode] (with the day, goals' histories)
    <run>/objects/<name>/object.json                           ObjectAsset (+ its asset files)

Exporters, statistics and evaluation read runs through `RunView` only.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .errors import InputError
from .records import (DayChange, Episode, NavMap, ObjectAsset, ReceptaclePlane, RecordError, RegionMap, Relevance,
                      SceneAsset, SceneVariant, load_json)

if TYPE_CHECKING:
    from .config import RunConfig


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

    def config(self) -> "RunConfig":
        """Return the run's resolved `RunConfig` (``config.yaml``; the defaults where a run folder has none)."""
        from .config import load_config

        path = self.root / "config.yaml"
        return load_config(path if path.is_file() else None)

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

    def planes(self, scene: str) -> list[ReceptaclePlane]:
        """Return a scene's receptacle planes: with floor and region (semantics) when the run has them, else as
        perceive found them; [] when it has neither."""
        for stage in ("semantics", "perceive"):
            p = self.root / "scenes" / scene / stage / "planes.json"
            if p.exists():
                return _load(p, ReceptaclePlane)
        return []

    def variants(self, scene: str) -> list[SceneVariant]:
        """Return a scene's SceneVariants sorted by index."""
        vs = [_load(p, SceneVariant) for p in sorted((self.root / "scenes" / scene / "variants").glob("*/variant.json"))]
        return sorted(vs, key=lambda v: v.index)

    def all_variants(self) -> list[SceneVariant]:
        """Return every variant of every scene."""
        return [v for s in self.scene_names() for v in self.variants(s)]

    def days(self, scene: str) -> list[SceneVariant]:
        """Return the days of a scene's chain of days (SceneVariants with their `day`) in day order ([]: none)."""
        vs = [_load(p, SceneVariant) for p in sorted((self.root / "scenes" / scene / "days").glob("*/variant.json"))]
        return sorted(vs, key=lambda v: v.day or 0)

    def day_change(self, day: SceneVariant) -> DayChange:
        """Return what changed on a day of a chain since the day before (its ``day.json``)."""
        return _load(self.variant_dir(day) / "day.json", DayChange)

    def dataset_variants(self, scene: str) -> list[SceneVariant]:
        """Return what a dataset of the scene holds: its variants by index, then its chain's days in order."""
        return self.variants(scene) + self.days(scene)

    def all_dataset_variants(self) -> list[SceneVariant]:
        """Return `dataset_variants` of every scene."""
        return [v for s in self.scene_names() for v in self.dataset_variants(s)]

    def variant_dir(self, variant: SceneVariant) -> Path:
        """Return the folder of a variant's records (a day's: under the scene's ``days/``)."""
        if variant.day is not None:
            return self.root / "scenes" / variant.scene / "days" / variant.name
        return self.root / "scenes" / variant.scene / "variants" / variant.name

    def episodes(self, variant: SceneVariant) -> list[Episode]:
        """Return a variant's episodes ([] when it has none or no episodes.json)."""
        p = self.variant_dir(variant) / "episodes.json"
        return _load(p, Episode) if p.exists() else []

    def object_library(self) -> list[ObjectAsset]:
        """Return the run's converted object library (objects/objects.json, sorted by name)."""
        return _load(self.root / "objects" / "objects.json", ObjectAsset)

    def objects(self) -> dict[str, ObjectAsset]:
        """Return every ObjectAsset by name."""
        return {p.parent.name: _load(p, ObjectAsset) for p in sorted((self.root / "objects").glob("*/object.json"))}

    def secret_split(self) -> dict | None:
        """Return the run's secret-split record (``split.json``: ``{"secret": true, "salt_digest"}``), None if open."""
        p = self.root / "split.json"
        return json.loads(p.read_text(encoding="utf-8")) if p.is_file() else None

    def run_id(self) -> str:
        """Return a digest of the run's record files (identifies the run across exports)."""
        h = hashlib.sha256()
        for p in (sorted(self.root.glob("scenes/*/scene.json")) + sorted(self.root.glob("scenes/*/variants/*/*.json"))
                  + sorted(self.root.glob("scenes/*/days/*/*.json")) + sorted(self.root.glob("objects/*/object.json"))):
            h.update(p.relative_to(self.root).as_posix().encode())
            h.update(p.read_bytes())
        return h.hexdigest()[:20]


__all__ = ["RunView"]
