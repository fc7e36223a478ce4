"""Executors: run tasks (`sdovon_mj.tasks`) in local worker processes or on Ray, with one retry bookkeeping.

Both executors hand each task's result to `Attempts`, which decides what runs next: a failed task again (at most
`retries` times; a bad input never, it fails the same way every time), the rest of a task whose worker held too
much memory (in a fresh process, not an attempt), the follow-up tasks of a finished one (export units).
"""

from __future__ import annotations

import dataclasses
import os
from collections import deque
from multiprocessing import get_context
from multiprocessing.connection import wait as mp_wait
from typing import Any, Callable

from . import numerics
from .errors import StageError
from .gl import RENDER_ENV
from .memory import holds_too_much, rss_mb
from .seeds import SALT_ENV
from .tasks import TaskResult, TaskSpec, run_task

# The worker memory limit (MiB) of `generate` and `LocalExecutor`: a worker that holds more after a stage hands on
# its work to a fresh process. Why this figure: the demo's worker holds 0.29 GB after its scene and 0.36 GB after
# its exports (small runs never pay for a new process), and a stage that starts from at most 1 GB has 3 GB of its
# own under the 4 GB goal per worker: the HM3D-size scene's largest stage, perceive, takes 3.1 GB above a fresh
# process (docs/results.md).
WORKER_MEMORY_MB = 1024.0


class Attempts:
    """The retry bookkeeping of one executor map: each task's runs, its partial results, the final results."""

    def __init__(self, specs: list[TaskSpec], retries: int, progress: Callable[[TaskResult], None] | None,
                 follow: Callable[[TaskResult], list[TaskSpec]] | None) -> None:
        """Start the bookkeeping of `specs`.

        Parameters
        ----------
        specs : list of TaskSpec
            The tasks of the map (follow-up tasks are appended).
        retries : int
            Runs of a failed task after its first (a deterministic failure is not retried).
        progress : callable, optional
            Called with each final result.
        follow : callable, optional
            Called with each final result; returns further tasks to run in the same map.
        """
        self.specs = list(specs)
        self.retries = retries
        self.progress = progress
        self.follow = follow
        self.runs = {i: 0 for i in range(len(self.specs))}
        self.partial: dict[int, TaskResult] = {}
        self.results: dict[int, TaskResult] = {}

    def settle(self, i: int, spec: TaskSpec, r: TaskResult) -> list[tuple[int, TaskSpec, bool]]:
        """Account for one run of task `i` (`spec`: all or the rest of its stages); return the tasks to run next as
        (index, spec, first): ``first`` marks a task to run before those waiting (its rest, its retry)."""
        if r.ok and r.rest:  # on in a fresh process, with what this part did
            self.partial[i] = r.after(self.partial.get(i))
            return [(i, dataclasses.replace(self.specs[i], stages=r.rest), True)]
        self.runs[i] += 1
        if not r.ok and not r.deterministic and self.runs[i] <= self.retries:  # again, from the stage that failed
            return [(i, spec, True)]
        r = r.after(self.partial.pop(i, None))
        r.attempts = self.runs[i]
        self.results[i] = r
        if self.progress:
            self.progress(r)
        out = []
        for extra in self.follow(r) if self.follow else []:
            self.specs.append(extra)
            self.runs[len(self.specs) - 1] = 0
            out.append((len(self.specs) - 1, extra, False))
        return out

    def ordered(self) -> list[TaskResult]:
        """Return the final results in the order of the specs (then the follow-up tasks in submission order)."""
        return [self.results[i] for i in range(len(self.specs))]


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
        book = Attempts(specs, self.retries, progress, follow)
        queue: deque[tuple[int, TaskSpec]] = deque(enumerate(book.specs))

        def settle(i: int, spec: TaskSpec, r: TaskResult) -> None:
            """Account for one run of task i and queue what runs next (a rest or a retry before the waiting tasks)."""
            for j, nxt, first in book.settle(i, spec, r):
                if first:
                    queue.appendleft((j, nxt))
                else:
                    queue.append((j, nxt))

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
        return book.ordered()

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
            # what workers must see as this process does: the secret salt's file name (they derive the variant seeds;
            # the file must be readable there) and the renderer choice (`gl`: llvmpipe, or the recorded override)
            env = {k: os.environ[k] for k in (SALT_ENV, RENDER_ENV) if k in os.environ}
            ray.init(ignore_reinit_error=True, log_to_driver=False, include_dashboard=False,
                     runtime_env={"env_vars": {"MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), **env}}, **kwargs)
        self.remote = ray.remote(num_cpus=1)(run_task)

    def map(self, specs: list[TaskSpec], progress: Callable[[TaskResult], None] | None = None,
            follow: Callable[[TaskResult], list[TaskSpec]] | None = None) -> list[TaskResult]:
        """Run every task on the cluster; return results in the order of `specs` (then follow-ups, `LocalExecutor.map`)."""
        book = Attempts(specs, self.retries, progress, follow)
        refs = {self.remote.remote(s): (i, s) for i, s in enumerate(book.specs)}
        while refs:
            done, _ = self.ray.wait(list(refs), num_returns=1)
            i, spec = refs.pop(done[0])
            try:
                r = self.ray.get(done[0])
            except Exception as e:  # worker lost: a failed attempt
                r = TaskResult(spec, ok=False, error=f"ray task failed: {type(e).__name__}: {e}")
            for j, nxt, _first in book.settle(i, spec, r):
                refs[self.remote.remote(nxt)] = (j, nxt)
        return book.ordered()


def make_executor(name: str, jobs: int = 1, address: str | None = None, retries: int = 1,
                  memory_mb: float = WORKER_MEMORY_MB) -> Any:
    """Return the executor named `local` or `ray`.

    Parameters
    ----------
    name : str
        ``local`` (worker processes, `LocalExecutor`) or ``ray`` (`RayExecutor`).
    jobs : int
        Parallel tasks (local workers; Ray CPUs when it starts a local cluster).
    address : str, optional
        A Ray cluster's address (none: a local Ray).
    retries : int
        Runs of a failed task after its first (a bad input is not retried).
    memory_mb : float
        The local workers' memory limit in MiB (0: none; `LocalExecutor`).
    """
    if name == "local":
        return LocalExecutor(jobs, retries, memory_mb)
    if name == "ray":
        return RayExecutor(address, retries, num_cpus=jobs if not address else None)
    raise StageError(f"unknown executor '{name}' (local, ray)")


__all__ = ["Attempts", "LocalExecutor", "RayExecutor", "WORKER_MEMORY_MB", "make_executor", "rasterizer_threads"]
