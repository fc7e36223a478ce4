"""The artifact store: one folder per scene, atomic writes, per-stage fingerprints.

Every file is written to a temporary name in the same folder, flushed, fsync'ed and renamed over
the target, so a reader (or a rerun after a kill) sees either the old file or the new one, never a
half one. A stage is *done* when its marker ``<key>/.done.json`` holds the fingerprint of its
inputs + config + code version; the marker is written last, after all the stage's outputs.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

from . import __version__

DONE = ".done.json"
TIMING = ".timing.json"  # wall seconds of a stage: kept apart so outputs compare byte for byte


CACHE_OFF = ("", "off", "none", "0")


def user_cache_dir(sub: str) -> Path | None:
    """Return the shared cache folder `sub`: $SDOVON_CACHE/<sub>, else ~/.cache/sdovon-mj/<sub> (None: SDOVON_CACHE=off)."""
    env = os.environ.get("SDOVON_CACHE")
    if env is None:
        return Path.home() / ".cache" / "sdovon-mj" / sub
    return None if env.lower() in CACHE_OFF else Path(env) / sub


def dumps(data: Any) -> str:
    """Deterministic JSON text (sorted keys, fixed separators, trailing newline): every JSON file a run writes."""
    return json.dumps(data, sort_keys=True, indent=1, ensure_ascii=False, allow_nan=False) + "\n"


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
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
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
    """What a finished stage left: fingerprint, outputs, seconds."""

    fingerprint: str
    outputs: list[str]
    seconds: float


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

    def is_done(self, stage: str, fp: str | None = None) -> bool:
        """Return whether `stage` finished (with fingerprint `fp`, when given) and its outputs exist."""
        mark = self.mark(stage)
        if mark is None:
            return False
        if fp is not None and mark.fingerprint != fp:
            return False
        return all(self.path(o).exists() for o in mark.outputs)

    def mark(self, stage: str) -> StageMark | None:
        """Return a stage's marker, or None when it has not finished."""
        p = self._marker(stage)
        if not p.exists():
            return None
        try:
            d = json.loads(p.read_text(encoding="utf-8"))
            t = self.path(stage) / TIMING
            seconds = float(json.loads(t.read_text(encoding="utf-8"))["seconds"]) if t.exists() else 0.0
            return StageMark(d["fingerprint"], list(d["outputs"]), seconds)
        except (json.JSONDecodeError, KeyError, TypeError, ValueError):
            return None

    def mark_done(self, stage: str, fp: str, outputs: Iterable[str | Path], seconds: float = 0.0) -> None:
        """Record that `stage` finished with fingerprint `fp` (written after its outputs)."""
        outs = sorted(o if isinstance(o, str) else self.rel(o) for o in outputs)
        self.write_json(Path(stage) / TIMING, {"seconds": round(seconds, 4)})
        self.write_json(Path(stage) / DONE, {"fingerprint": fp, "outputs": outs})

    def invalidate(self, stage: str) -> None:
        """Forget that `stage` finished (its outputs stay until overwritten)."""
        try:
            self._marker(stage).unlink()
        except FileNotFoundError:
            pass


class Timer:
    """Context manager measuring wall seconds."""

    def __enter__(self) -> "Timer":
        self.t0 = time.perf_counter()
        self.seconds = 0.0
        return self

    def __exit__(self, *exc: Any) -> None:
        self.seconds = time.perf_counter() - self.t0
