"""The data model every stage speaks: plain dataclasses + numpy, exact JSON / npz round trips.

Conventions (all records):
- Positions are MuJoCo world frame: metres, **Z up**. Frames of other simulators appear only
  inside exporters.
- Quaternions are **wxyz** (MuJoCo order).
- Camera poses ``T_cam`` are 4x4 world <- camera transforms in the **OpenCV** camera convention
  (x right, y down, z forward); ``K`` is the 3x3 pinhole intrinsic matrix.
- Path fields are POSIX strings relative to the root of the store (or output folder) the record
  was written into, so a run folder can be moved and two runs compare byte for byte.
- Polygons are (M, 2) arrays of world XY vertices in counter-clockwise order.

``to_dict`` / ``from_dict`` encode numpy arrays exactly (dtype, shape, raw bytes as base64), so a
JSON round trip reproduces every bit. ``save_npz`` / ``load_npz`` keep big arrays (observations)
uncompressed-exact in compressed npz shards.
"""

from __future__ import annotations

import base64
import dataclasses
import functools
import io
import json
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar, Union, get_args, get_origin, get_type_hints

import numpy as np

from .errors import SdovonError
from .store import dumps
from .geometry import polygon_area, quat_to_mat
from .grid import GridFrame, lookup

T = TypeVar("T", bound="Record")

_REGISTRY: dict[str, type["Record"]] = {}


class RecordError(SdovonError, ValueError):
    """A record file that cannot be read back (wrong kind, missing field, corrupt)."""


@functools.lru_cache(maxsize=None)
def _fields(cls: type) -> tuple[dataclasses.Field, ...]:
    """Return a record class's dataclass fields in declaration order (once per class)."""
    return dataclasses.fields(cls)


@functools.lru_cache(maxsize=None)
def _hints(cls: type) -> dict[str, Any]:
    """Return a record class's resolved type hints (once per class: decoding a run folder's records evaluated the
    string annotations again for every record). Callers read it, never change it."""
    return get_type_hints(cls)


def _encode(value: Any) -> Any:
    """Encode a field value as JSON-able data, arrays exactly."""
    if isinstance(value, Record):
        return value.to_dict()
    if isinstance(value, np.ndarray):
        arr = np.ascontiguousarray(value)
        return {
            "__ndarray__": base64.b64encode(arr.tobytes()).decode("ascii"),
            "dtype": arr.dtype.str,
            "shape": list(arr.shape),
        }
    if isinstance(value, (list, tuple)):
        return [_encode(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _encode(v) for k, v in value.items()}
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating,)):
        return float(value)
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, Path):
        return value.as_posix()
    return value


def _decode_array(data: dict[str, Any]) -> np.ndarray:
    """Decode an exactly encoded numpy array."""
    raw = base64.b64decode(data["__ndarray__"])
    return np.frombuffer(raw, dtype=np.dtype(data["dtype"])).reshape(data["shape"]).copy()


def _decode(value: Any, typ: Any) -> Any:
    """Decode JSON data into the declared field type."""
    if value is None:
        return None
    origin = get_origin(typ)
    if origin in (Union, types.UnionType):
        args = [a for a in get_args(typ) if a is not type(None)]
        if len(args) == 1:
            return _decode(value, args[0])
        if isinstance(value, dict) and "__ndarray__" in value:
            return _decode_array(value)
        return value
    if isinstance(value, dict) and "__ndarray__" in value:
        return _decode_array(value)
    if isinstance(typ, type) and issubclass(typ, Record):
        return typ.from_dict(value)
    if origin in (list, tuple):
        args = get_args(typ)
        inner = args[0] if args else Any
        items = [_decode(v, inner) for v in value]
        return items if origin is list else tuple(items)
    if origin is dict:
        _k, inner = get_args(typ)
        return {k: _decode(v, inner) for k, v in value.items()}
    if typ is np.ndarray:
        return np.asarray(value)
    return value


TAG = "__record__"  # the key naming a record's class in its dict form (fields may be called `kind`)


class Record:
    """Base of all records: exact dict/JSON round trips and a class tag.

    A record's tag in files is its class name, unless the class keeps an older one: a renamed class
    declares ``class NewName(Record, tag="OldName")`` so the files it writes keep their bytes and old
    run folders still load (the tag is a file-format name, stable across renames).
    """

    _tag: str = ""  # set per class by __init_subclass__

    def __init_subclass__(cls, tag: str | None = None, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls._tag = tag or cls.__name__
        other = _REGISTRY.get(cls._tag)
        if other is not None and other.__qualname__ != cls.__qualname__:
            raise TypeError(f"record tag {cls._tag!r} of {cls.__qualname__} is already {other.__qualname__}'s")
        _REGISTRY[cls._tag] = cls

    @classmethod
    def record_type(cls) -> str:
        """Return the record's type name (its tag in files)."""
        return cls._tag

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data (arrays encoded exactly)."""
        out: dict[str, Any] = {TAG: self.record_type()}
        for f in _fields(type(self)):
            out[f.name] = _encode(getattr(self, f.name))
        return out

    @classmethod
    def from_dict(cls: type[T], data: dict[str, Any]) -> T:
        """Rebuild a record from `to_dict` data."""
        if not isinstance(data, dict):
            raise RecordError(f"{cls.__name__}: expected a mapping, got {type(data).__name__}")
        kind = data.get(TAG, cls.record_type())
        if kind != cls.record_type():
            raise RecordError(f"expected a {cls.record_type()} record, found {kind}")
        hints = _hints(cls)
        kwargs = {}
        for f in _fields(cls):
            if f.name in data:
                kwargs[f.name] = _decode(data[f.name], hints[f.name])
            elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:  # type: ignore[misc]
                raise RecordError(f"{cls.__name__} record lacks field '{f.name}'")
        return cls(**kwargs)

    def to_json(self) -> str:
        """Return deterministic JSON text of the record."""
        return dumps(self.to_dict())

    @classmethod
    def from_json(cls: type[T], text: str) -> T:
        """Parse a record from JSON text."""
        return cls.from_dict(json.loads(text))


def record_from_dict(data: dict[str, Any]) -> Record:
    """Rebuild a record of any registered kind from `to_dict` data."""
    kind = data.get(TAG) if isinstance(data, dict) else None
    if kind not in _REGISTRY:
        raise RecordError(f"unknown record kind {kind!r}")
    return _REGISTRY[kind].from_dict(data)


def records_equal(a: Any, b: Any) -> bool:
    """Compare two records (or values) exactly, arrays bit for bit."""
    return dumps(_encode(a)) == dumps(_encode(b))


# ----------------------------------------------------------------------------------------------
# Assets


@dataclass
class Floor(Record):
    """One storey of a scene: its walkable height (world Z)."""

    index: int
    height: float
    area: float = 0.0


@dataclass
class SemanticInstance(Record):
    """An instance of the scene's own semantics (sidecar, HM3D txt, ScanNet aggregation)."""

    id: int
    label: str
    geoms: list[str] = field(default_factory=list)
    room: int = -1
    floor: int = -1
    kind: str = ""
    bounds: np.ndarray | None = None  # (2, 3) world min/max
    receptacle: bool | None = None  # the input forces (True) or forbids (False) it as a receptacle; None: labels decide

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data; `receptacle` only when set (records without it keep their bytes)."""
        out = super().to_dict()
        if self.receptacle is None:
            del out["receptacle"]
        return out


@dataclass
class Room(Record):
    """Ground-truth room of a generated world (for evaluating the semantics stage)."""

    id: int
    type: str
    floor: int
    polygon: np.ndarray  # (M, 2) CCW


@dataclass
class SupportSurface(Record):
    """Ground-truth horizontal support surface of a receptacle instance."""

    instance_id: int
    height: float
    polygon: np.ndarray  # (M, 2) CCW


@dataclass
class SceneAsset(Record):
    """A converted scene: visual-only MJCF plus what the input knew about it."""

    name: str
    mjcf: str
    source: str = ""
    license: str = ""
    floors: list[Floor] = field(default_factory=list)
    instances: list[SemanticInstance] = field(default_factory=list)
    bounds: np.ndarray | None = None  # (2, 3) world min/max
    rooms: list[Room] = field(default_factory=list)
    support_surfaces: list[SupportSurface] = field(default_factory=list)
    mesh: str = ""  # merged Z-up metre mesh of the whole scene (for ray casts, slicing)
    content_hash: str = ""
    articulated: list[ArticulatedFixture] = field(default_factory=list)  # omitted from the JSON when empty
    # What the input held that the conversion did not use (a texture it could not decode, an instance whose template
    # is missing, a sidecar it did not read...), one line each naming the file and why; printed at the end of a run.
    unused: list[str] = field(default_factory=list)  # omitted from the JSON when empty

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data; `articulated` and `unused` left out when empty (older bytes kept)."""
        out = super().to_dict()
        for key in ("articulated", "unused"):
            if not out.get(key, 1):
                del out[key]
        return out

    def instance(self, instance_id: int) -> SemanticInstance:
        """Return the semantic instance with this id."""
        for inst in self.instances:
            if inst.id == instance_id:
                return inst
        raise KeyError(f"scene {self.name} has no instance {instance_id}")


@dataclass
class ArticulatedPart(Record):
    """One movable part of an articulated object (a URDF revolute/continuous/prismatic joint) in its MJCF.

    `joint` and `body` are names in the object's model.xml (a composer's attach prefix goes in front);
    `kind` is "hinge" (range in radians) or "slide" (range in metres); `range` is None for an unlimited
    (continuous) hinge; `axis` is the joint axis in the frame of `body`; `link` the URDF child link's name.
    """

    joint: str
    kind: str  # hinge | slide
    range: tuple[float, float] | None
    body: str
    axis: tuple[float, float, float]
    link: str = ""


@dataclass
class InteriorSurface(Record):
    """A support surface inside an articulated scene fixture (a shelf, a drawer bottom, a cabinet floor).

    `height` (m, world Z) and the CCW `polygon` (N, 2, world XY) are taken with every part closed; `joint` is the
    scene joint that must open to reach it (None: reachable as is); `body` the scene body it moves with.
    """

    height: float
    polygon: np.ndarray
    joint: str | None
    body: str


@dataclass
class ArticulatedFixture(Record):
    """An articulated piece built into a converted scene (``world.articulated``): its bodies and joints are in the
    scene MJCF, its visual geoms named as scene instance `instance_id`'s (``inst_<id>_<j>``).

    `model` is the converted piece's model.xml (relative to the store root, like `SceneAsset.mjcf`), `position` (m)
    and `yaw` (degrees about +Z) its root frame in the world, `parts` its movable joints with scene names (``art_<id>/
    <joint>``), `interiors` its inside surfaces. A piece from a dataset (a Habitat articulated object instance) may
    stand at any orientation: `quat` (wxyz) is then its root frame's rotation and `yaw` only that frame's heading;
    `scale` is the uniform scale its URDF was converted at, beyond the URDF's own (both left out of the JSON at
    their defaults, None and 1).
    """

    instance_id: int
    label: str
    model: str
    position: np.ndarray
    yaw: float
    parts: list[ArticulatedPart] = field(default_factory=list)
    interiors: list[InteriorSurface] = field(default_factory=list)
    quat: np.ndarray | None = None
    scale: float = 1.0

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data; `quat` and `scale` only when set (our own pieces keep their bytes)."""
        out = super().to_dict()
        if self.quat is None:
            del out["quat"]
        if self.scale == 1.0:
            del out["scale"]
        return out

    def rotation(self) -> np.ndarray:
        """Return the 3x3 rotation of the root frame in the world (`quat`, else the yaw about +Z)."""
        if self.quat is not None:
            return quat_to_mat(np.asarray(self.quat, dtype=float))
        c, s = float(np.cos(np.radians(self.yaw))), float(np.sin(np.radians(self.yaw)))
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


OMIT_WHEN_NONE = ("parts", "semantic_id")  # ObjectAsset fields left out of the JSON when None (older bytes kept)


@dataclass
class ObjectAsset(Record):
    """A converted household object: MJCF with visual meshes and CoACD collision hulls.

    An articulated object (from URDF) lists its movable `parts`; `semantic_id` is a dataset's semantic
    class id when the input gave one (Habitat ``.ao_config.json``). Both are None for a rigid mesh object
    and then absent from the record's JSON.
    """

    name: str
    category: str
    mjcf: str
    bbox: np.ndarray  # (2, 3) min/max in the object frame (metres, Z up)
    mass: float
    hull_count: int
    volume: float = 0.0  # hull volume, m^3
    volume_ratio: float = 0.0  # hull volume / mesh volume
    source: str = ""
    license: str = ""
    content_hash: str = ""
    parts: list[ArticulatedPart] | None = None  # articulated objects only (omitted from JSON when None)
    semantic_id: int | None = None  # dataset semantic id when given (omitted from JSON when None)

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data; `parts` / `semantic_id` left out when None."""
        out = super().to_dict()
        for k in OMIT_WHEN_NONE:
            if out.get(k, 0) is None:
                del out[k]
        return out

    @property
    def footprint_radius(self) -> float:
        """Radius of the object's XY bounding circle about its origin."""
        lo, hi = np.asarray(self.bbox[0]), np.asarray(self.bbox[1])
        corners = np.array([[lo[0], lo[1]], [lo[0], hi[1]], [hi[0], lo[1]], [hi[0], hi[1]]])
        return float(np.linalg.norm(corners, axis=1).max())


# ----------------------------------------------------------------------------------------------
# Observation


@dataclass
class NavMap(Record):
    """Navigable top-down map of one floor. Cell (i, j) centre = origin + ((j+.5)*res, (i+.5)*res)."""

    floor: int
    height: float
    origin: np.ndarray  # (2,) world XY of the grid corner (row 0, col 0)
    resolution: float
    navigable: np.ndarray  # (H, W) bool, eroded by the agent radius
    free: np.ndarray  # (H, W) bool, floor present and no obstacle (not eroded)

    @property
    def frame(self) -> GridFrame:
        """Return the grid frame (grid <-> world conversion) of the map."""
        return GridFrame(np.asarray(self.origin, dtype=float), float(self.resolution), tuple(self.navigable.shape))

    def is_navigable(self, xy: np.ndarray) -> np.ndarray:
        """Return whether world XY points (N, 2) fall on navigable cells."""
        return lookup(self.navigable, self.frame, xy)


@dataclass
class CoverageCamera(Record, tag="Viewpoint"):  # tag: the files' name of this record before its renames
    """Where the observe stage put a camera to cover a floor (its frames sweep yaw and pitch from here); not an
    episode goal's `ViewPoint`, which is where an agent stands to see its goal."""

    floor: int
    position: np.ndarray  # (3,) world, camera height included


@dataclass
class Observation(Record):
    """One RGB-D(+segmentation) frame with its camera."""

    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray  # (H, W) float32 metres along the optical axis, 0 = invalid
    K: np.ndarray  # (3, 3)
    T_cam: np.ndarray  # (4, 4) world <- camera (OpenCV)
    segmentation: np.ndarray | None = None  # (H, W) int32 instance id, -1 = none
    view_id: int = 0
    viewpoint: int = 0
    yaw: float = 0.0  # deg
    pitch: float = 0.0  # deg


# ----------------------------------------------------------------------------------------------
# Perception


@dataclass
class Detection(Record):
    """A 2D instance in one image: mask, label, score."""

    mask: np.ndarray  # (H, W) bool
    label: str
    score: float
    view_id: int = 0
    gt_id: int = -1  # ground-truth instance id when known (gt detector)


@dataclass
class Instance(Record):
    """A fused 3D instance: centred points P, centre p, label l (paper equation 2)."""

    id: int
    label: str
    points: np.ndarray  # (N, 3) float32, centred
    center: np.ndarray  # (3,)
    confidences: list[float] = field(default_factory=list)
    source_views: list[int] = field(default_factory=list)
    gt_id: int = -1
    # (N,) float32 per point: the greatest height (m) of a camera centre that observed it above the point
    # (> 0: seen from above; an up-facing support surface can only be seen so); NaN: unknown; None: not
    # recorded (instances built elsewhere, files written before it existed)
    view_height: np.ndarray | None = None

    @property
    def world_points(self) -> np.ndarray:
        """Return the instance's points in world coordinates."""
        return np.asarray(self.points, dtype=float) + np.asarray(self.center, dtype=float)

    @property
    def bounds(self) -> np.ndarray:
        """Return the (2, 3) axis-aligned box of the world points."""
        p = self.world_points
        return np.stack([p.min(axis=0), p.max(axis=0)])


@dataclass
class ReceptaclePlane(Record):
    """A horizontal support plane of a receptacle instance."""

    id: int
    instance_id: int
    label: str
    height: float
    polygon: np.ndarray  # (M, 2) CCW world XY
    normal: np.ndarray  # (3,)
    region: str = ""
    floor: int = 0
    inliers: int = 0
    part: str | None = None  # the articulated part (scene joint) that closes over it; omitted from the JSON when None

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data; `part` left out when None (older bytes kept)."""
        out = super().to_dict()
        if out.get("part", 0) is None:
            del out["part"]
        return out

    @property
    def area(self) -> float:
        """Return the signed polygon area (m^2, positive when counter-clockwise)."""
        return polygon_area(self.polygon)


# ----------------------------------------------------------------------------------------------
# Semantics


@dataclass
class RegionMap(Record):
    """Dense region labels of one floor on a grid aligned with its NavMap."""

    floor: int
    origin: np.ndarray  # (2,)
    resolution: float
    labels: list[str]  # region vocabulary
    label_map: np.ndarray  # (H, W) int16 index into labels, -1 = unknown
    scores: np.ndarray  # (H, W, len(labels)) float32 aggregated proposal scores
    backend: str = ""  # backend (and model) that proposed the regions
    fallbacks: list[str] = field(default_factory=list)  # questions answered by the fallback backend, and why

    @property
    def frame(self) -> GridFrame:
        """Return the grid frame (grid <-> world conversion) of the map (aligned with its floor's NavMap)."""
        return GridFrame(np.asarray(self.origin, dtype=float), float(self.resolution), tuple(self.label_map.shape))

    def region_at(self, xy: np.ndarray) -> str:
        """Return the region label at a world XY point ('' if outside or unknown)."""
        frame = self.frame
        rc = frame.to_cell(np.asarray(xy, dtype=float)[None, :2])
        if frame.inside(rc)[0] and self.label_map[rc[0, 0], rc[0, 1]] >= 0:
            return self.labels[int(self.label_map[rc[0, 0], rc[0, 1]])]
        return ""


PAIR_MODEL_SOURCES = ("learned",)  # Relevance row sources whose p_pair is a model of the pair itself


@dataclass
class Relevance(Record):
    """P(obj|region) and P(obj|receptacle) tables, the pair model of both directions, and who produced them.

    ``p_pair[o, r, c]`` (when the backend has one) is the calibrated chance that a person calls
    receptacle c in region r a right place for object o: the *search* direction ranks the pairs of
    one object by it (`search`, `pair_score`: Semantic A*), the *placement* direction (`joint`) asks
    which categories belong at a pair more than elsewhere in the scene (Bayes' rule) when p_pair is a
    learned pair model, else normalises it over objects (the paper's eq. 5 for a product of answers).
    Without p_pair, both directions use P(obj|rgn) * P(obj|rec) (the paper's eq. 5). ``sources[o]``
    says what produced row o (``learned``, ``table``, ``embedding`` for a label the table lacks, a
    server backend's name, or
    ``fallback:<backend>`` when the server's answer failed and the fallback answered).
    """

    objects: list[str]
    regions: list[str]
    receptacles: list[str]
    p_obj_region: np.ndarray  # (O, R): column-normalised over objects
    p_obj_receptacle: np.ndarray  # (O, C)
    backend: str = "offline"
    model: str = ""
    fallbacks: list[str] = field(default_factory=list)
    p_pair: np.ndarray | None = None  # (O, R, C): P(pair right | object), 0-1, rows not normalised
    sources: list[str] = field(default_factory=list)  # (O,) what produced each object's row

    def has_pair_model(self) -> bool:
        """Return whether p_pair comes from a learned pair model for every row (sources all in PAIR_MODEL_SOURCES)."""
        return self.p_pair is not None and bool(self.sources) and all(s in PAIR_MODEL_SOURCES for s in self.sources)

    def _pair_index(self, region: str, receptacle: str) -> tuple[int | None, int | None]:
        r = self.regions.index(region) if region in self.regions else None
        c = self.receptacles.index(receptacle) if receptacle in self.receptacles else None
        return r, c

    def joint(self, region: str, receptacle: str,
              pairs: list[tuple[str, str]] | None = None) -> np.ndarray:
        """Return the placement-direction relevance of every object for one (region, receptacle).

        With a learned pair model (every row's source ``learned``), which categories belong here more
        than elsewhere (Bayes' rule, a uniform prior over categories): a person putting object o
        somewhere in the scene picks a place q among the scene's pairs in proportion to how right it is,
        P(q | o) = p_pair[o, q] / sum_q' p_pair[o, q'], and P(o | q) = P(q | o) / sum_o' P(q | o'). An
        object that fits every place alike (a popular one) puts 1/len(pairs) of its weight here, one
        that fits only here all of it. `pairs` are the (region, receptacle) pairs the scene offers (its
        planes'; the queried pair is always one); default: every region x receptacle of this record;
        pairs this record does not know are left out. Otherwise the paper's eq. 5 (without its typo),
        `pairs` unused: p_pair (the product of a backend's two answers) normalised over objects, or
        without p_pair P(obj|rgn) * P(obj|rec). An unknown region or receptacle counts as uniform.
        """
        r, c = self._pair_index(region, receptacle)
        n = len(self.objects)
        if self.p_pair is not None and r is not None and c is not None and not self.has_pair_model():
            col = np.asarray(self.p_pair[:, r, c], dtype=float)
            tot = float(col.sum())
            return col / tot if tot > 0 else np.full(n, 1.0 / max(n, 1))
        if self.p_pair is not None and r is not None and c is not None:
            pp = np.asarray(self.p_pair, dtype=float)
            if pairs is None:
                where = {(a, b) for a in range(len(self.regions)) for b in range(len(self.receptacles))}
            else:
                where = {self._pair_index(rg, rc) for rg, rc in pairs}
                where = {(a, b) for a, b in where if a is not None and b is not None} | {(r, c)}
            rows = np.array([pp[:, a, b] for a, b in sorted(where)]).sum(axis=0)  # (O,) sum over the scene's pairs
            here = pp[:, r, c]
            p_q_o = np.where(rows > 0, here / np.where(rows > 0, rows, 1.0), 1.0 / len(where))
            tot = float(p_q_o.sum())
            return p_q_o / tot if tot > 0 else np.full(n, 1.0 / max(n, 1))
        pr = self.p_obj_region[:, r] if r is not None else np.full(n, 1.0 / max(n, 1))
        pc = self.p_obj_receptacle[:, c] if c is not None else np.full(n, 1.0 / max(n, 1))
        return np.asarray(pr, dtype=float) * np.asarray(pc, dtype=float)

    def pair_score(self, obj: str, region: str, receptacle: str) -> float:
        """Return the search-direction score of one (region, receptacle) for an object (higher: look there first).

        With a pair model: p_pair (comparable across pairs of one object); else the object's row
        of P(obj|rgn) * P(obj|rec). Unknown regions or receptacles score by their known part only.
        """
        i = self.objects.index(obj)
        r, c = self._pair_index(region, receptacle)
        if self.p_pair is not None and r is not None and c is not None:
            return float(self.p_pair[i, r, c])
        pr = float(self.p_obj_region[i, r]) if r is not None else 1.0
        pc = float(self.p_obj_receptacle[i, c]) if c is not None else 1.0
        return pr * pc

    def search(self, obj: str) -> list[tuple[str, str, float]]:
        """Return every (region, receptacle, score) for an object, best place to look first."""
        out = [(r, c, self.pair_score(obj, r, c)) for r in self.regions for c in self.receptacles]
        return sorted(out, key=lambda t: (-t[2], t[0], t[1]))

    def plane_relevance(self, category: str, planes: list["ReceptaclePlane"],
                        pairs: list[tuple[str, str]] | None = None) -> np.ndarray:
        """Return each plane's relevance for one object category in the placement direction: `joint` at the plane's
        (region, receptacle) among `pairs` (default: the planes' own pairs), negative values as 0; ones for a
        category this record does not know. The moves of a chain of days are drawn by it and their statistics
        compare with it (`sdovon_mj.place.days`, `sdovon_mj.stats.day_statistics`)."""
        if category not in self.objects:
            return np.ones(len(planes))
        pairs = sorted({(p.region, p.label) for p in planes}) if pairs is None else pairs
        i = self.objects.index(category)
        at = {q: max(float(self.joint(q[0], q[1], pairs)[i]), 0.0) for q in sorted({(p.region, p.label) for p in planes})}
        return np.array([at[(p.region, p.label)] for p in planes])

    def top_pairs(self, pairs: list[tuple[str, str]], k: int) -> dict[str, set[tuple[str, str]]]:
        """Return, per object, the k of a scene's (region, receptacle) pairs where it belongs most.

        "Most" in the placement direction: the k pairs where the object takes the largest share of `joint`
        over the scene's `pairs` (ties by region, then receptacle name). Placement keeps a category to these
        pairs (``place.top_pairs``) and the placement statistics count a placed object on them as a hit
        (`sdovon_mj.stats.placement_top_pairs`): one definition for both.
        """
        pairs = sorted(set(pairs))
        joints = {q: self.joint(q[0], q[1], pairs) for q in pairs}
        return {o: {(r, c) for _s, r, c in sorted((-float(joints[(r, c)][i]), r, c) for r, c in pairs)[:k]}
                for i, o in enumerate(self.objects)}


# ----------------------------------------------------------------------------------------------
# Placement


@dataclass
class Placement(Record):
    """One placed object: what, where it was meant to go, where it came to rest."""

    object_id: str  # unique within the variant, e.g. "obj_003"
    asset: str  # ObjectAsset name
    category: str
    plane_id: int
    receptacle_instance: int
    region: str
    spawn_pos: np.ndarray  # (3,)
    spawn_quat: np.ndarray  # (4,) wxyz
    settled_pos: np.ndarray | None = None
    settled_quat: np.ndarray | None = None
    status: str = "pending"  # resting | resting_elsewhere | fell | unstable | dropped
    reason: str = ""
    attempts: int = 1
    part: str | None = None  # inside an articulated piece: the part (scene joint) closing over it; omitted when None

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data; `part` left out when None (older bytes kept)."""
        out = super().to_dict()
        if out.get("part", 0) is None:
            del out["part"]
        return out


@dataclass
class SceneVariant(Record):
    """A scene with settled objects."""

    scene: str
    index: int
    seed: int
    placements: list[Placement] = field(default_factory=list)
    qpos: np.ndarray | None = None
    mjcf: str = ""  # composed MJCF (scene + support + objects), relative path
    notes: list[str] = field(default_factory=list)
    articulation: dict[str, float] | None = None  # articulated part joint -> position (rad / m); omitted when None
    day: int | None = None  # a day of the scene's chain of days (place.days): its index; omitted when None

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data; `articulation` and `day` left out when None (older bytes kept)."""
        out = super().to_dict()
        for key in ("articulation", "day"):
            if out.get(key, 0) is None:
                del out[key]
        return out

    @property
    def name(self) -> str:
        """Return the variant's name, e.g. 'apt_0000_v002' ('apt_0000_d002' for day 2 of the scene's chain)."""
        return f"{self.scene}_v{self.index:03d}" if self.day is None else day_name(self.scene, self.day)

    @property
    def resting(self) -> list[Placement]:
        """Return the placements that came to rest on their intended plane."""
        return [p for p in self.placements if p.status == "resting"]


def day_name(scene: str, day: int) -> str:
    """Return the name of day `day` of a scene's chain, e.g. 'apt_0000_d002' (a variant's name on that day)."""
    return f"{scene}_d{day:03d}"


# A goal's history on its day (`Goal.history`): where the object was the day before.
UNMOVED, MOVED, NEW = "unmoved", "moved", "new"


@dataclass
class DayMove(Record):
    """One object that moved overnight: from which receptacle plane (region, label) to which."""

    object_id: str
    category: str
    from_plane: int
    to_plane: int
    from_receptacle: str
    to_receptacle: str
    from_region: str
    to_region: str


@dataclass
class DayChange(Record):
    """What changed from the day before in a scene's chain of days (day 0: everything arrived).

    The lists are the habit model's draws (`sdovon_mj.place.days`), each object once: `stayed`, `moved`, `left`,
    `arrived`. `dropped`: drawn objects that did not come to rest on their plane (object id -> why; absent that day
    and after). `resettled`: objects that stayed but that settling moved (object id -> metres their position moved).
    `rates`: the overnight probabilities each present object was drawn with (object id -> [move, leave]) and
    `arrive_rate` the arrivals' (per object present the day before), so statistics can compare draws with the config.
    """

    scene: str
    day: int
    stayed: list[str] = field(default_factory=list)
    moved: list[DayMove] = field(default_factory=list)
    left: list[str] = field(default_factory=list)
    arrived: list[str] = field(default_factory=list)
    dropped: dict[str, str] = field(default_factory=dict)
    resettled: dict[str, float] = field(default_factory=dict)
    rates: dict[str, list[float]] = field(default_factory=dict)
    arrive_rate: float = 0.0
    previous: int = 0  # objects present (resting) the day before
    next_object: int = 0  # the number of the next new object (``obj_<n>``: ids are never reused in a chain)

    def history(self, object_id: str) -> str:
        """Return an object's history on this day: `UNMOVED`, `MOVED` or `NEW`."""
        if object_id in self.arrived or self.day == 0:
            return NEW
        return MOVED if any(m.object_id == object_id for m in self.moved) else UNMOVED


# ----------------------------------------------------------------------------------------------
# Episodes


@dataclass
class ViewPoint(Record):
    """An episode goal's view point (habitat-lab's ``view_points``): where an agent stands, base on the floor, and its
    camera orientation to see the goal; not the observe stage's `CoverageCamera`."""

    position: np.ndarray  # (3,) agent base on the floor
    rotation: np.ndarray  # (4,) wxyz yaw about +Z
    visible_fraction: float = 0.0


@dataclass
class Goal(Record):
    """A goal object instance with its view points."""

    object_id: str
    category: str
    position: np.ndarray  # (3,)
    view_points: list[ViewPoint] = field(default_factory=list)
    bounds: np.ndarray | None = None  # (2, 3)
    open_part: str | None = None  # hidden in a closed articulated part: the joint to open (view points with it open)
    history: str | None = None  # on a day of a chain: unmoved / moved / new since the day before; omitted when None

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data; `open_part` and `history` left out when None (older bytes kept)."""
        out = super().to_dict()
        for key in ("open_part", "history"):
            if out.get(key, 0) is None:
                del out[key]
        return out


@dataclass
class Episode(Record):
    """An ObjectNav episode."""

    episode_id: str
    scene: str
    variant: str
    object_category: str
    start_position: np.ndarray  # (3,) on the floor
    start_rotation: np.ndarray  # (4,) wxyz
    goals: list[Goal] = field(default_factory=list)
    geodesic_distance: float = 0.0
    euclidean_distance: float = 0.0
    closest_goal_object_id: str = ""
    floor: int = 0
    # The Habitat-style start filters this start passed (episodes.min/max_start_distance, start_ratio_threshold)
    # and its geodesic / Euclidean ratio to the nearest view point.
    start_filters: dict[str, float] = field(default_factory=dict)
    day: int | None = None  # an episode of a day of a chain (place.days): the day; omitted when None

    def to_dict(self) -> dict[str, Any]:
        """Return the record as JSON-able data; `day` left out when None (older bytes kept)."""
        out = super().to_dict()
        if out.get("day", 0) is None:
            del out["day"]
        return out


# ----------------------------------------------------------------------------------------------
# Files


def save_json(record_or_records: Record | list[Record], path: str | Path) -> None:
    """Write a record (or a list of records) as deterministic JSON, atomically."""
    from .store import atomic_write_text

    data = _encode(record_or_records)
    atomic_write_text(Path(path), dumps(data))


def load_json(path: str | Path, cls: type[T] | None = None) -> Any:
    """Read a record (or a list of records) written by `save_json`."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise RecordError(f"{path}: not a valid record file ({e})") from None
    try:
        if isinstance(data, list):
            return [cls.from_dict(d) if cls else record_from_dict(d) for d in data]
        return cls.from_dict(data) if cls else record_from_dict(data)
    except (RecordError, KeyError, TypeError, ValueError) as e:
        raise RecordError(f"{path}: {e}") from None


def save_npz(records: list[Record], path: str | Path) -> None:
    """Write records with big arrays as one compressed npz shard (exact), atomically."""
    from .store import atomic_write_bytes

    arrays: dict[str, np.ndarray] = {}
    meta = []
    for i, rec in enumerate(records):
        d = {TAG: rec.record_type()}
        for f in dataclasses.fields(rec):  # type: ignore[arg-type]
            v = getattr(rec, f.name)
            if isinstance(v, np.ndarray):
                key = f"{i}/{f.name}"
                arrays[key] = v
                d[f.name] = {"__npz__": key}
            else:
                d[f.name] = _encode(v)
        meta.append(d)
    arrays["__meta__"] = np.frombuffer(dumps(meta).encode("utf-8"), dtype=np.uint8)
    buf = io.BytesIO()
    _savez_deterministic(buf, arrays)
    atomic_write_bytes(Path(path), buf.getvalue())


def _savez_deterministic(fileobj: io.BytesIO, arrays: dict[str, np.ndarray]) -> None:
    """np.savez_compressed with fixed zip timestamps, so equal arrays give equal bytes."""
    import zipfile

    with zipfile.ZipFile(fileobj, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for key in sorted(arrays):
            info = zipfile.ZipInfo(key + ".npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            b = io.BytesIO()
            np.lib.format.write_array(b, np.asanyarray(arrays[key]), allow_pickle=False)
            zf.writestr(info, b.getvalue())


def load_npz(path: str | Path) -> list[Record]:
    """Read records written by `save_npz`."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(bytes(z["__meta__"]).decode("utf-8"))
            out = []
            for d in meta:
                cls = _REGISTRY[d[TAG]]
                for k, v in list(d.items()):
                    if isinstance(v, dict) and "__npz__" in v:
                        d[k] = {"__ndarray__": None, "_arr": z[v["__npz__"]]}
                out.append(_from_npz_dict(cls, d))
            return out
    except (OSError, KeyError, ValueError) as e:
        raise RecordError(f"{path}: not a valid record shard ({e})") from None


def _from_npz_dict(cls: type[T], d: dict[str, Any]) -> T:
    """Rebuild a record whose arrays were loaded from an npz shard."""
    arrays = {k: v["_arr"] for k, v in d.items() if isinstance(v, dict) and "_arr" in v}
    rest = {k: v for k, v in d.items() if k not in arrays}
    rec = cls.from_dict({**rest, **{k: None for k in arrays}})
    for k, v in arrays.items():
        setattr(rec, k, np.array(v))
    return rec
