"""The A* agents' search order: the memory's receptacles in visiting order, from the relevance of the goal category
to their (region, receptacle) pairs (subclasses choose the order: `RandomAStar`, `SemanticAStar`)."""

from __future__ import annotations

from typing import Any, Generator

import numpy as np

from ..records import Relevance
from .memory import SceneMemory


class SearchOrder:
    """The order in which `ReceptacleAStar` visits its memory's receptacles (``order``: fixed at the episode start;
    ``_entries``: one at a time)."""

    def relevance_for(self, memory: SceneMemory, category: str) -> Relevance | None:
        """Return the relevance of a goal category to the memory's (region, receptacle) pairs.

        From the semantics backend (cached per scene and category); the generator's table only for the
        ``relevance`` oracle variant.
        """
        if "relevance" in self.oracle_parts:
            return self.env.oracle.relevance
        key = (memory.scene, category)
        if key not in self._relevance:
            from ..semantics import relevance

            regions = sorted({e.region for e in memory.entries if e.region} | set(self.semantics.region_labels))
            recs = sorted({e.plane.label for e in memory.entries})
            # over the dataset's object categories (one vocabulary for every variant): P(o|rec) and P(o|rgn) are
            # normalised over the object list
            objects = sorted(set(self.object_categories) | {category})
            self._relevance[key] = relevance(objects, regions, recs, self.backend()) if recs else None
        return self._relevance[key]

    def order(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> list:
        """Return the memory entries in visiting order."""
        raise NotImplementedError

    def _entries(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> Generator[Any, None, None]:
        """Yield the entries to visit, one at a time (default: `order`, fixed at the episode start)."""
        yield from self.order(memory, category, rng)
