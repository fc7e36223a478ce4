"""The A* agents' memory, once per floor of a scene: the first visit (frontier exploration), ExtractPlanes on its
frames with the pipeline's stages (instances, receptacle planes, regions), and the memory an episode plans on."""

from __future__ import annotations

import dataclasses
from typing import Any, Generator

import numpy as np

from ..actions import STOP
from ..config import ReceptacleConfig
from .frontier import Explorer
from .memory import build_memory, container_planes, extract_planes

# Two poses stand on the same floor when their heights differ by less than this (m): a storey is more than twice it
# (the default world's are 3 m; HM3D / MP3D storeys 2.5-3.5 m), steps of a split level less.
FLOOR_TOLERANCE = 1.0


class FirstVisitMemory:
    """What `ReceptacleAStar` remembers of each floor it visited first: ``self.memories`` ((scene, floor height) ->
    `SceneMemory`), built from its own frames; the semantics backend it builds them with."""

    def backend(self):
        """Return the semantics backend of the agent's own ExtractPlanes and relevance (built once)."""
        if self._backend is None:
            from ..semantics import get_backend

            self._backend = get_backend(self.semantics)
        return self._backend

    def _height(self) -> float:
        """Return the height of the floor the agent stands on (its localized pose's z, m)."""
        return round(float(np.asarray(self.ts.observation["position"], float)[2]), 2)

    def memory_key(self, scene: str, z: float) -> tuple[str, float] | None:
        """Return the key of the memory of `scene`'s first visit of the floor at height `z` (m), None without one.

        A multi-storey home gets one first visit per floor with episodes (the evaluator starts each on its floor,
        as a robot carried there); an episode plans on its own floor's memory.
        """
        near = [(abs(h - z), h) for (sc, h) in self.memories if sc == scene and abs(h - z) < FLOOR_TOLERANCE]
        return (scene, min(near)[1]) if near else None

    def _explore(self, env) -> Generator[int, object, None]:
        """The first visit of a floor: frontier exploration (`frontier.Explorer`), then ExtractPlanes on its frames;
        STOP."""
        self._explore_key = (env.scene, self._height())
        if self.memory_key(*self._explore_key) is not None:  # visited before: nothing to learn
            yield STOP
            return
        s = max(1, int(round(self.sensors.width / max(1, int(self.explore_size[0])))))
        self._explorer = Explorer(self.nav, self.agent_config, self.sensors.K, max_steps=env.max_steps - 1, downsample=s)
        gen = self._explorer.run(self.ts)
        try:
            a, render = next(gen)
            while True:
                self.wants_frame = render
                ts = yield a
                a, render = gen.send(ts)
        except StopIteration:
            pass
        self.wants_frame = False
        self._build_memory(env)
        yield STOP

    def end(self, view: Any, ts: Any) -> None:
        """After a first visit the evaluator ended (its step budget): build the memory from what was seen."""
        if view.phase == "explore" and getattr(self, "_explorer", None) is not None:
            self._build_memory(view)
        if view.phase == "explore":
            self.info = dict(self.explored)
        elif self._memory_key is not None:  # the floor whose memory the episode planned on
            self.info["memory_floor_z"] = self._memory_key[1]

    def _build_memory(self, env) -> None:
        """ExtractPlanes on the first visit's frames: instances, receptacle planes, regions -> the scene's memory."""
        ex, self._explorer = self._explorer, None
        frames, occ = ex.frames, ex.occ
        labels = self.receptacle_labels
        if not labels:  # the backend names the receptacles among what the agent detected (prompt C.1)
            from ..semantics import identify_receptacles

            seen = sorted({d.label for f in frames for d in self.detector.detect(f)})
            labels = tuple(identify_receptacles(seen, self.backend()))
        instances, planes, rm, navmap = extract_planes(frames, self.detector, labels, occ, self.backend(),
                                                       self.perceive, ReceptacleConfig(), self.semantics)
        if self.open_labels:  # furniture with doors or drawers but no plane seen (a closed fridge): keep it too
            planes = planes + container_planes(instances, planes, self.open_labels, navmap, rm)
        trav, frame = occ.traversable(), occ.frame
        key = self._explore_key
        floor = env.oracle.floor_at(key[1]) if {"navmap", "region_map"} & set(self.oracle_parts) else 0
        if "navmap" in self.oracle_parts:  # ORACLE: plan on the generator's map
            nm = env.oracle.navmap(floor)
            trav, frame = nm.navigable, nm.frame
        if "region_map" in self.oracle_parts:  # ORACLE: the generator's regions
            true_rm = env.oracle.region_map(floor)
            if true_rm is not None:
                planes = [dataclasses.replace(pl, region=true_rm.region_at(np.asarray(pl.polygon, float).mean(axis=0))
                                              or pl.region) for pl in planes]
        self.memories[key] = build_memory(env.scene, [], {}, trav, frame, labels, planes)
        self.memories[key].instances = instances
        self.explored = {"floor_z": key[1], "frames": len(frames), "free_cells": int((occ.state == 1).sum()),
                         "steps": int(ex.steps), "instances": len(instances), "planes": len(planes), "stop_reason": occ.stop_reason,
                         "regions": sorted({pl.region for pl in planes if pl.region})}
