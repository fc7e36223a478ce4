"""The exporter interface: options, report, the `Exporter` base and the output-folder policy.

Exporter plugins (entry-point group ``sdovon_mj.exporters``) subclass `Exporter` and read the run through
`sdovon_mj.runview.RunView` only. The core runs them through `run_export`.

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

Units (optional, for parallel exports): an exporter may split its work by overriding `Exporter.units`
(a list of `ExportUnit`: a key and the scenes whose records it reads, or None for the whole run),
`Exporter.export_unit` (writes one unit's files, returns a JSON-able `UnitResult`) and `Exporter.finish`
(writes the dataset-level files from the units' results, in `units` order). Its `export` then need not be
written: the base class runs the units in order and finishes (the serial path). The pipeline runs the units
as tasks of their own (each with its done-marker under ``export/<fmt>.units/<key>``, started as soon as the
scenes it reads are done) and the finishing step last; both paths write the same bytes. A plugin that
declares no units (``units`` returns None) runs as one task through its ``export``, as before.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

from . import plugins
from .errors import InputError, SdovonError
from .records import Episode, SceneVariant
from .runview import RunView
from .store import atomic_write_text, fingerprint

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
    secret: dict[str, Any] | None = None  # the run's secret-split record (`RunView.secret_split`); None: open split


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


@dataclass(frozen=True)
class ExportUnit:
    """One independently exportable piece of a dataset (see the module docstring, Units)."""

    key: str  # unique within the export and file-system safe (e.g. a scene name)
    scenes: tuple[str, ...] | None = None  # the scenes whose records it reads; None: every scene (waits for all)


@dataclass
class UnitResult:
    """What one unit wrote (JSON-able: the pipeline keeps it beside the unit's done-marker)."""

    key: str
    variants: list[str] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)  # variant -> reason
    episodes: int = 0
    files: list[str] = field(default_factory=list)  # relative to the export's out_dir
    index: list[dict] = field(default_factory=list)  # the unit's rows of the dataset index (exporter-defined)
    data: dict[str, Any] = field(default_factory=dict)  # anything else the exporter's finish step needs

    def to_dict(self) -> dict[str, Any]:
        """Return the result as plain JSON data."""
        return {"key": self.key, "variants": list(self.variants), "skipped": dict(self.skipped),
                "episodes": int(self.episodes), "files": sorted(self.files), "index": list(self.index),
                "data": dict(self.data)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "UnitResult":
        """Return a result from `to_dict` data."""
        return cls(str(d["key"]), list(d["variants"]), dict(d["skipped"]), int(d["episodes"]), list(d["files"]),
                   list(d["index"]), dict(d["data"]))


class Exporter:
    """Base of exporter plugins: sees records and the run folder only."""

    name: str = "base"
    # The layout version of what the exporter writes: part of every export fingerprint, so a run exported by an
    # older layout is exported again on resume instead of being kept (bump it when the written files change).
    version: str = ""

    def units(self, run: RunView, options: ExportOptions) -> list[ExportUnit] | None:
        """Return the export's units in order (None: the exporter runs as one task through `export`)."""
        return None

    def export_unit(self, run: RunView, out_dir: Path, options: ExportOptions, unit: ExportUnit) -> UnitResult:
        """Write one unit's files under out_dir and return what it wrote (exporters with units override it)."""
        raise NotImplementedError

    def finish(self, run: RunView, out_dir: Path, options: ExportOptions, results: list[UnitResult]) -> ExportReport:
        """Write the dataset-level files from the units' results (in `units` order) and return the report."""
        raise NotImplementedError

    def export(self, run: RunView, out_dir: Path, options: ExportOptions) -> ExportReport:
        """Write the run in this exporter's format under out_dir and report what was written.

        The base implementation is the serial path of an exporter with units: every unit in order, then
        `finish`; an exporter without units overrides it.
        """
        units = self.units(run, options)
        if units is None:
            raise NotImplementedError(f"exporter {type(self).__name__} declares neither units nor export()")
        return self.finish(run, Path(out_dir), options,
                           [self.export_unit(run, Path(out_dir), options, u) for u in units])


def exporter_units(exporter: Any, run: RunView, options: ExportOptions) -> list[ExportUnit] | None:
    """Return an exporter's units, or None for a plugin that declares none (also one not subclassing Exporter)."""
    fn = getattr(exporter, "units", None)
    units = fn(run, options) if callable(fn) else None
    if units is None:
        return None
    units = list(units)
    keys = [u.key for u in units]
    if len(set(keys)) != len(keys) or any(not k or "/" in k or k.startswith(".") for k in keys):
        raise ExportError(f"exporter {getattr(exporter, 'name', exporter)}: unit keys must be unique file names, got {keys}")
    return units


def unit_digest(run: RunView, unit: ExportUnit) -> str:
    """Return a digest of the records a unit reads (its scenes' scene, navmap, semantics and variant records, objects).

    A unit that reads the whole run (``scenes`` None) gets the run's `RunView.run_id`.
    """
    if unit.scenes is None:
        return run.run_id()
    files = [p for s in sorted(unit.scenes) for p in run.scene_record_files(s)] + run.object_record_files()
    parts = [(p.relative_to(run.root).as_posix(), hashlib.sha256(p.read_bytes()).hexdigest()) for p in files
             if p.is_file() and not p.name.startswith(".")]  # not the stages' done-markers and timing files
    return fingerprint(parts)


def merge_unit_results(fmt: str, out_dir: Path, name: str, results: list[UnitResult]) -> tuple[ExportReport, list[Path]]:
    """Return the report of a whole export from its units' results (in unit order) and the files they wrote."""
    report = ExportReport(format=fmt, out_dir=str(out_dir), name=name)
    written: list[Path] = []
    for r in results:
        report.variants += r.variants
        report.skipped.update(r.skipped)
        report.episodes += r.episodes
        written += [Path(out_dir) / f for f in r.files]
    return report, written


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
    """Apply the output-folder policy (module docstring); raise ExportError when the export must not go there.

    Parameters
    ----------
    out_dir : Path
        The export's output folder.
    fmt, name, split : str
        The exporter's format, the dataset name and split (what the folder's manifest records).
    run_id : str
        The run's id (`RunView.run_id`): the same dataset from another run is refused.
    merge : bool
        Whether another dataset may share the folder.
    """
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
    """Add (or refresh) this export's entry in the folder's manifest.

    Parameters
    ----------
    out_dir : Path
        The export's output folder.
    fmt, name, split, run_id : str
        The entry: format, dataset name, split and the run's id (as in `prepare_out_dir`).
    """
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


def exportable_variants(run: RunView, report: ExportReport) -> Iterator[tuple[SceneVariant, list[Episode]]]:
    """Yield (variant, episodes) for every variant with episodes; record the others in report.skipped."""
    for variant in run.all_dataset_variants():
        eps = run.episodes(variant)
        if not eps:
            report.skipped[variant.name] = "no valid goals (zero episodes)"
            continue
        yield variant, eps


def finish_export(report: ExportReport, root: Path, options: ExportOptions, index: list[dict], written: list[Path],
                  index_key: str = "variants", extra: dict[str, Any] | None = None) -> ExportReport:
    """Write the dataset's ``index.json`` ({dataset, split, <index_key>: index, **extra}, and ``secret_split`` (the
    salt's digest) for a split made with a secret salt: absent for an open one) and fill report.files; return report.

    Parameters
    ----------
    report : ExportReport
        The export's report (its ``files`` are filled, relative to ``report.out_dir``).
    root : Path
        The dataset folder ``index.json`` goes into.
    options : ExportOptions
        Dataset name and split (and `secret`: the secret split's record, if any).
    index : list of dict
        One entry per exported item.
    written : list of Path
        Every file the export wrote (``index.json`` is added).
    index_key : str
        The key of `index` in ``index.json``.
    extra : dict, optional
        More top-level keys of ``index.json``.
    """
    secret = {"secret_split": dict(options.secret)} if options.secret else {}
    atomic_write_text(root / "index.json", json.dumps({"dataset": options.name, "split": options.split,
                                                       index_key: index, **(extra or {}), **secret},
                                                      indent=1, sort_keys=True) + "\n")
    written.append(root / "index.json")
    report.files = sorted({p.relative_to(Path(report.out_dir)).as_posix() for p in written})
    return report


def make_exporter(fmt: str) -> Exporter:
    """Return an exporter instance for a plugin name."""
    obj = plugins.load("exporter", fmt)
    exp = obj() if isinstance(obj, type) else obj
    if not hasattr(exp, "export"):
        raise plugins.PluginError(f"exporter plugin '{fmt}' has no export() method")
    if not getattr(exp, "name", ""):
        exp.name = fmt
    return exp


def export_run(run_dir: str | Path, fmt: str, out: str | Path, name: str = "sdovon", split: str = "val",
               merge: bool = False, extra: dict[str, Any] | None = None) -> ExportReport:
    """Export a run folder with a named exporter plugin and return its ExportReport.

    Parameters
    ----------
    run_dir : str or Path
        The run folder.
    fmt : str
        Exporter plugin name.
    out : str or Path
        Output folder (the output-folder policy of the module docstring applies).
    name, split : str
        Dataset and split names.
    merge : bool
        Add the dataset next to other datasets already in ``out``.
    extra : dict, optional
        Exporter-specific options (`ExportOptions.extra`, e.g. ``{"standalone": True}`` for MJCF).
    """
    run = RunView(run_dir)
    return run_export(make_exporter(fmt), run, Path(out), ExportOptions(name=name, split=split, merge=merge,
                                                                         extra=dict(extra or {}),
                                                                         secret=run.secret_split()))


__all__ = ["MANIFEST", "ExportError", "ExportOptions", "ExportReport", "ExportUnit", "Exporter", "RunView", "UnitResult",
           "exporter_units", "unit_digest", "merge_unit_results", "read_manifest",
           "prepare_out_dir", "record_export", "run_export", "make_exporter", "export_run", "exportable_variants",
           "finish_export"]
