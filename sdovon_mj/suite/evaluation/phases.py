"""One phase (a first visit or an episode) run through the agent protocol: the session with the agent (sealed or in
this process), the environment stepped from its reset to its end, and the frames of an episode's video."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..observation import ObservationBuilder
from ..protocol import MODES, InProcessSession, Phase, SealedSession
from ..video import EpisodeVideo


def open_session(agent: Any, mode: str, width: int, height: int, seal: bool = True, read: tuple[str, ...] = (),
                 protect: tuple[Path, ...] = ()) -> Any:
    """Return a protocol session with the agent: ``sealed`` (its own process) or ``in-process``.

    Parameters
    ----------
    agent : AgentSpec or agent object
        The agent to run.
    mode : str
        ``sealed`` or ``in-process``.
    width, height : int
        The camera's image size, pixels (the frame buffer's layout).
    seal : bool
        Seal the agent process's file system (sealed mode).
    read : tuple of str
        More paths a sealed agent may read.
    protect : tuple of Path
        Folders no path the agent may read may contain (the dataset, the results).
    """
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r} ({' or '.join(MODES)})")
    if mode == "in-process":
        return InProcessSession(agent)
    return SealedSession(agent, width, height, seal=seal, read=read, protect=protect)


def _record(video: EpisodeVideo | None, env: Any, obs: dict, rendered: bool) -> None:
    """Add the frame of this step to an episode's video: the view the agent got, or (it asked for no frame and got a
    blank one) the view rendered here for the video alone; the pose from the evaluator's physics."""
    if video is not None:
        rgb = obs["rgb"] if rendered else env.task.render(env.physics, segmentation=False)[0]
        video.add(rgb, env.task.state.position, env.task.state.yaw)


def run_phase(session: Any, env: Any, builder: ObservationBuilder, phase: Phase, at_reset: dict | None = None,
              video: EpisodeVideo | None = None) -> dict:
    """Run one phase (a first visit or an episode) from the environment's reset to its end; return the agent's info.

    Parameters
    ----------
    session
        The agent's session (`open_session`).
    env
        The environment, its next reset set (an episode or a first visit).
    builder : ObservationBuilder
        Builds the agent's observations within its knowledge.
    phase : Phase
        What begins (sent to the agent with the first observation).
    at_reset : dict, optional
        Filled with the episode's difficulty after the reset, before the agent acts (``in_view``, ``visible``:
        `start_visibility`).
    video : EpisodeVideo, optional
        Records a frame after the reset and after every step (steps + 1), here in the evaluator.
    """
    env.task.render_frames = True  # every phase's first observation is rendered
    ts = env.reset()
    if at_reset is not None:
        at_reset["in_view"], at_reset["visible"] = env.task.start_visibility(env.physics)
    obs = builder(ts.observation, True)
    _record(video, env, obs, True)
    reply = session.begin(phase, obs, True)
    while True:
        env.task.render_frames = reply.frame
        ts = env.step(reply.action)
        obs = builder(ts.observation, reply.frame)
        _record(video, env, obs, reply.frame)
        if ts.last():
            return session.end(obs, reply.frame)
        reply = session.step(obs, reply.frame)
