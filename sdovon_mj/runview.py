"""The run folder's layout, in one home: `RunLayout` composes every path inside a run folder (run-relative, posix),
`RunView` reads a run's records through it. Writers (the stage functions of `sdovon_mj.stages`, the place stage,
`prepare_run`, the manifest) and readers (exporters, statistics, evaluation, audit, the commands) ask these two;
no other module of the package spells a run-folder path (tests/test_structure.py checks it).

Run folder layout::

    <run>/config.yaml                                          the resolved config
    <run>/inputs.json                                          the scene and object inputs ([]: the default world)
    <run>/manifest.json, timings.json                          the record of the last run (`sdovon_mj.manifest`)
    <run>/split.json                                           a secret split's record (the salt's digest only)
    <run>/inputs/                                              default-world scenes and objects written as inputs
    <run>/objects/objects.json                                 list[ObjectAsset]; failures.json: files not converted
    <run>/objects/<name>/object.json                           ObjectAsset (+ its asset files)
    <run>/scenes/<scene>/scene.json                            SceneAsset (+ its asset files)
    <run>/scenes/<scene>/observe/navmap_<floor>.json           NavMap, one per floor (+ view points, shards, pictures)
    <run>/scenes/<scene>/perceive/planes.json                  list[ReceptaclePlane] as perceive found them
    <run>/scenes/<scene>/perceive/instances.npz, llm.json      fused instances; receptacle naming's LLM fallbacks
    <run>/scenes/<scene>/semantics/regions_<floor>.json        RegionMap, one per floor (optional)
    <run>/scenes/<scene>/semantics/planes.json                 the planes with floor and region (optional)
    <run>/scenes/<scene>/semantics/relevance.json              Relevance (optional)
    <run>/scenes/<scene>/variants/<variant>/variant.json       SceneVariant (variant.xml: its composed MJCF)
    <run>/scenes/<scene>/variants/<variant>/episodes.json      list[Episode]
    <run>/scenes/<scene>/days/<scene>_d<day>/variant.json      a day of the scene's chain (place.days): SceneVariant
    <run>/scenes/<scene>/days/<scene>_d<day>/day.json          DayChange (what stayed, moved, left, arrived)
    <run>/scenes/<scene>/days/<scene>_d<day>/episodes.json     list[Episode] (with the day, goals' histories)
    <run>/export/<fmt>/, <fmt>.report.json, <fmt>.units/       exporter outputs, report, per-unit markers
    <run>/stats/                                               summary tables (markdown + JSON) and category charts
    <run>/cache/llm/                                           LLM replies (semantics.cache)
    <run>/pictures/                                            `sdovon-mj show`'s top-down pictures (default)

Each stage's marker folder (`RunLayout.MARKERS`) holds its ``.done.json`` (`sdovon_mj.store`). A stage's own
files that no other module opens by name (pictures, view points, observation shards: perceive takes every shard,
`RunLayout.observations`) are named by the stage inside the folder the layout gives it.

How to add a path: add a `RunLayout` method (or constant) returning the run-relative path, its arguments the names
it depends on (scene, variant name, floor, format; ``"*"`` makes a glob pattern); add its line to the table above;
write it through that method in the stage that makes it (and name it among the stage's outputs in
`sdovon_mj.stages`), read it through a `RunView` method. A new stage adds its marker folder to `RunLayout.MARKERS`.
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


class RunLayout:
    """Where each file of a run folder lives: run-relative posix paths (see the module docstring's table)."""

    CONFIG = "config.yaml"
    INPUTS = "inputs.json"
    MANIFEST = "manifest.json"
    TIMINGS = "timings.json"
    SCENES = "scenes"
    OBJECTS = "objects"
    OBJECT_LIBRARY = "objects/objects.json"
    OBJECT_FAILURES = "objects/failures.json"
    STATS = "stats"
    EXPORT = "export"  # exporter outputs and their markers
    EVAL = "eval"  # `sdovon-mj demo`'s evaluation results
    PICTURES = "pictures"  # `sdovon-mj show`'s default picture folder
    LLM_CACHE = "cache/llm"
    SPLIT = "split.json"  # a secret split's record (`seeds.split_record`: the salt's digest); absent: an open split
    # Each stage's marker folder (`sdovon_mj.stages.Stage.key`): {scene}, {variant} (a variant's name), {fmt}, {day}.
    MARKERS = {
        "world:objects": "inputs/objects",
        "objects": "objects",
        "world:scene": "inputs/scenes/{scene}",
        "convert": "scenes/{scene}/convert",
        "observe": "scenes/{scene}/observe",
        "perceive": "scenes/{scene}/perceive",
        "semantics": "scenes/{scene}/semantics",
        "place": "scenes/{scene}/variants/{variant}/place",
        "episodes": "scenes/{scene}/variants/{variant}/episodes",
        "day": "scenes/{scene}/days/{day}/day",  # {day}: the day's name (`records.day_name`)
        "day:episodes": "scenes/{scene}/days/{day}/day_episodes",
        "export": "export/{fmt}.stage",
    }

    @staticmethod
    def is_run(root: str | Path) -> bool:
        """Whether a folder is a run folder (its config and its scenes folder)."""
        return (Path(root) / RunLayout.CONFIG).is_file() and (Path(root) / RunLayout.SCENES).is_dir()

    @staticmethod
    def object_record(name: str) -> str:
        """Return an object's record (``*``: the glob of every object's)."""
        return f"objects/{name}/object.json"

    @staticmethod
    def scene_dir(scene: str) -> str:
        """Return a scene's folder (``*``: the glob of every scene's)."""
        return f"scenes/{scene}"

    @staticmethod
    def scene_record(scene: str) -> str:
        """Return a scene's SceneAsset record."""
        return f"scenes/{scene}/scene.json"

    @staticmethod
    def stage_dir(scene: str, stage: str) -> str:
        """Return a scene stage's folder (``observe``, ``perceive``, ``semantics``)."""
        return f"scenes/{scene}/{stage}"

    @staticmethod
    def navmap(scene: str, floor: int | str = "*") -> str:
        """Return a floor's NavMap (default ``*``: the glob of every floor's)."""
        return f"scenes/{scene}/observe/{RunLayout.navmap_file(floor)}"

    @staticmethod
    def navmap_file(floor: int | str, suffix: str = ".json") -> str:
        """Return the file name of a floor's NavMap inside the observe folder (``suffix`` ``.png``: its picture)."""
        return f"navmap_{floor}{suffix}"

    @staticmethod
    def observations(scene: str) -> str:
        """Return the glob of a scene's observation shards (``*.npz`` of the observe folder)."""
        return f"scenes/{scene}/observe/*.npz"

    @staticmethod
    def instances(scene: str) -> str:
        """Return a scene's fused instances (perceive)."""
        return f"scenes/{scene}/perceive/instances.npz"

    @staticmethod
    def planes(scene: str, stage: str) -> str:
        """Return a scene's receptacle planes as `stage` wrote them (``perceive``: found; ``semantics``: with floor
        and region)."""
        return f"scenes/{scene}/{stage}/planes.json"

    @staticmethod
    def targeted_views(scene: str) -> str:
        """Return a scene's targeted views (perceive)."""
        return f"scenes/{scene}/perceive/targeted_views.json"

    @staticmethod
    def llm_record(scene: str) -> str:
        """Return perceive's record of receptacle naming's LLM backend and fallbacks."""
        return f"scenes/{scene}/perceive/llm.json"

    @staticmethod
    def regions(scene: str, floor: int | str = "*", suffix: str = ".json") -> str:
        """Return a floor's RegionMap (``suffix`` ``.png``: its picture; default floor ``*``: the glob)."""
        return f"scenes/{scene}/semantics/regions_{floor}{suffix}"

    @staticmethod
    def relevance(scene: str) -> str:
        """Return a scene's Relevance."""
        return f"scenes/{scene}/semantics/relevance.json"

    @staticmethod
    def variant_name(scene: str, index: int) -> str:
        """Return the name of a scene's variant (``<scene>_v<index:03d>``)."""
        return f"{scene}_v{index:03d}"

    @staticmethod
    def variant_dir(scene: str, variant: str = "*") -> str:
        """Return a variant's folder (default ``*``: the glob of every variant's)."""
        return f"scenes/{scene}/variants/{variant}"

    @staticmethod
    def variant_record(scene: str, variant: str = "*") -> str:
        """Return a variant's SceneVariant record."""
        return f"{RunLayout.variant_dir(scene, variant)}/variant.json"

    @staticmethod
    def variant_mjcf(scene: str, variant: str) -> str:
        """Return a variant's composed MJCF."""
        return f"{RunLayout.variant_dir(scene, variant)}/variant.xml"

    @staticmethod
    def episodes(scene: str, variant: str = "*") -> str:
        """Return a variant's episodes."""
        return f"{RunLayout.variant_dir(scene, variant)}/episodes.json"

    @staticmethod
    def day_dir(scene: str, day: str = "*") -> str:
        """Return a day's folder in the scene's chain of days (`day`: its name, `records.day_name`; ``*``: the glob)."""
        return f"scenes/{scene}/days/{day}"

    @staticmethod
    def day_record(scene: str, day: str = "*") -> str:
        """Return a day's SceneVariant record."""
        return f"{RunLayout.day_dir(scene, day)}/variant.json"

    @staticmethod
    def day_change(scene: str, day: str = "*") -> str:
        """Return a day's DayChange record (what stayed, moved, left and arrived since the day before)."""
        return f"{RunLayout.day_dir(scene, day)}/day.json"

    @staticmethod
    def day_mjcf(scene: str, day: str) -> str:
        """Return a day's composed MJCF."""
        return f"{RunLayout.day_dir(scene, day)}/variant.xml"

    @staticmethod
    def day_episodes(scene: str, day: str = "*") -> str:
        """Return a day's episodes."""
        return f"{RunLayout.day_dir(scene, day)}/episodes.json"

    @staticmethod
    def dataset_dir(variant: SceneVariant) -> str:
        """Return the folder of a variant's records: a day of a chain under ``days/``, a variant under ``variants/``."""
        if variant.day is not None:
            return RunLayout.day_dir(variant.scene, variant.name)
        return RunLayout.variant_dir(variant.scene, variant.name)

    @staticmethod
    def export_dir(fmt: str) -> str:
        """Return an exporter's output folder (only the exporter writes there)."""
        return f"export/{fmt}"

    @staticmethod
    def export_report(fmt: str) -> str:
        """Return an export's report."""
        return f"export/{fmt}.report.json"

    @staticmethod
    def export_unit(fmt: str, unit: str = "") -> str:
        """Return an export unit's marker folder (``export/<fmt>.units/<unit>``; no unit: the units' folder)."""
        return f"export/{fmt}.units/{unit}" if unit else f"export/{fmt}.units"

    @staticmethod
    def stage_of(key: str) -> str:
        """Return the stage a marker folder belongs to (``scenes/a/observe`` -> observe, ``export/mjcf.stage`` ->
        export:mjcf, ``export/mjcf.units/<unit>`` -> export:mjcf)."""
        parts = key.split("/")
        if parts[0] == "inputs" and len(parts) > 1:
            return "world:objects" if parts[1] == "objects" else "world:scene"
        if parts[0] == RunLayout.EXPORT:
            if len(parts) > 2 and parts[1].endswith(".units"):  # an export unit
                return "export:" + parts[1].removesuffix(".units")
            return "export:" + parts[-1].removesuffix(".stage")
        return parts[-1]

    @staticmethod
    def marker(stage: str, scene: str = "", variant: str = "", fmt: str = "", day: str = "") -> str:
        """Return a declared stage's marker folder in one place of the run (`MARKERS`).

        Parameters
        ----------
        stage : str
            A declared stage's name (a key of `MARKERS`).
        scene : str
            The scene (scene, variant and chain stages).
        variant : str
            The variant's name (variant stages).
        fmt : str
            The exporter (export stages).
        day : str
            The day's name (`records.day_name`; chain stages).
        """
        return RunLayout.MARKERS[stage].format(scene=scene, variant=variant, fmt=fmt, day=day)


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
        if not (self.root / RunLayout.SCENES).is_dir():
            raise InputError(self.root, "not a run folder (no scenes/ inside)")

    def path(self, rel: str | Path) -> Path:
        """Return the absolute path of a run-relative path."""
        return self.root / Path(rel)

    def config(self) -> "RunConfig":
        """Return the run's resolved `RunConfig` (``config.yaml``; the defaults where a run folder has none)."""
        from .config import load_config

        path = self.root / RunLayout.CONFIG
        return load_config(path if path.is_file() else None)

    def scene_names(self) -> list[str]:
        """Return the scene names (sorted)."""
        return sorted(p.parent.name for p in self.root.glob(RunLayout.scene_record("*")))

    def scenes(self) -> list[SceneAsset]:
        """Return every SceneAsset (sorted by name)."""
        return [self.scene(n) for n in self.scene_names()]

    def scene(self, name: str) -> SceneAsset:
        """Return one SceneAsset."""
        return _load(self.root / RunLayout.scene_record(name), SceneAsset)

    def navmaps(self, scene: str) -> list[NavMap]:
        """Return a scene's NavMaps sorted by floor."""
        maps = [_load(p, NavMap) for p in sorted(self.root.glob(RunLayout.navmap(scene)))]
        return sorted(maps, key=lambda m: m.floor)

    def relevance(self, scene: str) -> Relevance | None:
        """Return a scene's relevance tables (None when the run has none)."""
        p = self.root / RunLayout.relevance(scene)
        return _load(p, Relevance) if p.exists() else None

    def region_maps(self, scene: str) -> list[RegionMap]:
        """Return a scene's region maps sorted by floor ([] when the run has none)."""
        maps = [_load(p, RegionMap) for p in sorted(self.root.glob(RunLayout.regions(scene)))]
        return sorted(maps, key=lambda m: m.floor)

    def planes(self, scene: str) -> list[ReceptaclePlane]:
        """Return a scene's receptacle planes: with floor and region (semantics) when the run has them, else as
        perceive found them; [] when it has neither."""
        for stage in ("semantics", "perceive"):
            p = self.root / RunLayout.planes(scene, stage)
            if p.exists():
                return _load(p, ReceptaclePlane)
        return []

    def variants(self, scene: str) -> list[SceneVariant]:
        """Return a scene's SceneVariants sorted by index."""
        vs = [_load(p, SceneVariant) for p in sorted(self.root.glob(RunLayout.variant_record(scene)))]
        return sorted(vs, key=lambda v: v.index)

    def all_variants(self) -> list[SceneVariant]:
        """Return every variant of every scene."""
        return [v for s in self.scene_names() for v in self.variants(s)]

    def days(self, scene: str) -> list[SceneVariant]:
        """Return the days of a scene's chain of days (SceneVariants with their `day`) in day order ([]: none)."""
        vs = [_load(p, SceneVariant) for p in sorted(self.root.glob(RunLayout.day_record(scene)))]
        return sorted(vs, key=lambda v: v.day or 0)

    def day_change(self, day: SceneVariant) -> DayChange:
        """Return what changed on a day of a chain since the day before (its ``day.json``)."""
        return _load(self.root / RunLayout.day_change(day.scene, day.name), DayChange)

    def dataset_variants(self, scene: str) -> list[SceneVariant]:
        """Return what a dataset of the scene holds: its variants by index, then its chain's days in order."""
        return self.variants(scene) + self.days(scene)

    def all_dataset_variants(self) -> list[SceneVariant]:
        """Return `dataset_variants` of every scene."""
        return [v for s in self.scene_names() for v in self.dataset_variants(s)]

    def variant_dir(self, variant: SceneVariant) -> Path:
        """Return the folder of a variant's records (a day's: under the scene's ``days/``)."""
        return self.root / RunLayout.dataset_dir(variant)

    def episodes(self, variant: SceneVariant) -> list[Episode]:
        """Return a variant's episodes, a day's for a day of a chain ([] when it has none or no episodes.json)."""
        p = self.root / (RunLayout.episodes(variant.scene, variant.name) if variant.day is None
                         else RunLayout.day_episodes(variant.scene, variant.name))
        return _load(p, Episode) if p.exists() else []

    def object_library(self) -> list[ObjectAsset]:
        """Return the run's converted object library (objects/objects.json, sorted by name)."""
        return _load(self.root / RunLayout.OBJECT_LIBRARY, ObjectAsset)

    def objects(self) -> dict[str, ObjectAsset]:
        """Return every ObjectAsset by name."""
        return {p.parent.name: _load(p, ObjectAsset) for p in sorted(self.root.glob(RunLayout.object_record("*")))}

    def scene_record_files(self, scene: str) -> list[Path]:
        """Return the record files of a scene: its SceneAsset, NavMaps, semantics records, variant records and its
        chain's day records (the files an export unit of the scene reads; existing ones only, each group sorted)."""
        return ([self.root / RunLayout.scene_record(scene)] + sorted(self.root.glob(RunLayout.navmap(scene)))
                + sorted(self.root.glob(f"{RunLayout.stage_dir(scene, 'semantics')}/*.json"))
                + sorted(self.root.glob(f"{RunLayout.variant_dir(scene)}/*.json"))
                + sorted(self.root.glob(f"{RunLayout.day_dir(scene)}/*.json")))

    def object_record_files(self) -> list[Path]:
        """Return every object's record file (sorted)."""
        return sorted(self.root.glob(RunLayout.object_record("*")))

    def secret_split(self) -> dict | None:
        """Return the run's secret-split record (``split.json``: ``{"secret": true, "salt_digest"}``), None if open."""
        p = self.root / RunLayout.SPLIT
        return json.loads(p.read_text(encoding="utf-8")) if p.is_file() else None

    def run_id(self) -> str:
        """Return a digest of the run's record files (identifies the run across exports)."""
        h = hashlib.sha256()
        for p in (sorted(self.root.glob(RunLayout.scene_record("*")))
                  + sorted(self.root.glob(f"{RunLayout.variant_dir('*')}/*.json"))
                  + sorted(self.root.glob(f"{RunLayout.day_dir('*')}/*.json")) + self.object_record_files()):
            h.update(p.relative_to(self.root).as_posix().encode())
            h.update(p.read_bytes())
        return h.hexdigest()[:20]


__all__ = ["RunLayout", "RunView"]
