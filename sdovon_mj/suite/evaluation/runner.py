"""The rows of a results table run over the same episodes: which agent each row runs (a plugin built here, or named
by an `AgentSpec` for the sealed process), which bundles (a balanced subset of a dataset), and the parallel runner
that cuts the work into one row on one scene per task."""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ... import plugins
from ...config import AgentConfig, NavConfig
from ..bundle import Bundle, find_bundles, load_bundle
from ..protocol import REPLY_TIMEOUT, SETUP_TIMEOUT, AgentSpec
from .loop import drawn_by, evaluate


def make_agent(name: str, nav: NavConfig, seed: int = 0, final_nav: bool = True, agent: AgentConfig | None = None) -> Any:
    """Return the agent plugin `name` built here (the plugin's code runs in this process: for a sealed evaluation
    name it with `agent_spec`).

    Parameters
    ----------
    name : str
        The plugin's name.
    nav : NavConfig
        Actions, FN and step limit (``final_nav`` sets ``nav.final_nav``).
    seed : int
        The agent's seed.
    final_nav : bool
        Final point-goal navigation after a detection.
    agent : AgentConfig, optional
        Its body and camera (default `AgentConfig()`).
    """
    factory = plugins.load("agent", name)
    return factory(nav=replace(nav, final_nav=bool(final_nav)), agent=agent or AgentConfig(), seed=seed)


def agent_spec(name: str, nav: NavConfig, seed: int = 0, final_nav: bool = True, agent: AgentConfig | None = None,
               **kwargs: Any) -> AgentSpec:
    """Return the `AgentSpec` of plugin `name` (or ``module:Class``) with the plugin factory's arguments.

    Parameters
    ----------
    name : str
        The plugin's name or ``module:Class``.
    nav, seed, final_nav, agent : as in `make_agent`
    **kwargs
        More keyword arguments of the agent's class (``explore_steps``, ``per_metre``, ``semantics``, ...).
    """
    return AgentSpec(name, {"nav": replace(nav, final_nav=bool(final_nav)), "agent": agent or AgentConfig(),
                            "seed": int(seed), **kwargs})


def select_bundles(dataset: str | Path, per_scene: int) -> list[Bundle]:
    """Return the first `per_scene` variants of every scene of a dataset, loaded (scenes and variant folders sorted).

    A balanced subset for evaluating on many scenes at once (`evaluate` takes the list, and every run over it reuses
    the loaded bundles): the first N episodes of a dataset all come from its first scene.
    """
    by_scene: dict[str, list[Bundle]] = {}
    for p in find_bundles(dataset):
        b = load_bundle(p)
        kept = by_scene.setdefault(str(b.episodes[0].scene) if b.episodes else p.name, [])
        if len(kept) < per_scene:
            kept.append(b)
    return [b for scene in sorted(by_scene) for b in by_scene[scene]]


@dataclass(frozen=True)
class Row:
    """One row of a results table: its label, the agent (an `AgentSpec`, or an agent object) and how it runs."""

    label: str
    agent: Any
    mode: str = "sealed"


def _row_task(task: tuple) -> list[dict]:
    """Evaluate one row on one scene's bundles (a worker's unit of `run_rows`)."""
    bundles, row, nav, body, out, seed, seal, read, videos, timeout, setup_timeout, render = task
    return evaluate(bundles, row.agent, nav=nav, out=out, label=row.label, progress=False, mode=row.mode, seed=seed,
                    body=body, seal=seal, read=read, videos=videos, timeout=timeout, setup_timeout=setup_timeout,
                    render=render)


def run_rows(dataset: str | Path | list[Path | Bundle], rows: list[Row], out: Path | None = None, jobs: int = 1,
             episodes: int | None = None, seed: int = 0, nav: NavConfig | None = None, body: AgentConfig | None = None,
             seal: bool = True, read: tuple[str, ...] = (), progress: bool = True, video: int = 0,
             timeout: float = REPLY_TIMEOUT, setup_timeout: float = SETUP_TIMEOUT,
             render: str = "auto") -> dict[str, list[dict]]:
    """Evaluate table rows over the same episodes; return each row's results (episode order).

    The work is cut into tasks of one row on one scene (its first visit, then its episodes), run on `jobs`
    processes (``spawn``: each chooses its renderer, `render`; on a GPU their environments share it) in row-major
    order; with ``out`` every finished episode is written at once, and running
    the same call again resumes (finished episodes are read back, not run). ``episodes``: the first N episodes of the
    dataset (bundles in order), the same for every row.

    Parameters
    ----------
    dataset
        As `evaluate`'s.
    rows
        The rows (labels unique).
    out
        Results folder (None: nothing written, no resume).
    jobs
        Worker processes (1: this process).
    episodes
        Evaluate at most this many episodes per row.
    seed
        Seed of the first visits' start poses.
    nav, body
        Environment settings (default: each row's agent's).
    seal, read
        As `evaluate`'s.
    progress
        Print one line per finished task.
    video
        Record the first N episodes (in results order) of every row as MP4 (needs ``out``; `evaluate`'s ``videos``).
    timeout, setup_timeout
        As `evaluate`'s.
    render
        As `evaluate`'s (checked here first: `gpu` without a GPU stops before any work).
    """
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    drawn_by(render)
    paths = find_bundles(dataset) if isinstance(dataset, (str, Path)) else list(dataset)
    bundles = [p if isinstance(p, Bundle) else load_bundle(p) for p in paths]
    left = sum(len(b.episodes) for b in bundles) if episodes is None else int(episodes)
    kept: list[Bundle] = []
    for b in bundles:
        if left <= 0:
            break
        kept.append(b if len(b.episodes) <= left else replace(b, episodes=b.episodes[:left]))
        left -= len(kept[-1].episodes)
    scenes: dict[str, list[Bundle]] = {}
    for b in kept:
        scenes.setdefault(str(b.episodes[0].scene) if b.episodes else b.name, []).append(b)
    if len({r.label for r in rows}) != len(rows):
        raise ValueError("row labels must be unique")
    videos = tuple([e.episode_id for sc in scenes for b in scenes[sc] for e in b.episodes][:max(int(video), 0)])
    tasks = [(row, sc, (scenes[sc], row, nav, body, out, seed, seal, tuple(read), videos, float(timeout),
                        float(setup_timeout), render)) for row in rows for sc in scenes]
    got: dict[tuple[str, str], list[dict]] = {}
    t0 = time.perf_counter()
    if jobs <= 1:
        for row, sc, task in tasks:
            got[(row.label, sc)] = _row_task(task)
            if progress:
                print(f"{row.label} / {sc}: {len(got[(row.label, sc)])} episodes ({time.perf_counter() - t0:.0f} s)", flush=True)
    else:
        with ProcessPoolExecutor(max_workers=int(jobs), mp_context=get_context("spawn")) as pool:
            futures = {pool.submit(_row_task, task): (row.label, sc) for row, sc, task in tasks}
            for f, key in futures.items():
                got[key] = f.result()
                if progress:
                    print(f"{key[0]} / {key[1]}: {len(got[key])} episodes ({time.perf_counter() - t0:.0f} s)", flush=True)
    return {row.label: [r for sc in scenes for r in got[(row.label, sc)]] for row in rows}
