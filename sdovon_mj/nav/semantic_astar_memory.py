"""Semantic A* with object memory: the lifelong baseline that searches first where it last saw the goal category (on
an earlier episode or day of the scene), then by the prior, and forgets a sighting it finds empty."""

from __future__ import annotations

from .agent import public_home
from .object_memory import ObjectMemory
from .semantic_astar import SemanticAStar


@public_home
class SemanticAStarMemory(ObjectMemory, SemanticAStar):
    """Semantic A* (`SemanticAStar`: the same arguments, the same prior) with object memory (`ObjectMemory`): its
    sightings survive across the episodes and days of a scene, as long as its process does (one per scene in a
    lifelong evaluation)."""

    name = "semantic-astar-memory"
