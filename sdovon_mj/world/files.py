"""Byte-deterministic file writing of the default world: sorted-key JSON, rounded numbers, atomic writes."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np


def num(x: float) -> float:
    """Round a coordinate for JSON (6 decimals, no negative zero)."""
    return float(round(float(x), 6)) + 0.0


def poly_json(p: np.ndarray) -> list[list[float]]:
    """Return a polygon as a JSON list of [x, y]."""
    return [[num(a), num(b)] for a, b in np.asarray(p)]


def dumps_json(data: dict, indent: int | None = 1) -> str:
    """Serialise JSON deterministically (sorted keys)."""
    if indent is None:
        return json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return json.dumps(data, sort_keys=True, indent=indent, ensure_ascii=True) + "\n"


def write_bytes(path: Path, data: bytes) -> None:
    """Write a file atomically (temp file + rename)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)
