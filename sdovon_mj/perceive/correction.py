"""Fusion error correction (paper section 3.2): of two fused instances whose 3D boxes overlap with
IoU >= IoU_min, keep the one whose top-k constituent detections have the higher mean confidence,
k being the smaller of the two constituent counts."""

from __future__ import annotations

import numpy as np

from ..config import PerceiveConfig
from ..records import Instance


def box_iou_3d(a: np.ndarray, b: np.ndarray) -> float:
    """Return the IoU of two axis-aligned boxes given as (2, 3) min/max arrays."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    inter = np.clip(np.minimum(a[1], b[1]) - np.maximum(a[0], b[0]), 0.0, None).prod()
    va, vb = np.prod(a[1] - a[0]), np.prod(b[1] - b[0])
    union = va + vb - inter
    return float(inter / union) if union > 0 else 0.0


def topk_confidence(inst: Instance, k: int) -> float:
    """Return the mean of an instance's k highest detection confidences."""
    c = sorted((float(x) for x in inst.confidences), reverse=True)[: max(int(k), 1)]
    return float(np.mean(c)) if c else 0.0


def correct_fusion(instances: list[Instance], cfg: PerceiveConfig) -> list[Instance]:
    """Return the instances with the less reliable member of every strongly overlapping pair removed."""
    n = len(instances)
    boxes = [inst.bounds for inst in instances]
    pairs = []
    for i in range(n):
        for j in range(i + 1, n):
            iou = box_iou_3d(boxes[i], boxes[j])
            if iou >= cfg.iou_min:
                pairs.append((-iou, i, j))
    alive = [True] * n
    for _neg, i, j in sorted(pairs):
        if not (alive[i] and alive[j]):
            continue
        a, b = instances[i], instances[j]
        k = min(len(a.confidences), len(b.confidences))
        ca, cb = topk_confidence(a, k), topk_confidence(b, k)
        # Lower confidence loses; ties keep the one with more constituents, then the earlier one.
        key_a = (ca, len(a.confidences), -i)
        key_b = (cb, len(b.confidences), -j)
        alive[j if key_a >= key_b else i] = False
    return [inst for inst, ok in zip(instances, alive) if ok]
