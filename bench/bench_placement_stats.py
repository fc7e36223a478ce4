"""Placement statistics of a generated dataset: share of placed objects on their top-3 (region, receptacle) pairs.

    python bench/bench_placement_stats.py RUN_DIR [RUN_DIR ...] [--k 3]

RUN_DIR is a `sdovon-mj generate` (or `sdovon-mj demo`) output folder, e.g. the default world's demo run.
Prints, per run and over all, the placed objects, the share on one of their top-k available pairs
(`sdovon_mj.stats.placement_top_pairs`), the expected share of a uniform random placement on the same
planes, and their ratio (issue 15 asks for >= 3x with k = 3), beside the ratio's ceiling on the same planes
(a placement that only ever uses categories whose top-k holds the plane's pair: `placement_top_pairs`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    """Print the figures; exit 0."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="generated run folders")
    ap.add_argument("--k", type=int, default=3, help="top-k pairs per category")
    args = ap.parse_args(argv)

    from sdovon_mj.stats import placement_top_pairs

    placed = hits = 0
    rand = 0.0
    for run in args.runs:
        r = placement_top_pairs(run, k=args.k)
        placed += r["placed"]
        hits += r["on_top_k"]
        rand += r["random_share"] * r["placed"]
        print(f"{run}: {r['placed']} placed, {r['share']:.3f} on their top-{args.k} pairs, random {r['random_share']:.3f}, "
              f"ratio {r['ratio']:.2f} (ceiling {r['ceiling']:.2f}: only categories whose top-{args.k} holds the pair)")
    if len(args.runs) > 1 and placed:
        print(f"all: {placed} placed, {hits / placed:.3f} on their top-{args.k} pairs, random {rand / placed:.3f}, "
              f"ratio {(hits / placed) / max(rand / placed, 1e-12):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
