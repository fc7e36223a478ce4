"""The baselines table of the README (issue 30): every row through the sealed protocol, cluster-bootstrap intervals,
the episodes' difficulty and the first visits' budget; resumable per episode, runnable on N processes.

    python bench/bench_baselines.py --dataset RUN/export/mjcf --out RESULTS [--per-scene 5] [--jobs 2] [--width 320]
    python bench/bench_baselines.py --dataset D --out RESULTS --rows "semantic-astar" "random-astar"   # some rows
    python bench/bench_baselines.py --out RESULTS --report          # the tables from what RESULTS holds, nothing run
    python bench/bench_baselines.py --generate /tmp/nav --scenes 0 1 --variants 2 --k-e 1 --out RESULTS   # small job

A killed run resumes where it stopped: run the same command again (finished episodes are read back from
``RESULTS/episodes``; a row on a scene whose episodes are not all done explores that scene again). Work is cut into
one row on one scene at a time, spread over ``--jobs`` processes.

Rows (``ROWS``; ``--full`` adds the ablations): Semantic A*, Random A* (own first visit + ExtractPlanes, GT category
sensor, localized) and the no-prior Semantic Frontier agent (GPS+compass only), each with the paper's FN
(Navigate(p_g | eps_nav), then STOP); the same three with our FN with retries (STOP where the object is in view
within the view radius, other places tried); both A* agents without FN; the distance-aware Semantic A* (relevance
per metre of path) beside the paper's order; and the cross-prior row, Semantic A* ranking with the curated table
(`semantics.offline_model=table`) while the objects were placed by the learned model. ``--full`` adds the search
ranking, the facing-only look, our lattice FN and the ORACLE rows (the generator's relevance, region map, navmap).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

from sdovon_mj.config import AgentConfig, NavConfig, SemanticsConfig, load_config  # noqa: E402
from sdovon_mj.suite import find_bundles, load_bundle  # noqa: E402
from sdovon_mj.store import json_safe  # noqa: E402
from sdovon_mj.suite.evaluation.runner import Row, agent_spec, run_rows, select_bundles  # noqa: E402
from sdovon_mj.suite.evaluation.tables import tables_markdown  # noqa: E402

# The orderings the table is read for, each on the same episodes (paired, cluster bootstrap).
PAIRS = [("semantic-astar", "random-astar"), ("random-astar", "semantic-frontier (no prior)"),
         ("semantic-astar", "semantic-frontier (no prior)"), ("semantic-astar", "semantic-astar no-FN"),
         ("random-astar", "random-astar no-FN"), ("semantic-astar FN-retry", "semantic-astar"),
         ("random-astar FN-retry", "random-astar"), ("semantic-frontier FN-retry", "semantic-frontier (no prior)"),
         ("semantic-astar per-metre", "semantic-astar"), ("semantic-astar", "semantic-astar table-semantics"),
         ("semantic-astar", "semantic-astar facing-only"), ("random-astar", "random-astar facing-only")]


def rows(body: AgentConfig, full: bool, mode: str = "sealed") -> list[Row]:
    """Return the table's rows (agents named by spec: built only in their own processes)."""
    nav = NavConfig()
    retry = replace(nav, fn_mode="retry")

    def r(label: str, name: str, nav_: NavConfig = nav, final_nav: bool = True, **kw) -> Row:
        return Row(label, agent_spec(name, nav_, 0, final_nav=final_nav, agent=body, **kw), mode)

    out = [r("semantic-astar", "semantic-astar"), r("random-astar", "random-astar"),
           r("semantic-frontier (no prior)", "semantic-frontier"),
           r("semantic-astar FN-retry", "semantic-astar", retry), r("random-astar FN-retry", "random-astar", retry),
           r("semantic-frontier FN-retry", "semantic-frontier", retry),
           r("semantic-astar no-FN", "semantic-astar", final_nav=False),
           r("random-astar no-FN", "random-astar", final_nav=False),
           r("semantic-astar per-metre", "semantic-astar", per_metre=True),
           r("semantic-astar table-semantics", "semantic-astar", semantics=SemanticsConfig(offline_model="table"))]
    if full:
        lattice, facing = replace(nav, fn_mode="lattice"), replace(nav, look_yaws=1)
        out += [r("semantic-astar search-ranking", "semantic-astar", ranking="search"),
                r("semantic-astar facing-only", "semantic-astar", facing),
                r("random-astar facing-only", "random-astar", facing),
                r("semantic-astar lattice-FN", "semantic-astar", lattice),
                r("random-astar lattice-FN", "random-astar", lattice)]
        for parts in (("relevance",), ("region_map",), ("navmap",), ("relevance", "region_map", "navmap")):
            out.append(r(f"ORACLE semantic-astar + {'+'.join(parts)}", "semantic-astar", oracle_parts=parts))
    return out


def generate_dataset(root: Path, scenes: list[int], variants: int, k_e: int) -> Path:
    """Generate a default-world dataset with the pipeline (resumable); return its MJCF export."""
    from sdovon_mj.pipeline import generate

    cfg = load_config(None, [f"world.scene_seeds={scenes}", f"place.k_v={variants}", f"episodes.k_e={k_e}",
                             "world.object_variants=2", "exporters=[mjcf]"])
    t0 = time.perf_counter()
    summary = generate(root, cfg, jobs=2, progress=False)
    print(f"generated {root} in {time.perf_counter() - t0:.0f} s; failures: {[f.error for f in summary.failures]}")
    return root / "export" / "mjcf"


def report(out: Path, labels: list[str] | None = None) -> dict[str, list[dict]]:
    """Return the per-episode results a results folder holds, by row (labels: the folders' names, or `labels`)."""
    per: dict[str, list[dict]] = {}
    for d in sorted((out / "episodes").iterdir()) if (out / "episodes").is_dir() else []:
        res = [json.loads(p.read_text(encoding="utf-8")) for p in sorted(d.glob("*.json"))]
        if res:
            per[res[0]["agent"]] = res
    if labels:
        per = {k: per[k] for k in labels if k in per}
    ids = set.intersection(*(set(r["episode_id"] for r in v) for v in per.values())) if per else set()
    return {k: [r for r in v if r["episode_id"] in ids] for k, v in per.items()}  # the episodes every row ran


def main() -> None:
    """Run the rows (or read them back) and print the tables."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default=None, help="MJCF bundle dataset folder")
    ap.add_argument("--generate", default=None, help="generate a default-world dataset into this run folder first")
    ap.add_argument("--scenes", type=int, nargs="*", default=[0, 1, 2, 3])
    ap.add_argument("--variants", type=int, default=3)
    ap.add_argument("--k-e", type=int, default=3)
    ap.add_argument("--out", required=True, help="results folder (per-episode JSON; a rerun resumes)")
    ap.add_argument("--episodes", type=int, default=None, help="the first N episodes of the (selected) dataset")
    ap.add_argument("--per-scene", type=int, default=None,
                    help="evaluate the first N variants of every scene (a balanced subset of a large dataset)")
    ap.add_argument("--width", type=int, default=320, help="camera width (height: 3/4 of it)")
    ap.add_argument("--jobs", type=int, default=1, help="processes (one row on one scene at a time)")
    ap.add_argument("--full", action="store_true", help="add the ablation rows (search ranking, facing only, "
                                                        "lattice FN, ORACLE privileges)")
    ap.add_argument("--rows", nargs="*", default=None, help="run only the rows with these labels")
    ap.add_argument("--in-process", action="store_true", help="run the agents in-process (debugging)")
    ap.add_argument("--report", action="store_true", help="print the tables of what --out holds, run nothing")
    a = ap.parse_args()
    out = Path(a.out)
    body = AgentConfig(sensor_width=a.width, sensor_height=a.width * 3 // 4)
    table = rows(body, a.full, "in-process" if a.in_process else "sealed")
    if a.rows is not None:
        table = [r for r in table if r.label in a.rows]
    if a.report:
        per = report(out, [r.label for r in table] if a.rows is not None else None)
    else:
        root = Path(a.dataset) if a.dataset else generate_dataset(Path(a.generate), a.scenes, a.variants, a.k_e)
        data = select_bundles(root, a.per_scene) if a.per_scene else [load_bundle(p) for p in find_bundles(root)]
        print(f"{len(table)} rows x {sum(len(b.episodes) for b in data)} episodes "
              f"({len({b.episodes[0].scene for b in data if b.episodes})} scenes, {len(data)} variants), "
              f"{a.width}x{body.sensor_height}, {a.jobs} processes -> {out}", flush=True)
        t0 = time.perf_counter()
        per = run_rows(data, table, out, jobs=a.jobs, episodes=a.episodes)
        print(f"wall time {time.perf_counter() - t0:.0f} s", flush=True)
    md, summaries = tables_markdown(per, PAIRS, paper=False, categories=False)
    speed = "\n".join(f"- {k}: {s.get('episodes_per_minute', float('nan')):.1f} episodes/min per process (episodes only)"
                      + (f", first visit {s['first_visit']['seconds']:.0f} s per scene" if s.get("first_visit") else "")
                      for k, s in summaries.items())
    md += "\n## Speed (shared machine: indicative)\n\n" + speed + "\n"
    out.mkdir(parents=True, exist_ok=True)
    (out / "tables.md").write_text(md, encoding="utf-8")
    (out / "summary.json").write_text(json.dumps(json_safe(summaries), indent=1, sort_keys=True) + "\n", encoding="utf-8")
    print(md)


if __name__ == "__main__":
    main()
