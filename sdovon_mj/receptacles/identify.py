"""Receptacle identification: instances whose label is a receptacle label, or that the input flags.

The labels are prespecified (ReceptacleConfig.labels) or, when that is empty -- or when fewer than
``ReceptacleConfig.llm_share`` of the instances match it (node-named artist scenes: 'countertop marble',
'kitchen island') -- named by the LLM backend with prompt C.1 (``sdovon_mj.semantics.identify_receptacles``;
the pipeline wires it in ``perceive.surfaces.receptacle_labels``).

A scene's input may decide for some instances (``receptacle: true|false`` in ``assets.yaml``, kept as
``SemanticInstance.receptacle``): `ReceptacleLabels` carries those decisions, keyed by the ground-truth
instance id a fused instance records (``Instance.gt_id``), and they win over the labels.
"""

from __future__ import annotations

import re
from typing import Iterable, Mapping

from ..records import Instance


class ReceptacleLabels(tuple):
    """Receptacle labels (a tuple of str) plus the input's per-instance decisions that win over them.

    ``forced`` maps a ground-truth instance id (``SemanticInstance.id`` = ``Instance.gt_id``) to True (a
    receptacle whatever its label) or False (never one).
    """

    forced: Mapping[int, bool]

    def __new__(cls, labels: Iterable[str] = (), forced: Mapping[int, bool] | None = None) -> "ReceptacleLabels":
        """Return the labels with the decisions `forced` (gt instance id -> bool)."""
        obj = super().__new__(cls, tuple(labels))
        obj.forced = dict(forced or {})
        return obj


def normalize_label(label: str) -> str:
    """Return a label lower-cased with '_'/'-' as spaces and single spaces."""
    return " ".join(re.sub(r"[_\-]+", " ", str(label).lower()).split())


def is_receptacle(label: str, labels: Iterable[str]) -> bool:
    """Return whether a label names a receptacle (case, separators and spaces ignored)."""
    key = normalize_label(label)
    for lab in labels:
        n = normalize_label(lab)
        if key == n or key.replace(" ", "") == n.replace(" ", ""):
            return True
    return False


def forced_flag(inst: Instance, labels: Iterable[str]) -> bool | None:
    """Return the input's decision for one instance (None: none; `labels` a `ReceptacleLabels` or plain labels)."""
    forced = getattr(labels, "forced", None)
    if not forced or int(inst.gt_id) < 0:
        return None
    return forced.get(int(inst.gt_id))


def receptacle_instances(instances: list[Instance], labels: Iterable[str]) -> list[Instance]:
    """Return the receptacle instances: those the input forces, else those whose label is a receptacle label."""
    flags = [forced_flag(inst, labels) for inst in instances]
    names = list(labels)
    return [inst for inst, f in zip(instances, flags) if (f if f is not None else is_receptacle(inst.label, names))]


def matched_share(instances: list[Instance], labels: Iterable[str]) -> float:
    """Return the share of instances identified as receptacles by `labels` (and forced flags); 0 for none."""
    if not instances:
        return 0.0
    return len(receptacle_instances(instances, labels)) / len(instances)
