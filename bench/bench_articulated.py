"""Articulated receptacles (``world.articulated``) through the pipeline: measure what issue 17 asks to show.

Runs `generate` up to the episodes of default-world apartments with articulated furniture (doors and drawers open
for perception, seeded open / closed / ajar per variant) and prints, over all variants:

- the share of resting objects inside articulated receptacles (on a plane whose `part` is set; target >= 20 %),
  and how many objects the parts displaced or tunnelled when they moved;
- the parts' states drawn (open / closed / ajar);
- for every resting object inside a fully closed piece that is a valid goal: whether its goal names the part to open
  (`Goal.open_part`), and for each goal naming a part, the object's pixel fraction in a full agent-camera render
  from its best view point with the part open (must reach eta_gt) and in the variant's state (must stay below).

    python bench/bench_articulated.py                         # apartments 2 and 4, 5 variants each
    python bench/bench_articulated.py --scenes 0 1 --variants 2 --out /tmp/art_bench
    python bench/bench_articulated.py --eval          # then export MJCF bundles and run the A* baselines on them

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
        rc = evaluate_agents(out, args.width)
    return rc


def evaluate_agents(out: Path, width: int) -> int:
    """Export the run as MJCF bundles and print the A* baselines' tables (all episodes, then the inside ones)."""
    from sdovon_mj.config import AgentConfig, NavConfig
    from sdovon_mj.nav.agents import RandomAStar, SemanticAStar
    from sdovon_mj.suite.evaluate import evaluate, inside_table, overall_table, summarize

    mjcf = out.parent / "mjcf"
    if not mjcf.exists():
        proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "export", str(out), "--format", "mjcf", "--out",
                               str(mjcf)], cwd=REPO, capture_output=True, text=True)
        if proc.returncode != 0:
            print(proc.stdout[-3000:], proc.stderr[-3000:])
            return 1
    body, nav = AgentConfig(sensor_width=width, sensor_height=width * 3 // 4), NavConfig()
    rows = {}
    for label, agent in (("semantic-astar", SemanticAStar(nav, agent=body)),
                         ("random-astar", RandomAStar(nav, agent=body)),
                         ("semantic-astar never opens", SemanticAStar(nav, agent=body, open_tries=0))):
        t0 = time.perf_counter()
        res = evaluate(mjcf, agent, nav, progress=False)
        rows[label] = summarize(res)
        opened = sum(1 for r in res if r["info"].get("opened", 0) > 0)
        print(f"{label}: {len(res)} episodes in {time.perf_counter() - t0:.0f} s; opened a part in {opened}", flush=True)
    print(overall_table(rows, paper=False))
    print("\nInside articulated receptacles:\n" + (inside_table(rows) or "(no inside episode)"))
    return 0


def report(out: Path) -> int:
    """Print the figures of a finished run folder."""
    from sdovon_mj.config import load_config
    from sdovon_mj.episodes.generate import build_goals
    from sdovon_mj.episodes.inside import part_opened, seen_fraction
    from sdovon_mj.episodes.viewpoints import load_variant_model
    from sdovon_mj.records import NavMap, ReceptaclePlane, SceneVariant, load_json
    from sdovon_mj.sim.articulation import part_instance, part_joints

    import mujoco

    cfg = load_config(out / "config.yaml")
    eta = cfg.agent.eta_gt
    tot = {"resting": 0, "inside": 0, "displaced": 0, "tunnelled": 0, "placed": 0}
    states = {"open": 0, "closed": 0, "ajar": 0}
    hidden_goals = named = hidden_not_goal = 0
    checks, ok_open, ok_closed = 0, 0, 0
    for vfile in sorted(out.glob("scenes/*/variants/*/variant.json")):
        v = load_json(vfile, SceneVariant)
        scene_dir = vfile.parents[2]
        planes = {p.id: p for p in load_json(scene_dir / "semantics/planes.json", ReceptaclePlane)}
        navmaps = [load_json(p, NavMap) for p in sorted((scene_dir / "observe").glob("navmap_*.json"))]
        tot["placed"] += len(v.placements)
        for p in v.placements:
            tot["resting"] += p.status == "resting"
            tot["displaced"] += p.status == "displaced"
            tot["tunnelled"] += p.status == "tunnelled"
            tot["inside"] += p.status == "resting" and planes[p.plane_id].part is not None
        model, data = load_variant_model(v, out)
        closed_parts = set()
        for j in part_joints(model):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
            q, (lo, hi) = v.articulation[name], model.jnt_range[j]
            kind = "closed" if q <= lo + 1e-9 else "open" if q >= hi - 1e-9 else "ajar"
            states[kind] += 1
            if kind == "closed":
                closed_parts.add(name)
        goals, _floors, rep = build_goals(v, navmaps, out, cfg.episodes, cfg.agent)
        by_obj = {g.object_id: g for g in goals}
        for p in v.resting:  # inside a piece whose every part is closed (a two-door cabinet with one door open shows it)
            piece = [n for n in v.articulation if p.part and part_instance(n) == part_instance(p.part)]
            if p.part and all(n in closed_parts for n in piece):
                g = by_obj.get(p.object_id)
                if g is None:
                    hidden_not_goal += 1
                    continue
                hidden_goals += 1
                named += g.open_part == p.part
        for g in goals:
            if g.open_part is None:
                continue
            checks += 1
            closed = seen_fraction(model, data, g, g.view_points[0], cfg.agent)
            with part_opened(model, data, g.open_part, g.object_id):
                opened = seen_fraction(model, data, g, g.view_points[0], cfg.agent)
            ok_open += opened >= eta
            ok_closed += closed < eta
            print(f"  {v.name} {g.object_id} {g.category:<12} part {g.open_part:<28} open {opened:.5f}  closed {closed:.5f}")
    share = tot["inside"] / max(1, tot["resting"])
    print(f"resting objects: {tot['resting']} of {tot['placed']} placed; inside articulated receptacles: {tot['inside']} "
          f"({100 * share:.1f} %; target >= 20 %)")
    print(f"moved when the parts were set: displaced {tot['displaced']}, tunnelled {tot['tunnelled']}")
    print(f"part states drawn: {states}")
    print(f"resting objects inside a fully closed piece: {hidden_goals + hidden_not_goal}; valid goals {hidden_goals}, "
          f"of which name the part to open: {named}; without any view point even with the part open: {hidden_not_goal}")
    print(f"goals naming a part: {checks}; seen with the part open (>= eta_gt {eta:g}): {ok_open}; "
          f"hidden with the variant's state (< eta_gt): {ok_closed}")
    summary = {"inside_share": share, **tot, "states": states, "hidden_goals": hidden_goals, "named": named,
               "hidden_not_goal": hidden_not_goal, "render_checks": checks, "open_seen": ok_open, "closed_hidden": ok_closed}
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
