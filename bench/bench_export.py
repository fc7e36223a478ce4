"""Time and size per variant of every exporter (habitat, mjcf, usd, urdf) on a run folder.

    python bench/bench_export.py RUN_DIR [--formats habitat mjcf usd urdf] [--repeat 1]

Each format is exported into a fresh temporary folder; one line per format: variants written, seconds per
variant (wall, best of --repeat), MB per variant (all files the export wrote / variants), split into the
per-variant files (named after a variant) without the episode records, the episode records (the same
records in every format), and what is shared once (scene, object assets, meshes, textures): 300 variants
cost about shared + 300 x (per-variant + episodes).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")


def main() -> None:
    """Run the benchmark and print figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", help="a run folder (sdovon-mj generate --out RUN_DIR)")
    ap.add_argument("--formats", nargs="+", default=["habitat", "mjcf", "usd", "urdf"])
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    from sdovon_mj.export import ExportOptions, RunView, make_exporter, run_export

    run = RunView(args.run_dir)
    names = [v.name for v in run.all_variants()]
    print(f"run: {run.root}  variants: {len(names)}")
    print(f"{'format':8s} {'variants':>8s} {'s/variant':>10s} {'MB/variant':>11s} {'per-variant MB':>15s} "
          f"{'episodes MB':>12s} {'shared MB':>10s}")
    for fmt in args.formats:
        best = float("inf")
        for _ in range(max(1, args.repeat)):
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                rep = run_export(make_exporter(fmt), run, Path(tmp), ExportOptions(name="bench"))
                dt = time.perf_counter() - t0
                best = min(best, dt)
                files = [p for p in Path(tmp).rglob("*") if p.is_file()]
                total = sum(p.stat().st_size for p in files)
                mine = [p for p in files if any(v in p.relative_to(tmp).as_posix() for v in rep.variants)]
                eps = sum(p.stat().st_size for p in mine
                          if "episodes" in p.name or "episodes" in p.parent.name or p.name.endswith(".json.gz"))
                per = sum(p.stat().st_size for p in mine) - eps
        n = max(1, len(rep.variants))
        print(f"{fmt:8s} {len(rep.variants):8d} {best / n:10.2f} {total / n / 1e6:11.2f} {per / n / 1e6:15.3f} "
              f"{eps / n / 1e6:12.3f} {(total - per - eps) / 1e6:10.2f}")


if __name__ == "__main__":
    main()
