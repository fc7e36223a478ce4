"""Process memory: what a stage may start from and what it used (the /proc probes of the pipeline's tasks).

A stage starts after freed memory went back to the system (`release_memory`) and records its peak
(`reset_peak_rss`, `peak_rss_mb`); a worker that holds too much after a stage hands on its work (`holds_too_much`).
"""

from __future__ import annotations

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


def before_stage() -> None:
    """Prepare this process for a stage: freed memory back to the system (unless `holds_too_much` just did and
    nothing ran since), the peak reset so that `peak_rss_mb` measures the stage alone."""
    global _TRIMMED
    if not _TRIMMED:  # after `holds_too_much` nothing has run that a collection would find
        release_memory()
    reset_peak_rss()
    _TRIMMED = False


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


__all__ = ["before_stage", "holds_too_much", "peak_rss_mb", "release_memory", "reset_peak_rss", "rss_mb"]
