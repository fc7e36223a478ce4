"""What an evaluated agent observes: the dataset's vocabulary, the sensors it is told about once, and its
observation dict, built from the environment's state within its declared `Knowledge`.

One home for the agent's view of the world, shared by the sealed evaluation (`suite.protocol`) and any other
front end (a Gymnasium environment builds its observations with `ObservationBuilder` too):

- `Vocabulary`: the dataset's goal categories, object categories and the labels of its category image, the same
  for every variant (recorded in the MJCF export's ``index.json``, ``vocabulary``; `dataset_vocabulary` reads it, or
  gathers it from the bundles of exports written before it was recorded).
- `Sensors`: sent to the agent once: image size, intrinsics, depth range, camera height, the action space and its
  step sizes, the step limit, the vocabulary and the knowledge granted.
- `ObservationBuilder`: the dm_control task's observation -> the agent's. Keys: ``rgb`` (H, W, 3) uint8,
  ``depth`` (H, W, 1) float32 metres clipped to the sensor range, ``gps`` (2,) and ``compass`` (1,) from the
  episode start (habitat-lab's convention), ``pitch`` (1,) rad, ``position`` (3,) / ``heading`` (1,) (the start
  frame, or the scene frame for ``pose="absolute"``), ``objectgoal`` (1,) int64 index into
  ``Vocabulary.goal_categories`` (-1 during a first visit) and ``objectgoal_text`` (str, "" during a first visit);
  with the ground-truth detector declared, ``category`` (H, W) int16: per pixel the index into
  ``Vocabulary.labels`` of what it shows, -1 for nothing labelled (Habitat's semantic sensor mapped to
  categories: no instance ids, no id -> label table). Never a reward.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from .. import native
from ..actions import ACTION_NAMES
from ..config import AgentConfig, NavConfig
from ..errors import InputError
from ..knowledge import Knowledge
from ..sim.camera import intrinsics
from ..sim.model import OBJECT_ID_BASE
from ..sim.frames import blank_image


@dataclass(frozen=True)
class Vocabulary:
    """The dataset's categories: goal categories (``objectgoal`` indexes them), category-image labels, and the object
    categories (every category of placed objects, goals included: what agents normalise relevance over)."""

    goal_categories: tuple[str, ...]
    labels: tuple[str, ...]
    object_categories: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.object_categories:  # a record without them: the goal categories
            object.__setattr__(self, "object_categories", tuple(self.goal_categories))

    def label_index(self) -> dict[str, int]:
        """Return label -> index into `labels`."""
        return {lab: i for i, lab in enumerate(self.labels)}

    def to_dict(self) -> dict[str, list[str]]:
        """Return the JSON form (``index.json``'s ``vocabulary``)."""
        return {"goal_categories": list(self.goal_categories), "labels": list(self.labels),
                "object_categories": list(self.object_categories)}

    @classmethod
    def from_dict(cls, d: dict, where: str | Path = "vocabulary") -> "Vocabulary":
        """Read the JSON form (InputError naming `where` when malformed)."""
        try:
            goals = tuple(str(x) for x in d["goal_categories"])
            labels = tuple(str(x) for x in d["labels"])
            objects = tuple(str(x) for x in d.get("object_categories", ()))
        except (KeyError, TypeError, AttributeError) as e:
            raise InputError(where, f"'vocabulary' needs lists 'goal_categories' and 'labels' ({e})") from None
        if any(len(set(x)) != len(x) for x in (goals, labels, objects)):
            raise InputError(where, "'vocabulary' lists a category twice")
        return cls(goals, labels, objects)

    @classmethod
    def of_bundles(cls, bundles: Iterable[Any]) -> "Vocabulary":
        """Return the union over loaded bundles: goal categories of their episodes, every label their detector names,
        the categories of their placed objects."""
        goals: set[str] = set()
        labels: set[str] = set()
        objects: set[str] = set()
        for b in bundles:
            goals |= {e.object_category for e in b.episodes}
            labels |= {lab for lab in b.detector_labels().values() if lab}
            objects |= {lab for lab in b.object_labels.values() if lab}
        return cls(tuple(sorted(goals)), tuple(sorted(labels | goals)), tuple(sorted(objects | goals)))


def dataset_vocabulary(root: str | Path | None, bundles: Iterable[Any] = ()) -> Vocabulary:
    """Return a dataset's vocabulary: ``index.json``'s ``vocabulary`` in the dataset folder `root`, else the union
    over every bundle under `root` (exports written before it was recorded, fixture datasets), else over the given
    loaded `bundles` (no common dataset folder)."""
    from .bundle import find_bundles, load_bundle

    if root is None:
        return Vocabulary.of_bundles(bundles)
    root = Path(root)
    idx = root / "index.json"
    if idx.is_file():
        try:
            meta = json.loads(idx.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as e:
            raise InputError(idx, f"not valid JSON ({e})") from None
        if isinstance(meta, dict) and isinstance(meta.get("vocabulary"), dict):
            return Vocabulary.from_dict(meta["vocabulary"], idx)
    given = {Path(b.root).resolve(): b for b in bundles}
    return Vocabulary.of_bundles(given.get(p.resolve()) or load_bundle(p) for p in find_bundles(root))


@dataclass(frozen=True)
class Sensors:
    """What an agent is told once, before anything else: its camera, the action space and the vocabulary."""

    width: int  # px
    height: int  # px
    hfov: float  # deg
    K: np.ndarray  # (3, 3) intrinsics
    depth_min: float  # m: depth is clipped to [depth_min, depth_max]
    depth_max: float  # m
    camera_height: float  # m above the floor
    eta: float  # the ground-truth detector's visibility threshold (pixel fraction)
    agent: AgentConfig  # the body and camera the environment simulates
    nav: NavConfig  # the environment's action sizes, step limit and success distance
    vocabulary: Vocabulary
    knowledge: Knowledge  # what the evaluator grants (the agent's own declaration)
    actions: tuple[str, ...] = ACTION_NAMES
    extras: dict = field(default_factory=dict)


def make_sensors(agent: AgentConfig, nav: NavConfig, vocabulary: Vocabulary, knowledge: Knowledge) -> Sensors:
    """Return the `Sensors` of an environment built with `agent` and `nav`."""
    return Sensors(int(agent.sensor_width), int(agent.sensor_height), float(agent.hfov),
                   intrinsics(agent.sensor_width, agent.sensor_height, agent.hfov), float(nav.depth_min),
                   float(nav.depth_max), float(agent.camera_height), float(agent.eta_gt), agent, nav, vocabulary, knowledge)


def rendered_images(knowledge: Knowledge) -> dict[str, bool]:
    """Return `make_environment`'s image arguments for an agent's declared knowledge: the segmentation behind the
    category image with the ground-truth detector, the colour image unless it reads none (`Knowledge.rgb`)."""
    return {"semantic": knowledge.detector == "gt", "rgb": bool(knowledge.rgb)}


class ObservationBuilder:
    """Build an agent's observation dict from the dm_control task's observation, within its declared knowledge.

    ``task_obs`` is `ObjectNavTask.get_observation`'s dict (rendered with ``semantic=True`` when the ground-truth
    detector is declared, ``pose_observations=True``). `segment_labels` maps the variant's segmentation ids (scene
    instances and placed objects, `Bundle.detector_labels`) to labels; it stays here, in the evaluator: the agent
    gets per-pixel indices into the dataset's `Vocabulary.labels` only.
    """

    def __init__(self, knowledge: Knowledge, vocabulary: Vocabulary, segment_labels: dict[int, str]) -> None:
        self.knowledge = knowledge
        self.vocabulary = vocabulary
        self.goal_index = {c: i for i, c in enumerate(vocabulary.goal_categories)}
        index = vocabulary.label_index()
        ids = {int(k): index[v] for k, v in segment_labels.items() if v in index}
        inst = [k for k in ids if 0 <= k < OBJECT_ID_BASE]
        objs = [k - OBJECT_ID_BASE for k in ids if k >= OBJECT_ID_BASE]
        self._inst_n = (max(inst) + 1) if inst else 0
        n_obj = (max(objs) + 1) if objs else 0
        # one table over compressed ids: [0, inst_n) scene instances, [inst_n, inst_n + n_obj) objects, then "none"
        self._lut = np.full(self._inst_n + n_obj + 1, -1, np.int16)
        for k, v in ids.items():
            self._lut[k if k < OBJECT_ID_BASE else self._inst_n + k - OBJECT_ID_BASE] = v

    @classmethod
    def for_bundle(cls, bundle: Any, knowledge: Knowledge, vocabulary: Vocabulary | None = None) -> "ObservationBuilder":
        """Return the builder of a loaded bundle (`Bundle`): its segment labels, the dataset's vocabulary (default:
        `dataset_vocabulary` of the folder the bundle sits in)."""
        vocab = vocabulary if vocabulary is not None else dataset_vocabulary(Path(bundle.root).parent, [bundle])
        return cls(knowledge, vocab, bundle.detector_labels())

    def category_image(self, segment_ids: np.ndarray) -> np.ndarray:
        """Return the (H, W) int16 category image of a segmentation-id image (-1: nothing labelled)."""
        lib = native.library()
        if lib is not None and isinstance(segment_ids, np.ndarray) and segment_ids.dtype == np.int32:
            s = np.ascontiguousarray(segment_ids)  # one compiled pass, the same rows of the table as below
            out = np.empty(s.shape, np.int16)
            lut = np.ascontiguousarray(self._lut, dtype=np.int16)
            lib.sdv_category(s.ctypes.data, s.size, self._inst_n, OBJECT_ID_BASE, lut.ctypes.data, len(lut),
                             out.ctypes.data)
            return out
        s = np.asarray(segment_ids, np.int64)
        none = len(self._lut) - 1
        key = np.where(s >= OBJECT_ID_BASE, s - OBJECT_ID_BASE + self._inst_n, s)
        key = np.where((s < 0) | (key >= none) | ((s < OBJECT_ID_BASE) & (s >= self._inst_n)), none, key)
        return self._lut[key]

    def __call__(self, task_obs: dict, rendered: bool = True) -> dict:
        """Return the agent's observation (see the module docstring for the keys)."""
        o = task_obs
        gps = np.asarray(o["gps"], np.float32).copy()
        compass = np.asarray(o["compass"], np.float32).copy()
        text = str(o["objectgoal_text"])
        out = {"rgb": o["rgb"], "depth": o["depth"], "gps": gps, "compass": compass,
               "pitch": np.asarray(o["pitch"], np.float32).copy(),
               "objectgoal": np.array([self.goal_index.get(text, -1)], np.int64), "objectgoal_text": text}
        if self.knowledge.pose == "absolute":
            out["position"] = np.asarray(o["position"], np.float32).copy()
            out["heading"] = np.asarray(o["heading"], np.float32).copy()
        else:
            out["position"] = np.array([gps[0], gps[1], 0.0], np.float32)
            out["heading"] = compass.copy()
        if self.knowledge.detector == "gt":
            seg = o.get("semantic")
            if seg is None or not rendered:
                out["category"] = blank_image(tuple(np.shape(o["depth"])[:2]), np.int16, -1)
            else:
                out["category"] = self.category_image(seg)
        return out


__all__ = ["ObservationBuilder", "Sensors", "Vocabulary", "dataset_vocabulary", "make_sensors", "rendered_images"]
