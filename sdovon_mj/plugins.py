"""Plugin lookup by entry point: exporters, detectors, LLM backends, converters, agents (habitat-lab style registries).

The core reaches `exporters/` and `assets_convert/` only through this registry, never by import."""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Any, Callable

from .errors import SdovonError

GROUPS = {
    "exporter": "sdovon_mj.exporters",
    "detector": "sdovon_mj.detectors",
    "llm_backend": "sdovon_mj.llm_backends",
    "converter": "sdovon_mj.converters",
    "agent": "sdovon_mj.agents",
}

# Built-ins registered in code too, so a source checkout (no `pip install`) finds them.
_BUILTIN: dict[str, dict[str, str]] = {
    "sdovon_mj.exporters": {
        "habitat": "exporters.habitat:HabitatExporter",
        "mjcf": "exporters.mjcf_bundle:MjcfBundleExporter",
        "usd": "exporters.usd:UsdExporter",
        "urdf": "exporters.urdf:UrdfExporter",
    },
    "sdovon_mj.detectors": {
        "gt": "sdovon_mj.perceive.gt_detector:GroundTruthDetector",
        "owl-sam": "sdovon_mj.perceive.open_vocab:OpenVocabDetector",
    },
    "sdovon_mj.converters": {
        "mesh": "assets_convert.plugin:MeshConverter",
    },
    "sdovon_mj.agents": {
        "random-astar": "sdovon_mj.nav.agents:RandomAStar",
        "semantic-astar": "sdovon_mj.nav.agents:SemanticAStar",
        "semantic-astar-memory": "sdovon_mj.nav.agents:SemanticAStarMemory",
        "semantic-frontier": "sdovon_mj.nav.agents:SemanticFrontierAgent",
        "semantic-frontier-memory": "sdovon_mj.nav.agents:SemanticFrontierMemory",
        "oracle": "sdovon_mj.nav.agents:OracleAgent",
        "random": "sdovon_mj.nav.agents:RandomAgent",
    },
    "sdovon_mj.llm_backends": {
        "offline": "sdovon_mj.semantics.backends.offline:OfflineBackend",
        "ollama": "sdovon_mj.semantics.backends.ollama:OllamaBackend",
        "openai": "sdovon_mj.semantics.backends.openai_compat:OpenAIBackend",
    },
}

_LOCAL: dict[str, dict[str, Callable[..., Any]]] = {g: {} for g in GROUPS.values()}


class PluginError(SdovonError, LookupError):
    """A plugin that is not registered or fails to load."""


def _group(kind: str) -> str:
    if kind in GROUPS:
        return GROUPS[kind]
    if kind in GROUPS.values():
        return kind
    raise PluginError(f"unknown plugin kind '{kind}' (known: {', '.join(GROUPS)})")


def register(kind: str, name: str, obj: Callable[..., Any]) -> None:
    """Register a plugin in-process (tests, notebooks); entry points are the durable way."""
    _LOCAL[_group(kind)][name] = obj


def _load_target(target: str) -> Any:
    import importlib

    module, _, attr = target.partition(":")
    mod = importlib.import_module(module)
    obj: Any = mod
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def available(kind: str) -> list[str]:
    """Return the names of every plugin of a kind (built-in, installed, registered)."""
    group = _group(kind)
    names = set(_BUILTIN.get(group, {})) | set(_LOCAL[group])
    names |= {ep.name for ep in entry_points(group=group)}
    return sorted(names)


def load(kind: str, name: str) -> Any:
    """Return the plugin class/factory registered under `name`."""
    group = _group(kind)
    if name in _LOCAL[group]:
        return _LOCAL[group][name]
    eps = [ep for ep in entry_points(group=group) if ep.name == name]
    try:
        if eps:
            return eps[0].load()
        if name in _BUILTIN.get(group, {}):
            return _load_target(_BUILTIN[group][name])
    except Exception as e:  # a broken plugin must say which one and why
        raise PluginError(f"{kind} plugin '{name}' failed to load: {type(e).__name__}: {e}") from e
    raise PluginError(f"no {kind} plugin named '{name}' (available: {', '.join(available(kind)) or 'none'})")


def converter(name: str = "mesh") -> Any:
    """Return an instance of the converter plugin `name` (kind ``converter``; ``mesh`` is assets_convert's)."""
    obj = load("converter", name)
    return obj() if isinstance(obj, type) else obj
