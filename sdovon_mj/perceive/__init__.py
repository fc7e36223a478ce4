"""Perceive stage: detect 2D instances, back-project them, fuse across views, correct fusion errors.

Public API (plain functions over records):
    detect(observations, detector, score_threshold) -> list[Detection]
    detect_stream(observations, detector, score_threshold) -> iterator of (Observation, detections)
    backproject_detections(obs, detections, cfg) -> list[Instance]
    fuse_instances(instances, cfg) -> list[Instance]
    correct_fusion(instances, cfg) -> list[Instance]
    perceive_scene(observations, scene, cfg, seed, look_again=None) -> list[Instance]
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Iterable

from ..config import AgentConfig, PerceiveConfig
from ..records import Instance, Observation, SceneAsset
from .backproject import backproject_detections, voxel_downsample
from .correction import box_iou_3d, correct_fusion
from .detectors import BaseDetector, Detector, detect, detect_stream, make_detector
from .fusion import InstanceFuser, fuse_instances, label_similarity

__all__ = [
    "BaseDetector", "Detector", "InstanceFuser", "backproject_detections", "box_iou_3d", "correct_fusion",
    "detect", "detect_stream", "fuse_instances", "label_similarity", "make_detector", "perceive_scene", "voxel_downsample",
]


def _perceive_cfg(cfg: Any) -> PerceiveConfig:
    """Accept a PerceiveConfig or a RunConfig."""
    return cfg.perceive if hasattr(cfg, "perceive") else cfg


def perceive_scene(observations: Iterable[Observation], scene: SceneAsset | None, cfg: Any, seed: int = 0,
                   detector: Detector | None = None, batch_size: int = 8,
                   look_again: Callable[[list[Instance], int], Iterable[Observation]] | None = None,
                   agent: AgentConfig | None = None) -> list[Instance]:
    """Return the fused, error-corrected 3D instances seen in a stream of observations (ids 0..n-1).

    ``look_again(instances, next_view_id)``, when given, is called once with the instances of the first
    pass and returns more observations (targeted views); they are fused into the same instances.

    Parameters
    ----------
    observations : iterable of Observation
        RGB-D views with camera poses (world metres).
    scene : SceneAsset or None
        The scene (the ground-truth detector reads its instances).
    cfg : PerceiveConfig or RunConfig
        Perceive settings (a run config's ``perceive`` section is used).
    seed : int
        Seed of the detector and the depth noise.
    detector : Detector, optional
        Detector to use (default: the one the config names).
    batch_size : int
        Views per detector batch.
    look_again : callable, optional
        ``look_again(instances, next_view_id)`` returning targeted observations (see above).
    agent : AgentConfig, optional
        The agent (passed to the detector plugin; the ground-truth detector reads its ``eta_gt``).
    """
    pcfg = _perceive_cfg(cfg)
    det = detector if detector is not None else make_detector(pcfg, scene, seed, agent)
    fuser = InstanceFuser(pcfg)
    next_view = 0

    def fuse(stream: Iterable[Observation]) -> None:
        nonlocal next_view
        for obs, keep in detect_stream(stream, det, pcfg.score_threshold, batch_size):
            next_view = max(next_view, int(obs.view_id) + 1)
            fuser.add_view(backproject_detections(obs, keep, pcfg, seed))

    def corrected() -> list[Instance]:
        kept = correct_fusion(fuser.instances(), pcfg)
        return [dataclasses.replace(inst, id=k) for k, inst in enumerate(kept)]

    fuse(observations)
    if look_again is None:
        return corrected()
    fuse(look_again(corrected(), next_view))
    return corrected()
