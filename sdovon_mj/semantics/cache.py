"""Disk cache of validated LLM answers, keyed by backend, model, prompt version and canonical inputs.

One JSON file per entry (``<dir>/<key[:2]>/<key>.json``, written atomically) holding the inputs,
the validated result and every raw reply of the exchange, for audit. The cache, not a sampling
seed, is what makes re-runs against a server reproducible.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from ..records import dumps
from ..store import atomic_write_text


def canonical(data: Any) -> str:
    """Return canonical JSON text of JSON-able data (sorted keys, no spaces)."""
    return json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=False)


def cache_key(backend: str, model: str, prompt_version: str, inputs: Any, options: Any = None) -> str:
    """Return the hex key of one question to one model.

    Parameters
    ----------
    backend : str
        Backend name.
    model : str
        Model name.
    prompt_version : str
        Version of the prompt template.
    inputs : JSON-able
        The question's inputs.
    options : JSON-able, optional
        Sampling options that change the answer.
    """
    blob = canonical({"backend": backend, "model": model, "prompt": prompt_version, "inputs": inputs,
                      "options": options or {}})
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


class DiskCache:
    """A folder of cached answers; unreadable entries count as misses."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.hits = 0
        self.misses = 0

    def _path(self, key: str) -> Path:
        return self.root / key[:2] / f"{key}.json"

    def get(self, key: str) -> dict[str, Any] | None:
        """Return the cached entry for `key`, or None."""
        p = self._path(key)
        try:
            entry = json.loads(p.read_text(encoding="utf-8"))
        except (FileNotFoundError, json.JSONDecodeError, UnicodeDecodeError):
            self.misses += 1
            return None
        if not isinstance(entry, dict) or entry.get("key") != key or "result" not in entry:
            self.misses += 1
            return None
        self.hits += 1
        return entry

    def put(self, key: str, entry: dict[str, Any]) -> Path:
        """Store an entry (inputs, result, raw replies) atomically; return its file."""
        p = self._path(key)
        atomic_write_text(p, dumps({**entry, "key": key}))
        return p

    def __len__(self) -> int:
        return sum(1 for _ in self.root.glob("*/*.json")) if self.root.exists() else 0
