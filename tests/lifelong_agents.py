"""A test agent of the lifelong evaluation (tests/test_lifelong.py), written only against the agent protocol: it
counts the "new day" messages and the episodes it heard, and can crash in one episode. The evaluator never imports
this module (it is named by `AgentSpec("lifelong_agents:DayCounter")` and built in the agent's own process)."""

from __future__ import annotations

from sdovon_mj.actions import STOP, TURN_LEFT
from sdovon_mj.knowledge import Knowledge


class DayCounter:
    """Blind: turns `steps` times, then STOP. Reports in its info the new days and episodes this process has seen
    (one process per scene: both count from the scene's start); raises in its episode `crash_at` (0-based, -1: never)."""

    name = "day-counter"
    knowledge = Knowledge(detector="none")

    def __init__(self, steps: int = 2, crash_at: int = -1) -> None:
        self.steps, self.crash_at = int(steps), int(crash_at)
        self.days, self.episodes, self.n = 0, 0, 0
        self.wants_frame = False
        self.info: dict = {}

    def setup(self, sensors) -> None:
        self.sensors = sensors

    def new_day(self) -> None:
        self.days += 1

    def reset(self, view, ts) -> None:
        self.n = 0
        self.episodes += 1

    def act(self, ts) -> int:
        if self.episodes - 1 == self.crash_at:
            raise RuntimeError("deliberate crash")
        self.n += 1
        return STOP if self.n > self.steps else TURN_LEFT

    def end(self, view, ts) -> None:
        self.info = {"days": self.days, "episodes": self.episodes}
