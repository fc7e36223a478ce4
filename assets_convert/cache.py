"""Conversion cache: key = hash(input bytes + referenced files + every parameter + converter version).

Folder: ``$SDOVON_CACHE/convert`` when SDOVON_CACHE is set (``off`` disables caching), else ``~/.cache/sdovon-mj/convert``.
A finished entry is a folder renamed into place atomically; a hit hard-links (or copies) it out.
Each entry records the sha256 of its files (``.entry.json``); a hit whose files no longer match (a truncated
or edited file, an entry from before the record) is discarded and converted again, never used as it is.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from sdovon_mj.store import CACHE_OFF, user_cache_dir

CONVERTER_VERSION = "assets_convert-9"  # bump whenever the output of a conversion changes (9: one MJCF material per look)


def cache_root(cache_dir: str | Path | None = None) -> Path | None:
    """Return the cache folder (None when caching is off)."""
    if cache_dir is not None:
        return None if str(cache_dir).lower() in CACHE_OFF else Path(cache_dir)
    return user_cache_dir("convert")


def cache_key(files: list[Path], params: dict[str, Any]) -> str:
    """Return the hex key of a conversion: file bytes (in order) + parameters + converter version."""
    h = hashlib.sha256()
    h.update(CONVERTER_VERSION.encode())
    h.update(json.dumps(params, sort_keys=True, default=str).encode())
    for f in files:
        h.update(b"\0file\0")
        h.update(Path(f).name.encode("utf-8", "backslashreplace"))
        with open(f, "rb") as fh:
            while True:
                b = fh.read(1 << 20)
                if not b:
                    break
                h.update(b)
    return h.hexdigest()[:32]


ENTRY = ".entry.json"  # {relative file: sha256} of a cache entry, written before the entry is renamed in


def _entry_digests(folder: Path) -> dict[str, str]:
    """Return {relative POSIX path: sha256} of every file of an entry folder (its record aside)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.name != ENTRY:
            out[p.relative_to(folder).as_posix()] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def entry_problem(entry: Path) -> str:
    """Return why a cache entry cannot be used ('' when its files match its record)."""
    if not (entry / "asset.json").is_file():
        return "no asset.json"
    try:
        want = json.loads((entry / ENTRY).read_text(encoding="utf-8"))
    except FileNotFoundError:
        return f"no {ENTRY} (an entry of an older converter)"
    except (OSError, ValueError) as e:
        return f"unreadable {ENTRY} ({e})"
    got = _entry_digests(entry)
    if got != want:
        bad = sorted(k for k in set(got) | set(want) if got.get(k) != want.get(k))
        return "files changed since it was stored: " + ", ".join(bad[:3]) + (" ..." if len(bad) > 3 else "")
    return ""


def lookup(root: Path | None, key: str) -> Path | None:
    """Return the cached folder of a key, or None (a damaged entry is discarded: a miss)."""
    if root is None:
        return None
    p = root / key
    if not p.is_dir():
        return None
    if entry_problem(p):
        discard(p)
        return None
    return p


def discard(entry: Path) -> None:
    """Remove a cache entry (renamed away first, so no reader sees half of it)."""
    gone = entry.with_name(f".{entry.name}.bad.{os.getpid()}")
    try:
        os.rename(entry, gone)
    except OSError:
        return  # another process discarded (or replaced) it first
    shutil.rmtree(gone, ignore_errors=True)


def store(root: Path | None, key: str, src: Path) -> None:
    """Copy a finished conversion folder into the cache (atomic rename; a racing writer wins)."""
    if root is None:
        return
    root.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{key}.", dir=root))
    try:
        shutil.copytree(src, tmp, dirs_exist_ok=True)
        (tmp / ENTRY).write_text(json.dumps(_entry_digests(tmp), sort_keys=True), encoding="utf-8")
        try:
            os.rename(tmp, root / key)
        except OSError:
            pass  # another process stored the same key first
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def scratch_dir(dst: Path) -> Path:
    """Return a new empty scratch folder beside `dst` (``.<name>.tmp.<pid>.<random>``), for `replace_dir`.

    The pid in its name lets a later `replace_dir` of the same target remove it if this process is killed first.
    """
    dst.parent.mkdir(parents=True, exist_ok=True)
    return Path(tempfile.mkdtemp(prefix=f".{dst.name}.tmp.{os.getpid()}.", dir=dst.parent))


def _alive(pid: int) -> bool:
    """Return whether a process with this id exists (another user's counts as alive)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def remove_stale(dst: Path) -> list[Path]:
    """Remove what killed processes left beside `dst`: ``.<name>.old.<pid>`` and ``.<name>.tmp.<pid>.*`` folders
    of processes that no longer exist (a SIGKILL between the renames of `replace_dir`, or during a build into a
    `scratch_dir`). Returns the folders removed. Dot-folders are never read as scenes or objects, but they would
    stay in the run folder forever.
    """
    removed = []
    for p in dst.parent.glob(f".{dst.name}.*"):
        rest = p.name[len(dst.name) + 2:].split(".")
        if len(rest) >= 2 and rest[0] in ("old", "tmp") and rest[1].isdigit() and int(rest[1]) != os.getpid() \
                and not _alive(int(rest[1])) and p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
    return removed


def link_tree(src: Path, dst: Path) -> None:
    """Replace folder `dst` with a hard-linked (else copied) copy of `src`, atomically by rename."""
    tmp = scratch_dir(dst)

    def _link(s: str, d: str) -> None:
        try:
            os.link(s, d)
        except OSError:
            shutil.copy2(s, d)

    shutil.copytree(src, tmp, copy_function=_link, dirs_exist_ok=True, ignore=shutil.ignore_patterns(ENTRY))
    replace_dir(tmp, dst)


def replace_dir(tmp: Path, dst: Path) -> None:
    """Move a finished folder over `dst` (old contents removed; what killed processes left beside it too)."""
    remove_stale(dst)
    old = None
    if dst.exists():
        old = dst.with_name(f".{dst.name}.old.{os.getpid()}")
        if old.exists():
            shutil.rmtree(old, ignore_errors=True)
        os.rename(dst, old)
    os.rename(tmp, dst)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
