"""Human judgements of where objects belong, and the measure that scores a method against them.

The file layout is Housekeep's (Kant et al., ECCV 2022; ``housekeep_train_val.json``):
``room_receptacles`` ("room|receptacle" pairs), ``objects``, ``splits`` (split -> objects) and
``votes[object]`` = {"correct": [...], "misplaced": [...], "implausible": [...]} with one count per
pair, out of ``annotators_per_pair`` people.

The measure (Housekeep's own): a pair is *correct* for an object when at least 6 of 10 annotators
voted it correct. ORR mAP: for every (object, room) with at least one correct receptacle, rank that
room's receptacles by the method's score and take the average precision (tied scores enter the
ranking together); the mean over those (object, room). OR mAP: per object, rank the rooms; a room
is correct if it holds a correct receptacle. Chance is the expected average precision of a uniformly
random order (exact, not sampled).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError

CORRECT_FRACTION = 0.6  # "at least 6 of 10 annotators voted correct"


def phrase(name: str) -> str:
    """Return a label as plain text for a language model: 'bottom_cabinet' -> 'bottom cabinet'."""
    return _phrase(name if isinstance(name, str) else str(name))


@lru_cache(maxsize=1 << 16)
def _phrase(name: str) -> str:  # a pure function of the text: the relevance scores ask it for every pair, every time
    return " ".join(name.replace("_", " ").split()).lower()


@dataclass
class Judgements:
    """Human votes: `correct[i, k]` of `annotators` people called pair k a tidy place for object i."""

    path: str
    pairs: list[tuple[str, str]]  # (room, receptacle), file spelling
    objects: list[str]
    splits: dict[str, list[str]]
    correct: np.ndarray  # (O, P) int vote counts
    annotators: int
    rooms: list[str] = field(default_factory=list)
    receptacles: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.rooms:
            self.rooms = sorted({r for r, _ in self.pairs})
        if not self.receptacles:
            self.receptacles = sorted({c for _, c in self.pairs})

    def default_split(self) -> str:
        """Return the split scored when none is named: ``val`` when the file has one, else its only split (a file of
        held-out objects with one split, such as ``test``; ``all`` for a file without splits); InputError naming the
        file and its splits when it has several and no ``val``."""
        if "val" in self.splits:
            return "val"
        if len(self.splits) == 1:
            return next(iter(self.splits))
        raise InputError(self.path, f"no split 'val' and {len(self.splits)} others "
                                    f"({', '.join(sorted(self.splits))}): name one (--split NAME, or all)")

    def split(self, name: str) -> list[str]:
        """Return the objects of one split (InputError naming the file when it has no such split)."""
        if name == "all":
            return list(self.objects)
        if name not in self.splits:
            raise InputError(self.path, f"no split {name!r} (splits: {', '.join(sorted(self.splits)) or 'none'})")
        return list(self.splits[name])

    def fraction(self, objects: list[str]) -> np.ndarray:
        """Return the fraction of annotators voting correct, (len(objects), P)."""
        idx = [self.objects.index(o) for o in objects]
        return self.correct[idx].astype(np.float64) / float(self.annotators)

    def room_columns(self, room: str) -> list[int]:
        """Return the pair indices of one room."""
        return [k for k, (r, _c) in enumerate(self.pairs) if r == room]

    def receptacle_columns(self, receptacle: str) -> list[int]:
        """Return the pair indices of one receptacle type (every room it stands in)."""
        return [k for k, (_r, c) in enumerate(self.pairs) if c == receptacle]


def load_judgements(path: str | Path) -> Judgements:
    """Read a human-judgement file in the layout of ``housekeep_train_val.json`` (InputError names what is wrong)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as e:
        raise InputError(path, f"cannot read: {e.strerror or e}") from e
    except ValueError as e:
        raise InputError(path, f"not JSON: {e}") from e
    if not isinstance(data, dict):
        raise InputError(path, "expected a JSON object with room_receptacles, objects, splits, votes")
    for key in ("room_receptacles", "objects", "votes"):
        if key not in data:
            raise InputError(path, f"missing key '{key}'")
    pairs: list[tuple[str, str]] = []
    for p in data["room_receptacles"]:
        if not isinstance(p, str) or p.count("|") != 1 or not all(p.split("|")):
            raise InputError(path, f"room_receptacles entry {p!r} is not 'room|receptacle'")
        room, rec = p.split("|")
        pairs.append((room, rec))
    if len(set(pairs)) != len(pairs):
        raise InputError(path, "room_receptacles has repeated pairs")
    objects = [str(o) for o in data["objects"]]
    annotators = data.get("annotators_per_pair", 10)
    if not isinstance(annotators, int) or annotators < 1:
        raise InputError(path, f"annotators_per_pair must be a positive integer, got {annotators!r}")
    rows = []
    for o in objects:
        v = data["votes"].get(o)
        if not isinstance(v, dict) or "correct" not in v:
            raise InputError(path, f"votes[{o!r}] lacks a 'correct' list")
        c = v["correct"]
        if not isinstance(c, list) or len(c) != len(pairs):
            raise InputError(path, f"votes[{o!r}]['correct'] has {len(c) if isinstance(c, list) else 'no'} "
                                   f"counts, expected {len(pairs)} (one per room_receptacles pair)")
        if not all(isinstance(x, int) and 0 <= x <= annotators for x in c):
            raise InputError(path, f"votes[{o!r}]['correct'] holds a count outside 0..{annotators}")
        rows.append(c)
    splits = data.get("splits") or {"all": objects}
    if not isinstance(splits, dict):
        raise InputError(path, "splits must map a split name to a list of objects")
    for name, objs in splits.items():
        missing = [o for o in objs if o not in objects]
        if missing:
            raise InputError(path, f"split {name!r} names objects without votes: {', '.join(missing[:5])}")
    return Judgements(path=str(path), pairs=pairs, objects=objects, splits={k: list(v) for k, v in splits.items()},
                      correct=np.asarray(rows, dtype=np.int64).reshape(len(objects), len(pairs)), annotators=annotators)


# ----------------------------------------------------------------------------------------------
# The measure


def average_precision(scores: np.ndarray, positive: np.ndarray) -> float:
    """Return the average precision of a ranking by decreasing score; tied scores enter together.

    A group of tied items enters the ranking at once: each positive in it gets the precision at the
    end of the group. A constant scorer therefore scores the positive rate, never a lucky order.
    """
    s = np.asarray(scores, dtype=np.float64)
    pos = np.asarray(positive, dtype=bool)
    n_pos = int(pos.sum())
    if n_pos == 0:
        raise ValueError("average precision needs at least one positive")
    order = np.argsort(-s, kind="stable")
    s, pos = s[order], pos[order]
    total, seen, seen_pos, i = 0.0, 0, 0, 0
    while i < len(s):
        j = i
        while j < len(s) and s[j] == s[i]:
            j += 1
        group_pos = int(pos[i:j].sum())
        seen += j - i
        seen_pos += group_pos
        total += group_pos * seen_pos / seen
        i = j
    return total / n_pos


def chance_average_precision(n: int, n_pos: int) -> float:
    """Return the expected average precision of a uniformly random order of n items with n_pos positives.

    E[AP] = (1/N) [H_N + (R-1)/(N-1) (N - H_N)], H_N the N-th harmonic number (exact).
    """
    if n_pos < 1 or n < n_pos:
        raise ValueError(f"need 1 <= n_pos <= n, got n={n}, n_pos={n_pos}")
    h = float(sum(1.0 / k for k in range(1, n + 1)))
    if n == 1:
        return 1.0
    return (h + (n_pos - 1) / (n - 1) * (n - h)) / n


@dataclass
class Score:
    """ORR and OR mean average precision of a method on some objects, with chance beside."""

    orr_map: float
    or_map: float
    orr_chance: float
    or_chance: float
    n_orr: int  # (object, room) pairs ranked
    n_or: int  # objects ranked over rooms

    def as_dict(self) -> dict[str, Any]:
        """Return the figures as a plain dict (rounded to 4 decimals)."""
        return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in self.__dict__.items()}


def score_method(j: Judgements, objects: list[str], pair_scores: np.ndarray, room_scores: np.ndarray) -> Score:
    """Return the ORR / OR mAP of a method's scores on `objects`.

    Parameters
    ----------
    j : Judgements
        The human votes.
    objects : list of str
        Objects to score (rows of the two score arrays).
    pair_scores : ndarray, shape (len(objects), len(j.pairs))
        The method's score of each room-receptacle pair for each object (any scale; higher = better).
    room_scores : ndarray, shape (len(objects), len(j.rooms))
        The method's score of each room for each object.
    """
    pos = j.fraction(objects) >= CORRECT_FRACTION - 1e-9
    orr, orr_c, orl, orl_c = [], [], [], []
    for i in range(len(objects)):
        room_pos = []
        for r in j.rooms:
            cols = j.room_columns(r)
            p = pos[i, cols]
            room_pos.append(bool(p.any()))
            if p.any():
                orr.append(average_precision(pair_scores[i, cols], p))
                orr_c.append(chance_average_precision(len(cols), int(p.sum())))
        rp = np.array(room_pos)
        if rp.any():
            orl.append(average_precision(room_scores[i], rp))
            orl_c.append(chance_average_precision(len(rp), int(rp.sum())))
    mean = lambda xs: float(np.mean(xs)) if xs else float("nan")  # noqa: E731
    return Score(mean(orr), mean(orl), mean(orr_c), mean(orl_c), len(orr), len(orl))


def backend_scores(backend: Any, j: Judgements, objects: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Ask a semantics backend for its pair and room scores of `objects` over the file's vocabulary.

    Names are passed as plain text ('bottom cabinet', "childs room"); pair scores come from the
    backend's search-direction model (`Backend.answer_pairs`: its own (or its fallback's), or the product of its region
    and receptacle answers). Returns (pair scores (O, P), room scores (O, R)).
    """
    rooms = [phrase(r) for r in j.rooms]
    recs = [phrase(c) for c in j.receptacles]
    ri = {r: i for i, r in enumerate(j.rooms)}
    ci = {c: i for i, c in enumerate(j.receptacles)}
    pair = np.zeros((len(objects), len(j.pairs)))
    room = np.zeros((len(objects), len(j.rooms)))
    for i, o in enumerate(objects):
        obj = phrase(o)
        before = len(backend.fallbacks)
        s_rgn = backend.score_regions(obj, rooms)
        s_rec = backend.score_receptacles(obj, recs)
        room[i] = [float(s_rgn.get(r, 0.0)) for r in rooms]
        table = backend.answer_pairs(obj, rooms, recs, room[i], np.array([float(s_rec.get(c, 0.0)) for c in recs]),
                                     len(backend.fallbacks) > before)
        pair[i] = [table[ri[r], ci[c]] for r, c in j.pairs]
    return pair, room
