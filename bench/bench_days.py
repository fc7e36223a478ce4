"""Days in a home on the default world: a chain of days per scene and its figures (issue 49).

    python bench/bench_days.py --out /tmp/days [--seeds 0 1] [--days 5] [--jobs 2]

Generates (or resumes) the default world with ``place.days`` on two workers, then prints: per day what stayed, moved,
left and arrived; over every object-day the observed counts against the configured rates' 99.9 % intervals
(`sdovon_mj.stats.day_statistics`); whether identities persist (each object keeps its asset and category, the draws
partition the objects present, ids are never reused); the independent variant check of every day (settled, on its
plane, no interpenetration: `sdovon_mj.place.check_variant`); the moves' mean relevance against every plane's; then
the chains again on two copies of the run: one on one worker, one killed with SIGKILL after its second day and
resumed on two workers, each compared byte for byte with the first. Ends with a markdown section for docs/results.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))


def _generate(run: Path, seeds: list[int], days: int, jobs: int, *more: str, **kw: object) -> subprocess.Popen:
    """Start `sdovon-mj generate` of the default world with a chain of `days` days per scene."""
    sets = ["--set", f"world.scene_seeds={list(seeds)}", "--set", f"place.days={days}"]
    return subprocess.Popen([sys.executable, "-m", "sdovon_mj.cli", "generate", "--out", str(run), "--jobs", str(jobs),
                             "--quiet", *sets, *more], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            **kw)  # type: ignore[call-overload]


def _days_digests(run: Path) -> dict[str, str]:
    """Return the digests of every file of the run's chains of days."""
    from run_digests import run_digests

    return {k: v for k, v in run_digests(run).items() if "/days/" in k}


def identities(view: object) -> tuple[int, list[str]]:
    """Return (object-days checked, problems) of the run's chains: draws partition the objects present, an object
    keeps its asset and category, ids are never reused."""
    problems: list[str] = []
    n = 0
    for scene in view.scene_names():  # type: ignore[attr-defined]
        days = view.days(scene)  # type: ignore[attr-defined]
        changes = [view.day_change(d) for d in days]  # type: ignore[attr-defined]
        ever: dict[str, tuple[str, str]] = {}
        for d in days:
            for p in d.placements:
                if ever.setdefault(p.object_id, (p.asset, p.category)) != (p.asset, p.category):
                    problems.append(f"{d.name}: {p.object_id} changed its asset or category")
        for prev, ch in zip(days, changes[1:]):
            before = {p.object_id for p in prev.resting}
            drawn = [*ch.stayed, *(m.object_id for m in ch.moved), *ch.left]
            n += len(before)
            if sorted(drawn) != sorted(before):
                problems.append(f"{scene} day {ch.day}: the draws do not partition the objects present")
            seen_before = {p.object_id for d in days[:ch.day] for p in d.placements}
            if set(ch.arrived) & seen_before:
                problems.append(f"{scene} day {ch.day}: an arrival reuses an id")
    return n, problems


def main(argv: list[str] | None = None) -> int:
    """Run the bench and print its figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="work folder (run/, copies)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1], help="default-world home seeds (scenes)")
    ap.add_argument("--days", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    from sdovon_mj.place import check_variant
    from sdovon_mj.place.check import PENETRATION_TOL
    from sdovon_mj.runview import RunView
    from sdovon_mj.stats import day_statistics, days_table

    out = Path(a.out)
    run = out / "run"
    t0 = time.perf_counter()
    proc = _generate(run, a.seeds, a.days, a.jobs)
    _, err = proc.communicate()
    if proc.returncode:
        print(err[-3000:], file=sys.stderr)
        return 1
    gen_s = time.perf_counter() - t0
    view = RunView(run)
    stats = day_statistics(run)
    print(days_table(stats))
    n, problems = identities(view)
    print(f"\nidentities: {n} object-days checked, {len(problems)} problems {problems[:5]}")
    checked = failed = 0
    worst = 0.0
    for scene in view.scene_names():
        planes = view.planes(scene)
        for d in view.days(scene):
            c = check_variant(d, planes, run)
            resting = {p.object_id for p in d.resting}
            checked += len(resting)
            failed += sum(1 for o in c.objects if o.object_id in resting and not o.ok)
            worst = max(worst, c.max_penetration)
    print(f"variant checks of every day: {checked} resting objects, {failed} failed, worst object-object penetration "
          f"{1000 * worst:.2f} mm (tolerance {1000 * PENETRATION_TOL:.1f} mm)")
    ref = _days_digests(run)
    same = {}
    for name, jobs, kill in (("one worker", 1, False), ("SIGKILL after day 1, resumed on two workers", 2, True)):
        copy = out / ("copy_kill" if kill else "copy_one")
        if copy.exists():
            shutil.rmtree(copy)
        shutil.copytree(run, copy, symlinks=True)
        for p in copy.glob("scenes/*/days"):
            shutil.rmtree(p)
        more = ("--set", "exporters=[]")
        if kill:
            first = next(iter(sorted(copy.glob("scenes/*")))) / "days"
            p = _generate(copy, a.seeds, a.days, jobs, *more, start_new_session=True)
            while p.poll() is None and not list(first.glob("*_d001/day/.done.json")):
                time.sleep(0.05)
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
        p = _generate(copy, a.seeds, a.days, jobs, *more)
        _, err = p.communicate()
        got = _days_digests(copy) if p.returncode == 0 else {}
        same[name] = got == ref
        print(f"chains rerun ({name}): {len(got)} files, {'the same bytes' if got == ref else 'DIFFERENT'}")
    r = stats["rates"]
    pr = stats["prior"]
    print("\n--- docs/results.md section ---")
    print(f"### Days in a home: {a.days}-day chains on the default world ({time.strftime('%Y-%m-%d')}, "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, generate {gen_s:.0f} s)\n")
    print(f"`python bench/bench_days.py --out DIR --seeds {' '.join(map(str, a.seeds))} --days {a.days}`: "
          f"{len(a.seeds)} apartments (world.scene_seeds), every default object category, place.days = {a.days}.\n")
    print("| outcome | observed | expected | 99.9 % interval | object-days | within |\n|---|---|---|---|---|---|")
    for k, v in r.items():
        print(f"| {k} | {v['observed']} | {v['expected']:.1f} | {v['interval'][0]}-{v['interval'][1]} | "
              f"{v['object_days']} | {'yes' if v['within'] else 'no'} |")
    print(f"\nIdentities: {n} object-days, {len(problems)} problems. Variant checks of every day: {checked} resting "
          f"objects, {failed} failed, worst penetration {1000 * worst:.2f} mm. Moves: {pr['moves']}, mean relevance "
          f"of the plane moved to {pr['mean_relevance_moved_to']:.4f} against {pr['mean_relevance_all_planes']:.4f} "
          f"over every plane. Same bytes: " + "; ".join(f"{k}: {'yes' if v else 'no'}" for k, v in same.items()) + ".")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
