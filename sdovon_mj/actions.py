"""The ObjectNav discrete action space (habitat-lab's order), shared by the suite's task and the agents.

The environment (`suite.objectnav`) applies these actions and the agents (`nav`) emit them; both
import them from here, so neither imports the other for them.
"""

from __future__ import annotations

STOP, MOVE_FORWARD, TURN_LEFT, TURN_RIGHT, LOOK_UP, LOOK_DOWN = range(6)
ACTION_NAMES = ("STOP", "MOVE_FORWARD", "TURN_LEFT", "TURN_RIGHT", "LOOK_UP", "LOOK_DOWN")
