"""Offline backend: answers the four appendix C questions without a server.

Relevance (C.3, C.4 and the pair scores of both directions) comes from the learned model
(`semantics.learned`, trained on human votes; ``semantics.offline_model = learned``, the default) or
from the curated priors table (``table``, the earlier behaviour). Receptacle naming (C.1) and region
proposals (C.2) use the table in both modes.
No server, no randomness: the same question always gets the same answer.
- receptacles: labels the table (or its head noun) calls a receptacle;
- region proposals: naive-Bayes score of each region over the window's distinct labels,
  sum over labels of log((s + 1) / 11) with s the label's 0-10 region score (labels the table lacks
  use the embedding nearest-neighbour row at half weight; labels that say nothing about regions --
  walls, doors -- are skipped); regions most likely first, at least five, none when no label is
  informative;
- relevance: table scores (embedding fallbacks for unknown labels) mixed with a floor, so that
  no candidate gets zero.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...errors import StageError
from .. import prompts
from ..priors import FLOOR, Priors, default_priors, with_floor
from ..validate import normalise
from . import Backend

UNKNOWN_WEIGHT = 0.5  # weight of a label scored by embeddings in the region-proposal sum
MIN_PROPOSALS = 5


class OfflineBackend(Backend):
    """Commonsense priors + MiniLM embedding fallback; never calls a server."""

    name = "offline"

    def __init__(self, *args: Any, priors: Priors | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.cache = None  # answers are computed, not fetched
        self.mode = getattr(self.cfg, "offline_model", "learned")
        if self.mode not in ("learned", "table"):
            raise StageError(f"semantics.offline_model must be 'learned' or 'table', got {self.mode!r}")
        self._priors = priors
        if self.mode == "learned":
            from ..learned import default_model

            self.model = "learned-v" + default_model().version
        else:
            self.model = "priors-v" + (priors or default_priors()).table["version"]

    def pair_scores(self, obj: str, regions: list[str], receptacles: list[str], region_scores: np.ndarray,
                    receptacle_scores: np.ndarray) -> np.ndarray:
        """Return 0-1 pair scores (R, C): the learned pair head (floored), or the table's product rule.

        Parameters
        ----------
        obj, regions, receptacles, region_scores, receptacle_scores
            As `Backend.pair_scores`; the answers (0-10, shapes (R,), (C,)) serve the table mode only.
        """
        if self.mode != "learned":
            return super().pair_scores(obj, regions, receptacles, region_scores, receptacle_scores)
        from ..learned import default_model

        p = default_model().score_pairs(obj, list(regions), list(receptacles))
        return np.round(FLOOR / 10.0 + (1.0 - FLOOR / 10.0) * p, 6)

    def row_source(self, obj: str) -> str:
        """Return 'learned', or 'table' / 'embedding' (a label the table lacks) in table mode."""
        if self.mode == "learned":
            return "learned"
        return "table" if self.priors.resolve(obj, embed=False) is not None else "embedding"

    @property
    def priors(self) -> Priors:
        """Return the priors in use."""
        if self._priors is None:
            self._priors = default_priors()
        return self._priors

    def chat(self, messages: list[dict[str, str]], schema: dict[str, Any]) -> str:  # pragma: no cover
        """Not used: the offline backend answers in `ask`."""
        raise NotImplementedError("the offline backend answers questions directly")

    def ask(self, prompt_id: str, payload: dict[str, Any]) -> Any:
        """Answer one appendix C question from the priors."""
        if prompt_id == prompts.RECEPTACLES:
            seen: set[str] = set()
            out = []
            for lab in payload["objects"]:
                n = normalise(lab)
                if n and n not in seen and self.priors.is_receptacle(lab):
                    seen.add(n)
                    out.append(lab)
            return out
        if prompt_id == prompts.REGION_PROPOSALS:
            return self._propose(list(payload["objects"]), list(payload.get("_vocabulary") or []))
        if self.mode == "learned" and prompt_id in (prompts.RECEPTACLE_RELEVANCE, prompts.REGION_RELEVANCE):
            from ..learned import default_model

            m = default_model()
            if prompt_id == prompts.RECEPTACLE_RELEVANCE:
                names = list(payload["furniture"])
                p = m.score_receptacles(payload["object"], names)
            else:
                names = list(payload["regions"])
                p = m.score_rooms(payload["object"], names)
            return {k: round(with_floor(10.0 * float(v)), 4) for k, v in zip(names, p)}
        if prompt_id == prompts.RECEPTACLE_RELEVANCE:
            raw = self.priors.scores(payload["object"], list(payload["furniture"]), "receptacles")
            return {k: round(with_floor(v), 4) for k, v in raw.items()}
        if prompt_id == prompts.REGION_RELEVANCE:
            raw = self.priors.scores(payload["object"], list(payload["regions"]), "regions")
            return {k: round(with_floor(v), 4) for k, v in raw.items()}
        raise KeyError(f"unknown prompt {prompt_id!r}")

    def region_log_scores(self, labels: list[str]) -> dict[str, float]:
        """Return the naive-Bayes log score of every canonical region for a set of labels ({} if none informative)."""
        pri = self.priors
        total = {r: 0.0 for r in pri.regions}
        informative = False
        for lab in sorted({normalise(x) for x in labels if normalise(x)}):
            prof = pri.region_profile(lab)
            weight = 1.0
            if prof is None:
                if pri.resolve(lab) is not None:
                    continue  # known but says nothing about regions (wall, door, ...)
                prof = pri.knn_row(lab, "regions")
                weight = UNKNOWN_WEIGHT
            informative = True
            for r in pri.regions:
                total[r] += weight * math.log((prof[r] + 1.0) / 11.0)
        return total if informative else {}

    def _propose(self, labels: list[str], vocabulary: list[str]) -> list[str]:
        """Return region names, most likely first (vocabulary spellings where they match)."""
        scores = self.region_log_scores(labels)
        if not scores:
            return []
        order = sorted(scores, key=lambda r: (-scores[r], r))
        spell = {}
        for v in vocabulary:
            c = self.priors.resolve_region(v)
            if c is not None and c not in spell:
                spell[c] = v
        best = scores[order[0]]
        keep = [r for r in order if scores[r] >= best - 6.0]  # drop regions e^6 times less likely
        keep = order[: max(MIN_PROPOSALS, len(keep))]
        return [spell.get(r, r) for r in keep]
