"""The honest baselines and what each former privilege was worth (issue 14): prints markdown tables.

    python bench/bench_baselines.py --dataset RUN/export/mjcf [--episodes N] [--width 320] [--quick]
    python bench/bench_baselines.py --generate /tmp/nav300 [--scenes 0 1 2 3] [--variants 3] [--k-e 3]
    python bench/bench_baselines.py --dataset D --per-scene 5 --rows semantic-astar random-astar --json a.json
    python bench/bench_baselines.py --merge a.json b.json        # one table from rows run in separate processes

Rows: Semantic A*, Random A* (own exploration + ExtractPlanes, GT detector, localized), the no-prior Semantic
Frontier agent (GPS+compass only), each with the paper's FN, without FN and with our lattice FN; then Semantic
A* with one former privilege switched on at a time (ORACLE rows: the generator's relevance table, region map,
navigable map) and all of them. Each row: SR, SPL, Soft SPL with 95 % bootstrap intervals, DTG, episodes/min.
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

from sdovon_mj.config import AgentConfig, NavConfig, load_config  # noqa: E402
from sdovon_mj.nav.agents import RandomAStar, SemanticAStar, SemanticFrontierAgent  # noqa: E402
from sdovon_mj.suite import find_bundles, load_bundle  # noqa: E402
from sdovon_mj.suite.evaluate import (episodes_per_minute, evaluate, inside_table, outcome_table,  # noqa: E402
                                      overall_table, paired_table, select_bundles, summarize)

# Orderings the issue asks about, compared on the same episodes (paired bootstrap): the ranking, prior knowledge, FN.
PAIRS = [("semantic-astar", "random-astar"), ("random-astar", "semantic-frontier (no prior)"),
         ("semantic-astar", "semantic-frontier (no prior)"), ("semantic-astar", "semantic-astar no-FN"),
         ("random-astar", "random-astar no-FN"), ("semantic-astar", "semantic-astar facing-only"),
         ("random-astar", "random-astar facing-only")]


def generate_dataset(root: Path, scenes: list[int], variants: int, k_e: int) -> Path:
    """Generate a default-world dataset with the pipeline (resumable); return its MJCF export."""
    from sdovon_mj.pipeline import generate

    cfg = load_config(None, [f"world.scene_seeds={scenes}", f"place.k_v={variants}", f"episodes.k_e={k_e}",
                             "world.object_variants=2", "exporters=[mjcf]"])
    t0 = time.perf_counter()
    summary = generate(root, cfg, jobs=2, progress=False)
    print(f"generated {root} in {time.perf_counter() - t0:.0f} s; failures: {[f.error for f in summary.failures]}")
    return root / "export" / "mjcf"


def print_tables(rows: dict, per_episode: dict | None = None) -> None:
    """Print the overall table, the paired differences, how episodes ended and, when some episodes hide a goal in a
    closed part, the inside table."""
    print(overall_table(rows, paper=False))
    paired = paired_table(per_episode or {}, PAIRS)
    if paired:
        print("\nPaired differences on the same episodes:\n" + paired)
    ended = outcome_table(rows)
    if ended:
        print("\nHow episodes ended (shares):\n" + ended)
    inside = inside_table(rows)
    if inside:
        print("\nInside articulated receptacles:\n" + inside)


def main() -> None:
    """Run the agents and print the tables."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default=None, help="MJCF bundle dataset folder")
    ap.add_argument("--generate", default=None, help="generate a default-world dataset into this run folder first")
    ap.add_argument("--scenes", type=int, nargs="*", default=[0, 1, 2, 3])
    ap.add_argument("--variants", type=int, default=3)
    ap.add_argument("--k-e", type=int, default=3)
    ap.add_argument("--episodes", type=int, default=None)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--quick", action="store_true", help="the three agents with the paper's FN only")
    ap.add_argument("--no-ablation", action="store_true",
                    help="the three agents with the paper's FN and both A* agents without FN (no lattice/ORACLE rows)")
    ap.add_argument("--per-scene", type=int, default=None,
                    help="evaluate the first N variants of every scene (a balanced subset of a large dataset)")
    ap.add_argument("--rows", nargs="*", default=None, help="run only the rows with these labels (as printed, e.g. 'semantic-astar no-FN')")
    ap.add_argument("--json", default=None, help="write the rows' summaries (and per-episode results) to this file")
    ap.add_argument("--merge", nargs="*", default=None,
                    help="print one table from --json files of earlier runs (parts of one row are pooled by episode)")
    ap.add_argument("--part", default=None, metavar="K/N",
                    help="evaluate only the scenes whose sorted index is K modulo N (rows split over processes; "
                         "--merge pools the parts)")
    a = ap.parse_args()
    if a.merge:
        import json

        rows, pooled, speed = {}, {}, {}
        for f in a.merge:
            data = json.loads(Path(f).read_text())
            for label, eps in (data.get("episodes") or {}).items():
                pooled.setdefault(label, []).extend(eps)
                speed.setdefault(label, []).append(data["rows"][label])
            for label, row in data["rows"].items():
                rows.setdefault(label, row)
        for label, eps in pooled.items():
            if len(speed[label]) > 1:  # parts of one row: the summary over every episode, the mean speed
                rows[label] = {**summarize(eps), "knowledge": speed[label][0].get("knowledge", ""),
                               "episodes_per_minute": float(np.mean([r["episodes_per_minute"] for r in speed[label]]))}
        print_tables(rows, pooled)
        return
    root = Path(a.dataset) if a.dataset else generate_dataset(Path(a.generate), a.scenes, a.variants, a.k_e)
    body = AgentConfig(sensor_width=a.width, sensor_height=a.width * 3 // 4)
    lattice = replace(NavConfig(), fn_mode="lattice")
    facing = replace(NavConfig(), look_yaws=1)  # Observe at a navigation point: the receptacle only, no look around
    runs = [("semantic-astar", SemanticAStar(agent=body)), ("random-astar", RandomAStar(agent=body)),
            ("semantic-frontier (no prior)", SemanticFrontierAgent(agent=body)),
            ("semantic-astar search-ranking", SemanticAStar(agent=body, ranking="search")),
            ("semantic-astar facing-only", SemanticAStar(nav=facing, agent=body)),
            ("random-astar facing-only", RandomAStar(nav=facing, agent=body))]
    if not a.quick:
        runs += [("semantic-astar no-FN", SemanticAStar(agent=body, final_nav=False)),
                 ("random-astar no-FN", RandomAStar(agent=body, final_nav=False))]
    if not (a.quick or a.no_ablation):
        runs += [("semantic-astar lattice-FN", SemanticAStar(nav=lattice, agent=body)),
                 ("random-astar lattice-FN", RandomAStar(nav=lattice, agent=body))]
        for parts in (("relevance",), ("region_map",), ("navmap",), ("relevance", "region_map", "navmap")):
            runs.append((f"ORACLE semantic-astar + {'+'.join(parts)}", SemanticAStar(agent=body, oracle_parts=parts)))
    if a.rows is not None:
        runs = [(label, agent) for label, agent in runs if label in a.rows]
    data = select_bundles(root, a.per_scene) if a.per_scene else root
    if a.part:
        k, n = (int(x) for x in a.part.split("/"))
        bundles = data if isinstance(data, list) else [load_bundle(p) for p in find_bundles(root)]
        scenes = sorted({b.episodes[0].scene for b in bundles if b.episodes})
        mine = {sc for i, sc in enumerate(scenes) if i % n == k}
        data = [b for b in bundles if b.episodes and b.episodes[0].scene in mine]
        print(f"part {k}/{n}: scenes {', '.join(sorted(mine))} ({sum(len(b.episodes) for b in data)} episodes)")
    rows, per_episode = {}, {}
    for label, agent in runs:
        t0 = time.perf_counter()
        res = evaluate(data, agent, agent.nav, a.episodes, progress=False)
        rows[label] = {**summarize(res), "knowledge": res[0]["knowledge"] if res else "",
                       "episodes_per_minute": episodes_per_minute(res, time.perf_counter() - t0)}
        per_episode[label] = [{k: r[k] for k in ("episode_id", "scene", "success", "spl", "soft_spl", "inside",
                                                 "must_open", "distance_to_goal", "shortest", "path_length", "outcome")}
                              for r in res]
        print(f"{label}: {len(res)} episodes, SR {rows[label]['success']:.3f}, SPL {rows[label]['spl']:.3f}, "
              f"{rows[label]['episodes_per_minute']:.1f} episodes/min", flush=True)
    if a.json:
        import json

        Path(a.json).write_text(json.dumps({"dataset": str(root), "per_scene": a.per_scene, "rows": rows,
                                            "episodes": per_episode}, default=float, indent=1), encoding="utf-8")
    print()
    print_tables(rows, per_episode)


if __name__ == "__main__":
    main()
