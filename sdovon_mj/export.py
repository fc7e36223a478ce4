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
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

from . import plugins
from .errors import InputError, SdovonError
from .records import Episode, SceneVariant
from .runview import RunView
from .store import atomic_write_text

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


def exportable_variants(run: RunView, report: ExportReport) -> Iterator[tuple[SceneVariant, list[Episode]]]:
    """Yield (variant, episodes) for every variant with episodes; record the others in report.skipped."""
    for variant in run.all_variants():
        eps = run.episodes(variant)
        if not eps:
            report.skipped[variant.name] = "no valid goals (zero episodes)"
            continue
        yield variant, eps


def finish_export(report: ExportReport, root: Path, options: ExportOptions, index: list[dict], written: list[Path],
                  index_key: str = "variants") -> ExportReport:
    """Write the dataset's ``index.json`` ({dataset, split, <index_key>: index}) and fill report.files; return report."""
    atomic_write_text(root / "index.json", json.dumps({"dataset": options.name, "split": options.split,
                                                       index_key: index}, indent=1, sort_keys=True) + "\n")
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
               merge: bool = False) -> ExportReport:
    """Export a run folder with a named exporter plugin and return its ExportReport."""
    return run_export(make_exporter(fmt), RunView(run_dir), Path(out), ExportOptions(name=name, split=split, merge=merge))


__all__ = ["MANIFEST", "ExportError", "ExportOptions", "ExportReport", "Exporter", "RunView", "read_manifest",
           "prepare_out_dir", "record_export", "run_export", "make_exporter", "export_run", "exportable_variants",
           "finish_export"]
