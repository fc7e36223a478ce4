"""Object-region and object-receptacle relevance (paper section 3.4, prompts C.3 and C.4).

For each object the backend scores every region and every receptacle 0-10. Scores are normalised
over objects, per region (receptacle): P(obj|rgn) = s(obj, rgn) / sum_obj s(obj, rgn); a column
whose scores are all 0 becomes uniform. The joint relevance is P(obj|rgn) * P(obj|rec)
(``Relevance.joint``; the paper's printed equation repeats one factor, a typo).

Both directions come from one model per backend: ``Relevance.p_pair`` (O, R, C) holds each object's
score of each region-receptacle pair (`Backend.pair_scores`: the offline backend's learned pair head,
or the product of a server's two answers); placement normalises it over objects per pair
(``Relevance.joint``), Semantic A* ranks one object's pairs by it (``Relevance.search``).
``Relevance.sources`` records what produced each object's row, ``Relevance.backend`` what answered.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..records import Relevance
from .backends import Backend


def _dedupe(names: Sequence[str]) -> list[str]:
    """Return names without repeats, first spelling kept, order kept."""
    out: list[str] = []
    for n in names:
        if n not in out:
            out.append(str(n))
    return out


def normalise_columns(s: np.ndarray) -> np.ndarray:
    """Return scores normalised over rows (objects) per column; all-zero columns become uniform."""
    s = np.asarray(s, dtype=np.float64)
    if s.size == 0:
        return s
    col = s.sum(axis=0, keepdims=True)
    uniform = np.full_like(s, 1.0 / s.shape[0])
    return np.where(col > 0, s / np.where(col > 0, col, 1.0), uniform)


def score_tables(objects: Sequence[str], regions: Sequence[str], receptacles: Sequence[str],
                 backend: Backend) -> tuple[np.ndarray, np.ndarray]:
    """Return raw 0-10 scores (O, R) object-region and (O, C) object-receptacle from the backend."""
    s_rgn, s_rec, _pair, _src = _ask_all(_dedupe(objects), _dedupe(regions), _dedupe(receptacles), backend)
    return s_rgn, s_rec


def _ask_all(objs: list[str], regs: list[str], recs: list[str],
             backend: Backend) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """Return region scores, receptacle scores, pair scores (O, R, C) and each row's source."""
    s_rgn = np.zeros((len(objs), len(regs)))
    s_rec = np.zeros((len(objs), len(recs)))
    pair = np.zeros((len(objs), len(regs), len(recs)))
    sources: list[str] = []
    for i, o in enumerate(objs):
        before = len(backend.fallbacks)
        if regs:
            sr = backend.score_regions(o, regs)
            s_rgn[i] = [float(sr.get(r, 0.0)) for r in regs]
        if recs:
            sc = backend.score_receptacles(o, recs)
            s_rec[i] = [float(sc.get(c, 0.0)) for c in recs]
        fell_back = len(backend.fallbacks) > before
        if regs and recs:
            pair[i] = backend.answer_pairs(o, regs, recs, s_rgn[i], s_rec[i], fell_back)
        if fell_back:
            sources.append(f"fallback:{backend.cfg.fallback}")
        else:
            sources.append(backend.row_source(o))
    return s_rgn, s_rec, pair, sources


def answered_by(backend_name: str, sources: Sequence[str]) -> str:
    """Return what actually answered: the backend, its fallback, or 'backend+fallback' when mixed."""
    fb = sorted({s.split(":", 1)[1] for s in sources if s.startswith("fallback:")})
    if not fb:
        return backend_name
    if all(s.startswith("fallback:") for s in sources):
        return "+".join(fb)
    return "+".join([backend_name] + fb)


def relevance(objects: Sequence[str], regions: Sequence[str], receptacles: Sequence[str],
              backend: Backend) -> Relevance:
    """Return P(obj|rgn), P(obj|rec) and the pair scores of both directions for objects, regions, receptacles."""
    n_fb = len(backend.fallbacks)
    objs, regs, recs = _dedupe(objects), _dedupe(regions), _dedupe(receptacles)
    s_rgn, s_rec, pair, sources = _ask_all(objs, regs, recs, backend)
    return Relevance(
        objects=objs, regions=regs, receptacles=recs,
        p_obj_region=normalise_columns(s_rgn), p_obj_receptacle=normalise_columns(s_rec),
        backend=answered_by(backend.name, sources), model=backend.model, fallbacks=list(backend.fallbacks[n_fb:]),
        p_pair=pair, sources=sources,
    )


def rank_pairs(rel: Relevance, obj: str) -> list[tuple[str, str, float]]:
    """Return (region, receptacle, search score of `obj`) pairs, best place to look first (`Relevance.search`)."""
    return rel.search(obj)
