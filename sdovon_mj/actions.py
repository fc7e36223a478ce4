"""The ObjectNav discrete action space (habitat-lab's order), shared by the suite's task and the agents.

The six habitat-lab actions come first; ``OPEN`` / ``CLOSE`` follow (issue 17): Habitat-style "magic" interaction
that drives the articulated part the agent looks at (within ``nav.open_reach``) to its open / closed limit.

The environment (`suite.objectnav`) applies these actions and the agents (`nav`) emit them; both
import them from here, so neither imports the other for them.
"""

from __future__ import annotations

STOP, MOVE_FORWARD, TURN_LEFT, TURN_RIGHT, LOOK_UP, LOOK_DOWN, OPEN, CLOSE = range(8)
ACTION_NAMES = ("STOP", "MOVE_FORWARD", "TURN_LEFT", "TURN_RIGHT", "LOOK_UP", "LOOK_DOWN", "OPEN", "CLOSE")
NAV_ACTIONS = ACTION_NAMES[:6]  # habitat-lab's ObjectNav actions; OPEN/CLOSE move articulated parts (doors, drawers)
