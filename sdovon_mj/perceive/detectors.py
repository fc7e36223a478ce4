"""The detector interface: image(s) in, 2D masks + labels + scores out; plugin lookup and batch helpers."""

from __future__ import annotations

from typing import Iterable, Iterator, Protocol, runtime_checkable

from ..config import AgentConfig, PerceiveConfig, ReceptacleConfig
from ..records import Detection, Observation, SceneAsset


@runtime_checkable
class Detector(Protocol):
    """What every detector plugin (entry-point group `sdovon_mj.detectors`) provides."""

    name: str

    def detect(self, obs: Observation) -> list[Detection]:
        """Return the 2D instances found in one observation."""
        ...

    def detect_batch(self, observations: list[Observation]) -> list[list[Detection]]:
        """Return the detections of several observations (one list per observation)."""
        ...


class BaseDetector:
    """Shared behaviour: `detect_batch` runs `detect` per observation."""

    name = "base"

    def detect(self, obs: Observation) -> list[Detection]:
        """Return the 2D instances found in one observation."""
        raise NotImplementedError

    def detect_batch(self, observations: list[Observation]) -> list[list[Detection]]:
        """Return the detections of several observations (one list per observation)."""
        return [self.detect(o) for o in observations]


def default_vocabulary(cfg: PerceiveConfig, receptacles: ReceptacleConfig | None = None) -> tuple[str, ...]:
    """Return the open-vocabulary prompts: cfg.vocabulary, else the receptacle labels."""
    if cfg.vocabulary:
        return tuple(cfg.vocabulary)
    return tuple((receptacles or ReceptacleConfig()).labels)


def make_detector(cfg: PerceiveConfig, scene: SceneAsset | None = None, seed: int = 0,
                  agent: AgentConfig | None = None) -> Detector:
    """Build the detector plugin named by cfg.detector (`gt`, `owl-sam`, or an installed one).

    Plugins are called as ``factory(cfg=PerceiveConfig, scene=SceneAsset | None, seed=int, agent=AgentConfig)``
    (``agent.eta_gt`` is the ground-truth detector's threshold).
    """
    from .. import plugins

    factory = plugins.load("detector", cfg.detector)
    return factory(cfg=cfg, scene=scene, seed=seed, agent=agent or AgentConfig())


def detect_stream(observations: Iterable[Observation], detector: Detector, score_threshold: float = 0.0,
                  batch_size: int = 8) -> Iterator[tuple[Observation, list[Detection]]]:
    """Yield each observation with its detections scoring at least `score_threshold` (detected in batches)."""
    batch: list[Observation] = []
    for obs in observations:
        batch.append(obs)
        if len(batch) >= batch_size:
            for o, dets in zip(batch, detector.detect_batch(batch)):
                yield o, [d for d in dets if d.score >= score_threshold]
            batch = []
    if batch:
        for o, dets in zip(batch, detector.detect_batch(batch)):
            yield o, [d for d in dets if d.score >= score_threshold]


def detect(observations: Iterable[Observation], detector: Detector, score_threshold: float = 0.0,
           batch_size: int = 8) -> list[Detection]:
    """Run a detector over observations; return detections scoring at least `score_threshold`."""
    return [d for _obs, dets in detect_stream(observations, detector, score_threshold, batch_size) for d in dets]
