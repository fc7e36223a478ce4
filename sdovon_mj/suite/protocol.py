"""The agent protocol: what crosses between the evaluator and an evaluated agent, in one process or two.

The evaluator (`suite.evaluation`) keeps the environment, the bundle, physics, the task and every generator record;
it talks to the agent through a session with five calls, each answered by the agent:

    setup(sensors)            once: `observation.Sensors` (camera, actions, step limit, vocabulary)
    scene(SceneStart)         before a scene's first visit / episodes: its id and the declared oracle parts
    begin(Phase, obs)         a phase starts: "explore" (the first visit of a ``prior="scene"`` agent: no goal,
                              a declared step budget) or "episode"; the reply is the first action
    step(obs)                 the next observation; the reply is the next action
    end(obs)                  the phase is over (STOP or its step limit); the reply is the agent's info dict
    new_day()                 a lifelong evaluation (days of a home): the next day of the scene begins; the message
                              holds nothing but that fact (`NEW_DAY`, the same bytes whatever changed overnight)

Replies are JSON objects (``{"action": int, "frame": bool}``, ``{"info": {...}}``): the evaluator never unpickles
anything an agent sends. ``frame`` says whether the next observation needs images (the evaluator skips rendering
otherwise and sends blank frames). Observations are `observation.ObservationBuilder` dicts; no reward is ever sent.

Agent side, `AgentRunner` turns the messages into calls of the agent's methods (``setup``, ``explore``, ``reset``,
``act``, ``end``; see `nav.agents` and docs/evaluation.md) with dm_env time steps (``reward`` None) and an
`AgentView` (scene, phase, episode id, steps taken, step limit, intrinsics, the declared `OracleParts`). Two
transports carry the same messages to the same runner: `InProcessSession` (debugging, labelled in every table) and
`SealedSession` (the agent in its own process, `suite.agent_process`).
"""

from __future__ import annotations

import json
import math
import os
import pickle
import socket
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..actions import ACTION_NAMES
from ..errors import InputError, SdovonError
from ..knowledge import ORACLE_PARTS, Knowledge, KnowledgeError, check_word
from ..sim.frames import blank_image
from ..store import json_safe

PHASES = ("explore", "episode")
MODES = ("sealed", "in-process")
MAX_REPLY_BYTES = 4 << 20  # an agent's reply (JSON) larger than this is a protocol error


# The "new day" message of a lifelong evaluation: no content but the fact, so it is the same bytes whatever changed
# overnight (what moved, left or arrived is for the agent to find out).
NEW_DAY = pickle.dumps(("new_day",), protocol=4)

# Why an agent's session failed (`AgentError.cause`): recorded with the episode it failed in.
CAUSES = ("crash", "timeout", "protocol error")
# Default limits of a sealed agent (seconds; `--agent-timeout`, `--agent-setup-timeout`): its set-up (interpreter
# start, imports, building it, `setup(sensors)`: model weights load here) and any one reply. The built-in agents'
# slowest reply, the end of a first visit (ExtractPlanes over its frames), takes about a minute at 640x480 on a loaded
# 2-core machine; five times that leaves room for slower machines while a hung agent costs minutes, not an hour.
SETUP_TIMEOUT = 600.0
REPLY_TIMEOUT = 300.0


class AgentError(SdovonError):
    """The agent failed or broke the protocol: ``cause`` is one of `CAUSES` (its process died or it raised: crash;
    no complete reply within its limit: timeout; a reply out of protocol: protocol error)."""

    def __init__(self, message: str, cause: str = "crash") -> None:
        super().__init__(message)
        self.cause = cause if cause in CAUSES else "crash"


@dataclass(frozen=True)
class AgentSpec:
    """An agent named, not built: a plugin name or ``"module:Class"``, and the keyword arguments to build it with.

    The sealed evaluation builds it in the agent's own process, so the agent's code never runs in the evaluator's.
    ``paths``: folders to look for ``module`` in (besides the installed packages), e.g. a folder of test agents.
    """

    target: str
    kwargs: dict = field(default_factory=dict)
    paths: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        """Return a default label: the plugin name or the class name."""
        return self.target.rsplit(":", 1)[-1]


@dataclass(frozen=True)
class SceneStart:
    """A scene begins: its id and the scene-level oracle parts the agent declared (nothing else)."""

    scene: str
    oracle: dict = field(default_factory=dict)  # "navmap": [NavMap], "region_map": [RegionMap], "relevance", "instance_labels"


@dataclass(frozen=True)
class Phase:
    """A phase begins: a first visit ("explore": no goal) or an episode, with its step limit."""

    kind: str
    scene: str
    episode_id: str = ""
    episode_index: int = -1
    max_steps: int = 0
    oracle: dict = field(default_factory=dict)  # "view_points": (N, 3), "floor": int (declared oracles only)


class OracleParts:
    """The generator artefacts an agent declared (`Knowledge.oracle`), as the evaluator sent them; others raise."""

    def __init__(self, knowledge: Knowledge, scene: dict, episode: dict) -> None:
        self._knowledge = knowledge
        self._scene = scene
        self._episode = episode

    def _grant(self, part: str) -> None:
        if part not in self._knowledge.oracle:
            raise KnowledgeError(f"oracle part '{part}' is not declared in this agent's Knowledge.oracle "
                                 f"{self._knowledge.oracle} ({', '.join(ORACLE_PARTS)} are generator data)")

    @staticmethod
    def _floor(maps: list, floor: int) -> Any:
        return next((m for m in maps if m.floor == floor), maps[0] if maps else None)

    def floor_at(self, z: float) -> int:
        """Return the floor whose height is nearest to `z` (m): the index of its navigable and region maps."""
        if not {"navmap", "region_map"} & set(self._knowledge.oracle):
            self._grant("navmap")
        heights = self._scene.get("floor_heights") or {0: 0.0}
        return int(min(heights, key=lambda f: (abs(heights[f] - float(z)), f)))

    def navmap(self, floor: int = 0) -> Any:
        """Return the generator's navigable map of a floor."""
        self._grant("navmap")
        return self._floor(self._scene["navmap"], floor)

    def region_map(self, floor: int = 0) -> Any:
        """Return the generator's region map of a floor (None without one)."""
        self._grant("region_map")
        return self._floor(self._scene["region_map"], floor)

    @property
    def relevance(self) -> Any:
        """Return the relevance table that drove placement (None without one)."""
        self._grant("relevance")
        return self._scene["relevance"]

    def instance_labels(self) -> dict[int, str]:
        """Return scene instance id -> true label."""
        self._grant("instance_labels")
        return dict(self._scene["instance_labels"])

    def view_points(self) -> np.ndarray:
        """Return the current episode's goal view points (N, 3)."""
        self._grant("view_points")
        return np.asarray(self._episode["view_points"], float).reshape(-1, 3)

    def episode_floor(self) -> int:
        """Return the floor the current episode is on."""
        self._grant("view_points")
        return int(self._episode["floor"])


class AgentView:
    """What the agent knows of the phase it is in (agent side): scene, phase, episode, steps, limits, sensors."""

    def __init__(self, sensors: Any, scene: SceneStart, phase: Phase) -> None:
        self.sensors = sensors
        self.K = sensors.K
        self.agent = sensors.agent
        self.nav = sensors.nav
        self.scene = phase.scene
        self.phase = phase.kind
        self.episode_id = phase.episode_id
        self.episode_index = int(phase.episode_index)
        self.max_steps = int(phase.max_steps)
        self.steps = 0
        self._oracle = OracleParts(sensors.knowledge, scene.oracle if scene.scene == phase.scene else {}, phase.oracle)

    @property
    def oracle(self) -> OracleParts:
        """Return the declared generator artefacts (`KnowledgeError` for an agent that declared none)."""
        if not self._oracle._knowledge.is_oracle:
            raise KnowledgeError("this agent is not an oracle (Knowledge.oracle is empty): generator artefacts "
                                 f"({', '.join(ORACLE_PARTS)}) are out of its reach")
        return self._oracle


def opaque_token(key: str, kind: str, name: str) -> str:
    """Return the opaque id an agent gets for a scene or an episode (``kind``): a digest of the split's key (a secret
    split's salt digest, '' for an open split), the kind and the real id. Stable for the same split (a scene's token
    across its episodes and runs: an agent's memory of a scene works), and without the split's key it names nothing:
    an agent cannot look an episode up in a table it made."""
    import hashlib

    return hashlib.sha256(f"sdovon-mj/token/{key}/{kind}/{name}".encode("utf-8")).hexdigest()[:16]


def encode_reply(reply: dict) -> bytes:
    """Return an agent reply as JSON bytes (what travels from the agent to the evaluator)."""
    return json.dumps(json_safe(reply, str), allow_nan=False, separators=(",", ":")).encode("utf-8")


@dataclass(frozen=True)
class Reply:
    """An agent's answer to begin/step: the action and whether the next observation needs images."""

    action: int
    frame: bool


def decode_reply(data: bytes, expect: str) -> Any:
    """Parse and check an agent's JSON reply: a `Reply` for ``"action"``, the dict for ``"info"``/``"ok"``.

    Anything else (not JSON, too large, an action outside the action space, an ``error``) raises `AgentError`.
    """
    bad = "protocol error"
    if len(data) > MAX_REPLY_BYTES:
        raise AgentError(f"agent reply of {len(data)} bytes exceeds {MAX_REPLY_BYTES}", bad)
    try:
        d = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise AgentError(f"agent reply is not JSON ({e})", bad) from None
    if not isinstance(d, dict):
        raise AgentError(f"agent reply must be a JSON object, got {type(d).__name__}", bad)
    if "error" in d:
        raise AgentError(f"the agent raised: {str(d['error'])[-4000:]}", "crash")
    if expect == "action":
        a, f = d.get("action"), d.get("frame", True)
        if not isinstance(a, int) or isinstance(a, bool) or not 0 <= a < len(ACTION_NAMES):
            raise AgentError(f"agent action {a!r} is not one of 0..{len(ACTION_NAMES) - 1} ({', '.join(ACTION_NAMES)})", bad)
        if not isinstance(f, bool):
            raise AgentError(f"agent reply 'frame' must be true or false, got {f!r}", bad)
        return Reply(a, f)
    if expect == "info":
        info = d.get("info", {})
        if not isinstance(info, dict):
            raise AgentError(f"agent info must be a JSON object, got {type(info).__name__}", bad)
        return info
    return d


def knowledge_from_json(d: Any) -> Knowledge:
    """Return the `Knowledge` an agent declared in its JSON reply (AgentError, a protocol error, when malformed:
    every string is checked by `Knowledge` itself, so nothing an agent declares can add a line or a cell to a table)."""
    if not isinstance(d, dict):
        raise AgentError(f"agent knowledge must be a JSON object, got {d!r}"[:300], "protocol error")
    try:
        steps = d.get("explore_steps", 0)
        if not isinstance(steps, int) or isinstance(steps, bool):
            raise ValueError(f"explore_steps must be an integer, got {steps!r}")
        oracle = d.get("oracle", ())
        if not isinstance(oracle, (list, tuple)):
            raise ValueError(f"oracle must be a list, got {oracle!r}")
        return Knowledge(detector=d.get("detector", "gt"), pose=d.get("pose", "gps+compass"),
                         prior=d.get("prior", "none"), oracle=tuple(oracle), fn=d.get("fn", "-"), explore_steps=steps,
                         rgb=d.get("rgb", True))
    except (TypeError, ValueError) as e:
        raise AgentError(f"agent knowledge {d!r}: {e}"[:500], "protocol error") from None


def agent_name(hello: dict) -> str:
    """Return the name an agent declared (`knowledge.check_word`: a protocol error when it is no plain word)."""
    try:
        return check_word(hello.get("name", "agent"), "agent name")
    except ValueError as e:
        raise AgentError(str(e), "protocol error") from None


def knowledge_to_json(k: Knowledge) -> dict:
    """Return a `Knowledge` as JSON data."""
    return {"detector": k.detector, "pose": k.pose, "prior": k.prior, "oracle": list(k.oracle), "fn": k.fn,
            "explore_steps": int(k.explore_steps), "rgb": bool(k.rgb)}


# ------------------------------------------------------------------------------------------------
# Agent side


class AgentRunner:
    """Agent side of the protocol: turns messages into calls of the agent, and its answers into reply dicts."""

    def __init__(self, agent: Any) -> None:
        import dm_env

        self._dm_env = dm_env
        self.agent = agent
        self.sensors: Any = None
        self.scene = SceneStart("")
        self.view: AgentView | None = None

    def hello(self) -> dict:
        """Return the agent's declaration: name and knowledge."""
        from ..knowledge import knowledge_of

        return {"name": str(getattr(self.agent, "name", type(self.agent).__name__)),
                "knowledge": knowledge_to_json(knowledge_of(self.agent))}

    def _ts(self, kind: str, obs: dict) -> Any:
        st = {"first": self._dm_env.StepType.FIRST, "mid": self._dm_env.StepType.MID, "last": self._dm_env.StepType.LAST}[kind]
        return self._dm_env.TimeStep(st, None, None, obs)

    def _act(self, ts: Any) -> dict:
        a = self.agent.act(ts)
        return {"action": int(a), "frame": bool(getattr(self.agent, "wants_frame", True))}

    def handle(self, kind: str, *args: Any) -> dict:
        """Handle one message; return the reply dict."""
        agent = self.agent
        if kind == "setup":
            self.sensors = args[0]
            if hasattr(agent, "setup"):
                agent.setup(self.sensors)
            return {"ok": True}
        if kind == "scene":
            self.scene = args[0]
            return {"ok": True}
        if kind == "begin":
            phase, obs = args
            self.view = AgentView(self.sensors, self.scene, phase)
            ts = self._ts("first", obs)
            if phase.kind == "explore":
                agent.explore(self.view, ts)
            else:
                agent.reset(self.view, ts)
            return self._act(ts)
        if kind == "step":
            self.view.steps += 1
            return self._act(self._ts("mid", args[0]))
        if kind == "new_day":
            if hasattr(agent, "new_day"):
                agent.new_day()
            return {"ok": True}
        if kind == "end":
            self.view.steps += 1
            if hasattr(agent, "end"):
                agent.end(self.view, self._ts("last", args[0]))
            return {"info": dict(getattr(agent, "info", None) or {})}
        raise AgentError(f"unknown protocol message {kind!r}")


# ------------------------------------------------------------------------------------------------
# Evaluator side: two transports of the same messages


class InProcessSession:
    """The agent runs in the evaluator's process (debugging; labelled "in-process" in every table).

    Replies still travel as JSON, so an agent behaves and reports exactly as it would sealed; the file system is
    not sealed and nothing stops an in-process agent from reaching the evaluator's objects.
    """

    mode = "in-process"

    def __init__(self, agent: Any) -> None:
        import time

        from .landlock import Seal

        self._t0 = time.monotonic()
        self.setup_seconds = math.nan
        if isinstance(agent, AgentSpec):
            agent = build_agent(agent)
        self.runner = AgentRunner(agent)
        self.seal = Seal(False, 0, "the agent runs in the evaluator's process")
        hello = self._call("ok", self.runner.hello)
        self.name = agent_name(hello)
        self.knowledge = knowledge_from_json(hello.get("knowledge"))

    def _call(self, expect: str, fn: Any, *args: Any) -> Any:
        import traceback

        try:
            reply = fn(*args)
        except Exception as e:  # the agent's error, as a sealed session reports it (chained: the debugger sees it)
            raise AgentError(f"the agent raised: {traceback.format_exc(limit=20)[-4000:]}", "crash") from e
        return decode_reply(encode_reply(reply), expect)

    def setup(self, sensors: Any) -> None:
        """Send the sensors (no limit holds in this process; `setup_seconds` is measured)."""
        import time

        self._call("ok", self.runner.handle, "setup", sensors)
        self.setup_seconds = round(time.monotonic() - self._t0, 3)

    def scene(self, start: SceneStart) -> None:
        """Announce a scene."""
        self._call("ok", self.runner.handle, "scene", start)

    def begin(self, phase: Phase, obs: dict, rendered: bool = True) -> Reply:
        """Start a phase; return the first action."""
        return self._call("action", self.runner.handle, "begin", phase, obs)

    def step(self, obs: dict, rendered: bool = True) -> Reply:
        """Send an observation; return the next action."""
        return self._call("action", self.runner.handle, "step", obs)

    def end(self, obs: dict, rendered: bool = True) -> dict:
        """End the phase; return the agent's info."""
        return self._call("info", self.runner.handle, "end", obs)

    def new_day(self) -> None:
        """Announce the scene's next day (`NEW_DAY`: the message itself, unpickled as the agent's process would)."""
        self._call("ok", self.runner.handle, *pickle.loads(NEW_DAY))

    def close(self) -> None:
        """Nothing to free."""


def build_agent(spec: AgentSpec) -> Any:
    """Build an agent from its spec in this process (a plugin name, or ``module:Class`` importable here)."""
    if ":" in spec.target:
        import importlib

        mod, _, qual = spec.target.partition(":")
        for p in reversed(spec.paths):
            if p not in sys.path:
                sys.path.insert(0, p)
        obj: Any = importlib.import_module(mod)
        for part in qual.split("."):
            obj = getattr(obj, part)
        return obj(**spec.kwargs)
    from .. import plugins

    return plugins.load("agent", spec.target)(**spec.kwargs)


class FrameBuffer:
    """The frames of one observation in memory shared with the agent's process (rgb, depth, category image).

    A memfd (an unlinked temporary file where memfd is unavailable) of fixed layout, passed to the agent's process
    as an inherited file descriptor: no name on any file system. The evaluator writes each rendered frame; the
    agent copies it out when the observation's header says a frame was rendered, and gets the same read-only blank
    frames otherwise (allocating and filling 2 MB of blanks per step cost more than the rest of a step).
    """

    def __init__(self, width: int, height: int, fd: int | None = None) -> None:
        import mmap

        self.w, self.h = int(width), int(height)
        n = self.h * self.w
        self.layout = {"rgb": (0, (self.h, self.w, 3), np.uint8), "depth": (3 * n, (self.h, self.w, 1), np.float32),
                       "category": (7 * n, (self.h, self.w), np.int16)}
        self.size = 9 * n
        self.owner = fd is None
        if fd is None:
            if hasattr(os, "memfd_create"):
                fd = os.memfd_create("sdovon-frames", os.MFD_CLOEXEC)
            else:
                fd, path = tempfile.mkstemp(prefix="sdovon-frames-")
                os.unlink(path)
            os.ftruncate(fd, self.size)
        self.fd = fd
        self.mm = mmap.mmap(fd, self.size, access=mmap.ACCESS_WRITE if self.owner else mmap.ACCESS_READ)

    def _view(self, key: str) -> np.ndarray:
        off, shape, dt = self.layout[key]
        return np.ndarray(shape, dt, buffer=self.mm, offset=off)

    def write(self, obs: dict, rendered: bool) -> dict:
        """Write the observation's frames (when rendered); return the header to send (everything else)."""
        head = {k: v for k, v in obs.items() if k not in self.layout}
        head["_frame"] = bool(rendered)
        head["_keys"] = [k for k in self.layout if k in obs]
        if rendered:
            for k in head["_keys"]:
                self._view(k)[...] = np.asarray(obs[k]).reshape(self.layout[k][1])
        return head

    def read(self, head: dict, depth_min: float) -> dict:
        """Return the observation a header describes, its frames copied out (read-only blank frames when not rendered:
        black rgb, depth at the near limit, category -1, as the environment's blank frames)."""
        obs = {k: v for k, v in head.items() if not k.startswith("_")}
        for k in head["_keys"]:
            if head["_frame"]:
                obs[k] = self._view(k).copy()
                continue
            _off, shape, dt = self.layout[k]
            obs[k] = blank_image(shape, dt, 0 if k == "rgb" else depth_min if k == "depth" else -1)
        return obs

    def close(self) -> None:
        """Unmap and close."""
        self.mm.close()
        os.close(self.fd)


@dataclass(frozen=True)
class SealPlan:
    """What the agent's process may read and write once sealed, and the modules it loads from given locations."""

    read: tuple[str, ...]
    write: tuple[str, ...]
    modules: tuple[tuple[str, str, tuple[str, ...]], ...]  # (name, origin file, package search locations)
    seal: bool = True


def _protected_under(paths: list[str], protect: list[Path]) -> str:
    """Return the first allowed path that contains a protected one (the dataset, the results), else ''."""
    for p in paths:
        try:
            base = Path(p).resolve()
        except OSError:
            continue
        for q in protect:
            if q == base or base in q.parents:
                return f"{q} lies under the agent-readable {base}"
    return ""


def _refuse_inside(paths: tuple[str, ...], protect: list[Path]) -> None:
    """Raise `InputError` for a path the agent was to read (``--agent-read``, its module folders) that lies inside a
    protected folder (the dataset, the results): granting it would hand the agent the answers."""
    for p in paths:
        base = Path(p).resolve()
        for q in protect:
            if base == q or q in base.parents:
                raise InputError(p, f"lies inside {q} (the dataset or the results folder): a sealed agent may not "
                                    "read it")


def _module_location(name: str, paths: tuple[str, ...]) -> tuple[str, str, tuple[str, ...]] | None:
    """Return where a top-level module lives (without importing it): (name, origin, search locations)."""
    from importlib.machinery import PathFinder

    spec = PathFinder.find_spec(name, list(paths) + sys.path)
    if spec is None or not spec.origin or spec.origin in ("built-in", "frozen"):
        return None
    return (name, str(spec.origin), tuple(spec.submodule_search_locations or ()))


def _interpreter_paths(python: str) -> set[str]:
    """Return what another interpreter (an agent's own virtual environment) needs to read: its environment's folder
    (``pyvenv.cfg`` beside ``bin/``) and the base installation it names (``home``), without running it."""
    exe = Path(python).absolute()
    out = {str(exe.parent)}
    cfg = exe.parent.parent / "pyvenv.cfg"
    if cfg.is_file():
        out.add(str(cfg.parent))
        for line in cfg.read_text(encoding="utf-8", errors="replace").splitlines():
            key, _, value = line.partition("=")
            if key.strip() == "home" and value.strip():
                out.add(str(Path(value.strip()).parent))
    else:
        out.add(str(exe.parent.parent))
    return out


def seal_plan(spec: Any, scratch: Path, extra_read: tuple[str, ...] = (), protect: tuple[Path, ...] = (),
              python: str | None = None) -> tuple[SealPlan, str]:
    """Return the agent process's allow-list (and why it cannot seal, '' when it can).

    Read: the Python installation and site-packages (and those of `python`, the agent's own interpreter), system
    libraries and configuration (/usr, /lib, /etc), ``sdovon_mj``'s own folder, the folder (or file) of the agent's
    top-level module and the spec's ``paths``, the embedding cache (read only), its own /proc entries, /sys, and
    `extra_read`. Write: its scratch folder, /dev/null and GPU device files; not /dev/shm and no cache, so nothing
    it writes outlives it. When an allowed path holds a protected one (the dataset, the results folder), the file
    system cannot be sealed and the reason says so; a path it was asked to read (`extra_read`, the spec's
    ``paths``) that lies inside a protected one is refused (`InputError`).

    Parameters
    ----------
    spec : AgentSpec
        The agent (its top-level module's folder and its ``paths`` become readable).
    scratch : Path
        The agent's private scratch folder (its only writable folder).
    extra_read : tuple of str
        More files or folders the agent may read (``eval --agent-read``: its weights).
    protect : tuple of Path
        Folders the agent must not read (the dataset, the results folder).
    python : str, optional
        The agent's own interpreter (its installation and site-packages become readable); None: this one.
    """
    import site
    import sysconfig

    import sdovon_mj

    from .. import native
    from ..embeddings import embedding_cache_dir

    protected = [Path(p).resolve() for p in protect]
    _refuse_inside(tuple(extra_read) + (tuple(spec.paths) if isinstance(spec, AgentSpec) else ()), protected)
    read = {sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix, "/usr", "/lib", "/lib64", "/etc",
            "/bin", "/proc/self", "/proc/cpuinfo", "/proc/meminfo", "/proc/stat", "/proc/sys", "/sys",
            "/dev/urandom", "/dev/random", "/dev/zero"}
    read |= {p for p in site.getsitepackages() + [sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]]}
    read |= set(sdovon_mj.__path__) | set(extra_read)
    if python:
        read |= _interpreter_paths(python)
    modules = []
    if isinstance(spec, AgentSpec):
        top = spec.target.split(":")[0].split(".")[0] if ":" in spec.target else ""
        if not top:  # a plugin name: its entry point names the module
            from importlib.metadata import entry_points

            eps = [ep for ep in entry_points(group="sdovon_mj.agents") if ep.name == spec.target]
            top = eps[0].value.split(":")[0].split(".")[0] if eps else ""
        loc = _module_location(top, spec.paths) if top and top != "sdovon_mj" else None
        if loc is not None:
            modules.append(loc)
            read |= set(loc[2]) if loc[2] else {loc[1]}
        read |= set(spec.paths)  # folders the spec names for its modules: the agent's own code
    else:  # an agent object: its class's top-level module (already imported here)
        top = type(spec).__module__.split(".")[0]
        mod = sys.modules.get(top)
        if top != "sdovon_mj" and mod is not None and getattr(mod, "__file__", None):
            loc = (top, str(mod.__file__), tuple(getattr(mod, "__path__", ()) or ()))
            modules.append(loc)
            read |= set(loc[2]) if loc[2] else {loc[1]}
    write = {str(scratch), "/dev/null"}
    emb = embedding_cache_dir()
    if emb is not None:
        read.add(str(emb))  # read only: an agent's writes there would outlive it (and reach the next evaluation)
    if native.library() is not None:  # built here first: the sealed agent may load the compiled kernels, not write them
        read.add(str(native.library_dir()))
    for dev in ("/dev/dri", "/dev/nvidiactl", "/dev/nvidia0", "/dev/nvidia-uvm", "/dev/nvidia-uvm-tools"):
        if os.path.exists(dev):  # an agent on a GPU reaches its accelerator
            write.add(dev)
    why = _protected_under(sorted(read | write), protected)
    return SealPlan(tuple(sorted(read)), tuple(sorted(write)), tuple(modules)), why


def _child_env(scratch: Path) -> dict[str, str]:
    """Return the agent process's environment: a few variables of ours, HOME and TMPDIR in its scratch folder."""
    keep = ("PATH", "LANG", "LC_ALL", "MUJOCO_GL", "PYOPENGL_PLATFORM", "HF_HUB_OFFLINE", "TRANSFORMERS_OFFLINE",
            "TOKENIZERS_PARALLELISM", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "LP_NUM_THREADS",
            "SDOVON_CACHE", "SDOVON_NATIVE", "CUDA_VISIBLE_DEVICES", "NVIDIA_VISIBLE_DEVICES")
    env = {k: os.environ[k] for k in keep if k in os.environ}
    env.update(HOME=str(scratch), TMPDIR=str(scratch), PYTHONDONTWRITEBYTECODE="1")
    # the shared caches where the evaluator finds them (HOME moved): the sealed agent may read only its embeddings
    env.setdefault("SDOVON_CACHE", str(Path.home() / ".cache" / "sdovon-mj"))
    # glibc: keep freed frame copies (2.7 MB a step at 640x480) in the heap instead of unmapping them, so the next
    # copy reuses the pages rather than faulting fresh ones in
    env.setdefault("MALLOC_MMAP_THRESHOLD_", str(64 << 20))
    env.setdefault("MALLOC_TRIM_THRESHOLD_", str(256 << 20))
    return env


def _frame(data: bytes) -> bytes:
    """Return a message framed as ``multiprocessing.connection`` frames it (the agent's side reads it with one)."""
    import struct

    return (struct.pack("!i", len(data)) if len(data) <= 0x7FFFFFFF else struct.pack("!iQ", -1, len(data))) + data


class SealedSession:
    """The agent in its own process: the sealing launcher (`landlock.launch`), then a fresh interpreter
    (``python -I -m sdovon_mj.suite.agent_process``) that starts sealed.

    Handed only a socket and the frame buffer as inherited descriptors: no argument, path or object of the
    evaluator's. The evaluator pickles its messages (it trusts itself); it reads the agent's replies as JSON only,
    each within a deadline (the set-up's, then one per reply): a silent agent, or one that sends half a reply, ends
    in `AgentError` with cause "timeout" and its process group is killed. Where Landlock is unavailable the
    session's `seal` says why and the evaluation goes on.

    Parameters
    ----------
    agent : AgentSpec or agent object
        What to build in the agent's process (an object is pickled: its class must be importable there).
    width, height : int
        The camera's image size, pixels: the frame buffer's layout.
    seal : bool
        Seal the file system (default); False runs the agent's process unsealed (debugging).
    read : tuple of str
        More files and folders the agent may read (model weights, its own data); none may lie inside `protect`.
    protect : tuple of Path
        Folders no allowed path may contain (the dataset, the results): else the file system is not sealed.
    timeout : float
        Seconds the evaluator waits for one reply (`REPLY_TIMEOUT`).
    setup_timeout : float
        Seconds from the start of the agent's process to its answer to `setup` (`SETUP_TIMEOUT`).
    log : Path, optional
        File for the agent process's stdout and stderr (appended); None: an unnamed temporary file, its end quoted
        in errors.
    python : str, optional
        The agent's interpreter (its own virtual environment; default this one's).
    """

    mode = "sealed"

    def __init__(self, agent: Any, width: int, height: int, seal: bool = True, read: tuple[str, ...] = (),
                 protect: tuple[Path, ...] = (), timeout: float = REPLY_TIMEOUT, setup_timeout: float = SETUP_TIMEOUT,
                 log: Path | None = None, python: str | None = None) -> None:
        import time

        from . import landlock
        from .landlock import Seal

        self.timeout = float(timeout)
        self.setup_timeout = float(setup_timeout)
        self._t0 = time.monotonic()
        self.setup_seconds = math.nan
        self.proc: subprocess.Popen | None = None
        self.frames: FrameBuffer | None = None
        self.sock: socket.socket | None = None
        self.broken = False
        self.scratch = Path(tempfile.mkdtemp(prefix="sdovon-agent-"))
        if log is not None:
            Path(log).parent.mkdir(parents=True, exist_ok=True)
        self.log = open(log, "ab") if log is not None else tempfile.TemporaryFile()  # noqa: SIM115 - kept open
        try:
            self.frames = FrameBuffer(width, height)
            plan, why = seal_plan(agent, self.scratch, tuple(read), tuple(protect), python)
            ours, theirs = socket.socketpair()
            exe = python or sys.executable
            cmd = [exe, "-I", "-S", str(Path(landlock.__file__).resolve()), str(theirs.fileno()), str(self.frames.fd)]
            try:
                self.proc = subprocess.Popen(cmd, pass_fds=(theirs.fileno(), self.frames.fd), cwd=str(self.scratch),
                                             env=_child_env(self.scratch), stdin=subprocess.DEVNULL, stdout=self.log,
                                             stderr=subprocess.STDOUT, close_fds=True, start_new_session=True)
            finally:
                theirs.close()
            self.sock = ours
            deadline = self._t0 + self.setup_timeout
            want = bool(seal) and not why
            self._send_raw(json.dumps({"read": plan.read, "write": plan.write, "seal": want}).encode("utf-8"), deadline)
            got = self._recv("ok", deadline)
            sealed = bool(got.get("sealed"))
            reason = why or ("sealing was switched off" if not seal else str(got.get("reason", "")))
            self.seal = Seal(sealed, int(got.get("abi", 0) or 0), "" if sealed else reason)
            self._send_raw(pickle.dumps(("agent", pickle.dumps(agent), plan.modules)), deadline)
            hello = self._recv("ok", deadline)
            self.name = agent_name(hello)
            self.knowledge = knowledge_from_json(hello.get("knowledge"))
        except BaseException:
            self.broken = True
            self.close()
            raise

    def _fail(self, message: str, cause: str) -> AgentError:
        """Mark the session broken and return the error (with the end of the agent's log, where it has one)."""
        self.broken = True
        tail = ""
        try:
            self.log.flush()
            self.log.seek(max(0, self.log.seek(0, os.SEEK_END) - 2000))
            tail = self.log.read().decode("utf-8", "replace").strip()
        except (OSError, ValueError):
            pass
        return AgentError(message + (f"\n--- the agent's output ends:\n{tail}" if tail else ""), cause)

    def _deadline(self, deadline: float | None) -> float:
        import time

        return time.monotonic() + self.timeout if deadline is None else deadline

    def _send_raw(self, data: bytes, deadline: float | None = None) -> None:
        import time

        left = self._deadline(deadline) - time.monotonic()
        try:
            if left <= 0:
                raise TimeoutError
            self.sock.settimeout(left)
            self.sock.sendall(_frame(data))
        except (TimeoutError, socket.timeout):
            raise self._fail(f"the agent took no message within {self.timeout:.0f} s", "timeout") from None
        except OSError as e:
            code = self.proc.poll() if self.proc else None
            raise self._fail(f"the agent's process is gone (exit code {code}): {e}", "crash") from None

    def _read_exact(self, n: int, deadline: float) -> bytes:
        import time

        buf = bytearray()
        while len(buf) < n:
            left = deadline - time.monotonic()
            try:
                if left <= 0:
                    raise TimeoutError
                self.sock.settimeout(left)
                chunk = self.sock.recv(min(n - len(buf), 1 << 20))
            except (TimeoutError, socket.timeout):
                what = "a complete reply" if buf or n > 4 else "a reply"
                raise self._fail(f"the agent sent no {what} within its limit", "timeout") from None
            except OSError as e:
                chunk, err = b"", e
            else:
                err = None
            if not chunk:
                code = self.proc.wait(timeout=5) if self.proc else None
                raise self._fail(f"the agent's process ended (exit code {code}){': ' + str(err) if err else ''}",
                                 "crash")
            buf += chunk
        return bytes(buf)

    def _recv(self, expect: str, deadline: float | None = None) -> Any:
        """Read one reply (``multiprocessing.connection`` framing) before the deadline; decode and check it."""
        import struct

        deadline = self._deadline(deadline)
        (n,) = struct.unpack("!i", self._read_exact(4, deadline))
        if n == -1:
            (n,) = struct.unpack("!Q", self._read_exact(8, deadline))
        if n > MAX_REPLY_BYTES:
            raise self._fail(f"agent reply of {n} bytes exceeds {MAX_REPLY_BYTES}", "protocol error")
        try:
            return decode_reply(self._read_exact(n, deadline), expect)
        except AgentError as e:
            raise self._fail(str(e), e.cause) from None

    def _send(self, *msg: Any) -> None:
        self._send_raw(pickle.dumps(msg))

    def setup(self, sensors: Any) -> None:
        """Send the sensors; the answer ends the agent's set-up (`setup_seconds`), within its set-up limit."""
        import time

        self._send_raw(pickle.dumps(("setup", sensors)), self._t0 + self.setup_timeout)
        self._recv("ok", self._t0 + self.setup_timeout)
        self.setup_seconds = round(time.monotonic() - self._t0, 3)

    def scene(self, start: SceneStart) -> None:
        """Announce a scene."""
        self._send("scene", start)
        self._recv("ok")

    def begin(self, phase: Phase, obs: dict, rendered: bool = True) -> Reply:
        """Start a phase; return the first action."""
        self._send("begin", phase, self.frames.write(obs, rendered))
        return self._recv("action")

    def step(self, obs: dict, rendered: bool = True) -> Reply:
        """Send an observation; return the next action."""
        self._send("step", self.frames.write(obs, rendered))
        return self._recv("action")

    def end(self, obs: dict, rendered: bool = True) -> dict:
        """End the phase; return the agent's info."""
        self._send("end", self.frames.write(obs, rendered))
        return self._recv("info")

    def new_day(self) -> None:
        """Announce the scene's next day: the `NEW_DAY` bytes, nothing else."""
        self._send_raw(NEW_DAY)
        self._recv("ok")

    def close(self) -> None:
        """Stop the agent's process (its whole process group: whatever it started) and free the frame buffer, the
        scratch folder and the log."""
        import shutil
        import signal

        try:
            if self.proc is not None and self.proc.poll() is None:
                if not self.broken:
                    try:
                        self.sock.settimeout(1.0)
                        self.sock.sendall(_frame(pickle.dumps(("close",))))
                        self.proc.wait(timeout=5)
                    except (OSError, subprocess.TimeoutExpired):
                        pass
            if self.proc is not None:
                try:
                    os.killpg(self.proc.pid, signal.SIGKILL)  # its own session: the agent and its children
                except (ProcessLookupError, PermissionError):
                    pass
                self.proc.wait(timeout=10)
        finally:
            if self.sock is not None:
                self.sock.close()
            if self.frames is not None:
                self.frames.close()
                self.frames = None
            self.log.close()
            shutil.rmtree(self.scratch, ignore_errors=True)


__all__ = ["AgentError", "AgentRunner", "AgentSpec", "AgentView", "CAUSES", "FrameBuffer", "InProcessSession", "MODES", "NEW_DAY",
           "OracleParts", "PHASES", "Phase", "REPLY_TIMEOUT", "Reply", "SETUP_TIMEOUT", "SceneStart", "SealedSession",
           "agent_name", "decode_reply", "opaque_token", "encode_reply", "knowledge_from_json", "knowledge_to_json", "seal_plan"]
