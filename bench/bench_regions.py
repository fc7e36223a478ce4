"""Region map on default-world apartments: agreement with true room types per room type, and timing.

    python bench/bench_regions.py [--seeds 5] [--radius R] [--step D] [--plain-disc] [--votes both|walking|euclidean]
                                  [--embeddings] [--labels]

Ground-truth instances (one per furniture instance, from the apartment mesh), a NavMap rasterised
from the room polygons, the offline backend. Prints, per room type, the share of navigable cells the
region map labels with the true type; the number of distinct window label sets (= region-proposal
questions an LLM backend would get); and seconds per map.

``--labels`` (window votes as configured) compares where the labels come from: the default world's own labels; the
scene written in the HM3D and Matterport3D layouts by the world writers and converted (labels from
``.semantic.txt`` / ``.house``); and node names (`support.node_names`: every label rewritten as modelling
tools and URDF files name parts, walls and floors as primitives), with the naming-noise rules of
`semantics.regions.room_label` and without them (each label only normalised).
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
    ap.add_argument("--labels", action="store_true",
                    help="per-room-type accuracy by label source: world, HM3D and MP3D layouts, node names (with and "
                         "without the naming-noise rules)")
    args = ap.parse_args(argv)

    from sdovon_mj.config import SemanticsConfig
    from sdovon_mj.semantics import get_backend, region_map
    from support.groundtruth import apartment_instances, apartment_navmap, region_accuracy
    from sdovon_mj.semantics.regions import _windows, floor_instances

    from sdovon_mj.world import generate_apartment

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
    if args.labels:
        label_sources(args.seeds, cfg, backend)
    return 0


def label_sources(seeds: int, cfg, backend) -> None:  # noqa: ANN001 - SemanticsConfig, a semantics Backend
    """Print per-room-type accuracy of the region map by where the instance labels come from (see the docstring)."""
    import tempfile
    from pathlib import Path
    from unittest import mock

    import numpy as np

    from assets_convert.scene import convert_scene
    from sdovon_mj.records import Instance
    from sdovon_mj.semantics import region_map, regions
    from sdovon_mj.semantics.validate import normalise
    from sdovon_mj.sim.model import load_scene_mesh
    from support.groundtruth import apartment_instances, apartment_navmap, region_accuracy
    from support.node_names import node_named_instances
    from sdovon_mj.world import STRUCTURE_LABELS, generate_apartment, write_apartment

    def converted(apt, mode: str, tmp: Path) -> list:
        path = write_apartment(apt, tmp / mode, mode, f"apt{apt.seed}")
        asset = convert_scene(path, tmp / f"out_{mode}", cache_dir="off")
        v, f, fi = load_scene_mesh(tmp / f"out_{mode}" / asset.mesh)
        out = []
        for s in asset.instances:
            faces = f[fi == s.id]
            if len(faces) == 0:
                continue
            pts = np.concatenate([v[np.unique(faces)], v[faces].mean(axis=1)])
            c = pts.mean(axis=0)
            out.append(Instance(id=s.id, label=s.label, points=(pts - c).astype(np.float32), center=c, gt_id=s.id))
        return out

    def with_structure(apt) -> list:
        """The apartment's instances, walls and floors included (an artist's scene has them as nodes too)."""
        v, f, fi = (np.asarray(a) for a in (apt.mesh.vertices, apt.mesh.faces, apt.mesh.face_instance))
        out = []
        for inst in apt.instances:
            faces = f[fi == inst.id]
            if len(faces):
                pts = np.concatenate([v[np.unique(faces)], v[faces].mean(axis=1)])
                c = pts.mean(axis=0)
                out.append(Instance(id=inst.id, label=inst.label, points=(pts - c).astype(np.float32), center=c,
                                    gt_id=inst.id))
        return out

    sources = ("world labels", "hm3d layout", "mp3d layout", "node names", "node names, raw")
    totals: dict[str, dict[str, list[int]]] = {s: {} for s in sources}
    with tempfile.TemporaryDirectory(prefix="bench-regions-") as tmp:
        for seed in range(seeds):
            apt = generate_apartment(seed)
            sets = {"world labels": apartment_instances(apt), "hm3d layout": converted(apt, "hm3d", Path(tmp)),
                    "mp3d layout": converted(apt, "mp3d", Path(tmp))}
            sets["node names"] = sets["node names, raw"] = node_named_instances(with_structure(apt), STRUCTURE_LABELS)
            for fl in apt.floors:
                nav = apartment_navmap(apt, fl.index)
                for src in sources:
                    if src == "node names, raw":
                        with mock.patch.object(regions, "room_label", lambda label: normalise(label)):
                            rm = region_map(sets[src], nav, backend, cfg)
                    else:
                        rm = region_map(sets[src], nav, backend, cfg)
                    for k, (a, n) in region_accuracy(rm, apt, nav).items():
                        t = totals[src].setdefault(k, [0, 0])
                        t[0] += a
                        t[1] += n
    print(f"\nper room type by label source ({seeds} apartments, votes {cfg.region_votes}; share of navigable cells "
          "labelled with the true type):")
    print(f"  {'room type':<12} " + " ".join(f"{s:>16}" for s in sources) + "   cells")
    types = sorted({k for t in totals.values() for k in t})
    for k in types + ["all"]:
        row, cells = [], 0
        for src in sources:
            t = totals[src]
            a, n = (sum(v[0] for v in t.values()), sum(v[1] for v in t.values())) if k == "all" else tuple(t.get(k, (0, 0)))
            row.append(f"{a / max(n, 1):>16.3f}")
            cells = n
        print(f"  {k:<12} " + " ".join(row) + f"   {cells}")


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
