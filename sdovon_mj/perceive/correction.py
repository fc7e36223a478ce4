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


def _overlapping_pairs(boxes: np.ndarray, iou_min: float, block: int = 512) -> list[tuple[float, int, int]]:
    """Return (-IoU, i, j) of every pair i < j of boxes (n, 2, 3) with IoU >= iou_min: `box_iou_3d`'s arithmetic,
    all pairs of a block of rows at once (a house fuses a thousand instances: a million pairs)."""
    out: list[tuple[float, int, int]] = []
    n = len(boxes)
    vol = np.prod(boxes[:, 1] - boxes[:, 0], axis=1)
    for r0 in range(0, n, block):
        a = boxes[r0:r0 + block]
        inter = np.clip(np.minimum(a[:, None, 1], boxes[None, :, 1]) - np.maximum(a[:, None, 0], boxes[None, :, 0]),
                        0.0, None).prod(axis=2)
        union = vol[r0:r0 + block, None] + vol[None, :] - inter
        with np.errstate(divide="ignore", invalid="ignore"):
            iou = np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)
        ii, jj = np.nonzero(iou >= iou_min)
        keep = jj > ii + r0
        out += [(-float(iou[i, j]), int(i + r0), int(j)) for i, j in zip(ii[keep], jj[keep])]
    return out


def topk_confidence(inst: Instance, k: int) -> float:
    """Return the mean of an instance's k highest detection confidences."""
    c = sorted((float(x) for x in inst.confidences), reverse=True)[: max(int(k), 1)]
    return float(np.mean(c)) if c else 0.0


def correct_fusion(instances: list[Instance], cfg: PerceiveConfig) -> list[Instance]:
    """Return the instances with the less reliable member of every strongly overlapping pair removed."""
    n = len(instances)
    pairs = _overlapping_pairs(np.array([np.asarray(inst.bounds, dtype=float) for inst in instances]).reshape(n, 2, 3),
                               float(cfg.iou_min))
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
