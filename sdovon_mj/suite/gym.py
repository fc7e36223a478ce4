"""Gymnasium environments over MJCF episode bundles: ``sdovon_mj/ObjectNav-v0``, for RL and embodied-AI code that
speaks Gymnasium (Stable-Baselines3, CleanRL, TorchRL, skrl, ...)::

    import gymnasium
    env = gymnasium.make("sdovon_mj.suite.gym:sdovon_mj/ObjectNav-v0", bundle="out/demo/export/mjcf/sdovon/apt_0000_v000")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.unwrapped.action_names.index("MOVE_FORWARD"))

Gymnasium 1.x imports the module named before ``:`` and registers what it registers (its entry-point plugins are gone
since 1.0); after ``import sdovon_mj.suite.gym`` the bare id works too. Importing `sdovon_mj` or `sdovon_mj.suite`
never imports Gymnasium.

One environment is one bundle (a scene variant) stepped by the suite's dm_control task (`suite.objectnav`); its
observations are built by the sealed evaluation's own `ObservationBuilder` within a declared `Knowledge` (default:
ground-truth category image, GPS+compass), over the dataset's `Vocabulary`, so a policy trained here reads the same
keys, shapes and indices that `sdovon-mj eval` hands an agent. Several bundles: one environment each in
``gymnasium.vector.AsyncVectorEnv`` (all variants of one dataset share its vocabulary, so their spaces match).

The knowledge boundary (docs/toolbox.md): by default (evaluation mode) the reward is always 0.0 and ``info`` holds
nothing of the scene, as in the sealed evaluation (`reset`'s ``info["render"]`` says which renderer draws). ``training=True`` returns the task's dense reward (the decrease of the geodesic distance
to the nearest goal view point, habitat-lab's) and puts the distance to goal and, at the episode's end, its metrics
in ``info``: generator knowledge, for training only. The environment object itself holds the generator's state (it
runs in the caller's process): results for a paper come from `sdovon-mj eval`, which seals the agent off.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from ..actions import ACTION_NAMES
from ..config import AgentConfig, NavConfig
from ..errors import InputError
from ..knowledge import Knowledge
from ..gl import RENDERS
from ..gl import use as use_renderer
from .bundle import Bundle, find_bundles, load_bundle
from .objectnav import make_environment
from .observation import ObservationBuilder, Sensors, Vocabulary, dataset_vocabulary, make_sensors, rendered_images
from .video import FPS, MapPanel, compose_frame

ENV_ID = "sdovon_mj/ObjectNav-v0"
EPISODE_ORDERS = ("random", "sequential")


def observation_space(sensors: Sensors, goal_text: bool = False) -> spaces.Dict:
    """Return the Dict space of the observations `ObservationBuilder` builds for `sensors` (its image size, depth range,
    tilt limit, vocabulary and knowledge); ``objectgoal_text`` (a `spaces.Text`) only with `goal_text`."""
    h, w = sensors.height, sensors.width
    vocab = sensors.vocabulary
    tilt = math.radians(float(sensors.nav.max_tilt))
    big = float(np.finfo(np.float32).max)  # habitat-lab's GPS bounds: any finite float32
    out: dict[str, spaces.Space] = {
        "rgb": spaces.Box(0, 255, (h, w, 3), np.uint8),
        "depth": spaces.Box(sensors.depth_min, sensors.depth_max, (h, w, 1), np.float32),
        "gps": spaces.Box(-big, big, (2,), np.float32),
        "compass": spaces.Box(-math.pi, math.pi, (1,), np.float32),
        "pitch": spaces.Box(-tilt, tilt, (1,), np.float32),
        "position": spaces.Box(-big, big, (3,), np.float32),
        "heading": spaces.Box(-math.pi, math.pi, (1,), np.float32),
        # habitat-lab's ObjectGoalSensor: a (1,) int64 index, here into Vocabulary.goal_categories
        "objectgoal": spaces.Box(0, max(len(vocab.goal_categories) - 1, 0), (1,), np.int64),
    }
    if sensors.knowledge.detector == "gt":
        out["category"] = spaces.Box(-1, max(len(vocab.labels) - 1, -1), (h, w), np.int16)
    if goal_text:
        chars = "".join(sorted(set("".join(vocab.goal_categories)))) or "?"
        out["objectgoal_text"] = spaces.Text(max(len(c) for c in vocab.goal_categories or ("?",)), min_length=0,
                                             charset=chars)
    return spaces.Dict(out)


def _one_bundle(bundle: str | Path | Bundle) -> Bundle:
    """Return the loaded bundle of a variant folder (InputError for a dataset of several variants)."""
    if isinstance(bundle, Bundle):
        return bundle
    path = Path(bundle)
    if not path.is_dir():
        raise InputError(path, "bundle folder not found")
    found = find_bundles(path)
    if len(found) != 1:
        raise InputError(path, f"holds {len(found)} variant folders: an environment runs one (pass one of them; several "
                               "bundles: one environment each, e.g. in gymnasium.vector.AsyncVectorEnv)")
    return load_bundle(found[0])


class ObjectNavEnv(gymnasium.Env):
    """ObjectNav on one MJCF bundle as a Gymnasium environment (id ``sdovon_mj/ObjectNav-v0``).

    Actions: ``Discrete(8)`` named by `action_names` (habitat-lab's six, then OPEN, CLOSE). Observations: a Dict of
    what the sealed evaluation hands an agent (`suite.observation`; `observation_space`). An episode ends with
    ``terminated`` on STOP and ``truncated`` at the step limit.

    Parameters
    ----------
    bundle
        A variant folder (with episodes.json) or a loaded `Bundle`.
    render_mode
        None or ``"rgb_array"``: `render` returns the agent's view (H, W, 3) uint8, or with `render_map` the episode
        video's frame (the view beside the top-down map and the path so far).
    training
        Return the dense reward and put distances and metrics in ``info`` (generator knowledge). Default False: the
        evaluation's boundary (reward 0.0, empty ``info``).
    width, height
        Camera image size in pixels (default `AgentConfig`'s 640 x 480).
    max_steps
        Episode step limit (default ``nav.max_steps``, 500).
    nav
        Action sizes, step limit, success distance, depth range (default `NavConfig()`).
    agent
        Body and camera (default `AgentConfig()`; `width` / `height` override its sensor size).
    knowledge
        What the agent observes (default `Knowledge()`: the ground-truth category image, GPS+compass). A first visit
        (``prior="scene"``) and oracle parts are the evaluation's, not offered here.
    episode_order
        ``random`` (default): each reset draws an episode with the environment's generator, so ``reset(seed=s)``
        picks the same episode for the same `s`; ``sequential``: the bundle's order, cycling (a seeded reset
        starts again at the first). ``reset(options={"episode": i or episode_id})`` picks one.
    vocabulary
        The dataset's vocabulary (default: `dataset_vocabulary` of the folder the bundle sits in).
    goal_text
        Add ``objectgoal_text`` (the goal category's name, a `spaces.Text`): open-vocabulary policies read it; many RL
        libraries accept Box / Discrete spaces only.
    render_map
        `render` draws the top-down map too (generator knowledge: needs `training`).
    render
        Which OpenGL renderer draws the observations: ``auto`` (default: the GPU's EGL when the machine has one, else
        Mesa's llvmpipe on the CPU), ``cpu`` or ``gpu`` (`RendererError` on a machine without one). A process draws
        with the renderer its first renderer chose (`sdovon_mj.gl`): ``gpu`` after a CPU choice is an error, ``auto``
        then says so. The record (`render_info`; ``info["render"]`` of `reset`) names what draws, and why ``auto``
        fell back to the CPU.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": FPS}

    def __init__(self, bundle: str | Path | Bundle, render_mode: str | None = None, training: bool = False,
                 width: int | None = None, height: int | None = None, max_steps: int | None = None,
                 nav: NavConfig | None = None, agent: AgentConfig | None = None, knowledge: Knowledge | None = None,
                 episode_order: str = "random", vocabulary: Vocabulary | None = None, goal_text: bool = False,
                 render_map: bool = False, render: str = "auto") -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode {render_mode!r}: only 'rgb_array' is offered")
        if episode_order not in EPISODE_ORDERS:
            raise ValueError(f"episode_order {episode_order!r} ({' or '.join(EPISODE_ORDERS)})")
        know = knowledge or Knowledge()
        if know.prior != "none" or know.oracle:
            raise ValueError("a first visit (prior='scene') and oracle parts are the evaluation's (`sdovon-mj eval`); "
                             "the Gymnasium environment runs episodes only")
        if render_map and not training:
            raise ValueError("render_map draws goals and the navigable map (generator knowledge): it needs training=True")
        if render not in RENDERS:
            raise ValueError(f"render {render!r}: one of {', '.join(RENDERS)}")
        self.render_info: dict[str, Any] = use_renderer(render)  # before the first context (RendererError here)
        self._bundle = _one_bundle(bundle)
        nav = nav or NavConfig()
        if max_steps is not None:
            nav = replace(nav, max_steps=int(max_steps))
        body = agent or AgentConfig()
        size = {k: int(v) for k, v in (("sensor_width", width), ("sensor_height", height)) if v is not None}
        body = replace(body, **size) if size else body
        vocab = vocabulary if vocabulary is not None else dataset_vocabulary(Path(self._bundle.root).parent, [self._bundle])
        self.render_mode = render_mode
        self.training = bool(training)
        self.render_map = bool(render_map)
        self.goal_text = bool(goal_text)
        self.episode_order = episode_order
        self.knowledge = know
        self.vocabulary = vocab
        self.sensors = make_sensors(body, nav, vocab, know)
        self.action_names: tuple[str, ...] = tuple(ACTION_NAMES)
        self.action_space = spaces.Discrete(len(ACTION_NAMES))
        self.observation_space = observation_space(self.sensors, self.goal_text)
        self._builder = ObservationBuilder(know, vocab, self._bundle.detector_labels())
        self._env = make_environment(self._bundle, nav=nav, agent=body, **rendered_images(know))
        self._ts: Any = None
        self._rgb: np.ndarray | None = None
        self._next = 0
        self._panel: MapPanel | None = None

    @property
    def num_episodes(self) -> int:
        """Return the number of episodes in the bundle."""
        return len(self._bundle.episodes)

    def _pick(self, seeded: bool, options: dict | None) -> int:
        """Return the index of the next episode (see `episode_order`)."""
        eps = self._bundle.episodes
        want = (options or {}).get("episode")
        if want is not None:
            if isinstance(want, str):
                ids = [e.episode_id for e in eps]
                if want not in ids:
                    raise ValueError(f"no episode {want!r} in {self._bundle.root}")
                return ids.index(want)
            if not 0 <= int(want) < len(eps):
                raise ValueError(f"episode index {want} out of range (the bundle has {len(eps)})")
            return int(want)
        if self.episode_order == "random":
            return int(self.np_random.integers(len(eps)))
        if seeded:
            self._next = 0
        i, self._next = self._next, (self._next + 1) % len(eps)
        return i

    def _observe(self, ts: Any) -> dict[str, Any]:
        """Return the Gymnasium observation of a dm_control time step (the sealed evaluation's, within the space)."""
        o = self._builder(ts.observation, True)
        self._rgb = o["rgb"]
        return {k: o[k] for k in self.observation_space.spaces}

    def _info(self, last: bool, first: bool = False) -> dict[str, Any]:
        """Return ``info``: in evaluation mode only the renderer record (`first`: at reset); in training mode that, the
        generator's distance and the final metrics."""
        if not self.training:
            return {"render": dict(self.render_info)} if first else {}
        task = self._env.task
        info: dict[str, Any] = {"distance_to_goal": float(task.distance), "episode_id": task.episode.episode_id,
                                **({"render": dict(self.render_info)} if first else {})}
        if last:
            m = task.metrics()
            info.update({"success": float(m.success), "spl": float(m.spl), "soft_spl": float(m.soft_spl),
                         "is_success": bool(m.success)})
        return info

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode (chosen as `episode_order` says, or ``options["episode"]``); return (observation, info)."""
        super().reset(seed=seed)
        self._env.task.set_next_episode(self._pick(seed is not None, options))
        self._env.task.render_frames = True
        self._ts = self._env.reset()
        self._panel = None
        return self._observe(self._ts), self._info(False, first=True)

    def step(self, action: Any) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """Take one action (an index into `action_names`); return (observation, reward, terminated, truncated, info).

        The reward is 0.0 unless `training` (then the decrease of the geodesic distance to the nearest goal view
        point, m). ``terminated`` on STOP, ``truncated`` at the step limit; after either, `reset` comes next.
        """
        if self._ts is None or self._ts.last():
            raise RuntimeError("the episode has ended (or never started): call reset() first")
        a = int(np.asarray(action).reshape(()))
        if not 0 <= a < len(self.action_names):
            raise ValueError(f"action {action!r} is not one of 0..{len(self.action_names) - 1} ({', '.join(self.action_names)})")
        self._ts = ts = self._env.step(a)
        last = bool(ts.last())
        terminated = last and float(ts.discount) == 0.0
        reward = float(ts.reward or 0.0) if self.training else 0.0
        return self._observe(ts), reward, terminated, last and not terminated, self._info(last)

    def render(self) -> np.ndarray | None:
        """Return the agent's last view (H, W, 3) uint8 (``render_mode="rgb_array"``), with `render_map` beside the
        top-down map; None without a render mode."""
        if self.render_mode is None:
            return None
        if self._rgb is None:
            raise RuntimeError("nothing to render before reset()")
        if not self.render_map:
            return self._rgb.copy()
        task = self._env.task
        if self._panel is None:
            self._panel = MapPanel(task.navmap, task.episode, self._rgb.shape[0])
        return compose_frame(self._rgb, self._panel.draw(task.trajectory, task.state.yaw))

    def close(self) -> None:
        """Free the renderers (closing twice is fine)."""
        if getattr(self, "_env", None) is not None:
            self._env.task.close()


def register_envs() -> None:
    """Register ``sdovon_mj/ObjectNav-v0`` with Gymnasium (again: nothing happens). Importing this module does it."""
    if ENV_ID not in gymnasium.registry:
        gymnasium.register(ENV_ID, entry_point=f"{__name__}:ObjectNavEnv")


register_envs()

__all__ = ["ENV_ID", "ObjectNavEnv", "observation_space", "register_envs"]
