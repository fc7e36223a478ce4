"""Region map on default-world apartments: agreement with true room types per room type, and timing.

    python bench/bench_regions.py [--seeds 5] [--radius R] [--step D] [--plain-disc] [--votes both|walking|euclidean]
                                  [--embeddings]

Ground-truth instances (one per furniture instance, from the apartment mesh), a NavMap rasterised
from the room polygons, the offline backend. Prints, per room type, the share of navigable cells the
region map labels with the true type; the number of distinct window label sets (= region-proposal
questions an LLM backend would get); and seconds per map.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("HF_HUB_OFFLINE", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # tests/support: the fixture scenes (not installed)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5, help="apartments 0..N-1")
    ap.add_argument("--radius", type=float, default=None, help="window radius r (default: config)")
    ap.add_argument("--step", type=float, default=None, help="window step d (default: config)")
    ap.add_argument("--plain-disc", action="store_true", help="the paper's plain disc windows (walls do not cut)")
    ap.add_argument("--votes", choices=("both", "walking", "euclidean"), default="both",
                    help="window vote weighting (semantics.region_votes); both: before/after table")
    ap.add_argument("--embeddings", action="store_true", help="also score the embedding fallback against the table")
    args = ap.parse_args(argv)

    from sdovon_mj.config import SemanticsConfig
    from sdovon_mj.semantics import get_backend, region_map
    from support.groundtruth import apartment_instances, apartment_navmap, region_accuracy
    from sdovon_mj.semantics.regions import _windows, floor_instances

    try:
        from sdovon_mj.world import generate_apartment  # type: ignore[attr-defined]
    except ImportError:
        from sdovon_mj.world.apartment import generate_apartment

    cfg = SemanticsConfig()
    if args.radius is not None:
        cfg = dataclasses.replace(cfg, window_radius=args.radius)
    if args.step is not None:
        cfg = dataclasses.replace(cfg, window_step=args.step)
    if args.plain_disc:
        cfg = dataclasses.replace(cfg, window_walls=False)
    backend = get_backend(cfg)
    backend.priors.resolve("bed")
    modes = ("euclidean", "walking") if args.votes == "both" else (args.votes,)
    print(f"r={cfg.window_radius} m, d={cfg.window_step} m, walls cut windows: {cfg.window_walls}, backend {backend.label}, "
          f"votes: {', '.join(modes)}")
    per_mode: dict[str, dict[str, list[int]]] = {}
    for mode in modes:
        mcfg = dataclasses.replace(cfg, region_votes=mode)
        per_type = per_mode.setdefault(mode, {})
        secs, questions, maps = 0.0, 0, 0
        for seed in range(args.seeds):
            apt = generate_apartment(seed)
            insts = apartment_instances(apt)
            for fl in apt.floors:
                nav = apartment_navmap(apt, fl.index)
                t0 = time.perf_counter()
                rm = region_map(insts, nav, backend, mcfg)
                dt = time.perf_counter() - t0
                secs += dt
                maps += 1
                n_sets = len({w[3] for w in _windows(floor_instances(insts, nav), nav, cfg.window_radius, cfg.window_step,
                                                      cfg.window_walls, walking=mode == "walking" and cfg.window_walls) if w[3]})
                questions += n_sets
                acc = region_accuracy(rm, apt, nav)
                hit, tot = sum(a for a, _ in acc.values()), sum(n for _, n in acc.values())
                print(f"[{mode}] seed {seed} floor {fl.index}: {hit / max(tot, 1):.3f} of {tot} navigable cells; "
                      + ", ".join(f"{k} {a / max(n, 1):.2f}" for k, (a, n) in sorted(acc.items()))
                      + f"; {n_sets} label sets; {dt:.2f} s")
                for k, (a, n) in acc.items():
                    v = per_type.setdefault(k, [0, 0])
                    v[0] += a
                    v[1] += n
        print(f"[{mode}] {maps} maps, {secs / max(maps, 1):.2f} s per map, {questions / max(maps, 1):.1f} region questions per map")
    print("\nper room type (share of navigable cells labelled with the true type):")
    print(f"  {'room type':<12} " + " ".join(f"{m:>10}" for m in modes) + "   cells")
    types = sorted({k for pt in per_mode.values() for k in pt})
    for k in types + ["all"]:
        cells = 0
        row = []
        for m in modes:
            pt = per_mode[m]
            a, n = (sum(v[0] for v in pt.values()), sum(v[1] for v in pt.values())) if k == "all" else tuple(pt.get(k, (0, 0)))
            row.append(f"{a / max(n, 1):>10.3f}")
            cells = n
        print(f"  {k:<12} " + " ".join(row) + f"   {cells}")
    if args.embeddings:
        embedding_agreement(backend.priors)
    return 0


def embedding_agreement(pri) -> None:  # noqa: ANN001 - a semantics.priors.Priors
    """Print how well the embedding fallbacks reproduce the table's best candidates (leave-one-out)."""
    import numpy as np

    from sdovon_mj.semantics.priors import KNN_K, KNN_T, _softmax

    t0 = time.perf_counter()
    objs = sorted(k for k, v in pri.labels.items() if v.get("kind") == "object" and v.get("receptacles"))
    vecs = pri.embedder.encode(objs)
    sims = vecs @ vecs.T
    for kind, cands in (("regions", pri.regions), ("receptacles", pri.receptacles)):
        rows = np.array([[pri.labels[o][kind].get(c, 0.0) for c in cands] for o in objs])
        res = {"direct": [0, 0], "knn": [0, 0]}
        for i, o in enumerate(objs):
            best = set(np.flatnonzero(rows[i] == rows[i].max()).tolist())
            s = pri.embedding_scores(o, list(cands), kind)
            direct = np.array([s[c] for c in cands])
            sim = sims[i].copy()
            sim[[j for j in range(len(objs)) if j == i or np.array_equal(rows[j], rows[i])]] = -9.0  # leave it out
            nn = np.argsort(-sim, kind="stable")[:KNN_K]
            knn = _softmax(sim[nn][None, :].astype(np.float64), KNN_T)[0] @ rows[nn]
            for name, pred in (("direct", direct), ("knn", knn)):
                order = np.argsort(-pred, kind="stable")
                res[name][0] += int(order[0] in best)
                res[name][1] += int(bool(set(order[:2].tolist()) & best))
        n = len(objs)
        print(f"{kind}: direct similarity top-1 {res['direct'][0] / n:.2f} top-2 {res['direct'][1] / n:.2f} "
              f"(temperature {pri._temperature(kind)}); table kNN (leave-one-out, k={KNN_K}) "
              f"top-1 {res['knn'][0] / n:.2f} top-2 {res['knn'][1] / n:.2f}  [{n} objects]")
    print(f"({time.perf_counter() - t0:.1f} s incl. model load)")


if __name__ == "__main__":
    sys.exit(main())
