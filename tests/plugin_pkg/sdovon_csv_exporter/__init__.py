"""Third-party exporter: writes <out>/<name>/episodes.csv with one row per episode."""

from __future__ import annotations

import csv
import io
from pathlib import Path

from sdovon_mj.export import ExportOptions, ExportReport, Exporter, RunView
from sdovon_mj.store import atomic_write_text


class CsvExporter(Exporter):
    """One CSV row per episode: variant, category, start xyz, geodesic distance, number of goals."""

    name = "csv"

    def export(self, run: RunView, out_dir: Path, options: ExportOptions) -> ExportReport:
        """Write episodes.csv for every variant with episodes."""
        report = ExportReport(format=self.name, out_dir=str(out_dir), name=options.name)
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["variant", "category", "x", "y", "z", "geodesic", "goals"])
        for v in run.all_variants():
            eps = run.episodes(v)
            if not eps:
                report.skipped[v.name] = "no episodes"
                continue
            for e in eps:
                w.writerow([v.name, e.object_category, *(f"{c:.3f}" for c in e.start_position), f"{e.geodesic_distance:.3f}", len(e.goals)])
            report.variants.append(v.name)
            report.episodes += len(eps)
        atomic_write_text(Path(out_dir) / options.name / "episodes.csv", buf.getvalue())
        report.files = [f"{options.name}/episodes.csv"]
        return report
