"""Object memory of the A* agents: where the agent last saw each object category, kept across episodes and days of a
scene (one agent process serves a scene's whole sequence of days), searched first, forgotten when found empty.

A sighting is the receptacle (an entry of the scene's first-visit memory, `memory.SceneMemory`) the agent was looking
at when a category covered at least the detector's ``eta`` of a rendered frame: the agent's own detections, on the
frames its search renders anyway (no extra frame is asked for). The receptacle looked at stands for where the object
is: an object seen past it, on a piece behind, is remembered at the wrong piece and forgotten when that piece is
searched in vain.
"""

from __future__ import annotations

from typing import Any, Generator

import numpy as np

from .memory import SceneMemory


class ObjectMemory:
    """Mixin for `ReceptacleAStar` agents: search first where the goal category was last seen, then in the agent's own
    order; a remembered receptacle searched without finding the goal is forgotten for that category.

    ``sightings`` maps (scene token, category) to the index of the entry last seen holding it; ``days`` counts the
    "new day" messages of a lifelong evaluation (`new_day`). The episode's ``info["object_memory"]`` reports the
    sightings held at its start and end, whether its first receptacle came from memory, and the days heard of.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.sightings: dict[tuple[str, str], int] = {}
        self.days = 0
        self._at_entry: int | None = None  # the entry the search is at (sightings are recorded there)
        self._recall: dict[str, Any] = {}

    def new_day(self) -> None:
        """The scene's next day begins: count it; the sightings stay (yesterday's memory is what is tested)."""
        self.days += 1

    def reset(self, view: Any, ts: Any) -> None:
        """Start an episode: note the sightings held (the memory that survived from earlier episodes and days)."""
        self._at_entry = None
        self._recall = {"at_start": len(self.sightings), "from_memory": False, "forgotten": 0, "days": self.days}
        super().reset(view, ts)

    def _detect(self) -> np.ndarray | None:
        """The agent's goal detection, and every category in the rendered frame recorded at the entry looked at."""
        mask = super()._detect()
        cat = self.ts.observation.get("category") if self.frame_fresh else None
        if cat is not None and self._at_entry is not None and self.detector is not None:
            ids, counts = np.unique(np.asarray(cat)[np.asarray(cat) >= 0], return_counts=True)
            need = self.detector.eta * np.asarray(cat).size
            for c, n in zip(ids.tolist(), counts.tolist()):
                if n >= need and 0 <= c < len(self.detector.labels):
                    self.sightings[(str(self.env.scene), self.detector.labels[c])] = self._at_entry
        return mask

    def _entries(self, memory: SceneMemory, category: str, rng: np.random.Generator) -> Generator[Any, None, None]:
        """Yield the remembered entry of the goal category first, then the agent's order without it; each entry the
        search comes back from (the goal not found there) loses its sighting of the category."""
        key = (str(self.env.scene), category)
        first = self.sightings.get(key)
        first = first if first is not None and 0 <= first < len(memory.entries) else None
        if first is not None:
            self._recall["from_memory"] = True
        rest = (e for e in super()._entries(memory, category, rng) if first is None or e is not memory.entries[first])
        for entry in ([memory.entries[first]] if first is not None else []):
            yield from self._visit(memory, key, entry)
        for entry in rest:  # lazily: a distance-aware order ranks from where the agent stands
            yield from self._visit(memory, key, entry)
        self._at_entry = None

    def _visit(self, memory: SceneMemory, key: tuple[str, str], entry: Any) -> Generator[Any, None, None]:
        """Yield one entry to search; when the search comes back (the goal not found there) forget its sighting."""
        self._at_entry = next(i for i, e in enumerate(memory.entries) if e is entry)
        yield entry
        if self.sightings.get(key) == self._at_entry:  # searched there in vain: the sighting is stale
            del self.sightings[key]
            self._recall["forgotten"] += 1

    def end(self, view: Any, ts: Any) -> None:
        """The phase is over: report the memory (episodes only)."""
        super().end(view, ts)
        if view.phase == "episode":
            self.info["object_memory"] = {**self._recall, "at_end": len(self.sightings)}
