"""Benchmark `generate` on a scaled-down SD-OVON-3k-shaped job; extrapolate to the full size.

SD-OVON-3k (paper table 1): 8 scenes, 363 variants (~45 per scene), ~2.9k episodes (~8 per variant).
Scaled down (defaults): 2 default-world apartments x 6 variants = 12 variants, with the per-variant
episode density kept near 8 (k_e episodes per goal category; the density is measured and printed).
Time is split into per-scene stages (world, convert, observe, perceive, semantics), which scale with the
number of scenes, and per-variant stages (place, episodes), which scale with the number of variants; the
full-size estimate is 8 x (per-scene seconds) + 363 x (per-variant seconds) + exports, divided by the
number of parallel workers (ideal scaling; both kinds of task are independent). Object conversion is
reported apart: the goal is stated "once assets are converted" (the converter caches them by content).

Peak memory per stage is each stage's peak resident set (VmHWM, reset at the start of the stage) in the
process that ran it, as recorded in timings.json. A second run measures a scan-mode apartment of about
500k triangles (`write_apartment(..., mode="scan", max_faces=500_000)`) through the whole scene pipeline.

With ``--full 3k`` (8 scenes x 45 variants) or ``--full 10k`` (25 scenes x 45 variants), 12 categories,
the bench runs the full-size job itself (no scan run) and prints the measured wall time beside the
extrapolation from the same run's per-stage seconds. ``--set world.preset=house`` runs it on the default
world's houses (8-16 rooms over their seeded 1-3 storeys, docs/world.md) instead of one-storey apartments, and
prints the houses' statistics (rooms, storeys, navigable area, instances per room, geodesic quartiles). ``--profile N`` (default 8) re-runs the observe,
perceive, place and episodes stages of the first scene / variant under cProfile on a copy of the job
and prints each stage's top N functions by own time (0: skip).

    python bench/bench_generate.py                      # 2 scenes x 6 variants + the scan apartment
    python bench/bench_generate.py --scenes 1 --variants 2 --no-scan    # quicker
    python bench/bench_generate.py --full 3k            # the SD-OVON-3k-size job, measured (idle machine!)
    python bench/bench_generate.py --full 3k --set world.preset=house    # the same on houses
    python bench/bench_generate.py --big                # the HM3D-size scene (>= 500 instances, >= 1.5 M triangles)

``--big`` writes one scene of HM3D-Semantics size with the HM3D layout writer (`big_hm3d_scene`: default-world
apartments side by side, their triangles split until the scene has ``--big-faces``; HM3DSem averages about 660
instances per scene) and runs it through `generate` in one worker, printing each stage's wall seconds and peak
resident memory (goal: < 4 GB per worker). ``--digests FILE`` writes the digest of every output of that run,
``--against FILE`` compares the run with another code version's digests (the byte check of a speed-up).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

# Paper table 1 sizes (the extrapolation target) and the job --full runs (45 variants per scene).
SIZES = {"3k": {"name": "SD-OVON-3k", "scenes": 8, "variants": 363, "episodes": 2900, "job_variants": 45},
         "10k": {"name": "SD-OVON-10k", "scenes": 25, "variants": 1127, "episodes": 10629, "job_variants": 45}}
FULL = SIZES["3k"]
PROFILED = ("observe", "perceive", "place", "episodes")
SCENE_STAGES = ("world:scene", "convert", "observe", "perceive", "semantics")
VARIANT_STAGES = ("place", "episodes")
CATEGORIES = ["mug", "bowl", "plate", "book", "bottle", "apple", "pillow", "laptop", "toothbrush", "towel", "vase",
              "remote"]


def house_preset(args: argparse.Namespace) -> bool:
    """Whether the job's homes are houses (``--set world.preset=house``)."""
    return any(x.replace(" ", "") == "world.preset=house" for x in args.set)


def bench_config(args: argparse.Namespace, scene_seeds: list[int], k_v: int):
    """Return the RunConfig of the scaled job (apartments of one storey; houses of their seeded 1-3 storeys)."""
    from sdovon_mj.config import load_config

    floors = "world.floors=0" if house_preset(args) else "world.floors=1"
    sets = [f"world.scene_seeds={scene_seeds}", floors, "world.object_variants=1",
            f"world.object_categories={CATEGORIES[: args.categories]}", f"observe.width={args.width}",
            f"observe.height={args.height}", f"place.k_v={k_v}", f"episodes.k_e={args.k_e}", "name=bench-generate"]
    return load_config(args.config, sets + list(args.set))


def run_job(out: Path, cfg, jobs: int, scenes: list[str] | None = None) -> tuple[dict, float]:
    """Run generate into `out`; return (timings.json, wall seconds)."""
    from sdovon_mj.pipeline import generate

    t0 = time.perf_counter()
    summary = generate(out, cfg, scenes=scenes, jobs=jobs, progress=None)
    wall = time.perf_counter() - t0
    for f in summary.failures:
        print(f"  FAILED {f.spec.label}: {f.error}", file=sys.stderr)
    return json.loads((out / "timings.json").read_text()), wall


def per_stage(timings: dict) -> tuple[dict[str, float], dict[str, float], dict[str, int]]:
    """Return seconds per stage (summed over tasks), peak MiB per stage (max over tasks), tasks per stage."""
    secs: dict[str, float] = {}
    peak: dict[str, float] = {}
    count: dict[str, int] = {}
    for t in timings["tasks"]:
        for k, v in t["seconds"].items():
            secs[k] = secs.get(k, 0.0) + v
            count[k] = count.get(k, 0) + 1
        for k, v in t.get("peak_rss_mb", {}).items():
            peak[k] = max(peak.get(k, 0.0), v)
    return secs, peak, count


def episodes_in(out: Path) -> tuple[int, int]:
    """Return (variants, episodes) written in a run folder."""
    files = sorted(out.glob("scenes/*/variants/*/episodes.json"))
    return len(files), sum(len(json.loads(p.read_text())) for p in files)


def episode_breakdown(out: Path, cfg, limit: int) -> None:
    """Re-run the episodes stage's function on up to `limit` variants and print where its time goes."""
    from sdovon_mj.episodes.generate import generate_episodes_with_report
    from sdovon_mj.records import SceneVariant, load_json
    from sdovon_mj.runview import RunView

    view = RunView(out)
    tot: dict[str, float] = {}
    n = goals = 0
    for vf in sorted(out.glob("scenes/*/variants/*/variant.json"))[:limit]:
        v = load_json(vf, SceneVariant)
        t0 = time.perf_counter()
        _eps, rep = generate_episodes_with_report(v, view.navmaps(v.scene), out, cfg.episodes, 0, cfg.agent)
        tot["total_s"] = tot.get("total_s", 0.0) + time.perf_counter() - t0
        for k, x in rep.timing.items():
            tot[k] = tot.get(k, 0.0) + float(x)
        n += 1
        goals += len(rep.kept)
    if not n:
        return
    m = {k: x / n for k, x in tot.items()}
    other = m["total_s"] - m["load_s"] - m["rays_s"] - m["pixel_rays_s"] - m["render_s"] - m["starts_s"]
    print(f"\nepisodes stage, where the time goes (mean of {n} variants, {goals / n:.1f} goals and "
          f"{m['view_points']:.0f} view points per variant):")
    print(f"  total {m['total_s']:.2f} s = model load {m['load_s']:.2f} + ray pre-test {m['rays_s']:.2f} "
          f"({m['rays']:.0f} candidates) + pixel rays {m['pixel_rays_s']:.2f} ({m['ray_confirmed']:.0f} view points "
          f"confirmed without a render) + visibility renders {m['render_s']:.2f} ({m['renders']:.0f} renders, "
          f"{m.get('renders_skipped', 0):.0f} skipped by the pixel bound, "
          f"{1000 * m['render_s'] / max(m['renders'], 1):.1f} ms each) + start poses {m['starts_s']:.2f} + other {other:.2f}")


def profile_stages(out: Path, cfg, top: int) -> None:
    """Re-run each stage of PROFILED once (first scene, first variant) under cProfile on a copy of the job.

    Prints, per stage, its seconds and the `top` functions by own time (the copy keeps the job's bytes
    and stage markers untouched; the stage writes the same bytes into the copy).
    """
    import cProfile
    import pstats
    import shutil

    from sdovon_mj.stages import STAGES, StageContext
    from sdovon_mj.store import Store

    scenes = sorted(p.name for p in (out / "scenes").iterdir() if p.is_dir()) if (out / "scenes").is_dir() else []
    if not scenes:
        return
    copy = out.parent / (out.name + "_profile")
    shutil.rmtree(copy, ignore_errors=True)
    shutil.copytree(out, copy)
    store = Store(copy)
    print(f"\nwhere each stage's time goes (cProfile, one task each, top {top} functions by own time):")
    for name in PROFILED:
        stage = STAGES[name]
        ctx = StageContext(store, cfg, scenes[0], 0 if stage.scope == "variant" else -1, "")
        prof = cProfile.Profile()
        t0 = time.perf_counter()
        prof.enable()
        try:
            stage.make(ctx)
        finally:
            prof.disable()
        wall = time.perf_counter() - t0
        st = pstats.Stats(prof)
        rows = sorted(st.stats.items(), key=lambda kv: -kv[1][2])[:top]  # (file, line, func) -> (cc, nc, tt, ct, callers)
        print(f"  {name} ({ctx.scene}{'/v0' if ctx.variant == 0 else ''}): {wall:.2f} s under the profiler")
        for (fname, line, func), (_cc, nc, tt, ct, _callers) in rows:
            where = f"{Path(fname).name}:{line}" if line else "~"
            print(f"    {tt:7.2f} s own {ct:7.2f} s cum {nc:8d} calls  {func} ({where})")
    shutil.rmtree(copy, ignore_errors=True)


def big_hm3d_scene(out: Path, apartments: int = 12, faces: int = 1_500_000) -> Path:
    """Write one HM3D-layout scene of `apartments` default-world apartments (one floor each) side by side in a grid,
    every triangle split 1-to-4 (the largest first in the last round) until the scene has at least `faces`
    triangles; return its ``<name>.glb``. Instance and room ids are renumbered; labels and room types are kept."""
    import dataclasses

    import numpy as np

    from sdovon_mj.world import WorldMesh, generate_apartment, write_apartment

    apts = [generate_apartment(seed, floors=1) for seed in range(apartments)]
    cols = int(np.ceil(np.sqrt(apartments)))
    verts, tris, finst, fcol, fmat, insts, rooms = [], [], [], [], [], [], []
    nv = 0
    for k, apt in enumerate(apts):
        off = np.array([(k % cols) * 12.0, (k // cols) * 12.0, 0.0])  # apartments are under 10 m across
        room_of = {r.id: len(rooms) + j for j, r in enumerate(apt.rooms)}
        rooms += [dataclasses.replace(r, id=room_of[r.id], polygon=np.asarray(r.polygon) + off[:2]) for r in apt.rooms]
        inst_of = {i.id: len(insts) + j for j, i in enumerate(apt.instances)}
        insts += [dataclasses.replace(i, id=inst_of[i.id], room=room_of.get(i.room, -1)) for i in apt.instances]
        m = apt.mesh
        verts.append(m.vertices + off)
        tris.append(m.faces + nv)
        nv += len(m.vertices)
        finst.append(np.vectorize(inst_of.get)(m.face_instance).astype(np.int32))
        fcol.append(m.face_color)
        fmat.append(m.face_material)
    v, f = np.concatenate(verts), np.concatenate(tris)
    attrs = [np.concatenate(finst), np.concatenate(fcol), np.concatenate(fmat)]
    while len(f) < faces:  # split: a round of all triangles, or the largest ones when a round would overshoot
        tri = v[f]
        area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        n_split = len(f) if 4 * len(f) <= faces else int(np.ceil((faces - len(f)) / 3))
        split = np.argsort(-area, kind="stable")[:n_split]
        keep = np.setdiff1d(np.arange(len(f)), split)
        a, b, c = f[split, 0], f[split, 1], f[split, 2]
        mids = (v[a] + v[b]) / 2, (v[b] + v[c]) / 2, (v[c] + v[a]) / 2
        base = len(v)
        v = np.concatenate([v, *mids])
        n = len(split)
        ab, bc, ca = base + np.arange(n), base + n + np.arange(n), base + 2 * n + np.arange(n)
        new = np.concatenate([np.stack(t, axis=1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
        f = np.concatenate([f[keep], new])
        attrs = [np.concatenate([x[keep], np.tile(x[split], (4,) + (1,) * (x.ndim - 1))]) for x in attrs]
    mesh = WorldMesh(vertices=v, faces=f, face_instance=attrs[0], face_color=attrs[1], face_material=attrs[2])
    big = dataclasses.replace(apts[0], instances=tuple(insts), rooms=tuple(rooms), mesh=mesh, doors=(), articulated=())
    return write_apartment(big, out, mode="hm3d", name="big_hm3d")


class TreeMemory:
    """The peak resident memory of a process and its descendants together, sampled every second (Linux /proc)."""

    def __init__(self, pid: int) -> None:
        import threading

        self.pid, self.peak_mb, self._stop = pid, 0.0, threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _tree_rss_mb(self) -> float:
        children: dict[int, list[int]] = {}
        for d in Path("/proc").iterdir():
            if d.name.isdigit():
                try:
                    ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
                except (OSError, IndexError, ValueError):
                    continue
                children.setdefault(ppid, []).append(int(d.name))
        total, todo = 0.0, [self.pid]
        while todo:
            pid = todo.pop()
            todo += children.get(pid, [])
            try:
                total += int((Path("/proc") / str(pid) / "statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE")
            except (OSError, IndexError, ValueError):
                pass
        return total / 2**20

    def _run(self) -> None:
        while not self._stop.wait(1.0):
            self.peak_mb = max(self.peak_mb, self._tree_rss_mb())

    def stop(self) -> None:
        """Stop sampling."""
        self._stop.set()
        self._thread.join()


def run_big(args: argparse.Namespace, work: Path) -> None:
    """Write the HM3D-size scene, run it through generate in one worker, print per-stage seconds and peak memory."""
    from sdovon_mj.memory import peak_rss_mb, reset_peak_rss

    reset_peak_rss()
    t0 = time.perf_counter()
    glb = big_hm3d_scene(work / "big_input", args.big_apartments, args.big_faces)
    write_s, write_mb = time.perf_counter() - t0, peak_rss_mb()
    lines = (glb.parent / "big_hm3d.semantic.txt").read_text().splitlines()[1:]
    import trimesh

    n_faces = len(trimesh.load(glb, force="mesh", process=False).faces)
    print(f"big HM3D-layout scene {glb}: {len(lines)} labelled instances, {n_faces} triangles; written in "
          f"{write_s:.0f} s, peak {write_mb:.0f} MiB", flush=True)
    t0 = time.perf_counter()
    from sdovon_mj.inputs import check_inputs

    check_inputs([str(glb)])
    print(f"up-front input check: {time.perf_counter() - t0:.2f} s")
    # generate in a fresh process (one worker: jobs 1 runs the tasks in it), so its memory is the worker's own and
    # not what writing the scene left in this one
    import subprocess

    from sdovon_mj.config import dump_yaml

    cfg = bench_config(args, [0], args.variants)
    (work / "big_config.yaml").write_text(dump_yaml(cfg), encoding="utf-8")
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "sdovon_mj.cli", "generate", "--out", str(work / "big_job"),
                             "--scenes", str(glb), "--config", str(work / "big_config.yaml"), "--jobs", "1", "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    tree_peak = TreeMemory(proc.pid)
    out, err = proc.communicate()
    wall = time.perf_counter() - t0
    tree_peak.stop()
    if proc.returncode != 0:
        print(f"generate exited {proc.returncode}: {err.strip()[-2000:]}")
    for line in err.splitlines():
        if line.startswith("note:"):
            print(line)
    timings = json.loads((work / "big_job" / "timings.json").read_text())
    secs, peak, _count = per_stage(timings)
    print(f"\nstage          seconds   peak MiB  (one worker; generate wall {wall:.0f} s)")
    for k in sorted(secs, key=lambda k: -secs[k]):
        print(f"  {k:<12} {secs[k]:9.1f} {peak.get(k, 0):9.0f}")
    top = max(peak.values(), default=0.0)
    print(f"peak memory of a worker {top:.0f} MiB = {top * 2**20 / 1e9:.2f} GB (goal < 4 GB): "
          f"{'OK' if top * 2**20 < 4e9 else 'OVER'}")
    print(f"peak of generate's processes together (the command and its workers, sampled every second): "
          f"{tree_peak.peak_mb:.0f} MiB = {tree_peak.peak_mb * 2**20 / 1e9:.2f} GB")
    print(f"load average (1, 5, 15 min): {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} CPUs "
          "(figures taken on a shared machine are noisy)")
    byte_check(work / "big_job", args.digests, args.against)


def byte_check(run: Path, write: str | None, against: str | None) -> None:
    """Write the run's output digests to `write` and/or compare them with those in `against`, printing the verdict
    (same files, same bytes) and the first paths that differ."""
    if not (write or against):
        return
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    from run_digests import digest_diff, run_digests

    got = run_digests(run)
    if write:
        Path(write).write_text(json.dumps(got, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        print(f"digests of {len(got)} outputs written to {write}")
    if against:
        want = json.loads(Path(against).read_text(encoding="utf-8"))
        differ, only_new, only_old = digest_diff(want, got)
        same = not (differ or only_new or only_old)
        print(f"byte check against {against}: {len(got)} outputs, {len(differ)} differ, {len(only_new)} new, "
              f"{len(only_old)} missing: {'IDENTICAL' if same else 'DIFFERENT'}")
        for k in (differ + only_new + only_old)[:10]:
            print(f"  {k}")


def main() -> None:
    """Run the scaled job (+ the scan apartment) and print figures."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", type=int, default=2, help="default-world apartments (SD-OVON-3k: 8)")
    ap.add_argument("--variants", type=int, default=6, help="variants per scene (SD-OVON-3k: ~45)")
    ap.add_argument("--categories", type=int, default=8, help="object categories in the library")
    ap.add_argument("--k-e", type=int, default=1, help="episodes per goal category per variant")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--jobs", type=int, default=2, help="local worker processes")
    ap.add_argument("--config", default=None, help="base YAML config")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="extra config overrides")
    ap.add_argument("--out", default=None, help="work folder (default: a temp folder)")
    ap.add_argument("--scan-faces", type=int, default=500_000, help="triangles of the scan-mode apartment")
    ap.add_argument("--no-scan", action="store_true", help="skip the scan-mode memory run")
    ap.add_argument("--breakdown", type=int, default=4, help="variants re-run to print where the episodes stage's time goes")
    ap.add_argument("--profile", type=int, default=8, metavar="N",
                    help="print each stage's top N functions (cProfile re-run of one task; 0: skip)")
    ap.add_argument("--full", choices=sorted(SIZES), default=None,
                    help="run the full-size job (3k: 8 x 45, 10k: 25 x 45 variants, 12 categories) and print "
                         "its measured wall time beside the extrapolation (run it on an idle machine)")
    ap.add_argument("--big", action="store_true", help="only the HM3D-size scene: >= 500 instances, >= 1.5 M triangles")
    ap.add_argument("--big-apartments", type=int, default=12, help="default-world apartments in the big scene")
    ap.add_argument("--big-faces", type=int, default=1_500_000, help="triangles of the big scene")
    ap.add_argument("--digests", default=None, metavar="FILE",
                    help="--big: write the digest of every output of the big scene's run here (tools/run_digests.py)")
    ap.add_argument("--against", default=None, metavar="FILE",
                    help="--big: compare the run's outputs with digests another code version wrote (--digests): "
                         "the byte check of a speed-up, run once at the end")
    args = ap.parse_args()
    if args.big:
        work = Path(args.out or tempfile.mkdtemp(prefix="bench_generate_big_"))
        work.mkdir(parents=True, exist_ok=True)
        if args.variants == 6:
            args.variants = 1
        run_big(args, work)
        return
    global FULL
    if args.full:
        FULL = SIZES[args.full]
        args.scenes, args.variants, args.categories, args.no_scan = FULL["scenes"], FULL["job_variants"], 12, True
    work = Path(args.out or tempfile.mkdtemp(prefix="bench_generate_"))
    work.mkdir(parents=True, exist_ok=True)

    # ---- the scaled SD-OVON-3k-shaped job
    cfg = bench_config(args, list(range(args.scenes)), args.variants)
    out = work / "job"
    print(f"job: {args.scenes} scenes x {args.variants} variants, {args.categories} categories, k_e={args.k_e}, "
          f"{args.width}x{args.height}, {args.jobs} workers -> {out}", flush=True)
    timings, wall = run_job(out, cfg, args.jobs)
    secs, peak, count = per_stage(timings)
    n_var, n_eps = episodes_in(out)
    objects_wall = sum(sum(t["seconds"].values()) for t in timings["tasks"] if t["task"] == "objects")
    wall_ex = wall - objects_wall  # the objects task runs alone, before the others
    print(f"\nvariants {n_var}, episodes {n_eps} ({n_eps / max(n_var, 1):.1f} per variant; {FULL['name']}: "
          f"{FULL['episodes'] / FULL['variants']:.1f})")
    print(f"wall {wall:.0f} s, of which object library + conversion {objects_wall:.0f} s (cached objects: fast)")
    print(f"episodes per hour (wall, objects excluded): {3600 * n_eps / max(wall_ex, 1e-9):.0f}")
    print("\nstage          tasks   seconds  s/task   peak MiB")
    for k in sorted(secs, key=lambda k: -secs[k]):
        print(f"  {k:<12} {count[k]:5d} {secs[k]:9.1f} {secs[k] / count[k]:7.2f} {peak.get(k, 0):9.0f}")
    scene_s = sum(secs.get(k, 0.0) for k in SCENE_STAGES) / max(args.scenes, 1)
    var_s = sum(secs.get(k, 0.0) for k in VARIANT_STAGES) / max(n_var, 1)
    exp_s = sum(v for k, v in secs.items() if k.startswith("export")) / max(n_var, 1)
    full_cpu = FULL["scenes"] * scene_s + FULL["variants"] * (var_s + exp_s)
    print(f"\nper scene {scene_s:.1f} s, per variant {var_s:.2f} s (+ export {exp_s:.2f} s)")
    print(f"extrapolated {FULL['name']} ({FULL['scenes']} scenes, {FULL['variants']} variants, "
          f"~{FULL['episodes']} episodes): {full_cpu / 60:.1f} task-minutes = {full_cpu / 60 / args.jobs:.1f} min "
          f"on {args.jobs} workers (goal: < 30 min on 2 cores), "
          f"{3600 * FULL['episodes'] / max(full_cpu / args.jobs, 1e-9):.0f} episodes per hour")
    where = sorted(((k, v) for k, v in secs.items() if k not in ("objects", "world:objects")), key=lambda kv: -kv[1])
    full_split = {k: (FULL["scenes"] / args.scenes if k in SCENE_STAGES else FULL["variants"] / max(n_var, 1)) * v
                  for k, v in where}
    tot = sum(full_split.values()) or 1.0
    print("where the time goes at full size: " + ", ".join(f"{k} {100 * v / tot:.0f}%" for k, v in
                                                            sorted(full_split.items(), key=lambda kv: -kv[1])))
    if args.full:
        print(f"MEASURED {FULL['name']}-size job ({args.scenes} scenes x {args.variants} variants, {n_var} variants, "
              f"{n_eps} episodes): wall {wall / 60:.1f} min ({wall_ex / 60:.1f} min without the object library), "
              f"on {args.jobs} workers / {os.cpu_count()} CPUs; the extrapolation from this run's per-stage seconds "
              f"(ideal scaling, {FULL['variants']} variants): {full_cpu / 60 / args.jobs:.1f} min; "
              f"goal: < {30 if house_preset(args) or args.full != '3k' else 12} min")
    print(f"peak memory, any stage: {max(peak.values()):.0f} MiB (main process {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB)")
    if house_preset(args):
        from sdovon_mj.stats import dataset_statistics, homes_table

        print("\nthe houses (sdovon-mj show RUN --stats):\n" + homes_table(dataset_statistics(out)))
    print(f"load average while running (1, 5, 15 min): {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} CPUs")
    episode_breakdown(out, cfg, args.breakdown)
    if args.profile > 0:
        profile_stages(out, cfg, args.profile)

    if args.no_scan:
        return
    # ---- peak memory of a scan-mode apartment of ~500k triangles through the scene pipeline
    from sdovon_mj.memory import peak_rss_mb, reset_peak_rss
    from sdovon_mj.world import generate_home, write_apartment

    scan_dir = work / "scan_input"
    reset_peak_rss()
    t0 = time.perf_counter()
    home = generate_home(0, "house") if house_preset(args) else generate_home(0, "apartment", floors=1)
    mesh = write_apartment(home, scan_dir, mode="scan", name="scan_0000", max_faces=args.scan_faces)
    write_s, write_mb = time.perf_counter() - t0, peak_rss_mb()
    import trimesh

    faces = len(trimesh.load(mesh, process=False).faces)
    print(f"\nscan apartment {mesh.name}: {faces} triangles, written in {write_s:.0f} s, peak {write_mb:.0f} MiB")
    scfg = bench_config(args, [0], 1)
    timings, wall = run_job(work / "scan_job", scfg, 1, scenes=[str(mesh)])
    secs, peak, count = per_stage(timings)
    print("stage          seconds   peak MiB  (scan mode, one process)")
    for k in sorted(secs, key=lambda k: -secs[k]):
        print(f"  {k:<12} {secs[k]:9.1f} {peak.get(k, 0):9.0f}")
    top = max(list(peak.values()) + [write_mb])
    print(f"scan-mode peak memory {top:.0f} MiB = {top / 1024:.2f} GiB (goal < 4 GB): "
          f"{'OK' if top < 4 * 1024**3 / 2**20 else 'OVER'}")


if __name__ == "__main__":
    main()
