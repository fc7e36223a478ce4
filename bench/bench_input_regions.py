"""Region maps of a run against the regions its input scene carried: cell accuracy of the LLM sliding window.

    python bench/bench_input_regions.py RUN_DIR [RUN_DIR ...]

For every scene with region annotations in its input (`SceneAsset.rooms`: Habitat ``region_annotations``,
HM3D/MP3D regions with names, the default world's rooms) and every floor: the share of navigable cells inside an
annotated region whose window label (``semantics/regions_<floor>.json``) equals the input's region type
(``semantics.regions=input`` gives that map directly), per region type and overall.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="run folders (generate outputs)")
    args = ap.parse_args(argv)

    import numpy as np

    from sdovon_mj.records import RegionMap, load_json
    from sdovon_mj.runview import RunView
    from sdovon_mj.semantics import input_region_map

    for run in args.runs:
        view = RunView(run)
        for scene in view.scenes():
            if not scene.rooms:
                print(f"{run} {scene.name}: the input has no named regions")
                continue
            for nm in view.navmaps(scene.name):
                path = Path(run) / "scenes" / scene.name / "semantics" / f"regions_{nm.floor}.json"
                window: RegionMap = load_json(path, RegionMap)  # type: ignore[assignment]
                truth = input_region_map(scene.rooms, nm)
                nav = np.asarray(nm.navigable, dtype=bool) & (truth.label_map >= 0)
                got = np.array([window.labels[k] if k >= 0 else "" for k in window.label_map[nav]])
                want = np.array([truth.labels[k] for k in truth.label_map[nav]])
                print(f"{run} {scene.name} floor {nm.floor} ({window.backend}): {nav.sum()} cells, "
                      f"window = input on {np.mean(got == want):.3f}")
                for t in truth.labels:
                    sel = want == t
                    print(f"  {t:<12} {sel.sum():6d} cells  accuracy {np.mean(got[sel] == t):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
