"""Runs the stages over scenes and variants: resumable, reproducible, local pool or Ray (`generate`).

The run folder's layout is `sdovon_mj.runview`'s; what a task is, `sdovon_mj.tasks`; how tasks run (worker
processes, Ray, retries), `sdovon_mj.executors`; when exports start, `sdovon_mj.schedule`; the record of a run
(manifest.json, timings.json), `sdovon_mj.manifest`; the input check, `sdovon_mj.inputs`.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Iterable

from .config import RunConfig, dump_yaml
from .errors import InputError, InputsError, StageError
from .executors import WORKER_MEMORY_MB, make_executor
from .gl import generation_renderer
from .inputs import check_inputs
from .interrupt import sigterm_interrupts
from .manifest import RunSummary, write_manifest
from .runview import RunLayout
from .schedule import ExportSchedule
from .seeds import SALT_ENV, secret_salt, split_record
from .store import RunLock, Store, clean_temp_files
from .tasks import TaskResult, TaskSpec


def prepare_run(run_root: str | Path, cfg: RunConfig, scenes: list[str] | None = None,
                objects: list[str] | None = None) -> Store:
    """Create (or reopen) a run folder: write the config and the inputs list."""
    store = Store(run_root)
    clean_temp_files(store.root)
    cfg_text = dump_yaml(cfg)
    cfg_path = store.path(RunLayout.CONFIG)
    if cfg_path.exists() and cfg_path.read_text(encoding="utf-8") != cfg_text:
        # A changed config is fine: stages whose fingerprint changed are redone, the rest kept.
        pass
    store.write_text(RunLayout.CONFIG, cfg_text)
    inputs = {"scenes": [str(Path(s).resolve()) for s in (scenes or [])],
              "objects": [str(Path(o).resolve()) for o in (objects or [])]}
    store.write_json(RunLayout.INPUTS, inputs)
    _record_split(store)
    return store


def _record_split(store: Store) -> None:
    """Record a secret split in the run folder (``split.json``: the salt's digest, never the salt); refuse to resume
    a secret run without its salt (its place and episodes stages would be redone from the public seeds)."""
    record = split_record(secret_salt())
    old = store.path(RunLayout.SPLIT)
    if record is None and old.is_file():
        digest = json.loads(old.read_text(encoding="utf-8")).get("salt_digest", "?")
        raise InputError(old, f"this run's split is secret (salt digest {digest}): give its salt file with "
                              f"--secret-salt-file or {SALT_ENV} (delete split.json to redo it as an open split)")
    if record is not None:
        store.write_json(RunLayout.SPLIT, record)


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
    with sigterm_interrupts():  # before the lock shows
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
            # A signal can land between a writer's temp file and its cleanup (the window inside tempfile.mkstemp);
            # the lock is ours and the workers are stopped, so every temp file in the run now is a leftover.
            if lock.held:
                clean_temp_files(Path(run_root).resolve())
            raise
        finally:
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
    total = (bool(run_st) + (len(scene_names) if scene_st else 0) + n_variants + len(fmts)
             + (len(scene_names) if chain_st else 0))
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


__all__ = ["generate", "prepare_run"]
