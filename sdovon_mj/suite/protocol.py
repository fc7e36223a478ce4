"""The agent protocol: what crosses between the evaluator and an evaluated agent, in one process or two.

The evaluator (`suite.evaluation`) keeps the environment, the bundle, physics, the task and every generator record;
it talks to the agent through a session with five calls, each answered by the agent:

    setup(sensors)            once: `observation.Sensors` (camera, actions, step limit, vocabulary)
    scene(SceneStart)         before a scene's first visit / episodes: its id and the declared oracle parts
    begin(Phase, obs)         a phase starts: "explore" (the first visit of a ``prior="scene"`` agent: no goal,
                              a declared step budget) or "episode"; the reply is the first action
    step(obs)                 the next observation; the reply is the next action
    end(obs)                  the phase is over (STOP or its step limit); the reply is the agent's info dict

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
from ..errors import SdovonError
from ..knowledge import ORACLE_PARTS, Knowledge, KnowledgeError
from ..store import json_safe

PHASES = ("explore", "episode")
MODES = ("sealed", "in-process")
MAX_REPLY_BYTES = 4 << 20  # an agent's reply (JSON) larger than this is a protocol error


class AgentError(SdovonError):
    """The agent failed or broke the protocol (its process died, raised, answered out of protocol)."""


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
    if len(data) > MAX_REPLY_BYTES:
        raise AgentError(f"agent reply of {len(data)} bytes exceeds {MAX_REPLY_BYTES}")
    try:
        d = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise AgentError(f"agent reply is not JSON ({e})") from None
    if not isinstance(d, dict):
        raise AgentError(f"agent reply must be a JSON object, got {type(d).__name__}")
    if "error" in d:
        raise AgentError(f"the agent raised: {str(d['error'])[-4000:]}")
    if expect == "action":
        a, f = d.get("action"), d.get("frame", True)
        if not isinstance(a, int) or isinstance(a, bool) or not 0 <= a < len(ACTION_NAMES):
            raise AgentError(f"agent action {a!r} is not one of 0..{len(ACTION_NAMES) - 1} ({', '.join(ACTION_NAMES)})")
        if not isinstance(f, bool):
            raise AgentError(f"agent reply 'frame' must be true or false, got {f!r}")
        return Reply(a, f)
    if expect == "info":
        info = d.get("info", {})
        if not isinstance(info, dict):
            raise AgentError(f"agent info must be a JSON object, got {type(info).__name__}")
        return info
    return d


def knowledge_from_json(d: Any) -> Knowledge:
    """Return the `Knowledge` an agent declared in its JSON reply (AgentError when malformed)."""
    if not isinstance(d, dict):
        raise AgentError(f"agent knowledge must be a JSON object, got {d!r}")
    try:
        return Knowledge(detector=str(d.get("detector", "gt")), pose=str(d.get("pose", "gps+compass")),
                         prior=str(d.get("prior", "none")), oracle=tuple(str(x) for x in d.get("oracle", ())),
                         fn=str(d.get("fn", "-")), explore_steps=int(d.get("explore_steps", 0)))
    except (TypeError, ValueError) as e:
        raise AgentError(f"agent knowledge {d!r}: {e}") from None


def knowledge_to_json(k: Knowledge) -> dict:
    """Return a `Knowledge` as JSON data."""
    return {"detector": k.detector, "pose": k.pose, "prior": k.prior, "oracle": list(k.oracle), "fn": k.fn,
            "explore_steps": int(k.explore_steps)}


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
        from .landlock import Seal

        if isinstance(agent, AgentSpec):
            agent = build_agent(agent)
        self.runner = AgentRunner(agent)
        self.seal = Seal(False, 0, "the agent runs in the evaluator's process")
        hello = self._call("ok", self.runner.hello)
        self.name = str(hello.get("name", "agent"))
        self.knowledge = knowledge_from_json(hello.get("knowledge"))

    def _call(self, expect: str, fn: Any, *args: Any) -> Any:
        return decode_reply(encode_reply(fn(*args)), expect)

    def setup(self, sensors: Any) -> None:
        """Send the sensors."""
        self._call("ok", self.runner.handle, "setup", sensors)

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
        self._blank: dict[str, np.ndarray] = {}
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
            if k not in self._blank:
                _off, shape, dt = self.layout[k]
                blank = np.full(shape, 0 if k == "rgb" else depth_min if k == "depth" else -1, dt)
                blank.flags.writeable = False
                self._blank[k] = blank
            obs[k] = self._blank[k]
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


def _module_location(name: str, paths: tuple[str, ...]) -> tuple[str, str, tuple[str, ...]] | None:
    """Return where a top-level module lives (without importing it): (name, origin, search locations)."""
    from importlib.machinery import PathFinder

    spec = PathFinder.find_spec(name, list(paths) + sys.path)
    if spec is None or not spec.origin or spec.origin in ("built-in", "frozen"):
        return None
    return (name, str(spec.origin), tuple(spec.submodule_search_locations or ()))


def seal_plan(spec: Any, scratch: Path, extra_read: tuple[str, ...] = (), protect: tuple[Path, ...] = ()) -> tuple[SealPlan, str]:
    """Return the agent process's allow-list (and why it cannot seal, '' when it can).

    Read: the Python installation and site-packages, system libraries and configuration (/usr, /lib, /etc),
    ``sdovon_mj``'s own folder, the folder (or file) of the agent's top-level module and the spec's ``paths``, the
    shared embedding cache,
    its own /proc entries, /sys, and `extra_read`. Write: its scratch folder, /dev/shm, /dev/null, the embedding
    cache. When an allowed path holds a protected one (the dataset, the results folder), the file system cannot be
    sealed and the reason says so.
    """
    import site
    import sysconfig

    import sdovon_mj

    from ..embeddings import embedding_cache_dir

    read = {sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix, "/usr", "/lib", "/lib64", "/etc",
            "/bin", "/proc/self", "/proc/cpuinfo", "/proc/meminfo", "/proc/stat", "/proc/sys", "/sys",
            "/dev/urandom", "/dev/random", "/dev/zero"}
    read |= {p for p in site.getsitepackages() + [sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]]}
    read |= set(sdovon_mj.__path__) | set(extra_read)
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
    write = {str(scratch), "/dev/shm", "/dev/null"}
    emb = embedding_cache_dir()
    if emb is not None:
        try:
            emb.mkdir(parents=True, exist_ok=True)
            write.add(str(emb))
        except OSError:
            pass
    for dev in ("/dev/dri", "/dev/nvidiactl", "/dev/nvidia0", "/dev/nvidia-uvm", "/dev/nvidia-uvm-tools"):
        if os.path.exists(dev):  # an agent on a GPU reaches its accelerator
            write.add(dev)
    why = _protected_under(sorted(read | write), [Path(p).resolve() for p in protect])
    return SealPlan(tuple(sorted(read)), tuple(sorted(write)), tuple(modules)), why


def _child_env(scratch: Path) -> dict[str, str]:
    """Return the agent process's environment: a few variables of ours, HOME and TMPDIR in its scratch folder."""
    keep = ("PATH", "LANG", "LC_ALL", "MUJOCO_GL", "PYOPENGL_PLATFORM", "HF_HUB_OFFLINE", "TRANSFORMERS_OFFLINE",
            "TOKENIZERS_PARALLELISM", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "LP_NUM_THREADS",
            "SDOVON_CACHE", "CUDA_VISIBLE_DEVICES", "NVIDIA_VISIBLE_DEVICES")
    env = {k: os.environ[k] for k in keep if k in os.environ}
    env.update(HOME=str(scratch), TMPDIR=str(scratch), PYTHONDONTWRITEBYTECODE="1")
    # the shared caches where the evaluator finds them (HOME moved): the sealed agent may use only its embeddings
    env.setdefault("SDOVON_CACHE", str(Path.home() / ".cache" / "sdovon-mj"))
    # glibc: keep freed frame copies (2.7 MB a step at 640x480) in the heap instead of unmapping them, so the next
    # copy reuses the pages rather than faulting fresh ones in
    env.setdefault("MALLOC_MMAP_THRESHOLD_", str(64 << 20))
    env.setdefault("MALLOC_TRIM_THRESHOLD_", str(256 << 20))
    return env


class SealedSession:
    """The agent in its own process (a fresh interpreter, ``python -I -m sdovon_mj.suite.agent_process``).

    Handed only a socket and the frame buffer as inherited descriptors: no argument, path or object of the
    evaluator's. The evaluator pickles its messages (it trusts itself); it reads the agent's replies as JSON only.
    Before any agent code is imported, the process seals its file system with Landlock (`landlock.restrict`,
    `seal_plan`); where that is unavailable the session's `seal` says why and the evaluation goes on.

    Parameters
    ----------
    agent : AgentSpec or agent object
        What to build in the agent's process (an object is pickled: its class must be importable there).
    width, height : int
        The camera's image size, pixels: the frame buffer's layout.
    seal : bool
        Seal the file system (default); False runs the agent's process unsealed (debugging).
    read : tuple of str
        More files and folders the agent may read (model weights, its own data).
    protect : tuple of Path
        Folders no allowed path may contain (the dataset, the results): else the file system is not sealed.
    timeout : float
        Seconds the evaluator waits for one reply before it gives up on the agent.
    """

    mode = "sealed"

    def __init__(self, agent: Any, width: int, height: int, seal: bool = True, read: tuple[str, ...] = (),
                 protect: tuple[Path, ...] = (), timeout: float = 3600.0) -> None:
        from multiprocessing.connection import Connection

        from .landlock import Seal

        self.timeout = float(timeout)
        self.scratch = Path(tempfile.mkdtemp(prefix="sdovon-agent-"))
        self.frames = FrameBuffer(width, height)
        ours, theirs = socket.socketpair()
        cmd = [sys.executable, "-I", "-m", "sdovon_mj.suite.agent_process", str(theirs.fileno()), str(self.frames.fd)]
        try:
            self.proc = subprocess.Popen(cmd, pass_fds=(theirs.fileno(), self.frames.fd), cwd=str(self.scratch),
                                         env=_child_env(self.scratch), stdin=subprocess.DEVNULL, close_fds=True)
        finally:
            theirs.close()
        self.conn = Connection(ours.detach())
        try:
            plan, why = seal_plan(agent, self.scratch, tuple(read), tuple(protect))
            plan = SealPlan(plan.read, plan.write, plan.modules, seal=bool(seal) and not why)
            self.conn.send(("seal", plan))
            got = self._recv("ok")
            sealed = bool(got.get("sealed"))
            reason = why or ("sealing was switched off" if not seal else str(got.get("reason", "")))
            self.seal = Seal(sealed, int(got.get("abi", 0) or 0), "" if sealed else reason)
            self.conn.send(("agent", pickle.dumps(agent)))
            hello = self._recv("ok")
            self.name = str(hello.get("name", "agent"))
            self.knowledge = knowledge_from_json(hello.get("knowledge"))
        except BaseException:
            self.close()
            raise

    def _recv(self, expect: str) -> Any:
        if not self.conn.poll(self.timeout):
            self.close()
            raise AgentError(f"the agent did not answer within {self.timeout:.0f} s")
        try:
            data = self.conn.recv_bytes(MAX_REPLY_BYTES)
        except (EOFError, OSError) as e:
            code = self.proc.poll()
            raise AgentError(f"the agent's process ended (exit code {code}): {type(e).__name__}") from None
        return decode_reply(data, expect)

    def _send(self, *msg: Any) -> None:
        try:
            self.conn.send(msg)
        except (BrokenPipeError, ConnectionResetError, OSError) as e:
            raise AgentError(f"the agent's process is gone (exit code {self.proc.poll()}): {e}") from None

    def setup(self, sensors: Any) -> None:
        """Send the sensors."""
        self._send("setup", sensors)
        self._recv("ok")

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

    def close(self) -> None:
        """Stop the agent's process and free the frame buffer and scratch folder."""
        import shutil

        try:
            if self.proc.poll() is None:
                try:
                    self.conn.send(("close",))
                except OSError:
                    pass
                try:
                    self.proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait(timeout=5)
        finally:
            try:
                self.conn.close()
            except OSError:
                pass
            if self.frames is not None:
                self.frames.close()
                self.frames = None
            shutil.rmtree(self.scratch, ignore_errors=True)


__all__ = ["AgentError", "AgentRunner", "AgentSpec", "AgentView", "FrameBuffer", "InProcessSession", "MODES",
           "OracleParts", "PHASES", "Phase", "Reply", "SceneStart", "SealedSession", "decode_reply",
           "encode_reply", "knowledge_from_json", "knowledge_to_json", "seal_plan"]
