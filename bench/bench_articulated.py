"""Articulated receptacles (``world.articulated``) through the pipeline: measure what issue 17 asks to show.

Runs `generate` up to the episodes of default-world apartments with articulated furniture (doors and drawers open
for perception, seeded open / closed / ajar per variant) and prints, over all variants:

- the share of resting objects inside articulated receptacles (on a plane whose `part` is set; target >= 20 %),
  and how many objects the parts displaced or tunnelled when they moved;
- the parts' states drawn (open / closed / ajar);
- for every resting object inside a fully closed piece that is a valid goal: whether its goal names the part to open
  (`Goal.open_part`), and for each goal naming a part, the object's pixel fraction in a render of everything at
  the episodes' visibility size (``episodes.vis_width`` x ``vis_height``, as the suite's "goal seen" check) from its
  first view point with the part open (must reach eta_gt) and in the variant's state (must stay below).

    python bench/bench_articulated.py                         # apartments 2 and 4, 5 variants each
    python bench/bench_articulated.py --scenes 0 1 --variants 2 --out /tmp/art_bench
    python bench/bench_articulated.py --eval          # then export MJCF bundles and run the A* baselines on them
    python bench/bench_articulated.py --eval --inside-only --out /tmp/art/run   # only the inside episodes

With ``--eval`` the run is exported as MJCF bundles and Semantic A*, Random A* (both opening furniture with doors or
drawers where they do not see the goal) and Semantic A* that never opens are evaluated; the tables show every
episode and, apart, the "inside" episodes (a goal hidden in a closed part) and those whose every goal is hidden.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

REPO = Path(__file__).resolve().parents[1]


def _config(scenes: list[int], variants: int, categories: list[str]) -> str:
    """Return the run config YAML."""
    cats = f"  object_categories: [{', '.join(categories)}]\n" if categories else ""
    return (f"name: sdovon-articulated\nseed: 0\nworld:\n  scene_seeds: [{', '.join(map(str, scenes))}]\n  floors: 1\n"
            f"  object_variants: 1\n{cats}  articulated: true\nobserve:\n  width: 320\n  height: 240\n"
            f"place:\n  k_v: {variants}\nepisodes:\n  k_e: 2\n")


def main() -> int:
    """Run the job and print the figures."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, nargs="+", default=[2, 4], help="apartment seeds")
    ap.add_argument("--variants", type=int, default=5, help="variants per apartment")
    ap.add_argument("--categories", nargs="*", default=[], help="object categories (default: all)")
    ap.add_argument("--out", type=Path, default=None, help="run folder (default: a temporary one)")
    ap.add_argument("--eval", action="store_true", help="export MJCF bundles and evaluate the A* baselines on them")
    ap.add_argument("--width", type=int, default=320, help="agent camera width for --eval (height 3/4 of it)")
    ap.add_argument("--inside-only", action="store_true",
                    help="--eval only the episodes with a goal hidden in a closed part (each scene is still explored)")
    args = ap.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="bench_articulated_")) / "run"
    cfg_path = out.parent / "articulated.yaml"
    cfg_path.parent.mkdir(parents=True, exist_ok=True)
    cfg_path.write_text(_config(args.scenes, args.variants, args.categories), encoding="utf-8")
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "episodes", str(out), "--config", str(cfg_path)],
                          cwd=REPO, capture_output=True, text=True)
    if proc.returncode != 0:
        print(proc.stdout[-3000:], proc.stderr[-3000:])
        return 1
    print(f"pipeline to episodes: {time.perf_counter() - t0:.0f} s ({len(args.scenes)} apartments x {args.variants} variants)")
    rc = report(out)
    if rc == 0 and args.eval:
        rc = evaluate_agents(out, args.width, args.inside_only)
    return rc


def evaluate_agents(out: Path, width: int, inside_only: bool = False) -> int:
    """Export the run as MJCF bundles and print the A* baselines' tables (all episodes, then the inside ones)."""
    from dataclasses import replace

    from sdovon_mj.config import AgentConfig, NavConfig
    from sdovon_mj.nav.agents import RandomAStar, SemanticAStar
    from sdovon_mj.suite import find_bundles, load_bundle
    from sdovon_mj.suite.evaluation.loop import evaluate
    from sdovon_mj.suite.evaluation.statistics import summarize
    from sdovon_mj.suite.evaluation.tables import inside_table, overall_table

    mjcf = out.parent / "mjcf"
    if not mjcf.exists():
        proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "export", str(out), "--format", "mjcf", "--out",
                               str(mjcf)], cwd=REPO, capture_output=True, text=True)
        if proc.returncode != 0:
            print(proc.stdout[-3000:], proc.stderr[-3000:])
            return 1
    body, nav = AgentConfig(sensor_width=width, sensor_height=width * 3 // 4), NavConfig()
    data: Path | list = mjcf
    if inside_only:  # the bundles with their inside episodes only (a goal hidden in a closed part)
        data = [replace(b, episodes=kept) for b in map(load_bundle, find_bundles(mjcf))
                if (kept := [e for e in b.episodes if any(g.open_part for g in e.goals)])]
        print(f"inside episodes only: {sum(len(b.episodes) for b in data)} in {len(data)} variants")
    rows = {}
    for label, agent in (("semantic-astar", SemanticAStar(nav, agent=body)),
                         ("random-astar", RandomAStar(nav, agent=body)),
                         ("semantic-astar never opens", SemanticAStar(nav, agent=body, open_tries=0))):
        t0 = time.perf_counter()
        res = evaluate(data, agent, nav, progress=False)
        rows[label] = summarize(res)
        opened = sum(1 for r in res if r["info"].get("opened", 0) > 0)
        print(f"{label}: {len(res)} episodes in {time.perf_counter() - t0:.0f} s; opened a part in {opened}", flush=True)
    print(overall_table(rows, paper=False))
    print("\nInside articulated receptacles:\n" + (inside_table(rows) or "(no inside episode)"))
    return 0


def report(out: Path) -> int:
    """Print the figures of a finished run folder (`sdovon_mj.episodes.audit.audit_inside`)."""
    from sdovon_mj.episodes.audit import audit_inside

    a = audit_inside(out)
    for c in a.checks:
        print(f"  {c.variant} {c.object_id} {c.category:<12} part {c.part:<28} open {c.open_fraction:.5f}  "
              f"closed {c.closed_fraction:.5f}")
    print(f"resting objects: {a.resting} of {a.placed} placed; inside articulated receptacles: {a.inside} "
          f"({100 * a.inside_share:.1f} %; target >= 20 %)")
    print(f"moved when the parts were set: displaced {a.displaced}, tunnelled {a.tunnelled}")
    print(f"part states drawn: {a.states}")
    print(f"resting objects inside a fully closed piece: {a.hidden_goals + a.hidden_not_goal}; valid goals "
          f"{a.hidden_goals}, of which name the part to open: {a.named}, seen through a gap with it closed (render-checked): "
          f"{a.seen_closed}, unexplained: {a.unexplained or 0}; without any view point even with the part open: "
          f"{a.hidden_not_goal}")
    print(f"goals naming a part: {len(a.checks)}; seen with the part open (>= eta_gt {a.eta_gt:g}): {a.open_seen}; "
          f"hidden with the variant's state (< eta_gt): {a.closed_hidden}")
    print(json.dumps(a.summary()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
