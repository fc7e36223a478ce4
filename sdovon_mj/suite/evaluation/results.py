"""An evaluation's results folder: where each file of a run lies (per-episode JSON, first visits, videos, pictures),
the run key that marks a run's results, and reading a finished episode back (a rerun resumes).

The run key is a digest of the row's label, the agent (an `AgentSpec`'s target and arguments, or an agent object's
class and pickled state), the environment's settings, the mode, the seed and the package version; it names no
module of the evaluator, so results written before the evaluator was split stay this run's own.
"""

from __future__ import annotations

import hashlib
import json
import pickle
from pathlib import Path
from typing import Any

from ...config import AgentConfig, NavConfig, to_dict
from ..protocol import AgentSpec


def run_key(label: str, agent: Any, nav: NavConfig, body: AgentConfig, mode: str, seed: int) -> str:
    """Return the digest that marks one run's per-episode results (a resumed run reuses only its own).

    Parameters
    ----------
    label : str
        The row's name.
    agent : AgentSpec or agent object
        A spec counts by its target and arguments; an object by its class's module and qualified name and its
        pickled state (moving the class would change the key: the built-in agents keep their module name).
    nav : NavConfig
        The environment's actions, step limit and success radius.
    body : AgentConfig
        The agent's body and camera.
    mode : str
        ``sealed`` or ``in-process``.
    seed : int
        The evaluation seed.
    """
    who = [agent.target, sorted((k, repr(v)) for k, v in agent.kwargs.items())] if isinstance(agent, AgentSpec) \
        else [type(agent).__module__, type(agent).__qualname__, hashlib.sha256(pickle.dumps(agent)).hexdigest()]
    from ... import __version__

    blob = json.dumps([label, who, to_dict(nav), to_dict(body), mode, int(seed), __version__], sort_keys=True, default=str)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()[:16]


def result_path(out: Path, label: str, episode_id: str) -> Path:
    """Return the file of an episode's result: ``episodes/<label>/<episode id>.json`` (spaces of the label as ``_``)."""
    return out / "episodes" / label.replace(" ", "_") / f"{episode_id}.json"


def load_done(out: Path | None, label: str, key: str, episode_id: str) -> dict | None:
    """Return a finished episode's result of this run (same run key), or None."""
    if out is None:
        return None
    p = result_path(out, label, episode_id)
    try:
        r = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None
    return r if isinstance(r, dict) and r.get("run_key") == key else None


def video_path(label: str, episode_id: str) -> str:
    """Return an episode's video file, relative to the results folder (it names the agent and the episode)."""
    return f"videos/{label.replace(' ', '_')}/{episode_id}.mp4"


def exploration_path(out: Path, label: str, scene: str) -> Path:
    """Return the file of a scene's first visit: ``exploration/<label>/<scene>.json``."""
    return out / "exploration" / label.replace(" ", "_") / f"{scene}.json"


def picture_path(out: Path, label: str, episode_id: str) -> Path:
    """Return the file of an episode's trajectory picture: ``pictures/<label>/<episode id>.png``."""
    return out / "pictures" / label.replace(" ", "_") / f"{episode_id}.png"
