"""Receptacles stage: which fused instances are receptacles, and their support planes (paper 3.3).

Public API:
    receptacle_instances(instances, labels) -> list[Instance]
    detect_planes(instance, cfg) -> list[ReceptaclePlane]
    find_receptacle_planes(instances, cfg) -> list[ReceptaclePlane]
    sample_in_polygon(polygon, n, rng) -> (n, 2)
"""

from __future__ import annotations

from .em_planes import detect_planes, find_receptacle_planes
from .identify import receptacle_instances
from ..polygons import convex_hull_ccw, polygon_area, polygon_iou, sample_in_polygon, shrink_polygon

__all__ = [
    "convex_hull_ccw", "detect_planes", "find_receptacle_planes", "polygon_area",
    "polygon_iou", "receptacle_instances", "sample_in_polygon", "shrink_polygon",
]
