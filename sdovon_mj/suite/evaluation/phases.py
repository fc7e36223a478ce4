"""One phase (a first visit or an episode) run through the agent protocol: the session with the agent (sealed or in
this process; `LiveAgent` keeps one open through an evaluation, a new one after a failure), the environment stepped
from its reset to its end, and the frames of an episode's video."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..observation import ObservationBuilder
from ..protocol import MODES, REPLY_TIMEOUT, SETUP_TIMEOUT, InProcessSession, Phase, SceneStart, SealedSession
from ..video import EpisodeVideo


def open_session(agent: Any, mode: str, width: int, height: int, seal: bool = True, read: tuple[str, ...] = (),
                 protect: tuple[Path, ...] = (), timeout: float = REPLY_TIMEOUT, setup_timeout: float = SETUP_TIMEOUT,
                 log: Path | None = None) -> Any:
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
    timeout, setup_timeout : float
        Seconds for one reply and for the agent's set-up (sealed mode).
    log : Path, optional
        The agent process's stdout and stderr (sealed mode).
    """
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r} ({' or '.join(MODES)})")
    if mode == "in-process":
        return InProcessSession(agent)
    return SealedSession(agent, width, height, seal=seal, read=read, protect=protect, timeout=timeout,
                         setup_timeout=setup_timeout, log=log)


class LiveAgent:
    """The agent during one evaluation: its session opened (and set up) when first needed, and opened again after a
    failure (a new process: its memory is gone, and no scene's first visit is granted again). Each session hears of
    a scene once, by its token.

    Parameters
    ----------
    opener
        Returns a new session (`open_session` with the evaluation's arguments).
    sensors
        Returns the `Sensors` to set a session up with, from the agent's declared `Knowledge`.
    session
        A session already open and set up (e.g. a bench's), used until it fails.
    """

    def __init__(self, opener: Any, sensors: Any, session: Any = None) -> None:
        self._open, self._sensors = opener, sensors
        self.session = session
        self.knowledge = getattr(session, "knowledge", None)
        self.scene = ""

    def get(self, start: SceneStart | None = None) -> Any:
        """Return a live session (set up; `start` announced when it is another scene than the last)."""
        if self.session is None:
            self.session = self._open()
            self.knowledge = self.session.knowledge
            self.session.setup(self._sensors(self.knowledge))
            self.scene = ""
        if start is not None and start.scene != self.scene:
            self.session.scene(start)
            self.scene = start.scene
        return self.session

    def fail(self) -> None:
        """The session failed: end its process (the next `get` starts another)."""
        self.close()

    def close(self) -> None:
        """End the session's process, if one is open."""
        if self.session is not None:
            self.session.close()
        self.session = None


def _record(video: EpisodeVideo | None, env: Any, obs: dict, rendered: bool) -> None:
    """Add the frame of this step to an episode's video: the view the agent got, or (it asked for no frame, or reads
    no colour image, and got a blank one) the view rendered here for the video alone; the pose from the evaluator's
    physics."""
    if video is not None:
        own = rendered and env.task.render_rgb  # the agent's frame holds the colour image
        rgb = obs["rgb"] if own else env.task.render(env.physics, segmentation=False)[0]
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
        Filled with the physics state after the reset (``qpos``): the episode's difficulty is measured on it after
        the episode (`loop.run_episode`), so the time that takes tells the agent nothing.
    video : EpisodeVideo, optional
        Records a frame after the reset and after every step (steps + 1), here in the evaluator.
    """
    env.task.render_frames = True  # every phase's first observation is rendered
    ts = env.reset()
    if at_reset is not None:
        at_reset["qpos"] = env.physics.data.qpos.copy()
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
