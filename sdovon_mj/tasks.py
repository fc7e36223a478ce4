"""Tasks: the unit of work the executors run (the stages of one scope: the run, a scene, a variant, an export).

Tasks exchange only store paths: a task is (kind, run root, scene, variant) and reads everything else from the
run folder, so the same task runs in a local process or on a Ray worker (`sdovon_mj.executors`).
"""

from __future__ import annotations

import os
import sys
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from .config import load_config
from .errors import InputError, SdovonError, UsageError
from .memory import before_stage, holds_too_much, peak_rss_mb, rss_mb
from .runview import RunLayout
from .store import Store, Timer


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
    # the failure is a bad input (errors.InputError, UsageError): it fails the same way every time, so no retry
    deterministic: bool = False

    def after(self, before: "TaskResult | None") -> "TaskResult":
        """Return this result (a task's later stages, run in a fresh process) with what `before` (its earlier
        stages) did added."""
        if before is None:
            return self
        for k, v in before.seconds.items():
            self.seconds[k] = self.seconds.get(k, 0.0) + v
        self.skipped = before.skipped + self.skipped
        self.notes = before.notes + self.notes
        peaks = {**before.counters.get("peak_rss_mb", {})}
        for k, v in self.counters.get("peak_rss_mb", {}).items():
            peaks[k] = max(peaks.get(k, 0.0), v)
        self.counters = {**before.counters, **self.counters, "peak_rss_mb": peaks}
        self.spec = before.spec
        return self


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
        before_stage()
        with Timer() as t:
            outputs = fn()
        self.store.mark_done(key, fp, outputs, t.seconds)
        self.result.seconds[short] = self.result.seconds.get(short, 0.0) + t.seconds
        peaks = self.result.counters.setdefault("peak_rss_mb", {})
        peaks[short] = max(peaks.get(short, 0.0), peak_rss_mb())
        return True


def stage_name(key: str) -> str:
    """Return the stage a marker key belongs to (`sdovon_mj.runview.RunLayout.stage_of`)."""
    return RunLayout.stage_of(key)


def run_task(spec: TaskSpec, memory_mb: float = 0.0) -> TaskResult:
    """Execute one task in this process; failures are returned, never raised.

    With `memory_mb`, a stage after the first runs only while the process holds at most that much
    (`sdovon_mj.memory.holds_too_much`); the stages left are returned in ``TaskResult.rest`` for a fresh process.
    A bad input (`InputError`, `UsageError`) is marked ``deterministic``: the executors do not retry it.
    """
    if not sys.stderr.isatty():  # model loaders' progress bars would flood non-interactive logs
        os.environ.setdefault("HF_HUB_DISABLE_PROGRESS_BARS", "1")
    result = TaskResult(spec, ok=True)
    try:
        from . import stages

        store = Store(spec.run_root)
        cfg = load_config(store.path(RunLayout.CONFIG))
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
        result.deterministic = isinstance(e, (InputError, UsageError))
    except Exception as e:  # a task must report its cause, whatever it is
        result.ok = False
        tb = traceback.extract_tb(e.__traceback__)[-1]
        result.error = f"{type(e).__name__}: {e} (at {Path(tb.filename).name}:{tb.lineno})"
    return result


__all__ = ["StageRunner", "TaskResult", "TaskSpec", "run_task", "stage_name"]
