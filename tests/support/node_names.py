"""Labels as node and part names leave them: default-world labels rewritten in the styles modelling tools, robot
description files and exporters use (a bench and test fixture for region inference, not shipped data).

`node_name(label, k)` gives the k-th of `STYLES` applied to a label: camel case with a part and a Blender duplicate
suffix (``KitchenCabinet_Door.003``), words run together with a URDF link or joint suffix (``kitchencabinet_link``,
``kitchencabinet_hinge_joint``), a position and a primitive (``left_kitchen_cabinet_Cube``), a material and a number
(``KITCHEN_CABINET_oak_02``), a part path (``kitchen cabinet/handle``). Building pieces take primitive names as an
artist's walls and floors have them (``Cube.012``, ``Plane.004``). `node_named_instances` relabels a list of
`records.Instance` so.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

__all__ = ["STYLES", "node_name", "node_named_instances"]

PARTS = ("Door", "Body", "Base", "Top", "Frame", "Panel", "Handle", "Leg")


def _camel(words: list[str]) -> str:
    return "".join(w[:1].upper() + w[1:] for w in words)


STYLES = (
    lambda w, k: f"{_camel(w)}_{PARTS[k % len(PARTS)]}.{k % 1000:03d}",
    lambda w, k: f"{''.join(w)}_link",
    lambda w, k: f"{''.join(w)}_{'hinge' if k % 2 else 'slide'}_joint",
    lambda w, k: f"{('left', 'right', 'upper', 'lower')[k % 4]}_{'_'.join(w)}_{('Cube', 'Cylinder', 'Mesh')[k % 3]}",
    lambda w, k: f"{'_'.join(w).upper()}_{('oak', 'marble', 'steel', 'white')[k % 4]}_{k % 100:02d}",
    lambda w, k: f"{' '.join(w)}/{PARTS[k % len(PARTS)].lower()}",
)


def node_name(label: str, k: int, structure: bool = False) -> str:
    """Return label `label` written in naming style k % len(STYLES); a building piece (`structure`) as a primitive."""
    if structure:
        return f"{('Cube', 'Plane')[k % 2]}.{k % 1000:03d}"
    words = str(label).lower().replace("_", " ").split()
    return STYLES[k % len(STYLES)](words, k)


def node_named_instances(instances: Sequence, structure_labels: Sequence[str] = ()) -> list:
    """Return the instances with node-style labels (`node_name`, style by position; labels in `structure_labels`
    as primitives)."""
    skip = {s.lower() for s in structure_labels}
    return [dataclasses.replace(inst, label=node_name(inst.label, k, inst.label.lower() in skip))
            for k, inst in enumerate(instances)]
