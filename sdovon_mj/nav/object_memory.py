"""Object memory of the agents: where the agent last saw each object category, kept across episodes and days of a
scene (one agent process serves a scene's whole sequence of days), searched first, forgotten when found empty
(`ObjectMemory` for the A* agents, `FrontierObjectMemory` for the no-prior frontier agent).

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


class FrontierObjectMemory:
    """Mixin for `SemanticFrontierAgent`: where it last saw each category (scene-frame XY, from its own detections'
    depth), kept across the episodes and days of a scene; a frontier within ``nav.frontier_radius`` of where it last
    saw the goal category scores 1 (relevance scores are probabilities: memory comes first at equal distance). A
    remembered place it stands within ``nav.fn_viewpoint_radius`` of for a full turn of looks without seeing the goal
    is forgotten. Memory across episodes needs one frame for all of them: the agent declares itself localized
    (``pose="absolute"``) and centres each episode's map where it starts.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        from dataclasses import replace

        super().__init__(*args, **kwargs)
        self.knowledge = replace(self.knowledge, pose="absolute")
        self.places: dict[tuple[str, str], np.ndarray] = {}
        self.days = 0
        self._recall: dict[str, Any] = {}
        self._n_seen = 0
        self._misses: dict[tuple[str, str], int] = {}

    def new_day(self) -> None:
        """The scene's next day begins: count it; the places stay."""
        self.days += 1

    def reset(self, view: Any, ts: Any) -> None:
        """Start an episode: note the places held (the memory that survived from earlier episodes and days)."""
        self._n_seen, self._misses = 0, {}
        category = str(ts.observation["objectgoal_text"])
        self._recall = {"at_start": len(self.places), "from_memory": (str(view.scene), category) in self.places,
                        "forgotten": 0, "days": self.days}
        super().reset(view, ts)

    def _map_centre(self) -> np.ndarray:
        """Return where it starts, in the scene frame (its map's centre)."""
        return np.asarray(self.ts.observation["position"], float)[:2]

    def _floor_z(self) -> float:
        """Return the floor's height in the scene frame (its base stands on it)."""
        return float(np.asarray(self.ts.observation["position"], float)[2])

    def _looked(self, category: str, seen: list[tuple[np.ndarray, str]], found: bool) -> None:
        """Remember the look's new detections; count a look near where the goal was remembered that misses it."""
        from .frontier import scan_actions

        scene = str(self.env.scene)
        for xy, label in seen[self._n_seen:]:
            self.places[(scene, label)] = np.asarray(xy, float)
        self._n_seen = len(seen)
        key = (scene, category)
        if found or key not in self.places:
            return
        pos = np.asarray(self.ts.observation["position"], float)[:2]
        if np.linalg.norm(self.places[key] - pos) <= self.nav.fn_viewpoint_radius:
            self._misses[key] = self._misses.get(key, 0) + 1
            if self._misses[key] >= scan_actions(self.nav.turn_angle):  # a full turn there without it: stale
                del self.places[key]
                self._recall["forgotten"] += 1

    def _recalled(self, category: str, xy: np.ndarray) -> float:
        """Return 1 for a frontier near where the goal category was last seen, else 0."""
        p = self.places.get((str(self.env.scene), category))
        return 1.0 if p is not None and np.linalg.norm(p - np.asarray(xy, float)) <= self.nav.frontier_radius else 0.0

    def end(self, view: Any, ts: Any) -> None:
        """The phase is over: report the memory (episodes only)."""
        super().end(view, ts)
        if view.phase == "episode":
            self.info["object_memory"] = {**self._recall, "at_end": len(self.places)}
