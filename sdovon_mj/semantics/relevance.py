"""Object-region and object-receptacle relevance (paper section 3.4, prompts C.3 and C.4).

For each object the backend scores every region and every receptacle 0-10. Scores are normalised
over objects, per region (receptacle): P(obj|rgn) = s(obj, rgn) / sum_obj s(obj, rgn); a column
whose scores are all 0 becomes uniform. The joint relevance is P(obj|rgn) * P(obj|rec)
(``Relevance.joint``; the paper's printed equation repeats one factor, a typo).
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
    objs, regs, recs = _dedupe(objects), _dedupe(regions), _dedupe(receptacles)
    s_rgn = np.zeros((len(objs), len(regs)))
    s_rec = np.zeros((len(objs), len(recs)))
    for i, o in enumerate(objs):
        if regs:
            sr = backend.score_regions(o, regs)
            s_rgn[i] = [float(sr.get(r, 0.0)) for r in regs]
        if recs:
            sc = backend.score_receptacles(o, recs)
            s_rec[i] = [float(sc.get(c, 0.0)) for c in recs]
    return s_rgn, s_rec


def relevance(objects: Sequence[str], regions: Sequence[str], receptacles: Sequence[str],
              backend: Backend) -> Relevance:
    """Return P(obj|rgn) and P(obj|rec) tables for object categories, regions and receptacles."""
    n_fb = len(backend.fallbacks)
    s_rgn, s_rec = score_tables(objects, regions, receptacles, backend)
    return Relevance(
        objects=_dedupe(objects), regions=_dedupe(regions), receptacles=_dedupe(receptacles),
        p_obj_region=normalise_columns(s_rgn), p_obj_receptacle=normalise_columns(s_rec),
        backend=backend.name, model=backend.model, fallbacks=list(backend.fallbacks[n_fb:]),
    )


def rank_pairs(rel: Relevance, obj: str) -> list[tuple[str, str, float]]:
    """Return (region, receptacle, joint relevance of `obj`) pairs, most relevant first."""
    i = rel.objects.index(obj)
    out = []
    for r in rel.regions:
        for c in rel.receptacles:
            out.append((r, c, float(rel.joint(r, c)[i])))
    return sorted(out, key=lambda t: (-t[2], t[0], t[1]))
