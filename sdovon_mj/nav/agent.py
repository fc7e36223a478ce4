"""The base of the built-in agents: the protocol's calls (`setup`, `explore`, `reset`, `act`, `end`) driving a
policy written as a generator of actions (`Agent._run` for an episode, `Agent._explore` for a first visit).

Every built-in agent class names `sdovon_mj.nav.agents` as its module (`public_home`): that module is their public
name (entry points, plugins, pickles into the agent's process, the evaluator's run key of an agent object), so
moving a class between files changes none of these.
"""

from __future__ import annotations

from typing import Any, Generator, TypeVar

from ..actions import STOP
from ..config import AgentConfig, NavConfig
from ..knowledge import Knowledge
from .sensing import CategoryDetector

PUBLIC_MODULE = "sdovon_mj.nav.agents"
AgentClass = TypeVar("AgentClass", bound=type)


def public_home(cls: AgentClass) -> AgentClass:
    """Return the class with `PUBLIC_MODULE` as its module (where the agents are imported, pickled and named from)."""
    cls.__module__ = PUBLIC_MODULE
    return cls


@public_home
class Agent:
    """Base agent: generator-driven policies; `_run` (an episode) and `_explore` (a first visit) yield actions and
    read `self.ts`; ``self.env`` is the protocol's view of the current phase (`suite.protocol.AgentView`)."""

    name = "agent"
    knowledge = Knowledge()

    def __init__(self, nav: NavConfig | None = None, seed: int = 0, agent: AgentConfig | None = None) -> None:
        self.nav = nav or NavConfig()
        self.agent_config = agent or AgentConfig()  # body, camera and eta_gt the agent assumes
        self.seed = seed
        self.wants_frame = True
        self._gen: Generator[int, object, None] | None = None
        self.ts = None
        self.info: dict = {}
        self.sensors: Any = None
        self.detector: CategoryDetector | None = None
        self.object_categories: tuple[str, ...] = ()  # the dataset's object categories (`Vocabulary.object_categories`)

    def setup(self, sensors: Any) -> None:
        """Keep the sensors; with the ground-truth detector declared, detect instances in the category image."""
        self.sensors = sensors
        self.object_categories = tuple(sensors.vocabulary.object_categories)  # relevance is normalised over them
        if sensors.knowledge.detector == "gt":
            self.detector = CategoryDetector(sensors.vocabulary.labels, sensors.eta)

    def _start(self, view: Any, ts: Any, gen: Generator[int, object, None]) -> None:
        self.env, self.ts = view, ts
        self.info = {}
        self._gen = gen
        self._started = False
        self.frame_fresh = True  # whether the current observation's images were rendered (a phase's first one is)
        self._render_next = False

    def explore(self, view: Any, ts: Any) -> None:
        """Start the first visit of a scene (agents that declare ``prior="scene"``)."""
        self._start(view, ts, self._explore(view))

    def reset(self, view: Any, ts: Any) -> None:
        """Start an episode."""
        self._start(view, ts, self._run(view))

    def end(self, view: Any, ts: Any) -> None:
        """The phase is over (default: nothing to do)."""

    def new_day(self) -> None:
        """A lifelong evaluation's scene begins its next day (default: nothing to do; what changed overnight is for
        the agent to find out)."""

    def act(self, ts) -> int:
        """Return the next action for the current timestep (STOP once the policy is done)."""
        self.ts = ts
        self.frame_fresh = self._render_next
        try:
            a = next(self._gen) if not self._started else self._gen.send(ts)
        except StopIteration:
            a = STOP
        self._started = True
        self._render_next = bool(self.wants_frame)
        return int(a)

    def _explore(self, env) -> Generator[int, object, None]:
        yield STOP

    def _run(self, env) -> Generator[int, object, None]:
        yield STOP
