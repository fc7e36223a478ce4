"""Receptacles stage: which fused instances are receptacles, and their support planes (paper 3.3).

Public API:
    receptacle_instances(instances, labels) -> list[Instance]
    detect_planes(instance, cfg) -> list[ReceptaclePlane]
    find_receptacle_planes(instances, cfg) -> list[ReceptaclePlane]

Polygon helpers (hulls, IoU, shrinking, appendix-B sampling) live in `sdovon_mj.geometry`.
"""

from __future__ import annotations

from .em_planes import detect_planes, find_receptacle_planes
from .identify import receptacle_instances

__all__ = ["detect_planes", "find_receptacle_planes", "receptacle_instances"]
