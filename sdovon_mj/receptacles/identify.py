"""Receptacle identification: instances whose label is a receptacle label.

The labels are prespecified (ReceptacleConfig.labels) or, when that is empty, named by the LLM backend with
prompt C.1 (``sdovon_mj.semantics.identify_receptacles``; the pipeline wires it in ``perceive.surfaces.receptacle_labels``).
"""

from __future__ import annotations

import re
from typing import Iterable

from ..records import Instance


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


def receptacle_instances(instances: list[Instance], labels: Iterable[str]) -> list[Instance]:
    """Return the instances whose label is one of the receptacle labels."""
    labels = list(labels)
    return [inst for inst in instances if is_receptacle(inst.label, labels)]
