"""The learned semantics model: where people put things, from human votes, generalised by sentence embeddings.

Three heads share one form; each predicts, for an object and a *column* (a room-receptacle pair, a
room, or a receptacle), the fraction of people who would call that place correct for the object:

    q(o, k) = clip(mean_k + e(o) . W_k + beta * cos(e('a ' + o), e(k)), 0, 1)

``e`` is the bundled MiniLM sentence embedding (`embeddings.embed_labels`); ``W`` a ridge regression
from the object's embedding to the residual of the training votes after the zero-shot similarity
term (so a seen object reproduces its votes and an unseen one moves with its meaning); ``lambda``
and ``beta`` are chosen on the validation split, never on anything else. A column outside the
training vocabulary ("dishwasher in the garage", "wardrobe") gets the mean of the known columns'
ridge terms weighted by a softmax of embedding similarity (temperature chosen by leave-one-column-out
on the validation split) plus its own zero-shot term, so its score stays on the same calibrated
scale. Targets: the pair head learns the fraction voting the pair correct; the room head the
largest fraction over the room's receptacles; the receptacle head the largest over its rooms.

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


def pair_text(room: str, receptacle: str) -> str:
    """Return the phrase a room-receptacle pair is embedded as."""
    return f"{phrase(receptacle)} in the {phrase(room)}"


def object_vectors(objects: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Return the ridge features (N, 384) and zero-shot vectors (N, 384) of object names."""
    names = [phrase(o) for o in objects]
    return embed_labels(names), embed_labels(["a " + n for n in names])


def _softmax(x: np.ndarray, t: float) -> np.ndarray:
    z = (x - x.max(axis=-1, keepdims=True)) / t
    e = np.exp(z)
    return e / e.sum(axis=-1, keepdims=True)


@dataclass
class Head:
    """One fitted head: its training columns (phrases), the ridge terms and the zero-shot weight."""

    columns: list[str]
    mean: np.ndarray  # (K,)
    weights: np.ndarray  # (384, K)
    beta: float
    lam: float
    temperature: float  # softmax temperature over column similarity for unseen columns

    def __post_init__(self) -> None:
        self._index = {c: i for i, c in enumerate(self.columns)}
        self._col_vecs: np.ndarray | None = None

    def column_vectors(self) -> np.ndarray:
        """Return the embeddings of the training columns (K, 384)."""
        if self._col_vecs is None:
            self._col_vecs = embed_labels(list(self.columns))
        return self._col_vecs

    def predict(self, feats: np.ndarray, zs: np.ndarray, columns: list[str]) -> np.ndarray:
        """Return calibrated scores (N, len(columns)) in [0, 1] for objects (features, zero-shot vectors)."""
        base = self.mean[None, :] + feats @ self.weights  # (N, K) ridge terms of the known columns
        out = np.zeros((feats.shape[0], len(columns)))
        new = [c for c in columns if c not in self._index]
        mix: dict[str, np.ndarray] = {}
        if new:
            sims = embed_labels(new) @ self.column_vectors().T  # (M, K)
            w = _softmax(sims, self.temperature)
            for c, row in zip(new, w):
                mix[c] = row
        cvec = embed_labels(list(columns))
        zero = zs @ cvec.T  # (N, C)
        for j, c in enumerate(columns):
            ridge = base[:, self._index[c]] if c in self._index else base @ mix[c]
            out[:, j] = ridge + self.beta * zero[:, j]
        return np.clip(out, 0.0, 1.0)

    def to_dict(self) -> dict[str, Any]:
        """Return the head as JSON-ready data (arrays as little-endian float32 base64)."""
        enc = lambda a: base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode("ascii")  # noqa: E731
        return {"columns": list(self.columns), "beta": self.beta, "lambda": self.lam,
                "temperature": self.temperature, "mean": enc(self.mean), "weights": enc(self.weights)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Head":
        """Rebuild a head from `to_dict` data."""
        dec = lambda s: np.frombuffer(base64.b64decode(s), dtype="<f4").astype(np.float64)  # noqa: E731
        k = len(d["columns"])
        return cls(columns=list(d["columns"]), mean=dec(d["mean"]).reshape(k), weights=dec(d["weights"]).reshape(DIM, k),
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
             temperature: float) -> Head:
    """Fit one head by ridge regression on the residual after the zero-shot term.

    Parameters
    ----------
    feats : ndarray, shape (N, 384)
        Ridge features of the training objects (`object_vectors`).
    zs : ndarray, shape (N, 384)
        Zero-shot vectors of the training objects.
    columns : list of str
        Column phrases (K).
    targets : ndarray, shape (N, K)
        Fraction of annotators voting each column correct, 0-1.
    lam : float
        Ridge penalty (on unit-norm 384-d features).
    beta : float
        Weight of the zero-shot cosine similarity term.
    temperature : float
        Softmax temperature over column similarity for columns outside `columns`.
    """
    resid = targets - beta * (zs @ embed_labels(list(columns)).T)
    mean = resid.mean(axis=0)
    a = feats.T @ feats + lam * np.eye(feats.shape[1])
    w = np.linalg.solve(a, feats.T @ (resid - mean))
    return Head(columns=list(columns), mean=mean, weights=w, beta=float(beta), lam=float(lam),
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
