"""The one seed rule: every seed of a run derives from the master seed, never from global RNG state.

- a scene's seed: ``scene_seed(master, scene)`` (sha256 of ``"<master>/scene/<scene>"``, 31 bits);
- a variant's seed: ``variant_seed(scene_seed, index)`` (a numpy SeedSequence of the scene seed and index);
- a variant's episodes use the variant's seed (the episodes stage receives it with the variant);
- day `t` of a scene's chain of days: ``day_seed(scene_seed, t)`` (a SeedSequence of the scene seed, the day and a
  tag apart from the variants'); its episodes use it too.
Stage commands and ``generate`` both take their seeds from here, so they produce the same bytes.
"""

from __future__ import annotations

import hashlib

import numpy as np


def derive_seed(master: int, *names: object) -> int:
    """Return a 31-bit seed derived from a master seed and names (no global RNG state)."""
    blob = "/".join([str(master), *map(str, names)]).encode("utf-8")
    return int(hashlib.sha256(blob).hexdigest()[:8], 16) & 0x7FFFFFFF


def scene_seed(master: int, scene: str) -> int:
    """Return the seed of a scene of a run whose master seed is `master`."""
    return derive_seed(master, "scene", scene)


def variant_seed(scene_seed: int, index: int) -> int:
    """Return the seed of variant `index` of a scene, derived from the scene seed."""
    return int(np.random.SeedSequence([int(scene_seed) & 0xFFFFFFFF, int(index), 0x5D0]).generate_state(1)[0])


def day_seed(scene_seed: int, day: int) -> int:
    """Return the seed of day `day` of a scene's chain of days, derived from the scene seed (never a variant's)."""
    return int(np.random.SeedSequence([int(scene_seed) & 0xFFFFFFFF, int(day), 0xDA7]).generate_state(1)[0])


__all__ = ["day_seed", "derive_seed", "scene_seed", "variant_seed"]
