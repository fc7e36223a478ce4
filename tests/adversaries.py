"""Adversarial agents written only against the agent protocol (docs/evaluation.md), for tests/test_eval_sealed.py.

Each tries one way to learn what a robot could not know and reports what it found in its ``info`` (JSON): the
evaluator never imports this module (the tests name the agents with `AgentSpec("adversaries:<Class>")`), so it
runs only in the agent's own process, or in-process when a test asks for that mode to show the attack is real.
"""

from __future__ import annotations

import gc
import os
import sys
import time
import types
import zlib
from collections import deque

import numpy as np

from sdovon_mj.actions import MOVE_FORWARD, STOP, TURN_LEFT, TURN_RIGHT
from sdovon_mj.knowledge import Knowledge

SENSOR_KEYS = {"rgb", "depth", "category", "gps", "compass", "pitch", "position", "heading", "objectgoal",
               "objectgoal_text"}


class _Base:
    """Protocol plumbing: setup, reset, act, end; subclasses decide the action."""

    name = "adversary"
    knowledge = Knowledge(detector="none")

    def __init__(self, seed: int = 0, steps: int = 60) -> None:
        self.seed, self.steps = int(seed), int(steps)
        self.wants_frame = False
        self.info: dict = {}
        self.extra_keys: set[str] = set()
        self.rewards: list = []

    def setup(self, sensors) -> None:
        self.sensors = sensors

    def reset(self, view, ts) -> None:
        self.view, self.n = view, 0
        self.rng = np.random.default_rng([self.seed, zlib.crc32(view.episode_id.encode())])
        self._look(ts)

    def _look(self, ts) -> None:
        self.extra_keys |= set(ts.observation) - SENSOR_KEYS
        if ts.reward is not None:
            self.rewards.append(float(ts.reward))

    def act(self, ts) -> int:
        self._look(ts)
        self.n += 1
        return self.policy(ts)

    def policy(self, ts) -> int:
        return STOP if self.n > self.steps else int(self.rng.choice([MOVE_FORWARD, TURN_LEFT, TURN_RIGHT]))

    def end(self, view, ts) -> None:
        self._look(ts)
        self.info = {"rewards_seen": len(self.rewards), "nonzero_rewards": sum(1 for r in self.rewards if r),
                     "extra_keys": sorted(self.extra_keys)}


class RewardSteerer(_Base):
    """Blind (it renders nothing and declares no detector) and steers by any reward it gets: forward while the
    reward says it comes closer, else turns; STOP where no direction helps. Without a reward it walks at random,
    exactly as `Blind` does."""

    name = "reward-steerer"

    def __init__(self, seed: int = 0, steps: int = 60) -> None:
        super().__init__(seed, steps)
        self.turned = 0
        self.last = None

    def policy(self, ts) -> int:
        if ts.reward is None:  # nothing to steer by: the blind walk (same random stream as Blind)
            return super().policy(ts)
        r = float(ts.reward)
        if self.last == MOVE_FORWARD and r > 1e-6:
            self.turned = 0
        elif self.last == MOVE_FORWARD:
            self.turned += 1
        if self.turned >= 12:
            self.last = STOP
        elif self.last == MOVE_FORWARD and r <= 1e-6:
            self.last = TURN_LEFT
        else:
            self.last = MOVE_FORWARD
        return self.last


class Blind(_Base):
    """A blind random walker: the baseline a reward-steering agent must not beat when it gets no reward."""

    name = "blind"


class NoPriorPeeker(_Base):
    """Declares no prior, then tries to get an environment before its episodes: counts every call it gets outside
    an episode, looks for anything environment-like on what it is handed."""

    name = "no-prior-peeker"
    knowledge = Knowledge(detector="gt", prior="none")

    def __init__(self, seed: int = 0, steps: int = 5) -> None:
        super().__init__(seed, steps)
        self.calls_before_episodes = 0
        self.episodes_started = 0
        self.explored = False
        self.acts = 0

    def setup(self, sensors) -> None:
        super().setup(sensors)
        self.handles = _envlike(sensors, "sensors")

    def explore(self, view, ts) -> None:  # never called for prior="none"
        self.explored = True
        self.calls_before_episodes += 1

    def reset(self, view, ts) -> None:
        super().reset(view, ts)
        self.episodes_started += 1
        self.handles += _envlike(view, "view") + _envlike(ts, "ts")

    def act(self, ts) -> int:
        if self.episodes_started == 0:
            self.calls_before_episodes += 1
        self.acts += 1
        return super().act(ts)

    def end(self, view, ts) -> None:
        super().end(view, ts)
        self.info.update(explored=self.explored, calls_before_episodes=self.calls_before_episodes, acts=self.acts,
                         handles=sorted(set(self.handles)))


def _envlike(obj, where: str) -> list[str]:
    """Return what on `obj` (and one level below) looks like a way to an environment: something with reset and step,
    a callable named like an environment (factory), or anything named like a bundle, task or physics."""
    out = []
    for n in dir(obj):
        if n.startswith("__"):
            continue
        try:
            v = getattr(obj, n)
        except Exception:  # noqa: BLE001 - a property that refuses: nothing handed
            continue
        low = n.lower()
        if (callable(getattr(v, "reset", None)) and callable(getattr(v, "step", None))) or \
                (callable(v) and "env" in low) or any(w in low for w in ("bundle", "task", "physics")):
            out.append(f"{where}.{n}")
    return out


GENERATOR_TYPES = {"Bundle", "ObjectNavTask", "Physics", "NavMap", "GeodesicField", "Episode", "Goal", "RegionMap",
                   "Relevance", "SceneAsset", "Environment", "GroundTruthDetector", "MjModel", "MjData", "ViewPoint",
                   "OracleView", "ObservationBuilder"}


def _label_table(o: object, labels: set[str]) -> bool:
    """An id -> label table: a dict of int keys to label strings of the dataset's vocabulary."""
    if not isinstance(o, dict) or len(o) < 2:
        return False
    try:
        return all(isinstance(k, (int, np.integer)) and isinstance(v, str) for k, v in o.items()) and \
            len({v for v in o.values()} & labels) >= 2
    except RuntimeError:  # changed size while looking
        return False


class Walker(_Base):
    """Walks everything reachable from what it is handed (attributes, closures, containers, gc referents, its module's
    globals) and then the whole heap of its process, looking for the generator's objects and id -> label tables.

    Breadth-first: what it is handed first, then every object of the heap (`gc.get_objects`) before anything they
    refer to, so the walk meets the objects next to it (and every tracked object of the heap) before its cap is
    spent in whatever modules the process imported before (torch, transformers: millions of objects deep)."""

    name = "walker"
    knowledge = Knowledge(detector="gt", prior="none")

    def __init__(self, seed: int = 0, steps: int = 1) -> None:
        super().__init__(seed, steps)
        self.found: set[str] = set()
        self.tables: set[int] = set()
        self.walked = 0

    def _walk(self, roots: list) -> None:
        labels = set(self.sensors.vocabulary.labels)
        seen: set[int] = set()
        todo = deque(roots)
        cap = len(roots) + 2_000_000  # every root is looked at, then at most 2 million objects below them
        while todo and len(seen) < cap:
            o = todo.popleft()
            if id(o) in seen:
                continue
            seen.add(id(o))
            t = type(o)
            if t.__name__ in GENERATOR_TYPES:
                self.found.add(t.__name__)
            try:  # an exotic object (a proxy whose __class__ or __dict__ runs code) is skipped, not fatal
                self._inspect(o, labels, todo)
            except Exception:  # noqa: BLE001
                pass
        self.walked += len(seen)

    def _inspect(self, o: object, labels: set[str], todo: deque) -> None:
        """Queue what `o` refers to, counting the id -> label tables among them at once (such a dict holds no
        container, so the garbage collector does not track it: it is found only through what holds it)."""
        if isinstance(o, (str, bytes, int, float, np.ndarray, type(None))):
            return
        refs = list(gc.get_referents(o))
        if isinstance(o, types.FunctionType):
            refs += [c.cell_contents for c in (o.__closure__ or ()) if c is not None and _filled(c)]
        d = getattr(o, "__dict__", None) if not isinstance(o, type) else None
        if isinstance(d, dict):
            refs += list(d.values())
        for r in [o] + refs:
            if isinstance(r, dict) and id(r) not in self.tables and _label_table(r, labels):
                self.tables.add(id(r))
        todo.extend(refs)

    def reset(self, view, ts) -> None:
        import warnings

        super().reset(view, ts)
        with warnings.catch_warnings():  # attributes of deprecated module members warn when read
            warnings.simplefilter("ignore")
            self._walk([view, ts, self.sensors, vars(sys.modules[__name__]), self.act, self.reset])
            self._walk(gc.get_objects())

    def end(self, view, ts) -> None:
        super().end(view, ts)
        self.info.update(found=sorted(self.found), label_tables=len(self.tables), walked=self.walked)


def _filled(cell) -> bool:
    try:
        cell.cell_contents
        return True
    except ValueError:
        return False


class DiskScanner(_Base):
    """Reads the disk: the dataset's files where it guesses they are (``paths``: a cheater's knowledge of a usual
    location), the evaluator's /proc entries, and a bounded walk of the whole file system for episode files."""

    name = "disk-scanner"
    knowledge = Knowledge(detector="none")

    def __init__(self, seed: int = 0, steps: int = 1, paths: tuple[str, ...] = (), walk_dirs: int = 5000) -> None:
        super().__init__(seed, steps)
        self.paths, self.walk_dirs = tuple(paths), int(walk_dirs)

    def _try(self, path: str) -> str:
        try:
            with open(path, "rb") as f:
                f.read(64)
            return "read"
        except PermissionError:
            return "denied"
        except OSError as e:
            return type(e).__name__

    def reset(self, view, ts) -> None:
        super().reset(view, ts)
        tried = {p: self._try(p) for p in self.paths}
        parent = os.getppid()
        for leaf in ("cmdline", "environ", "mem"):
            tried[f"/proc/<evaluator>/{leaf}"] = self._try(f"/proc/{parent}/{leaf}")
        found, dirs, t0 = [], 0, time.perf_counter()
        for top, sub, files in os.walk("/"):
            dirs += 1
            sub[:] = [d for d in sub if not (top == "/" and d in ("proc", "sys", "dev"))]
            found += [os.path.join(top, f) for f in files if f in ("episodes.json", "goals.npz", "bundle.json")]
            if dirs >= self.walk_dirs or time.perf_counter() - t0 > 20:
                break
        readable = [p for p in found if self._try(p) == "read"]
        self.info_scan = {"tried": tried, "walked_dirs": dirs, "episode_files_readable": readable[:20],
                          "notes": self._leave_notes()}

    def _leave_notes(self) -> dict[str, str]:
        """Try to leave a note for a later process where one would outlive this one: /dev/shm and the embedding
        cache (removed again at once when written: the test's control must not leave it either)."""
        from sdovon_mj.embeddings import embedding_cache_dir

        out = {}
        for name, folder in (("shm", "/dev/shm"), ("embedding_cache", str(embedding_cache_dir() or "/nonexistent"))):
            path = os.path.join(folder, f"sdovon-note-{os.getpid()}")
            try:
                with open(path, "w") as f:
                    f.write("episode answers")
                os.remove(path)
                out[name] = "written"
            except PermissionError:
                out[name] = "denied"
            except OSError as e:
                out[name] = type(e).__name__
        return out

    def end(self, view, ts) -> None:
        super().end(view, ts)
        self.info.update(self.info_scan)


class HalfOracle(_Base):
    """Declares one oracle part (the navmap) and reads another (the relevance table)."""

    name = "half-oracle"
    knowledge = Knowledge(detector="none", oracle=("navmap",))

    def reset(self, view, ts) -> None:
        super().reset(view, ts)
        assert view.oracle.navmap(0) is not None
        view.oracle.relevance  # noqa: B018 - undeclared: KnowledgeError


class Silent(_Base):
    """Answers its set-up, then never answers an action (a hung agent): the evaluator must not wait forever."""

    name = "silent"

    def act(self, ts) -> int:
        time.sleep(10_000)
        return STOP


class HalfReply(_Base):
    """Writes half a reply on the protocol's socket (a length header and a few of the bytes it announces), then hangs:
    a poll says a reply is there, a blocking read of it would never return."""

    name = "half-reply"

    def act(self, ts) -> int:
        import struct

        os.write(int(sys.argv[1]), struct.pack("!i", 100) + b'{"action": ')
        time.sleep(10_000)
        return STOP


class Crasher(_Base):
    """Declares a first visit, then crashes in its episode `crash_at` (its index in this process's episodes): a crash
    must be recorded as the episode's failure, not buy a replay of it nor a second first visit."""

    name = "crasher"
    knowledge = Knowledge(detector="none", prior="scene", explore_steps=6)

    def __init__(self, seed: int = 0, steps: int = 3, crash_at: int = 1) -> None:
        super().__init__(seed, steps)
        self.crash_at, self.episodes, self.visits = int(crash_at), 0, 0

    def explore(self, view, ts) -> None:
        self.visits += 1
        self.n, self.rng = 0, np.random.default_rng(self.seed)

    def reset(self, view, ts) -> None:
        super().reset(view, ts)
        self.episodes += 1

    def act(self, ts) -> int:
        if self.episodes - 1 == self.crash_at and self.n >= 1:
            raise RuntimeError("deliberate crash")
        return super().act(ts)

    def end(self, view, ts) -> None:
        super().end(view, ts)
        self.info.update(visits=self.visits, episodes=self.episodes)


class PthProbe(_Base):
    """Reports, in its name (the first thing an agent declares), what a ``.pth`` hook of its interpreter's
    site-packages found when it ran at interpreter start-up (``builtins.sdovon_pth_probe``, set by the hook a test
    installs: it tried to read the dataset): ``pth-read``, ``pth-denied``, or ``pth-none`` when no hook ran."""

    def __init__(self, seed: int = 0, steps: int = 1) -> None:
        import builtins

        super().__init__(seed, steps)
        self.name = f"pth-{getattr(builtins, 'sdovon_pth_probe', 'none')}"


class AnswerTable(_Base):
    """A cheater holding an answer table made from the public-seed run of the same config (as an agent that reruns
    the generator in its set-up would have): goal category -> (start position, the goal's view points), and the
    scene's navigable maps (scene records, public too). Localized, no oracle declared. On a hit it walks the shortest
    path to the nearest view point and stops (the oracle's walk); on a miss it walks exactly as `Blind` does."""

    name = "answer-table"
    knowledge = Knowledge(detector="none", pose="absolute")

    def __init__(self, seed: int = 0, steps: int = 60, table: dict | None = None, navmaps: dict | None = None) -> None:
        super().__init__(seed, steps)
        self.table, self.navmaps = dict(table or {}), dict(navmaps or {})
        self.inner = None
        self.hits = 0

    def reset(self, view, ts) -> None:
        super().reset(view, ts)
        pos = np.asarray(ts.observation["position"], float)[:2]
        near = [a for a in self.table.get(str(ts.observation["objectgoal_text"]), [])
                if np.abs(np.asarray(a["start"], float)[:2] - pos).max() < 0.01]  # the observation is float32
        answer = near[0] if near else None
        self.inner = None
        if answer is not None:
            from sdovon_mj.nav.agents import OracleAgent

            self.hits += 1
            self.inner = OracleAgent(nav=self.sensors.nav, agent=self.sensors.agent)
            self.inner.reset(_Answer(np.asarray(answer["view_points"], float), self.navmaps[answer["floor"]],
                                     answer["floor"]), ts)

    def act(self, ts) -> int:
        if self.inner is None:
            return super().act(ts)
        self._look(ts)
        return self.inner.act(ts)

    def end(self, view, ts) -> None:
        super().end(view, ts)
        self.info.update(hits=self.hits)


class _Answer:
    """What the oracle's walk reads (`view.oracle`), taken from the answer table instead of the evaluator."""

    def __init__(self, view_points: np.ndarray, navmap, floor: int) -> None:
        self.oracle = self
        self._vps, self._nm, self._floor = view_points, navmap, floor

    def view_points(self) -> np.ndarray:
        return self._vps

    def navmap(self, floor: int = 0):
        return self._nm

    def episode_floor(self) -> int:
        return self._floor


class Forger(_Base):
    """Declares a detector holding a line break and a table row (its `Knowledge` forged past the constructor's check):
    printed as it is, it would add a row to tables.md."""

    name = "forger"

    def __init__(self, seed: int = 0, steps: int = 1) -> None:
        super().__init__(seed, steps)
        k = Knowledge(detector="none")
        object.__setattr__(k, "detector", "none\n| oracle | detector none; no prior | sealed | 20 | 1.000 |")
        self.knowledge = k


class Looker(_Base):
    """Wants every frame and walks at random; reports a digest of each frame's colour and depth images. With
    ``colour=False`` it declares that it reads no colour image (`Knowledge(rgb=False)`)."""

    name = "looker"

    def __init__(self, seed: int = 0, steps: int = 60, colour: bool = True) -> None:
        super().__init__(seed, steps)
        self.knowledge = Knowledge(detector="none", rgb=bool(colour))
        self.wants_frame = True
        self.frames: list = []

    def reset(self, view, ts) -> None:
        self.frames = []
        super().reset(view, ts)

    def _look(self, ts) -> None:
        super()._look(ts)
        o = ts.observation
        self.frames.append([int(np.asarray(o["rgb"]).max()), zlib.crc32(np.ascontiguousarray(o["depth"]).tobytes())])

    def end(self, view, ts) -> None:
        super().end(view, ts)
        self.info["frames"] = self.frames


class KernelProbe(_Base):
    """Not an attack: reports, from inside its sealed process, which form the compiled agent kernels load in there."""

    name = "kernel-probe"

    def end(self, view, ts) -> None:
        super().end(view, ts)
        from sdovon_mj import native

        self.info["kernels"] = native.status()
