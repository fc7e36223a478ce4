"""The detector interface: image(s) in, 2D masks + labels + scores out; plugin lookup and batch helpers."""

from __future__ import annotations

from typing import Iterable, Protocol, runtime_checkable

from ..config import PerceiveConfig, ReceptacleConfig
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


def make_detector(cfg: PerceiveConfig, scene: SceneAsset | None = None, seed: int = 0) -> Detector:
    """Build the detector plugin named by cfg.detector (`gt`, `owl-sam`, or an installed one)."""
    from .. import plugins

    factory = plugins.load("detector", cfg.detector)
    return factory(cfg=cfg, scene=scene, seed=seed)


def detect(observations: Iterable[Observation], detector: Detector, score_threshold: float = 0.0,
           batch_size: int = 8) -> list[Detection]:
    """Run a detector over observations; return detections scoring at least `score_threshold`."""
    out: list[Detection] = []
    batch: list[Observation] = []

    def flush() -> None:
        for dets in detector.detect_batch(batch):
            out.extend(d for d in dets if d.score >= score_threshold)
        batch.clear()

    for obs in observations:
        batch.append(obs)
        if len(batch) >= batch_size:
            flush()
    if batch:
        flush()
    return out
