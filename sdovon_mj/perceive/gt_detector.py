"""Ground-truth detector: masks from the segmentation image, labels from the scene's semantic instances.

One class for the pipeline's perceive stage (`detect`: one detection per labelled segment) and the
suite's A* agents (`category_mask`: the pixels of a goal category); both see an object when its
pixels cover at least ``AgentConfig.eta_gt`` of the image.
"""

from __future__ import annotations

import numpy as np

from ..config import AgentConfig, PerceiveConfig
from ..records import Detection, Observation, SceneAsset
from .detectors import BaseDetector


class GroundTruthDetector(BaseDetector):
    """Every segmentation id covering at least eta of the image becomes a detection.

    Scores are 1.0, or with ``score_noise`` > 0, ``1 - |N(0, score_noise)|`` clipped to [0, 1],
    drawn from a generator seeded by (seed, view id, instance id) so reruns give the same bytes.
    Segmentation ids without a label (placed objects, unlabelled geometry) are skipped unless
    ``labels`` names them.
    """

    name = "gt"

    def __init__(self, cfg: PerceiveConfig | None = None, scene: SceneAsset | None = None, seed: int = 0,
                 labels: dict[int, str] | None = None, eta: float | None = None,
                 score_noise: float | None = None, agent: AgentConfig | None = None) -> None:
        """Build the detector.

        Parameters
        ----------
        cfg
            Perceive settings (score noise); default `PerceiveConfig()`.
        scene
            Scene whose semantic instances label the segmentation ids.
        seed
            Seed of the score noise.
        labels
            Segmentation id -> label, added to (and overriding) the scene's.
        eta
            Minimum pixel fraction (0..1) of a detection; default ``agent.eta_gt``.
        score_noise
            Std of the score noise; default ``cfg.gt_score_noise``.
        agent
            The agent config holding ``eta_gt``; default `AgentConfig()`.
        """
        cfg = cfg or PerceiveConfig()
        self.labels: dict[int, str] = {}
        if scene is not None:
            self.labels.update({int(i.id): i.label for i in scene.instances if i.label})
        if labels:
            self.labels.update({int(k): v for k, v in labels.items()})
        self.eta = float((agent or AgentConfig()).eta_gt if eta is None else eta)
        self.score_noise = float(cfg.gt_score_noise if score_noise is None else score_noise)
        self.seed = int(seed)

    def _score(self, view_id: int, gt_id: int) -> float:
        """Return the detection confidence (1.0 unless a score noise model is set)."""
        if self.score_noise <= 0:
            return 1.0
        rng = np.random.default_rng([self.seed, int(view_id) & 0x7FFFFFFF, int(gt_id) & 0x7FFFFFFF])
        return float(np.clip(1.0 - abs(rng.normal(0.0, self.score_noise)), 0.0, 1.0))

    def detect(self, obs: Observation) -> list[Detection]:
        """Return one detection per labelled segmentation id visible in at least eta of the pixels."""
        seg = obs.segmentation
        if seg is None:
            raise ValueError(f"observation {obs.view_id} has no segmentation image; the gt detector needs one")
        ids, counts = np.unique(seg[seg >= 0], return_counts=True)
        total = float(seg.size)
        out: list[Detection] = []
        for gid, cnt in zip(ids.tolist(), counts.tolist()):
            label = self.labels.get(int(gid))
            if not label or cnt / total < self.eta:
                continue
            out.append(Detection(mask=(seg == gid), label=label, score=self._score(obs.view_id, gid),
                                 view_id=int(obs.view_id), gt_id=int(gid)))
        return out

    def category_mask(self, segmentation: np.ndarray | None, label: str) -> np.ndarray | None:
        """Return the (H, W) mask of every segment labelled ``label`` when it covers at least eta, else None."""
        if segmentation is None:
            raise ValueError("the gt detector needs a segmentation image (suite task semantic=True)")
        ids = np.array(sorted(i for i, lab in self.labels.items() if lab == label), dtype=np.int64)
        mask = np.isin(segmentation, ids)
        return mask if mask.sum() >= self.eta * mask.size else None
