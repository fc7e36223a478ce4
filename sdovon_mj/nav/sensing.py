"""The agents' ground-truth detector: instances from the category image, as a detector would report them.

The evaluation's ground-truth sensor is a per-pixel category image of the current frame (indices into the dataset's
label vocabulary, -1 for nothing labelled; `suite.observation`): no instance ids. `CategoryDetector` splits each
category into connected regions of the image (8-connected), one detection per region that covers at least ``eta``
of the image, as a detector reports separate boxes; fusing them across views into objects is the agent's own work
(`perceive.perceive_scene` in the A* agents' ExtractPlanes). Two objects of one category that touch in the image are
one detection, as they would be for a detector that sees no boundary between them.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..grid import true_box
from ..records import Detection, Observation

_EIGHT = np.ones((3, 3), bool)


class CategoryDetector:
    """Detections from a category image: connected regions of each label covering at least ``eta`` of the image."""

    name = "gt-category"

    def __init__(self, labels: tuple[str, ...] | list[str], eta: float) -> None:
        self.labels = tuple(labels)
        self.index = {lab: i for i, lab in enumerate(self.labels)}
        self.eta = float(eta)

    def detect(self, obs: Observation) -> list[Detection]:
        """Return one detection per connected region of a labelled category (score 1.0)."""
        cat = obs.segmentation
        if cat is None:
            raise ValueError(f"observation {obs.view_id} has no category image; the ground-truth detector needs one")
        cat = np.asarray(cat)
        need = self.eta * cat.size
        out: list[Detection] = []
        ids, counts = np.unique(cat[cat >= 0], return_counts=True)
        for c, n in zip(ids.tolist(), counts.tolist()):
            if n < need or not 0 <= c < len(self.labels):
                continue
            # labelled in the category's bounding box: no pixel of it lies outside, and the box keeps the image's
            # raster order, so the regions and their numbers are the whole image's
            mask = cat == c
            r0, r1, c0, c1 = true_box(mask)  # never None: category c has n >= 1 pixels
            win = (slice(r0, r1), slice(c0, c1))
            regions, k = ndimage.label(mask[win], structure=_EIGHT)
            sizes = np.bincount(regions.ravel(), minlength=k + 1)
            for r in range(1, k + 1):
                if sizes[r] >= need:
                    region = np.zeros(cat.shape, dtype=bool)
                    region[win] = regions == r
                    out.append(Detection(mask=region, label=self.labels[c], score=1.0, view_id=int(obs.view_id)))
        return out

    def detect_batch(self, observations: list[Observation]) -> list[list[Detection]]:
        """Return the detections of several observations."""
        return [self.detect(o) for o in observations]

    def category_mask(self, category_image: np.ndarray | None, label: str) -> np.ndarray | None:
        """Return the (H, W) mask of every pixel of ``label`` when it covers at least eta of the image, else None."""
        if category_image is None:
            raise ValueError("the ground-truth detector needs the category image (declare Knowledge(detector='gt'))")
        i = self.index.get(label)
        if i is None:
            return None
        mask = np.asarray(category_image) == i
        return mask if mask.sum() >= self.eta * mask.size else None


__all__ = ["CategoryDetector"]
