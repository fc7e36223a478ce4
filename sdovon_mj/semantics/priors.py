"""Commonsense priors that ship with the package, and an embedding fallback for labels they lack.

The table (``sdovon_mj/data/semantics/priors.json``) is curated by the authors: 0-10 scores of
where objects and furniture are found (regions) and what objects are put on (receptacles); see
its ``source`` field. A label the table lacks is resolved by synonyms, singular form and head
noun ("kitchen counter" -> counter); failing that, by its nearest table label in the bundled
all-MiniLM-L6-v2 embedding space (cosine >= ``NN_MIN``); failing that, its row is the
similarity-weighted mean of the rows of its ``KNN_K`` nearest table labels (softmax, temperature
``KNN_T``; leave-one-out on the table: top-1 0.73 / 0.60, top-2 0.83 / 0.75 for regions /
receptacles, against 0.44 / 0.17 top-1 for direct object-to-candidate similarity; see
``bench/bench_regions.py --embeddings``). A candidate region or receptacle the table lacks is scored
by direct embedding similarity, softmax-calibrated on the table (temperature fitted once per
process). Every score the offline backend returns is mixed with ``FLOOR`` so that no candidate
gets zero (research notes section 5.3).
"""

from __future__ import annotations

import json
import threading
from functools import lru_cache
from importlib import resources
from typing import Any

import numpy as np

from ..embeddings import embed_labels
from .validate import _singular, normalise

FLOOR = 0.5  # score a candidate gets when the table says 0 (0-10 scale)
NN_MIN = 0.72  # cosine to the nearest table label needed to borrow its row
KNN_K = 5  # table labels averaged for a label the table lacks
KNN_T = 0.05  # softmax temperature of their cosine similarities
TEMPERATURES = (0.01, 0.02, 0.03, 0.05, 0.08, 0.12, 0.2, 0.3)
REGION_TEMPLATE = ("a {}", "things found in a {}")
RECEPTACLE_TEMPLATE = ("a {}", "{}")


def with_floor(score: float) -> float:
    """Return a 0-10 score mixed with the floor: 0 -> FLOOR, 10 -> 10."""
    return float(FLOOR + (10.0 - FLOOR) * min(10.0, max(0.0, score)) / 10.0)


@lru_cache(maxsize=1)
def load_table() -> dict[str, Any]:
    """Return the curated priors table (package data)."""
    text = resources.files("sdovon_mj").joinpath("data/semantics/priors.json").read_text(encoding="utf-8")
    return json.loads(text)


def _softmax(x: np.ndarray, t: float) -> np.ndarray:
    z = (x - x.max(axis=-1, keepdims=True)) / t
    e = np.exp(z)
    return e / e.sum(axis=-1, keepdims=True)


class Priors:
    """Lookup of the curated table with synonym, head-noun and embedding fallbacks."""

    def __init__(self, table: dict[str, Any] | None = None) -> None:
        self.table = table or load_table()
        self.labels: dict[str, dict[str, Any]] = self.table["labels"]
        self.regions: list[str] = list(self.table["regions"])
        self.receptacles: list[str] = list(self.table["receptacles"])
        self.synonyms: dict[str, str] = self.table["synonyms"]
        self.region_synonyms: dict[str, str] = self.table["region_synonyms"]
        self._temps: dict[str, float] = {}
        self._lock = threading.Lock()

    # -- resolution -------------------------------------------------------------------------------

    def _lookup(self, n: str) -> str | None:
        """Exact / synonym / singular lookup of a normalised name."""
        for form in (n, _singular(n), n.replace(" ", ""), _singular(n).replace(" ", "")):
            if form in self.labels:
                return form
            if form in self.synonyms:
                return self.synonyms[form]
        return None

    def resolve(self, label: str, embed: bool = True) -> str | None:
        """Return the table label a free-form label means, or None."""
        n = normalise(label)
        if not n:
            return None
        hit = self._lookup(n)
        if hit:
            return hit
        words = n.split(" ")
        for i in range(1, len(words)):  # drop leading modifiers: "small wooden table" -> "table"
            hit = self._lookup(" ".join(words[i:]))
            if hit:
                return hit
        if not embed:
            return None
        return self._nearest(n)

    @lru_cache(maxsize=4096)  # noqa: B019 - one Priors per process
    def _nearest(self, n: str) -> str | None:
        """Return the table label nearest in embedding space, if close enough."""
        names = sorted(set(self.labels) | set(self.synonyms))
        vecs = embed_labels(names)
        q = embed_labels([n])[0]
        sims = vecs @ q
        i = int(np.argmax(sims))
        if float(sims[i]) < NN_MIN:
            return None
        return self.synonyms.get(names[i], names[i])

    def resolve_region(self, name: str) -> str | None:
        """Return the canonical region a free-form region name means, or None."""
        n = normalise(name)
        for form in (n, _singular(n)):
            if form in self.regions:
                return form
            if form in self.region_synonyms:
                return self.region_synonyms[form]
        # containment: "guest bedroom suite" -> bedroom; longest canonical name or synonym first
        words = f" {n} "
        keys = sorted(list(self.regions) + list(self.region_synonyms), key=lambda k: (-len(k), k))
        for k in keys:
            if f" {k} " in words:
                return k if k in self.regions else self.region_synonyms[k]
        return None

    def resolve_receptacle(self, name: str) -> str | None:
        """Return the canonical receptacle a free-form furniture name means, or None."""
        hit = self.resolve(name, embed=False)
        if hit in self.receptacles:
            return hit
        n = normalise(name)
        words = n.split(" ")
        for i in range(len(words)):
            tail = " ".join(words[i:])
            if tail in self.receptacles:
                return tail
        return None

    # -- scoring -----------------------------------------------------------------------------------

    def region_profile(self, label: str) -> dict[str, float] | None:
        """Return the table's region scores (0-10, canonical regions) of a label, or None if unknown/uninformative."""
        key = self.resolve(label)
        if key is None:
            return None
        regs = self.labels[key].get("regions") or {}
        if not regs:
            return None
        return {r: float(regs.get(r, 0.0)) for r in self.regions}

    def _temperature(self, kind: str) -> float:
        """Fit the softmax temperature that makes embedding similarity best match the table (KL)."""
        with self._lock:
            if kind in self._temps:
                return self._temps[kind]
            objs = sorted(k for k, v in self.labels.items() if v.get("kind") == "object" and v.get(kind))
            cands = self.regions if kind == "regions" else self.receptacles
            target = np.array([[self.labels[o][kind].get(c, 0.0) for c in cands] for o in objs]) + 0.1
            target /= target.sum(axis=1, keepdims=True)
            sims = self._sims(objs, cands, kind)
            best, best_kl = TEMPERATURES[0], np.inf
            for t in TEMPERATURES:
                p = _softmax(sims, t)
                kl = float(np.mean(np.sum(target * (np.log(target) - np.log(p + 1e-12)), axis=1)))
                if kl < best_kl - 1e-12:
                    best, best_kl = t, kl
            self._temps[kind] = best
            return best

    def _sims(self, objs: list[str], cands: list[str], kind: str) -> np.ndarray:
        """Return cosine similarities (len(objs), len(cands)) with the kind's templates."""
        t_obj, t_cand = REGION_TEMPLATE if kind == "regions" else RECEPTACLE_TEMPLATE
        a = embed_labels([t_obj.format(o) for o in objs])
        b = embed_labels([t_cand.format(c) for c in cands])
        return a @ b.T

    def embedding_scores(self, obj: str, candidates: list[str], kind: str) -> dict[str, float]:
        """Return 0-10 scores of candidates for an object from calibrated embedding similarity."""
        if not candidates:
            return {}
        t = self._temperature(kind)
        sims = self._sims([normalise(obj)], [normalise(c) for c in candidates], kind)[0]
        p = _softmax(sims[None, :], t)[0]
        p = p / p.max()
        return {c: float(10.0 * v) for c, v in zip(candidates, p)}

    def knn_row(self, label: str, kind: str) -> dict[str, float]:
        """Return a 0-10 row (canonical candidates) for a label the table lacks: mean of its nearest table rows."""
        keys = sorted(k for k, v in self.labels.items() if v.get(kind))
        if not keys:
            return {}
        sims = embed_labels(keys) @ embed_labels([normalise(label)])[0]
        nn = np.argsort(-sims, kind="stable")[:KNN_K]
        w = _softmax(sims[nn][None, :].astype(np.float64), KNN_T)[0]
        cands = self.regions if kind == "regions" else self.receptacles
        return {c: float(sum(wi * self.labels[keys[i]][kind].get(c, 0.0) for wi, i in zip(w, nn))) for c in cands}

    def scores(self, obj: str, candidates: list[str], kind: str) -> dict[str, float]:
        """Return raw 0-10 scores (no floor) of candidate regions or receptacles for an object."""
        assert kind in ("regions", "receptacles")
        key = self.resolve(obj)
        row = (self.labels[key].get(kind) or {}) if key else {}
        if not row:
            row = self.knn_row(obj, kind)
        out: dict[str, float] = {}
        missing: list[str] = []
        for c in candidates:
            canon = self.resolve_region(c) if kind == "regions" else self.resolve_receptacle(c)
            if row and canon is not None:
                out[c] = float(row.get(canon, 0.0))
            else:
                missing.append(c)
        if missing:
            out.update(self.embedding_scores(obj, missing, kind))
        return {c: out[c] for c in candidates}

    def is_receptacle(self, label: str) -> bool:
        """Return whether a label names a receptacle (a surface daily objects are put on)."""
        if self.resolve_receptacle(label) is not None:
            return True
        key = self.resolve(label)
        return key is not None and self.labels[key].get("kind") == "receptacle"


@lru_cache(maxsize=1)
def default_priors() -> Priors:
    """Return the process-wide priors over the shipped table."""
    return Priors()
