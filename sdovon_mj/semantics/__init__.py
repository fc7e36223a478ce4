"""Semantics stage (paper section 3.4, appendix C): LLM backends, region map, relevance.

Public API:
- ``get_backend(cfg, cache_dir) -> Backend`` (plugin group ``sdovon_mj.llm_backends``: offline,
  ollama, openai, or any installed plugin);
- ``identify_receptacles(labels, backend) -> list[str]`` (prompt C.1);
- ``region_map(instances, navmap, backend, cfg) -> RegionMap`` (prompt C.2, sliding window);
- ``relevance(objects, regions, receptacles, backend) -> Relevance`` (prompts C.3, C.4).
"""

from __future__ import annotations

from typing import Sequence

from .backends import Backend, get_backend
from .regions import annotate_planes, input_region_map, region_map, region_picture
from .relevance import relevance


def offline_data_digest() -> str:
    """Return a digest of the offline backend's shipped data (the learned model, the priors table).

    Part of the semantics stage's fingerprint: a new model file makes a resumed run compute its relevance again
    (every backend falls back to the offline one, so every run depends on it).
    """
    import hashlib
    from importlib import resources

    h = hashlib.sha256()
    folder = resources.files("sdovon_mj").joinpath("data/semantics")
    for name in sorted(f.name for f in folder.iterdir() if f.name.endswith(".json")):
        h.update(name.encode() + b"\0" + folder.joinpath(name).read_bytes())
    return h.hexdigest()[:16]


def identify_receptacles(labels: Sequence[str], backend: Backend) -> list[str]:
    """Return the labels that name receptacles (furniture daily objects are put on)."""
    seen: list[str] = []
    for lab in labels:
        if lab not in seen:
            seen.append(lab)
    return backend.receptacles(seen) if seen else []


__all__ = ["Backend", "annotate_planes", "get_backend", "identify_receptacles", "input_region_map", "offline_data_digest", "region_map", "region_picture", "relevance"]
