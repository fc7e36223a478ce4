"""Export scheduling: when each export task may start, as the variant tasks of its scenes finish."""

from __future__ import annotations

from typing import Any

from .config import RunConfig
from .tasks import TaskResult, TaskSpec


class ExportSchedule:
    """When each export task may start: an exporter's units as soon as the scenes they read have no variant
    task left (`sdovon_mj.export.ExportUnit`), its finishing step when its units are done; an exporter
    without units as one task once every variant is done. Used as the `follow` of an executor's map.
    """

    def __init__(self, root: str, fmts: list[str], cfg: RunConfig, variant_specs: list[TaskSpec],
                 failed_before: list[TaskResult]) -> None:
        """Plan the exports of `fmts` (a plugin that cannot be loaded here runs as one task and reports why).

        Parameters
        ----------
        root : str
            The run folder.
        fmts : list of str
            Exporter plugin names.
        cfg : RunConfig
            The run's config (dataset name and split).
        variant_specs : list of TaskSpec
            The variant tasks about to run (their scenes gate the units).
        failed_before : list of TaskResult
            Failed tasks so far (objects, scenes): with no variant done, the exports are not run.
        """
        from .export import ExportOptions, RunView, exporter_units, make_exporter

        self.root = root
        self.left: dict[str, int] = {}
        for v in variant_specs:
            self.left[v.scene] = self.left.get(v.scene, 0) + 1
        self.failed = list(failed_before)
        self.variants_ok = 0
        self.units: dict[str, list[Any] | None] = {}
        for fmt in fmts:
            try:
                units = exporter_units(make_exporter(fmt), RunView(root), ExportOptions(name=cfg.name, split=cfg.split,
                                                                                       secret=RunView(root).secret_split()))
            except Exception:  # the export task itself reports the cause
                units = None
            self.units[fmt] = units
        self.unsent = {fmt: list(u or []) for fmt, u in self.units.items()}
        self.units_left = {fmt: len(u or []) for fmt, u in self.units.items()}
        self.finished: set[str] = set()
        self.not_run: list[TaskResult] = []

    @property
    def n_units(self) -> int:
        """Return the number of unit tasks planned (for the progress bar)."""
        return sum(len(u or []) for u in self.units.values())

    def _scenes_done(self, scenes: tuple[str, ...] | None) -> bool:
        return all(n == 0 for n in self.left.values()) if scenes is None else all(self.left.get(s, 0) == 0 for s in scenes)

    def ready(self) -> list[TaskSpec]:
        """Return the export tasks that may start now (each returned once)."""
        out: list[TaskSpec] = []
        for fmt, units in self.units.items():
            if fmt in self.finished:
                continue
            for u in [u for u in self.unsent[fmt] if self._scenes_done(u.scenes)]:
                self.unsent[fmt].remove(u)
                out.append(TaskSpec("export", self.root, scene=u.key, fmt=fmt))
            waiting = self.units_left[fmt] > 0 if units is not None else not self._scenes_done(None)
            if waiting:
                continue
            self.finished.add(fmt)
            roots = [r for r in self.failed if not r.caused_by and r.spec.kind != "export"]
            if roots and not self.variants_ok:  # nothing to export: say why once per exporter
                cause = ", ".join(r.spec.label for r in roots)
                self.not_run.append(TaskResult(TaskSpec("export", self.root, fmt=fmt), ok=False, caused_by=cause,
                                               error=f"not run: no variant finished because {cause} failed"))
                continue
            out.append(TaskSpec("export", self.root, fmt=fmt))
        return out

    def follow(self, r: TaskResult) -> list[TaskSpec]:
        """Account for a finished task and return the export tasks it lets start."""
        if not r.ok:
            self.failed.append(r)
        if r.spec.kind in ("variant", "chain"):
            self.left[r.spec.scene] -= 1
            self.variants_ok += int(r.ok)
        elif r.spec.kind == "export" and r.spec.scene:
            self.units_left[r.spec.fmt] -= 1
        return self.ready()


__all__ = ["ExportSchedule"]
