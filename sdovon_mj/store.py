"""The artifact store: one folder per scene, atomic writes, per-stage fingerprints.

Every file is written to a temporary name in the same folder, flushed, fsync'ed and renamed over
the target, so a reader (or a rerun after a kill) sees either the old file or the new one, never a
half one. A stage is *done* when its marker ``<key>/.done.json`` holds the fingerprint of its
inputs + config + code version; the marker is written last, after all the stage's outputs, and records
each output's size and sha256 so a resume (and ``sdovon-mj verify``) notices an output damaged after
the stage finished (`Store.check_outputs`). One writer per run folder: `RunLock` (``.sdovon.lock``).
"""

from __future__ import annotations

import hashlib
import json
import os
import socket
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from . import __version__
from .errors import RunLockedError

DONE = ".done.json"
LOCK = ".sdovon.lock"  # the run folder's writer: pid, host, process start time (removed when the run ends)
TIMING = ".timing.json"  # wall seconds of a stage: kept apart so outputs compare byte for byte


CACHE_OFF = ("", "off", "none", "0")


def user_cache_dir(sub: str) -> Path | None:
    """Return the shared cache folder `sub`: $SDOVON_CACHE/<sub>, else ~/.cache/sdovon-mj/<sub> (None: SDOVON_CACHE=off)."""
    env = os.environ.get("SDOVON_CACHE")
    if env is None:
        return Path.home() / ".cache" / "sdovon-mj" / sub
    return None if env.lower() in CACHE_OFF else Path(env) / sub


def dumps(data: Any) -> str:
    """Deterministic JSON text (sorted keys, fixed separators, trailing newline): every JSON file a run writes.

    The text is exactly ``json.dumps(data, sort_keys=True, indent=1, ensure_ascii=False,
    allow_nan=False) + "\\n"``, built by `_dumps_fast` (the standard library's pure-Python indented
    encoder is ~3x slower); data it does not handle exactly (non-string keys, non-finite floats, types
    JSON rejects, cycles) goes through `json.dumps` itself, which also raises its usual errors.
    """
    try:
        return _dumps_fast(data) + "\n"
    except (_NotFast, RecursionError):
        return json.dumps(data, sort_keys=True, indent=1, ensure_ascii=False, allow_nan=False) + "\n"


def json_safe(x: Any, other: Callable[[Any], Any] | None = None) -> Any:
    """Return `x` as plain JSON data: dict keys as ``str``, tuples as lists, numpy arrays and scalars as Python
    values, non-finite floats as None (JSON has no inf/nan).

    Anything else goes through `other` (e.g. ``str`` for data from a third party that must always encode); without
    it, it is returned as is, so that `json.dumps` names a type it cannot write.
    """
    if isinstance(x, dict):
        return {str(k): json_safe(v, other) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v, other) for v in x]
    if isinstance(x, np.ndarray):
        return json_safe(x.tolist(), other)
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if np.isfinite(x) else None
    if x is None or isinstance(x, str) or other is None:
        return x
    return other(x)


class _NotFast(Exception):
    """Data `_dumps_fast` leaves to `json.dumps` (which then gives the exact text or the exact error)."""


_encode_str = getattr(json.encoder, "c_encode_basestring", None) or json.encoder.py_encode_basestring
_float_repr = float.__repr__
_int_repr = int.__repr__
_INF = float("inf")


def _dumps_fast(data: Any) -> str:
    """Return the text of ``json.dumps(data, sort_keys=True, indent=1, ensure_ascii=False, allow_nan=False)``.

    Mirrors `json.encoder._make_iterencode` for that configuration: the same type tests in the same order
    (str, None, True, False, int, float, list/tuple, dict), ``int.__repr__`` / ``float.__repr__`` for
    numbers (so int and float subclasses print as json prints them), json's C string escaper, items
    separated by ``","`` and a newline plus one space per level, ``": "`` after keys, dicts in sorted key
    order, empty containers as ``[]`` / ``{}``. Raises `_NotFast` where json would do something else
    (a key that is not a str, a NaN or infinity, a type it cannot encode).
    """
    parts: list[str] = []
    put = parts.append
    nls = ["\n"]

    def nl(level: int) -> str:
        """Return the newline + indentation of a level (memoised)."""
        while len(nls) <= level:
            nls.append("\n" + " " * len(nls))
        return nls[level]

    def leaf(o: Any) -> str | None:
        """Return the text of a scalar, None for a container (raises _NotFast for the rest)."""
        if isinstance(o, str):
            return _encode_str(o)
        if o is None:
            return "null"
        if o is True:
            return "true"
        if o is False:
            return "false"
        if isinstance(o, int):
            return _int_repr(o)
        if isinstance(o, float):
            if o != o or o == _INF or o == -_INF:
                raise _NotFast
            return _float_repr(o)
        if isinstance(o, (list, tuple, dict)):
            return None
        raise _NotFast

    def enc(o: Any, level: int) -> None:
        """Append the text of a container at an indentation level."""
        if isinstance(o, (list, tuple)):
            if not o:
                put("[]")
                return
            sep = nl(level + 1)
            put("[")
            for v in o:
                put(sep)
                sep = "," + nl(level + 1)
                t = leaf(v)
                if t is None:
                    enc(v, level + 1)
                else:
                    put(t)
            put(nl(level))
            put("]")
            return
        if not o:
            put("{}")
            return
        for k in o:
            if not isinstance(k, str):
                raise _NotFast
        sep = nl(level + 1)
        put("{")
        for k, v in sorted(o.items()):
            put(sep)
            sep = "," + nl(level + 1)
            put(_encode_str(k))
            put(": ")
            t = leaf(v)
            if t is None:
                enc(v, level + 1)
            else:
                put(t)
        put(nl(level))
        put("}")

    t = leaf(data)
    if t is not None:
        return t
    enc(data, 0)
    return "".join(parts)


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write bytes to `path` through a temp file + rename (no partial file, ever)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(e, OSError) and e.errno is not None and e.filename is None:  # e.g. disk full: name the file
            raise type(e)(e.errno, e.strerror, str(path)) from e
        raise


def atomic_write_text(path: Path, text: str) -> None:
    """Write UTF-8 text atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_copy(src: Path, dst: Path) -> None:
    """Copy a file atomically (temp file + rename)."""
    atomic_write_bytes(Path(dst), Path(src).read_bytes())


def file_hash(path: Path, chunk: int = 1 << 20) -> str:
    """Return the sha256 hex digest of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while True:
            b = f.read(chunk)
            if not b:
                break
            h.update(b)
    return h.hexdigest()


def fingerprint(*parts: Any) -> str:
    """Return a stable digest of JSON-able parts (inputs, config, code version)."""
    blob = json.dumps([__version__, *parts], sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()[:24]


def clean_temp_files(root: Path) -> int:
    """Remove temp files left by a killed writer under `root`; return how many."""
    n = 0
    for p in Path(root).rglob(".*.tmp"):
        try:
            p.unlink()
            n += 1
        except FileNotFoundError:
            pass
    return n


@dataclass
class StageMark:
    """What a finished stage left: fingerprint, outputs, seconds, and each output's size and sha256."""

    fingerprint: str
    outputs: list[str]
    seconds: float
    digests: dict[str, dict[str, Any]] | None = None  # None: a marker written before digests were recorded


def output_digest(path: Path) -> dict[str, Any]:
    """Return what a done-marker records of one output: ``{"size": bytes, "sha256": hex}`` (``{"dir": true}``)."""
    if path.is_dir():
        return {"dir": True}
    return {"size": path.stat().st_size, "sha256": file_hash(path)}


def check_digest(path: Path, want: dict[str, Any] | None) -> str:
    """Return what is wrong with an output against its recorded digest ('' when it matches).

    The size is compared first (a truncated file costs one ``stat``); the sha256 only when sizes agree.
    """
    if not path.exists():
        return "missing"
    if want is None:
        return ""
    if want.get("dir"):
        return "" if path.is_dir() else "not a folder any more"
    size = path.stat().st_size
    if size != want.get("size"):
        return f"size {size} bytes, recorded {want.get('size')}"
    if file_hash(path) != want.get("sha256"):
        return "contents changed (sha256 differs from the recorded one)"
    return ""


class Store:
    """A run folder: relative paths in, atomic files out, stage markers."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root).resolve()
        self.root.mkdir(parents=True, exist_ok=True)

    def path(self, rel: str | Path) -> Path:
        """Return the absolute path of a store-relative path."""
        return self.root / Path(rel)

    def rel(self, path: str | Path) -> str:
        """Return a POSIX path relative to the store root."""
        return Path(path).resolve().relative_to(self.root).as_posix()

    def write_bytes(self, rel: str | Path, data: bytes) -> Path:
        """Atomically write bytes at a store-relative path."""
        p = self.path(rel)
        atomic_write_bytes(p, data)
        return p

    def write_text(self, rel: str | Path, text: str) -> Path:
        """Atomically write text at a store-relative path."""
        return self.write_bytes(rel, text.encode("utf-8"))

    def write_json(self, rel: str | Path, data: Any) -> Path:
        """Atomically write deterministic JSON at a store-relative path."""
        return self.write_text(rel, dumps(data))

    def read_json(self, rel: str | Path) -> Any:
        """Read JSON from a store-relative path."""
        return json.loads(self.path(rel).read_text(encoding="utf-8"))

    def exists(self, rel: str | Path) -> bool:
        """Return whether a store-relative path exists."""
        return self.path(rel).exists()

    # -- stage markers ---------------------------------------------------------------------------

    def _marker(self, stage: str) -> Path:
        return self.path(stage) / DONE

    def is_done(self, stage: str, fp: str | None = None, verify: bool = False) -> bool:
        """Return whether `stage` finished (with fingerprint `fp`, when given) and its outputs exist.

        With ``verify``, every output must also match the size and digest its marker recorded.
        """
        mark = self.mark(stage)
        if mark is None:
            return False
        if fp is not None and mark.fingerprint != fp:
            return False
        if verify:
            return not self.check_outputs(stage, mark)
        return all(self.path(o).exists() for o in mark.outputs)

    def check_outputs(self, stage: str, mark: StageMark | None = None) -> list[str]:
        """Return one line per output of a finished stage that is missing or no longer matches its marker.

        An empty list: every output is as the stage left it (or the stage has no marker).
        """
        mark = mark or self.mark(stage)
        if mark is None:
            return []
        problems = []
        for o in mark.outputs:
            why = check_digest(self.path(o), (mark.digests or {}).get(o))
            if why:
                problems.append(f"{o}: {why}")
        return problems

    def mark(self, stage: str) -> StageMark | None:
        """Return a stage's marker, or None when it has not finished."""
        p = self._marker(stage)
        if not p.exists():
            return None
        try:
            d = json.loads(p.read_text(encoding="utf-8"))
            t = self.path(stage) / TIMING
            seconds = float(json.loads(t.read_text(encoding="utf-8"))["seconds"]) if t.exists() else 0.0
            digests = d.get("digests")
            return StageMark(d["fingerprint"], list(d["outputs"]), seconds,
                             dict(digests) if isinstance(digests, dict) else None)
        except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError, ValueError, AttributeError):
            return None

    def mark_done(self, stage: str, fp: str, outputs: Iterable[str | Path], seconds: float = 0.0) -> None:
        """Record that `stage` finished with fingerprint `fp` (written after its outputs)."""
        outs = sorted(o if isinstance(o, str) else self.rel(o) for o in outputs)
        digests = {o: output_digest(self.path(o)) for o in outs if self.path(o).exists()}
        self.write_json(Path(stage) / TIMING, {"seconds": round(seconds, 4)})
        self.write_json(Path(stage) / DONE, {"fingerprint": fp, "outputs": outs, "digests": digests})

    def stage_keys(self) -> list[str]:
        """Return the marker key of every stage that left a done-marker in this run folder (sorted)."""
        return sorted(p.parent.relative_to(self.root).as_posix() for p in self.root.rglob(DONE))

    def verify(self) -> dict[str, list[str]]:
        """Check every finished stage's outputs against its marker; return key -> problems (empty: intact).

        An unreadable marker is a problem of its own; a marker written before digests were recorded is
        checked for the existence of its outputs only.
        """
        out: dict[str, list[str]] = {}
        for key in self.stage_keys():
            mark = self.mark(key)
            out[key] = ([f"{key}/{DONE}: unreadable done-marker"] if mark is None else self.check_outputs(key, mark))
        return out

    def invalidate(self, stage: str) -> None:
        """Forget that `stage` finished (its outputs stay until overwritten)."""
        try:
            self._marker(stage).unlink()
        except FileNotFoundError:
            pass


def _start_time(pid: int) -> str:
    """Return a process's start time (clock ticks since boot, Linux ``/proc``), '' when unknown."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text(encoding="ascii", errors="replace")
        return stat.rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return ""


def process_alive(pid: int, started: str) -> bool:
    """Return whether process `pid` (on this host) runs and is the one that started at `started` (not a reused pid)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    now = _start_time(pid)
    return not (started and now and now != started)


class RunLock:
    """One writer per run folder: ``<root>/.sdovon.lock`` holds the owner's pid, host and start time.

    `acquire` creates it exclusively. A lock held by a live process refuses with `RunLockedError` naming
    the owner; a stale one (its process is gone, on this host) is taken over and `note` says so. A lock of
    another host cannot be checked and refuses (the message says how to remove it). `release` removes it.
    """

    def __init__(self, root: str | Path) -> None:
        self.path = Path(root) / LOCK
        self.note = ""
        self.held = False

    def _owner(self) -> dict[str, Any]:
        """Return this process as a lock owner."""
        return {"pid": os.getpid(), "host": socket.gethostname(), "started": _start_time(os.getpid()),
                "since": time.strftime("%Y-%m-%dT%H:%M:%S")}

    def acquire(self) -> "RunLock":
        """Take the lock (or raise RunLockedError naming the live owner); return self."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        me = self._owner()
        for _attempt in range(3):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                self._take_over_if_stale(me)
                continue
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(json.dumps(me, sort_keys=True) + "\n")
            self.held = True
            return self
        raise RunLockedError(f"{self.path.parent}: could not take the run-folder lock {self.path}")

    def _take_over_if_stale(self, me: dict[str, Any]) -> None:
        """Remove a stale lock (noting it) or raise RunLockedError naming its live owner."""
        try:
            raw = self.path.read_bytes()
            owner = json.loads(raw.decode("utf-8"))
            pid, host = int(owner["pid"]), str(owner["host"])
        except FileNotFoundError:
            return
        except (OSError, ValueError, KeyError, TypeError, UnicodeDecodeError):
            raw = self.path.read_bytes() if self.path.exists() else b""
            owner, pid, host = {}, -1, me["host"]  # unreadable: its writer died while writing it
        if host != me["host"]:
            raise RunLockedError(f"run folder {self.path.parent} is being written by pid {pid} on host {host} "
                                 f"(lock {self.path}); if that run is gone, remove the lock file")
        if pid > 0 and process_alive(pid, str(owner.get("started", ""))):
            raise RunLockedError(f"run folder {self.path.parent} is being written by pid {pid} on host {host} "
                                 f"since {owner.get('since', '?')} (lock {self.path}); wait for it or stop it")
        self.note = (f"took over a stale lock of pid {pid} on host {host} (that process is gone)" if pid > 0
                     else f"took over an unreadable lock file {self.path}")
        try:
            if self.path.read_bytes() == raw:  # not replaced meanwhile by a writer that took it over first
                self.path.unlink()
        except FileNotFoundError:
            pass

    def release(self) -> None:
        """Remove the lock if this process holds it."""
        if not self.held:
            return
        self.held = False
        try:
            owner = json.loads(self.path.read_text(encoding="utf-8"))
            if int(owner.get("pid", -1)) == os.getpid():
                self.path.unlink()
        except (OSError, ValueError):
            pass

    def __enter__(self) -> "RunLock":
        return self.acquire()

    def __exit__(self, *exc: Any) -> None:
        self.release()


class Timer:
    """Context manager measuring wall seconds."""

    def __enter__(self) -> "Timer":
        self.t0 = time.perf_counter()
        self.seconds = 0.0
        return self

    def __exit__(self, *exc: Any) -> None:
        self.seconds = time.perf_counter() - self.t0
