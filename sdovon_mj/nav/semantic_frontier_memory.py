"""The frontier agent with object memory: the no-prior Semantic Frontier agent that remembers where it saw each
category across the episodes and days of a scene and explores towards where it last saw the goal category first."""

from __future__ import annotations

from .agent import public_home
from .object_memory import FrontierObjectMemory
from .semantic_frontier import SemanticFrontierAgent


@public_home
class SemanticFrontierMemory(FrontierObjectMemory, SemanticFrontierAgent):
    """`SemanticFrontierAgent` (no prior, no first visit) with `FrontierObjectMemory`: localized (its memory needs
    one frame across episodes), its places survive across a scene's episodes and days as long as its process does."""

    name = "semantic-frontier-memory"
