"""The learned semantics model: where people put things, from human votes, generalised by sentence embeddings.

Three heads share one form; each predicts, for an object and a *column* (a room-receptacle pair, a
room, or a receptacle), the fraction of people who would call that place correct for the object:

    q(o, k) = clip(bias + e(o) . W . kc(k) + beta * cos(e('a ' + o), e(k)), 0, 1)

``e`` is the bundled MiniLM sentence embedding (`embeddings.embed_labels`); ``kc(k)`` the column
kernel exp((cos(e(k_i), e(k)) - 1) / T) against the K training columns; ``W`` (384, K) a
Kronecker-kernel ridge regression (object kernel linear in e(o), column kernel kc) of the training
votes' residual after the zero-shot term and one global bias. No per-column term: a column is
scored from its embedding only, so a column outside the training vocabulary ("wardrobe", "dishwasher
in the garage") takes the same formula, borrowing from training columns that mean the same and
from the zero-shot term alone when none does (never the average column's popularity). ``beta`` is
the per-column-centred least-squares slope on the train votes times a scale (the slope of a noisy
regressor is attenuated towards 0, and unseen columns rest on this term); the scale, ``lambda`` and
``T`` are chosen on the validation split (seen columns and each column group held out), never on
anything else. Targets: the pair head learns the fraction voting the pair
correct; the room head the largest fraction over the room's receptacles; the receptacle head the
largest over its rooms.

The fitted weights ship as ``sdovon_mj/data/semantics/learned.json`` (``tools/train_semantics.py``).
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Any

import numpy as np

from ..embeddings import DIM, embed_labels
from .judgements import Judgements, phrase

MODEL_PATH = "data/semantics/learned.json"
HEADS = ("pair", "room", "receptacle")
# Loaded weights are rounded to multiples of 2**-24 (|W| < 1: a float32 weight moves by < 3e-8): with embeddings
# on the 2**-20 grid (`embeddings.QUANTUM`) every product is a multiple of 2**-44 below 1, and the 384 of a row
# of ``e(o) . W`` add up exactly in float64 (< 2**53 multiples) in any order, so that term is the same bits on
# every CPU and thread count. What is left inexact is the column kernel's exp and its product with that term:
# float64 noise of a few units in the 14th digit against scores rounded to 6 decimals (`backends.offline`),
# a flip chance of about 1e-8 per score.
WEIGHT_QUANTUM = 2.0 ** -24


@lru_cache(maxsize=1 << 16)
def pair_text(room: str, receptacle: str) -> str:
    """Return the phrase a room-receptacle pair is embedded as."""
    return f"{phrase(receptacle)} in the {phrase(room)}"


def object_vectors(objects: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Return the ridge features (N, 384) and zero-shot vectors (N, 384) of object names."""
    names = [phrase(o) for o in objects]
    return embed_labels(names), embed_labels(["a " + n for n in names])


def column_kernel(a: np.ndarray, b: np.ndarray, temperature: float) -> np.ndarray:
    """Return the column kernel exp((cos(a, b) - 1) / temperature), shape (len(a), len(b)).

    1 for the same phrase, falling towards 0 for unrelated ones: an unseen column borrows from the
    training columns that mean the same, and from nothing when none does (no popularity fallback).
    """
    return np.exp((np.asarray(a) @ np.asarray(b).T - 1.0) / float(temperature))


@dataclass
class Head:
    """One fitted head: a bilinear object-column compatibility learned from the votes.

    ``q(o, k) = clip(bias + e(o) . W . kc(k) + beta * cos(e('a ' + o), e(k)), 0, 1)`` with
    ``kc(k) = column_kernel(columns, k)`` (K,): the compatibility of an object and a column is a
    function of both embeddings (Kronecker-kernel ridge regression, linear in the object embedding,
    a similarity kernel over column embeddings), one global bias, no per-column term. A column
    outside the training vocabulary is scored by the same formula.
    """

    columns: list[str]
    bias: float
    weights: np.ndarray  # (384, K): F^T alpha of the kernel ridge fit
    beta: float
    lam: float
    temperature: float  # column-kernel temperature

    def __post_init__(self) -> None:
        self._col_vecs: np.ndarray | None = None
        self._kc: dict[str, np.ndarray] = {}  # column text -> its column of the kernel (K,)

    def column_vectors(self) -> np.ndarray:
        """Return the embeddings of the training columns (K, 384)."""
        if self._col_vecs is None:
            self._col_vecs = embed_labels(list(self.columns))
        return self._col_vecs

    def predict(self, feats: np.ndarray, zs: np.ndarray, columns: list[str]) -> np.ndarray:
        """Return calibrated scores (N, len(columns)) in [0, 1] for objects (features, zero-shot vectors)."""
        if not columns:
            return np.zeros((feats.shape[0], 0))
        cvec = embed_labels(list(columns))
        kc = self._kernel(list(columns), cvec)  # (K, C)
        out = self.bias + (feats @ self.weights) @ kc + self.beta * (zs @ cvec.T)
        return np.clip(out, 0.0, 1.0)

    KERNEL_CACHE = 50_000  # columns kept (K floats each); past it the cache starts again

    def _kernel(self, columns: list[str], cvec: np.ndarray) -> np.ndarray:
        """Return `column_kernel` (K, len(columns)) of the training columns and these, each column computed once.

        A column's values do not depend on which others are asked with it: the embeddings lie on the 2**-20 grid
        (`embeddings.QUANTUM`), so each dot product of the matrix product is exact in float64 in any summation
        order, and the rest of the kernel is elementwise.
        """
        missing = [j for j, c in enumerate(columns) if c not in self._kc]
        if missing:
            if len(self._kc) + len(missing) > self.KERNEL_CACHE:
                self._kc.clear()
                missing = list(range(len(columns)))
            fresh = column_kernel(self.column_vectors(), cvec[missing], self.temperature)
            for n, j in enumerate(missing):
                self._kc[columns[j]] = fresh[:, n].copy()
        return np.stack([self._kc[c] for c in columns], axis=1)

    def to_dict(self) -> dict[str, Any]:
        """Return the head as JSON-ready data (arrays as little-endian float32 base64)."""
        enc = lambda a: base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode("ascii")  # noqa: E731
        return {"columns": list(self.columns), "beta": self.beta, "lambda": self.lam, "bias": self.bias,
                "temperature": self.temperature, "weights": enc(self.weights)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Head":
        """Rebuild a head from `to_dict` data (weights on the `WEIGHT_QUANTUM` grid)."""
        dec = lambda s: np.frombuffer(base64.b64decode(s), dtype="<f4").astype(np.float64)  # noqa: E731
        k = len(d["columns"])
        weights = np.round(dec(d["weights"]) / WEIGHT_QUANTUM) * WEIGHT_QUANTUM
        return cls(columns=list(d["columns"]), bias=float(d["bias"]), weights=weights.reshape(DIM, k),
                   beta=float(d["beta"]), lam=float(d["lambda"]), temperature=float(d["temperature"]))


def head_targets(j: Judgements, objects: list[str], head: str) -> tuple[list[str], np.ndarray]:
    """Return a head's column phrases and its training targets (len(objects), K) from the votes."""
    frac = j.fraction(objects)
    if head == "pair":
        return [pair_text(r, c) for r, c in j.pairs], frac
    if head == "room":
        return [phrase(r) for r in j.rooms], np.stack([frac[:, j.room_columns(r)].max(axis=1) for r in j.rooms], axis=1)
    if head == "receptacle":
        return ([phrase(c) for c in j.receptacles],
                np.stack([frac[:, j.receptacle_columns(c)].max(axis=1) for c in j.receptacles], axis=1))
    raise ValueError(f"unknown head {head!r} (one of {', '.join(HEADS)})")


def fit_head(feats: np.ndarray, zs: np.ndarray, columns: list[str], targets: np.ndarray, lam: float, beta: float,
             temperature: float, col_vecs: np.ndarray | None = None) -> Head:
    """Fit one head by Kronecker-kernel ridge regression on the residual after the zero-shot term.

    Parameters
    ----------
    feats : ndarray, shape (N, 384)
        Ridge features of the training objects (`object_vectors`); object kernel ``feats @ feats.T``.
    zs : ndarray, shape (N, 384)
        Zero-shot vectors of the training objects.
    columns : list of str
        Column phrases (K).
    targets : ndarray, shape (N, K)
        Fraction of annotators voting each column correct, 0-1.
    lam : float
        Ridge penalty.
    beta : float
        Weight of the zero-shot cosine similarity term.
    temperature : float
        Column-kernel temperature (`column_kernel`).
    col_vecs : ndarray, shape (K, 384), optional
        Embeddings of `columns` (computed when omitted).
    """
    cv = embed_labels(list(columns)) if col_vecs is None else col_vecs
    resid = targets - beta * (zs @ cv.T)
    bias = float(resid.mean())
    resid = resid - bias
    do, u = np.linalg.eigh(feats @ feats.T)
    dc, v = np.linalg.eigh(column_kernel(cv, cv, temperature))
    do, dc = np.clip(do, 0.0, None), np.clip(dc, 0.0, None)
    alpha = u @ ((u.T @ resid @ v) / (do[:, None] * dc[None, :] + lam)) @ v.T
    return Head(columns=list(columns), bias=bias, weights=feats.T @ alpha, beta=float(beta), lam=float(lam),
                temperature=float(temperature))


class LearnedModel:
    """The three fitted heads with the facts of their training (data source, splits, scores)."""

    def __init__(self, heads: dict[str, Head], info: dict[str, Any]) -> None:
        missing = [h for h in HEADS if h not in heads]
        if missing:
            raise ValueError(f"learned model lacks heads: {', '.join(missing)}")
        self.heads = heads
        self.info = info

    @property
    def version(self) -> str:
        """Return the model's version tag (records name it)."""
        return str(self.info.get("version", "0"))

    def _scores(self, head: str, obj: str, columns: list[str]) -> np.ndarray:
        feats, zs = object_vectors([obj])
        return self.heads[head].predict(feats, zs, columns)[0]

    def score_rooms(self, obj: str, rooms: list[str]) -> np.ndarray:
        """Return P(a person calls some receptacle of the room right for obj), per room, in [0, 1]."""
        return self._scores("room", obj, [phrase(r) for r in rooms])

    def score_receptacles(self, obj: str, receptacles: list[str]) -> np.ndarray:
        """Return P(a person calls the receptacle right for obj, in its best room), per receptacle, in [0, 1]."""
        return self._scores("receptacle", obj, [phrase(c) for c in receptacles])

    def score_pairs(self, obj: str, rooms: list[str], receptacles: list[str]) -> np.ndarray:
        """Return P(a person calls receptacle c in room r right for obj), shape (len(rooms), len(receptacles))."""
        cols = [pair_text(r, c) for r in rooms for c in receptacles]
        if not cols:
            return np.zeros((len(rooms), len(receptacles)))
        return self._scores("pair", obj, cols).reshape(len(rooms), len(receptacles))

    def nearest_training_object(self, obj: str) -> tuple[str, float]:
        """Return the training object nearest in meaning to obj and the cosine similarity."""
        names = list(self.info.get("train_objects") or [])
        if not names:
            return "", 0.0
        sims = embed_labels([phrase(n) for n in names]) @ embed_labels([phrase(obj)])[0]
        i = int(np.argmax(sims))
        return names[i], float(sims[i])

    def to_json(self) -> str:
        """Return the model as deterministic JSON text."""
        data = {"info": self.info, "heads": {h: self.heads[h].to_dict() for h in HEADS}}
        return json.dumps(data, indent=1, sort_keys=True) + "\n"

    @classmethod
    def from_json(cls, text: str) -> "LearnedModel":
        """Parse a model from `to_json` text."""
        data = json.loads(text)
        return cls({h: Head.from_dict(data["heads"][h]) for h in HEADS}, dict(data.get("info") or {}))


@lru_cache(maxsize=1)
def default_model() -> LearnedModel:
    """Return the shipped model (package data, trained by tools/train_semantics.py)."""
    text = resources.files("sdovon_mj").joinpath(MODEL_PATH).read_text(encoding="utf-8")
    return LearnedModel.from_json(text)
