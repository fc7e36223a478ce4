"""Agents for the ObjectNav suite: Random A*, Semantic A* (paper appendix D) and its distance-aware variant, the
no-prior Semantic Frontier agent, and the labelled oracle and random references.

Agents are plugins (`plugins.load("agent", name)`, entry point group ``sdovon_mj.agents``); the evaluation builds
them as ``factory(nav=NavConfig, agent=AgentConfig, seed=int)`` in their own process (``nav.final_nav`` switches
final point-goal navigation, ``nav.fn_mode`` picks the paper's FN, our FN with retries, or our lattice variant).
This package never imports the suite: what the agent gets comes in through the protocol's calls.

One agent a module: `random_agent`, `oracle_agent`, `random_astar`, `semantic_astar`, `semantic_astar_memory`
(with `object_memory`), `semantic_frontier`, `semantic_frontier_memory`; the A*
agents' common search in `receptacle_astar` (the episode) with what it does split by concept: `first_visit` (its
memory), `search_order`, `looking`, `planning`, `final_navigation`; their base `agent.Agent`. This module is their
public name: the entry points, the built-in plugins and the classes' ``__module__`` (`agent.public_home`: pickles
and the evaluator's run key of an agent object) name ``sdovon_mj.nav.agents``.

Every agent declares its `Knowledge` (detector, pose sensor, prior exploration and its step budget, oracle parts,
FN); the evaluation grants exactly that (`sdovon_mj.suite.protocol`): the A* agents build receptacles, planes,
regions and relevance from the frames of their own first visit with the pipeline's stages
(`memory.extract_planes`); only agents that declare oracle parts get generator artefacts, and the tables label them.

Protocol (what `suite.protocol.AgentRunner` calls, in the agent's process; docs/evaluation.md):
    agent.knowledge               what it uses (`sdovon_mj.knowledge.Knowledge`)
    agent.setup(sensors)          once: `suite.observation.Sensors` (camera, intrinsics K, actions, step limit,
                                  the dataset's vocabulary)
    agent.explore(view, ts)       prior="scene" only: the first visit of ``view.scene`` begins (no goal, a step
                                  budget of ``view.max_steps``); then act() until it returns STOP
    agent.reset(view, ts)         an episode begins (``view``: scene, episode id and index, steps, step limit)
    action = agent.act(ts)        one discrete action per time step (dm_env TimeStep, reward None)
    agent.end(view, ts)           the phase is over (STOP or its step limit); ``agent.info`` is read after it
    agent.new_day()               lifelong evaluation: the scene's next day begins (default no-op; no content)
    agent.wants_frame             whether the next observation needs rendered images (blank frames otherwise)
"""

from __future__ import annotations

from .agent import Agent
from .first_visit import FLOOR_TOLERANCE
from .oracle_agent import OracleAgent
from .planning import FAR_APPROACHES
from .random_agent import RandomAgent
from .random_astar import RandomAStar
from .receptacle_astar import OPENABLE_LABELS, ReceptacleAStar
from .semantic_astar import SemanticAStar
from .semantic_astar_memory import SemanticAStarMemory
from .semantic_frontier import SemanticFrontierAgent
from .semantic_frontier_memory import SemanticFrontierMemory

__all__ = ["Agent", "RandomAgent", "OracleAgent", "ReceptacleAStar", "RandomAStar", "SemanticAStar",
           "SemanticAStarMemory", "SemanticFrontierAgent",
           "SemanticFrontierMemory", "OPENABLE_LABELS", "FAR_APPROACHES", "FLOOR_TOLERANCE"]
