"""Runs the stages over scenes and variants: resumable, reproducible, local pool or Ray.

Run folder layout (all record paths are relative to the run root):

    config.yaml                 the resolved config
    manifest.json               config hash, seeds, package versions, per-stage fingerprints
    timings.json                wall seconds per stage (the only file that differs between reruns)
    inputs/                     default-world scenes and objects written as input files
    objects/objects.json        list[ObjectAsset]; objects/<name>/model.xml + assets
    scenes/<scene>/scene.json   SceneAsset (+ MJCF, textures, scene mesh npz)
    scenes/<scene>/observe/     navmap_<floor>.json, viewpoints.json, obs_*.npz shards, pictures
    scenes/<scene>/perceive/    instances.npz, planes.json
    scenes/<scene>/semantics/   regions_<floor>.json, relevance.json, pictures
    scenes/<scene>/variants/<variant>/variant.json, episodes.json, composed MJCF, pictures
    export/<format>/            exporter outputs
    stats/                      summary tables (markdown + JSON) and category charts

Tasks exchange only store paths: a task is (kind, run root, scene, variant) and reads everything
else from the run folder, so the same task runs in a local process or on a Ray worker.
"""

from __future__ import annotations

import json
import os
import sys
import time
import traceback
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Any, Callable, Iterable

from . import __version__
from .config import RunConfig, dump_yaml, load_config, to_dict
from .errors import SdovonError, StageError
from .records import dumps
from .seeds import scene_seed
from .store import Store, Timer, clean_temp_files


@dataclass(frozen=True)
class TaskSpec:
    """One unit of work; only paths and names, so it crosses process and machine boundaries."""

    kind: str  # objects | scene | variant | export
    run_root: str
    scene: str = ""
    variant: int = -1
    fmt: str = ""
    stages: tuple[str, ...] = ()  # only these stages of the task's scope (empty: all)

    @property
    def label(self) -> str:
        """Return a short human name of the task."""
        if self.kind == "variant":
            return f"{self.scene}/v{self.variant:03d}"
        return {"objects": "objects", "scene": self.scene, "export": f"export:{self.fmt}"}.get(self.kind, self.kind)


@dataclass
class TaskResult:
    """What a task reports back: ok or the cause of failure, stage seconds, counters."""

    spec: TaskSpec
    ok: bool
    error: str = ""
    seconds: dict[str, float] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)
    counters: dict[str, Any] = field(default_factory=dict)
    attempts: int = 1


class StageRunner:
    """Runs one named stage at most once per fingerprint, recording outputs and timing."""

    def __init__(self, store: Store, result: TaskResult) -> None:
        self.store = store
        self.result = result

    def run(self, key: str, fp: str, fn: Callable[[], list[str]]) -> bool:
        """Run `fn` (returning its output paths) unless `key` is done with fingerprint `fp`."""
        short = stage_name(key)
        if self.store.is_done(key, fp):
            self.result.skipped.append(key)
            return False
        self.store.invalidate(key)
        reset_peak_rss()
        with Timer() as t:
            outputs = fn()
        self.store.mark_done(key, fp, outputs, t.seconds)
        self.result.seconds[short] = self.result.seconds.get(short, 0.0) + t.seconds
        peaks = self.result.counters.setdefault("peak_rss_mb", {})
        peaks[short] = max(peaks.get(short, 0.0), peak_rss_mb())
        return True


def stage_name(key: str) -> str:
    """Return the stage a marker key belongs to (e.g. scenes/a/observe -> observe, export/mjcf.stage -> export:mjcf)."""
    parts = key.split("/")
    if parts[0] == "inputs" and len(parts) > 1:
        return "world:objects" if parts[1] == "objects" else "world:scene"
    if parts[0] == "export":
        return "export:" + parts[-1].removesuffix(".stage")
    return parts[-1]


def reset_peak_rss() -> None:
    """Reset this process's peak resident memory (Linux clear_refs; a no-op elsewhere)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def peak_rss_mb() -> float:
    """Return this process's peak resident memory in MiB since the last reset (else since start)."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return round(int(line.split()[1]) / 1024.0, 1)
    except OSError:
        pass
    import resource

    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)


def run_task(spec: TaskSpec) -> TaskResult:
    """Execute one task in this process; failures are returned, never raised."""
    if not sys.stderr.isatty():  # model loaders' progress bars would flood non-interactive logs
        os.environ.setdefault("HF_HUB_DISABLE_PROGRESS_BARS", "1")
    result = TaskResult(spec, ok=True)
    try:
        from . import stages

        store = Store(spec.run_root)
        cfg = load_config(store.path("config.yaml"))
        runner = StageRunner(store, result)
        scope = {"objects": "run"}.get(spec.kind, spec.kind)
        stages.run_task(store, cfg, runner, scope, spec.scene, spec.variant, spec.fmt, spec.stages or None)
    except SdovonError as e:
        result.ok, result.error = False, str(e)
    except Exception as e:  # a task must report its cause, whatever it is
        result.ok = False
        tb = traceback.extract_tb(e.__traceback__)[-1]
        result.error = f"{type(e).__name__}: {e} (at {Path(tb.filename).name}:{tb.lineno})"
    return result


# ----------------------------------------------------------------------------------------------
# Executors


class LocalExecutor:
    """Runs tasks in a process pool (`jobs` workers; 1 = in this process), with bounded retries."""

    def __init__(self, jobs: int = 1, retries: int = 1) -> None:
        self.jobs = max(1, int(jobs))
        self.retries = max(0, int(retries))

    def map(self, specs: list[TaskSpec], progress: Callable[[TaskResult], None] | None = None) -> list[TaskResult]:
        """Run every task; return results in the order of `specs`."""
        results: dict[int, TaskResult] = {}
        if self.jobs == 1 or len(specs) <= 1:
            for i, s in enumerate(specs):
                results[i] = self._with_retries(lambda s=s: run_task(s))
                if progress:
                    progress(results[i])
            return [results[i] for i in range(len(specs))]
        pending = {i: 0 for i in range(len(specs))}
        with ProcessPoolExecutor(max_workers=min(self.jobs, len(specs)), mp_context=get_context("spawn")) as pool:
            futs = {pool.submit(run_task, specs[i]): i for i in pending}
            while futs:
                done, _ = wait(list(futs), return_when=FIRST_COMPLETED)
                for fut in done:
                    i = futs.pop(fut)
                    try:
                        r = fut.result()
                    except Exception as e:  # worker crashed (e.g. killed): counts as a failed attempt
                        r = TaskResult(specs[i], ok=False, error=f"worker died: {type(e).__name__}: {e}")
                    pending[i] += 1
                    r.attempts = pending[i]
                    if not r.ok and pending[i] <= self.retries:
                        futs[pool.submit(run_task, specs[i])] = i
                        continue
                    results[i] = r
                    if progress:
                        progress(r)
        return [results[i] for i in range(len(specs))]

    def _with_retries(self, fn: Callable[[], TaskResult]) -> TaskResult:
        """Call `fn` until it succeeds or the retries are spent."""
        for attempt in range(1, self.retries + 2):
            r = fn()
            r.attempts = attempt
            if r.ok:
                return r
        return r


class RayExecutor:
    """Runs tasks as Ray remote functions (tasks carry store paths only), with bounded retries."""

    def __init__(self, address: str | None = None, retries: int = 1, num_cpus: int | None = None) -> None:
        try:
            import ray
        except ImportError:
            raise StageError("the ray executor needs Ray: pip install 'sdovon-mj[ray]'") from None
        self.ray = ray
        self.retries = max(0, int(retries))
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"address": address} if address else {"num_cpus": num_cpus}
            ray.init(ignore_reinit_error=True, log_to_driver=False, include_dashboard=False,
                     runtime_env={"env_vars": {"MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}}, **kwargs)
        self.remote = ray.remote(num_cpus=1)(run_task)

    def map(self, specs: list[TaskSpec], progress: Callable[[TaskResult], None] | None = None) -> list[TaskResult]:
        """Run every task on the cluster; return results in the order of `specs`."""
        results: dict[int, TaskResult] = {}
        attempts = {i: 1 for i in range(len(specs))}
        refs = {self.remote.remote(s): i for i, s in enumerate(specs)}
        while refs:
            done, _ = self.ray.wait(list(refs), num_returns=1)
            i = refs.pop(done[0])
            try:
                r = self.ray.get(done[0])
            except Exception as e:  # worker lost: a failed attempt
                r = TaskResult(specs[i], ok=False, error=f"ray task failed: {type(e).__name__}: {e}")
            r.attempts = attempts[i]
            if not r.ok and attempts[i] <= self.retries:
                attempts[i] += 1
                refs[self.remote.remote(specs[i])] = i
                continue
            results[i] = r
            if progress:
                progress(r)
        return [results[i] for i in range(len(specs))]


def make_executor(name: str, jobs: int = 1, address: str | None = None, retries: int = 1) -> Any:
    """Return the executor named `local` or `ray`."""
    if name == "local":
        return LocalExecutor(jobs, retries)
    if name == "ray":
        return RayExecutor(address, retries, num_cpus=jobs if not address else None)
    raise StageError(f"unknown executor '{name}' (local, ray)")


# ----------------------------------------------------------------------------------------------
# The whole run


@dataclass
class RunSummary:
    """What a run did: counts, failures, seconds per stage."""

    run_root: str
    scenes: list[str]
    results: list[TaskResult]
    seconds: dict[str, float]

    @property
    def failures(self) -> list[TaskResult]:
        """Return the failed tasks."""
        return [r for r in self.results if not r.ok]

    def table(self) -> str:
        """Return the end-of-run summary: dataset statistics, seconds per stage, failed tasks."""
        from . import stats

        st = stats.dataset_statistics(Path(self.run_root))
        lines = [stats.summary_table(st), "", "seconds per stage (this run; 0 = skipped, already done):"]
        for k, v in sorted(self.seconds.items(), key=lambda kv: -kv[1]):
            lines.append(f"  {k:<12} {v:8.2f}")
        if self.failures:
            lines.append("")
            lines.append("failed tasks:")
            for r in self.failures:
                lines.append(f"  {r.spec.label}: {r.error}")
        return "\n".join(lines)


def package_versions() -> dict[str, str]:
    """Return versions of the packages whose behaviour shapes the outputs."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"sdovon-mj": __version__, "python": sys.version.split()[0]}
    for name in ("mujoco", "dm-control", "trimesh", "coacd", "numpy", "scipy", "open3d", "torch"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "absent"
    return out


def prepare_run(run_root: str | Path, cfg: RunConfig, scenes: list[str] | None = None,
                objects: list[str] | None = None) -> Store:
    """Create (or reopen) a run folder: write the config and the inputs list."""
    store = Store(run_root)
    clean_temp_files(store.root)
    cfg_text = dump_yaml(cfg)
    cfg_path = store.path("config.yaml")
    if cfg_path.exists() and cfg_path.read_text(encoding="utf-8") != cfg_text:
        # A changed config is fine: stages whose fingerprint changed are redone, the rest kept.
        pass
    store.write_text("config.yaml", cfg_text)
    inputs = {"scenes": [str(Path(s).resolve()) for s in (scenes or [])],
              "objects": [str(Path(o).resolve()) for o in (objects or [])]}
    store.write_json("inputs.json", inputs)
    return store


def generate(run_root: str | Path, cfg: RunConfig, scenes: list[str] | None = None, objects: list[str] | None = None,
             executor: str = "local", jobs: int = 1, address: str | None = None, retries: int = 1,
             progress: bool | None = None, exporters: Iterable[str] | None = None,
             until: Iterable[str] | None = None, only_scenes: Iterable[str] | None = None) -> RunSummary:
    """Run the pipeline into `run_root`; finished stages are skipped on a rerun.

    Parameters
    ----------
    run_root : str or Path
        The run folder (created; an existing run is resumed).
    cfg : RunConfig
        The run's config (written to ``config.yaml``).
    scenes, objects : list of str, optional
        Scene files and object files/folders; none: the embedded default world.
    executor : str
        ``local`` (process pool) or ``ray``.
    jobs : int
        Parallel tasks (local workers / Ray CPUs).
    address : str, optional
        Ray cluster address.
    retries : int
        Retries of a failed task.
    progress : bool, optional
        Show a progress bar (None: when interactive).
    exporters : iterable of str, optional
        Exporter plugins to run (default: ``cfg.exporters``).
    until : iterable of str, optional
        Run only these stages and the stages they need (`sdovon_mj.stages.closure`); the per-stage commands
        use it. Default: every stage, then statistics.
    only_scenes : iterable of str, optional
        Only these scenes of the run (default: all).
    """
    from . import stages
    from .progress import Progress

    store = prepare_run(run_root, cfg, scenes, objects)
    ex = make_executor(executor, jobs, address, retries)
    wanted = stages.closure(list(until)) if until is not None else list(stages.STAGES)
    scene_names = stages.scene_names(store, cfg)
    if only_scenes is not None:
        unknown = sorted(set(only_scenes) - set(scene_names))
        if unknown:
            raise StageError(f"no scene {', '.join(unknown)} in this run (scenes: {', '.join(scene_names)})")
        scene_names = [s for s in scene_names if s in set(only_scenes)]
    root = str(store.root)
    run_st, scene_st, var_st = (tuple(stages.scope_stages(k, wanted)) for k in ("run", "scene", "variant"))
    fmts = list(cfg.exporters if exporters is None else exporters) if "export" in wanted else []
    n_variants = len(scene_names) * cfg.place.k_v if var_st else 0
    results: list[TaskResult] = []
    total = bool(run_st) + (len(scene_names) if scene_st else 0) + n_variants + len(fmts)
    with Progress(total=total, enabled=progress, desc="generate") as bar:
        def tick(r: TaskResult) -> None:
            bar.update(1, r.spec.label + ("" if r.ok else " FAILED"))

        if run_st:
            results += ex.map([TaskSpec("objects", root, stages=run_st)], tick)
            if not results[-1].ok:
                raise StageError(f"object library failed: {results[-1].error}")
        good = scene_names
        if scene_st:
            scene_results = ex.map([TaskSpec("scene", root, s, stages=scene_st) for s in scene_names], tick)
            results += scene_results
            good = [r.spec.scene for r in scene_results if r.ok]
        if var_st:
            bar.total -= (len(scene_names) - len(good)) * cfg.place.k_v
            results += ex.map([TaskSpec("variant", root, s, v, stages=var_st) for s in good for v in range(cfg.place.k_v)],
                              tick)
        for fmt in fmts:
            results += ex.map([TaskSpec("export", root, fmt=fmt)], tick)
    seconds: dict[str, float] = {}
    for r in results:
        for k, v in r.seconds.items():
            seconds[k] = seconds.get(k, 0.0) + v
    summary = RunSummary(str(store.root), scene_names, results, seconds)
    write_manifest(store, cfg, summary)
    if until is None:
        from . import stats

        stats.write_statistics(store.root)
    return summary


def write_manifest(store: Store, cfg: RunConfig, summary: RunSummary) -> None:
    """Write manifest.json (deterministic) and timings.json (wall seconds) for a run."""
    fps: dict[str, str] = {}
    for marker in sorted(store.root.rglob(".done.json")):
        key = marker.parent.relative_to(store.root).as_posix()
        fps[key] = json.loads(marker.read_text(encoding="utf-8"))["fingerprint"]
    manifest = {
        "sdovon_mj": __version__,
        "config": to_dict(cfg),
        "seed": cfg.seed,
        "scene_seeds": {s: scene_seed(cfg.seed, s) for s in summary.scenes},
        "packages": package_versions(),
        "stages": fps,
        "failures": [{"task": r.spec.label, "error": r.error, "attempts": r.attempts} for r in summary.failures],
    }
    store.write_json("manifest.json", manifest)
    timings = {
        "stage_seconds": {k: round(v, 3) for k, v in sorted(summary.seconds.items())},
        "tasks": [{"task": r.spec.label, "ok": r.ok, "seconds": {k: round(v, 3) for k, v in r.seconds.items()},
                   "skipped": r.skipped, "attempts": r.attempts,
                   "peak_rss_mb": r.counters.get("peak_rss_mb", {})} for r in summary.results],
        "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }
    store.write_json("timings.json", timings)


def summary_json(summary: RunSummary) -> str:
    """Return a run summary as JSON text (for logs and tests)."""
    return dumps({"run_root": summary.run_root, "scenes": summary.scenes,
                  "results": [{**asdict(r), "spec": asdict(r.spec)} for r in summary.results],
                  "seconds": summary.seconds})
