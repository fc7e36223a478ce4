"""Time and size of every exporter on a run folder: serial vs parallel (units on a local pool), output size.

    python bench/bench_export.py RUN_DIR [--formats habitat mjcf usd urdf] [--jobs 2] [--repeat 1] [--standalone]

Per format, into fresh temporary folders:

- serial: `sdovon_mj.export.run_export` in this process (the `sdovon-mj export` path; for an exporter with
  units that is every unit in order, then its finishing step);
- parallel: a copy of the run's records with the format's units as tasks on a `LocalExecutor` of ``--jobs``
  workers followed by the finishing step, as `generate` schedules them (exporters without units: one task);
- the output: MB and files, plus MB per variant split into per-variant files without the episode records,
  the episode records, and what is shared once (scene and object assets, meshes, textures).

Prints whether both paths wrote the same bytes, and per format an extrapolation (labelled as such) of the
output size to ``--target SCENES VARIANTS`` (default 8 x 45, the SD-OVON-3k size): per-variant MB (variant
files, episodes and goals) x variants + shared MB per scene x scenes. Wall times depend on the machine's load:
say what else ran.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")


def _tree(folder: Path) -> dict[str, str]:
    """Return relative path -> sha256 of every file under a folder."""
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _records_copy(run: Path, dst: Path) -> Path:
    """Copy a run folder without its exports (the parallel export writes its own export/<fmt>)."""
    shutil.copytree(run, dst, ignore=lambda d, names: ["export", "stats"] if Path(d) == run else [])
    return dst


def main() -> None:
    """Run the benchmark and print figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", help="a run folder (sdovon-mj generate --out RUN_DIR)")
    ap.add_argument("--formats", nargs="+", default=["habitat", "mjcf", "usd", "urdf"])
    ap.add_argument("--jobs", type=int, default=2, help="workers of the parallel export (default 2)")
    ap.add_argument("--repeat", type=int, default=1, help="best of N wall times")
    ap.add_argument("--standalone", action="store_true", help="mjcf: self-contained bundles (the old layout)")
    ap.add_argument("--target", nargs=2, type=int, default=[8, 45], metavar=("SCENES", "VARIANTS"),
                    help="extrapolate the output size to SCENES scenes x VARIANTS variants each (default 8 45)")
    args = ap.parse_args()
    from sdovon_mj.config import load_config
    from sdovon_mj.export import ExportOptions, RunView, make_exporter, run_export
    from sdovon_mj.executors import LocalExecutor
    from sdovon_mj.schedule import ExportSchedule

    src = Path(args.run_dir).resolve()
    run = RunView(src)
    cfg = load_config(src / "config.yaml")
    names = [v.name for v in run.all_variants()]
    print(f"run: {run.root}  scenes: {len(run.scene_names())}  variants: {len(names)}  parallel jobs: {args.jobs}  "
          f"cpus: {os.cpu_count()}  load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'format':8s} {'variants':>8s} {'serial s':>9s} {'parallel s':>11s} {'same bytes':>10s} {'MB':>9s} "
          f"{'files':>7s} {'per-variant MB':>15s} {'episodes MB':>12s} {'shared MB':>10s}")
    extrap: list[tuple[str, float, float]] = []
    for fmt in args.formats:
        extra = {"standalone": True} if args.standalone and fmt == "mjcf" else {}
        best_s = best_p = float("inf")
        for _ in range(max(1, args.repeat)):
            with tempfile.TemporaryDirectory(prefix="bench_export_") as tmp:
                tmp = Path(tmp)
                t0 = time.perf_counter()
                rep = run_export(make_exporter(fmt), run, tmp / "serial", ExportOptions(name=cfg.name, split=cfg.split,
                                                                                        extra=extra))
                best_s = min(best_s, time.perf_counter() - t0)
                serial = _tree(tmp / "serial")
                files = [p for p in (tmp / "serial").rglob("*") if p.is_file()]
                total = sum(p.stat().st_size for p in files)
                mine = [p for p in files if any(v in p.relative_to(tmp).as_posix() for v in rep.variants)]
                eps = sum(p.stat().st_size for p in mine
                          if "episodes" in p.name or "episodes" in p.parent.name or p.name.endswith(".json.gz")
                          or p.name.startswith("goals."))
                per = sum(p.stat().st_size for p in mine) - eps
                same = "-"
                if not extra:  # the pipeline exports with the run's config (no exporter extras)
                    copy = _records_copy(src, tmp / "run")
                    sched = ExportSchedule(str(copy), [fmt], cfg, [], [])
                    t0 = time.perf_counter()
                    results = LocalExecutor(jobs=args.jobs, retries=0).map(sched.ready(), follow=sched.follow)
                    best_p = min(best_p, time.perf_counter() - t0)
                    bad = [f"{r.spec.label}: {r.error}" for r in results if not r.ok]
                    if bad:
                        raise SystemExit(f"parallel export failed: {bad[0]}")
                    same = "yes" if _tree(copy / "export" / fmt) == serial else "NO"
        n = max(1, len(rep.variants))
        par = f"{best_p:11.1f}" if best_p < float("inf") else f"{'-':>11s}"
        print(f"{fmt:8s} {len(rep.variants):8d} {best_s:9.1f} {par} {same:>10s} {total / 1e6:9.2f} {len(files):7d} "
              f"{per / n / 1e6:15.3f} {eps / n / 1e6:12.3f} {(total - per - eps) / 1e6:10.2f}")
        extrap.append((fmt, (per + eps) / n, (total - per - eps) / max(1, len(run.scene_names()))))
    ts, tv = args.target
    print(f"EXTRAPOLATION (not measured) to {ts} scenes x {tv} variants = {ts * tv} variants: "
          f"MB per variant x {ts * tv} + shared MB per scene x {ts}")
    for fmt, per_variant, per_scene in extrap:
        print(f"  {fmt:8s} {per_variant / 1e6:.3f} MB/variant x {ts * tv} + {per_scene / 1e6:.2f} MB/scene x {ts} "
              f"= {(per_variant * ts * tv + per_scene * ts) / 1e6:.1f} MB (extrapolated)")


if __name__ == "__main__":
    main()
