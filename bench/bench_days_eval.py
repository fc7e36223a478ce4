"""The lifelong table (issue 50): agents on a chain dataset's days, sealed, in the lifelong order (each scene's days in
order in one agent process, "new day" between days); SR and SPL per day and by goal history, the stale stops.

    python bench/bench_days_eval.py --generate /tmp/days --scenes 0 1 --days 4 --out RESULTS [--width 160] [--jobs 2]
    python bench/bench_days_eval.py --dataset RUN/export/mjcf --out RESULTS         # an export with place.days
    python bench/bench_days_eval.py --out RESULTS --report                           # the tables from RESULTS alone

Rows: Semantic A* (the prior only: the same search order every day) and Semantic A* with object memory (searches
first where it last saw the goal category, forgets a sighting it finds empty), each with the paper's FN, and the
no-prior Semantic Frontier agent without memory (every episode from nothing) and with it (localized: explores towards
where it last saw the goal category first). Only the days are evaluated (the scene's
independent variants, exported beside them, are named and left out). The ordering of the rows is printed as
measured, never required. A killed run resumes (its begun sequences are recorded as not run, as the evaluator does).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

from sdovon_mj.config import AgentConfig, NavConfig, load_config  # noqa: E402
from sdovon_mj.store import json_safe  # noqa: E402
from sdovon_mj.suite import find_bundles, load_bundle  # noqa: E402
from sdovon_mj.suite.evaluation.runner import Row, agent_spec, run_rows  # noqa: E402
from sdovon_mj.suite.evaluation.tables import tables_markdown  # noqa: E402

ROWS = ("semantic-astar", "semantic-astar-memory", "semantic-frontier (no prior)", "semantic-frontier-memory")


def rows(body: AgentConfig, nav: NavConfig) -> list[Row]:
    """Return the table's rows (agents named by spec: built only in their own processes)."""
    plugin = {"semantic-frontier (no prior)": "semantic-frontier"}
    return [Row(label, agent_spec(plugin.get(label, label), nav, 0, agent=body)) for label in ROWS]


def generate_chains(root: Path, scenes: list[int], days: int, k_e: int) -> Path:
    """Generate default-world apartments with a chain of `days` days each (one variant a scene; resumable); return
    the MJCF export."""
    from sdovon_mj.pipeline import generate

    cfg = load_config(None, [f"world.scene_seeds={scenes}", "place.k_v=1", f"place.days={days}",
                             f"episodes.k_e={k_e}", "exporters=[mjcf]"])
    t0 = time.perf_counter()
    summary = generate(root, cfg, jobs=2, progress=False)
    print(f"generated {root} in {time.perf_counter() - t0:.0f} s; failures: {[f.error for f in summary.failures]}")
    return root / "export" / "mjcf"


def report(out: Path) -> dict[str, list[dict]]:
    """Return the per-episode results a results folder holds, by row, over the episodes every row ran."""
    per: dict[str, list[dict]] = {}
    for d in sorted((out / "episodes").iterdir()) if (out / "episodes").is_dir() else []:
        res = [json.loads(p.read_text(encoding="utf-8")) for p in sorted(d.glob("*.json"))]
        if res:
            per[res[0]["agent"]] = sorted(res, key=lambda r: (str(r["scene"]), r.get("day", -1), r["episode_id"]))
    ids = set.intersection(*(set(r["episode_id"] for r in v) for v in per.values())) if per else set()
    return {k: [r for r in v if r["episode_id"] in ids] for k, v in per.items()}


def machine() -> str:
    """Return the machine and commit the figures come from."""
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=Path(__file__).resolve().parent).stdout.strip()
    except OSError:
        commit = "?"
    return (f"{platform.node()}: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; "
            f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; commit {commit}")


def main() -> None:
    """Run (or report) the lifelong table."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", default=None, help="an MJCF export with days (place.days)")
    ap.add_argument("--generate", default=None, help="generate default-world chains into this run folder first")
    ap.add_argument("--scenes", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--days", type=int, default=4)
    ap.add_argument("--k-e", type=int, default=1, help="episodes per goal category and day")
    ap.add_argument("--out", required=True, help="results folder (resumable)")
    ap.add_argument("--width", type=int, default=160, help="camera width in pixels (height 3/4 of it)")
    ap.add_argument("--max-steps", type=int, default=500)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--report", action="store_true", help="print the tables of what --out holds; run nothing")
    a = ap.parse_args()
    out = Path(a.out)
    if not a.report:
        ds = Path(a.dataset) if a.dataset else generate_chains(Path(a.generate), a.scenes, a.days, a.k_e)
        paths = find_bundles(ds)
        days = [p for p in paths if load_bundle(p).day is not None]
        if len(days) < len(paths):
            print(f"left out: {len(paths) - len(days)} variant bundles of {ds} (independent variants, not days)")
        if not days:
            raise SystemExit(f"{ds} holds no days (generate with place.days > 0)")
        body = AgentConfig(sensor_width=a.width, sensor_height=a.width * 3 // 4)
        t0 = time.perf_counter()
        run_rows(days, rows(body, NavConfig(max_steps=a.max_steps)), out=out, jobs=a.jobs)
        print(f"evaluated in {time.perf_counter() - t0:.0f} s")
    per = report(out)
    md, summaries = tables_markdown(per, paper=False, categories=False)
    print(f"# Lifelong table ({machine()})\n\n{md}")
    if not a.report:
        (out / "lifelong.md").write_text(f"{machine()}\n\n{md}", encoding="utf-8")
        (out / "summary.json").write_text(json.dumps(json_safe(summaries), indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
