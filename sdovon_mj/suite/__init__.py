"""dm_control-style ObjectNav task suite over MJCF episode bundles.

    from sdovon_mj import suite
    env = suite.load("objectnav", task_kwargs={"bundle": "out/mjcf/apt_0000_v000"})
    ts = env.reset(); ts = env.step(suite.MOVE_FORWARD)

The suite owns the environment and the evaluation loop (`suite.evaluation.loop.evaluate`, the `eval`
command); agents come from `sdovon_mj.nav` through the plugin registry.

Tasks (tagged like `dm_control.suite`): ``objectnav`` (rgb+depth, 640x480), ``objectnav_semantic``
(adds segmentation) and ``objectnav_small`` (128x128, for fast training loops). Tests and benches run
them on the two-room fixture apartment of `tests/support/bundles.py` (the suite itself never imports it).
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

from dm_control.utils import containers

from ..actions import ACTION_NAMES, CLOSE, LOOK_DOWN, LOOK_UP, MOVE_FORWARD, OPEN, STOP, TURN_LEFT, TURN_RIGHT

SUITE = containers.TaggedTasks()

# Loaded on first use: an agent's process (`suite.agent_process`) imports this package for the protocol alone and
# needs neither MuJoCo nor dm_control's environment.
_LAZY = {"Bundle": "bundle", "find_bundles": "bundle", "load_bundle": "bundle", "ObjectNavTask": "objectnav",
         "Physics": "objectnav", "build_model": "objectnav", "make_environment": "objectnav"}

__all__ = ["SUITE", "ALL_TASKS", "BENCHMARKING", "load", "make_environment", "Bundle", "find_bundles", "load_bundle",
           "ObjectNavTask", "Physics", "build_model", "ACTION_NAMES", "STOP", "MOVE_FORWARD", "TURN_LEFT",
           "TURN_RIGHT", "LOOK_UP", "LOOK_DOWN", "OPEN", "CLOSE"]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _bundle_arg(bundle: Any) -> Any:
    from .bundle import Bundle, find_bundles

    if bundle is None:
        raise TypeError("this task needs task_kwargs={'bundle': <variant folder>}")
    if isinstance(bundle, Bundle):
        return bundle
    return find_bundles(bundle)[0] if not (Path(bundle) / "episodes.json").exists() else bundle


def _make(bundle: Any, environment_kwargs: dict | None, **task_kwargs: Any) -> Any:
    from .objectnav import make_environment

    return make_environment(_bundle_arg(bundle), **task_kwargs, **(environment_kwargs or {}))


@SUITE.add("benchmarking", "rgbd")
def objectnav(bundle: Any = None, environment_kwargs: dict | None = None, **task_kwargs: Any) -> Any:
    """ObjectNav with rgb + depth at 640x480, gps, compass, object goal."""
    return _make(bundle, environment_kwargs, **task_kwargs)


@SUITE.add("benchmarking", "rgbd", "semantic")
def objectnav_semantic(bundle: Any = None, environment_kwargs: dict | None = None, **task_kwargs: Any) -> Any:
    """ObjectNav with rgb + depth + semantic segmentation at 640x480."""
    task_kwargs.setdefault("semantic", True)
    return _make(bundle, environment_kwargs, **task_kwargs)


@SUITE.add("rgbd", "small")
def objectnav_small(bundle: Any = None, environment_kwargs: dict | None = None, **task_kwargs: Any) -> Any:
    """ObjectNav with rgb + depth at 128x128."""
    task_kwargs.setdefault("width", 128)
    task_kwargs.setdefault("height", 128)
    return _make(bundle, environment_kwargs, **task_kwargs)


ALL_TASKS = tuple(sorted(SUITE.keys()))
BENCHMARKING = tuple(sorted(SUITE.tagged("benchmarking")))
TASKS_BY_TAG = {tag: tuple(sorted(SUITE.tagged(tag))) for tag in ("benchmarking", "rgbd", "semantic", "small")}


def load(task_name: str, task_kwargs: dict | None = None, environment_kwargs: dict | None = None) -> Any:
    """Return the environment of a registered task (like `dm_control.suite.load`, without a domain)."""
    if task_name not in SUITE:
        raise ValueError(f"unknown task {task_name!r} (known: {', '.join(ALL_TASKS)})")
    return SUITE[task_name](environment_kwargs=environment_kwargs, **(task_kwargs or {}))
