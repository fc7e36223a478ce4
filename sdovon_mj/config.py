"""Every hyperparameter of the pipeline: the paper's appendix E table plus ours.

Configs are frozen dataclasses grouped by stage. Each field carries its unit, a one-line meaning
and, where the paper names it, its symbol (``field.metadata``). YAML in and out; an unknown key is
an error that names the key (and the file, when there is one).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field, fields, is_dataclass, replace
from pathlib import Path
from typing import Any, get_type_hints

import yaml

from .errors import SdovonError


class ConfigError(SdovonError, ValueError):
    """A config file or override that cannot be applied (unknown key, wrong type)."""


def _p(default: Any, unit: str, doc: str, symbol: str = "") -> Any:
    """Declare a config field with its unit, one-line meaning and paper symbol."""
    if isinstance(default, (list, dict)):
        raise TypeError("use tuples for sequence defaults so configs stay frozen and hashable")
    return field(default=default, metadata={"unit": unit, "doc": doc, "symbol": symbol})


@dataclass(frozen=True)
class AgentConfig:
    """The ObjectNav agent's body and camera: one home for observe, episodes, nav, suite and world.

    Habitat ObjectNav defaults. The ground-truth detector's threshold ``eta_gt`` lives here too: it
    defines when the agent's camera sees an object (perceive's gt detector, episode view points and
    the A* agents' gt detector all use it).
    """

    radius: float = _p(0.18, "m", "agent cylinder radius; the navigable map is eroded by it")
    height: float = _p(0.88, "m", "agent cylinder height: geometry from the floor up to this blocks the agent")
    camera_height: float = _p(0.88, "m", "agent camera height above the floor (observation renders, episode view points, the suite)")
    hfov: float = _p(79.0, "deg", "agent camera horizontal field of view (Habitat ObjectNav default)")
    sensor_width: int = _p(640, "px", "agent camera image width in the suite")
    sensor_height: int = _p(480, "px", "agent camera image height in the suite")
    eta_gt: float = _p(1e-4, "-", "ground-truth detector: an object is seen when its pixels cover at least this fraction of the image", "eta_gt")


@dataclass(frozen=True)
class WorldConfig:
    """The embedded default world: procedural apartments and objects."""

    scene_seeds: tuple[int, ...] = _p((0,), "-", "seeds of the default apartments used as scenes (k_s = len)", "k_s")
    scene_mode: str = _p("clean", "-", "clean (artist-like GLB) or scan (noisy fused PLY, ScanNet style)")
    floors: int = _p(0, "-", "storeys per apartment: 1, 2, or 0 for the seeded choice")
    object_seed: int = _p(0, "-", "seed of the procedural object library")
    object_variants: int = _p(3, "-", "shape variants per object category")
    object_categories: tuple[str, ...] = _p((), "-", "restrict the object library to these categories (empty = all)")


@dataclass(frozen=True)
class ConvertConfig:
    """Mesh -> MJCF conversion (assets_convert)."""

    units: str = _p("auto", "-", "auto, m, cm, mm, or a number: metres per file unit")
    up: str = _p("auto", "-", "auto (glTF: +Y, else +Z), +Y, +Z, -Y, ...")
    target_size: float = _p(0.0, "m", "rescale objects of unknown units so the largest extent equals this (0: off)")
    coacd_threshold: float = _p(0.05, "-", "CoACD concavity threshold")
    coacd_max_hulls: int = _p(32, "-", "maximum convex hulls per object")
    coacd_max_hull_vertices: int = _p(64, "-", "maximum vertices per hull")
    coacd_preprocess_resolution: int = _p(50, "-", "CoACD manifold preprocessing resolution")
    coacd_seed: int = _p(0, "-", "CoACD random seed")
    coacd_mcts_iterations: int = _p(60, "-", "CoACD MCTS iterations per cut (CoACD default 150: 2-3x slower, same hulls on our objects)")
    coacd_mcts_nodes: int = _p(10, "-", "CoACD MCTS child nodes per level (CoACD default 20)")
    coacd_mcts_max_depth: int = _p(2, "-", "CoACD MCTS search depth (CoACD default 3)")
    coacd_resolution: int = _p(1000, "-", "CoACD surface samples for its concavity metric (CoACD default 2000)")
    remesh_resolution: int = _p(80, "-", "open meshes: offset-surface grid steps across the largest extent before CoACD (closed manifolds are used as they are)")
    remesh_offset: float = _p(0.45, "grid steps", "open meshes: the CoACD input surface lies this far outside the triangles (>= 0.44 keeps sheets of any thickness)")
    default_density: float = _p(500.0, "kg/m^3", "density for categories without a known one")
    texture_max_size: int = _p(1024, "px", "textures are downscaled to at most this edge length")
    timeout_s: float = _p(300.0, "s", "per-object conversion timeout in a batch")
    coacd_closed_budget_s: float = _p(30.0, "s", "CoACD on a thin-walled closed mesh as it is runs in a child process this long at most; when it crashes or runs out, the offset surface goes to CoACD instead")
    jobs: int = _p(0, "-", "worker processes for batch conversion (0: number of cores)")


@dataclass(frozen=True)
class ObserveConfig:
    """Floors, navigable maps, coverage sampling and rendering (paper section 3.1)."""

    h_map: float = _p(0.3, "m", "slice height above the floor for the top-down map", "h_map")
    map_resolution: float = _p(0.05, "m/cell", "navigable map grid resolution")
    floor_cluster_tol: float = _p(0.15, "m", "heights closer than this belong to one floor")
    min_floor_area: float = _p(2.0, "m^2", "smallest horizontal area that counts as a floor")
    min_component_area: float = _p(1.0, "m^2", "navigable components smaller than this are dropped")
    eps_p_obs: float = _p(0.5, "-", "strong observation threshold on M_P", "epsilon_p_obs")
    r_min: float = _p(0.5, "m", "invalid observation radius (depth too close)", "r_min")
    r_max: float = _p(1.5, "m", "observation range; sigma of the coverage Gaussian (1.5: enough viewpoints that receptacle surfaces are seen from several sides, bench/bench_perceive.py --world)", "r_max")
    coverage_threshold: float = _p(0.95, "-", "stop when this fraction of navigable cells has M_P >= eps_p_obs (0.9 leaves small rooms unseen)")
    max_iterations: int = _p(500, "-", "maximum candidate draws of the coverage sampler")
    min_obstacle_distance: float = _p(0.3, "m", "candidates closer than this to an obstacle are rejected")
    yaw_steps: int = _p(6, "-", "camera yaw steps per viewpoint (360 deg / yaw_steps)")
    pitch_angles: tuple[float, ...] = _p((-30.0, 0.0), "deg", "camera pitch angles per yaw (negative looks down)")
    width: int = _p(640, "px", "image width of the observation renders (field of view: agent.hfov)")
    height: int = _p(480, "px", "image height of the observation renders")
    depth_min: float = _p(0.1, "m", "depth below this is invalid (0)")
    depth_max: float = _p(10.0, "m", "depth above this is invalid (0)")
    shadows: bool = _p(False, "-", "render shadows (off for data generation: speed)")
    seed: int = _p(0, "-", "coverage sampling seed offset (combined with the scene seed)")
    nav_slice: str = _p("band", "-", "obstacles: band (all geometry between obstacle_min_height and obstacle_max_height) or plane (the paper's single slice at h_map)")
    obstacle_min_height: float = _p(0.1, "m", "geometry above floor + this blocks the agent (band mode)")
    obstacle_max_height: float = _p(0.0, "m", "geometry below floor + this blocks the agent (band mode; 0: agent.height)")
    coverage_combine: str = _p("add", "-", "how a viewpoint's Gaussian is overlaid on M_P: add (sum, clipped to 1) or max")
    frames_per_shard: int = _p(24, "-", "observations per compressed npz shard")
    camera_heights: tuple[float, ...] = _p((2.0,), "m", "extra camera heights above the floor, rendered at every viewpoint and yaw with camera_height_pitches besides agent.camera_height (the agent camera cannot see the tops of shelves above it); empty: agent.camera_height only")
    camera_height_pitches: tuple[float, ...] = _p((-40.0,), "deg", "camera pitch angles at the extra camera_heights (negative looks down)")
    targeted_views: int = _p(2, "-", "targeted views per receptacle surface after a first perception pass: cameras around it that show most of what no view showed yet (0: coverage views only, as in the paper)")
    targeted_distance: tuple[float, ...] = _p((0.4, 2.0), "m", "targeted cameras stand on navigable cells this far (min, max) from the surface's XY box")
    targeted_spacing: float = _p(0.3, "m", "lattice spacing of targeted camera candidates")
    targeted_candidates: int = _p(24, "-", "at most this many candidate positions per surface (each tried at every camera height)")
    targeted_cell: float = _p(0.03, "m", "grid cell for what part of a surface a view shows")
    targeted_min_gain: float = _p(0.03, "-", "a targeted view must show at least this fraction of the surface's box unseen so far")
    targeted_width: int = _p(128, "px", "image width of the depth renders that score candidates (height keeps the aspect ratio)")


@dataclass(frozen=True)
class PerceiveConfig:
    """2D detection, back-projection, instance fusion and error correction (paper section 3.2)."""

    detector: str = _p("gt", "-", "detector plugin name (entry point group sdovon_mj.detectors)")
    detector_weights: str = _p("", "path", "local weights folder for open-vocabulary detectors")
    score_threshold: float = _p(0.3, "-", "detections below this score are dropped")
    gt_score_noise: float = _p(0.0, "-", "std of noise added to gt detection scores (0: score 1.0)")
    depth_noise_sigma: float = _p(0.0, "m", "Gaussian noise added to depth before back-projection (robustness tests)")
    fusion_preset: str = _p("paper", "-", "paper (k_sem 0.4 / k_geo 1.6 / phi_min 0.8), conceptgraphs, or custom (use k_sem/k_geo/phi_min as given)")
    k_sem: float = _p(0.4, "-", "weight of the label-embedding similarity term", "k_sem")
    k_geo: float = _p(1.6, "-", "weight of the point-overlap term", "k_geo")
    phi_min: float = _p(0.8, "-", "minimum similarity for a match", "phi_min")
    overlap_radius: float = _p(0.025, "m", "points closer than this count as overlapping")
    voxel_size: float = _p(0.02, "m", "voxel downsampling of fused instances")
    iou_min: float = _p(0.9, "-", "3D box IoU for fusion error correction", "IoU_min")
    min_points: int = _p(30, "-", "instances with fewer points are dropped")
    depth_min: float = _p(0.1, "m", "depth below this is not back-projected")
    depth_max: float = _p(10.0, "m", "depth above this is not back-projected")
    label_similarity: str = _p("minilm", "-", "label term of fusion: minilm (cosine of all-MiniLM-L6-v2 sentence embeddings, clipped to [0, 1]) or exact (1 if equal else 0)")
    vocabulary: tuple[str, ...] = _p((), "-", "text prompts of open-vocabulary detectors (empty: the receptacle labels)")
    owl_weights: str = _p("owlv2", "path", "box model subfolder of detector_weights (OWLv2 or Grounding DINO, transformers format)")
    sam_weights: str = _p("sam", "path", "mask model subfolder of detector_weights (SAM, transformers format)")


@dataclass(frozen=True)
class ReceptacleConfig:
    """Receptacle identification and EM plane detection (paper section 3.3, algorithm 1)."""

    labels: tuple[str, ...] = _p(
        ("table", "desk", "dresser", "bookshelf", "shelf", "bed", "sofa", "couch", "counter",
         "nightstand", "coffee table", "cabinet"),
        "-", "receptacle labels (prespecified); empty: ask the LLM backend", "L_rec")
    eps_t: float = _p(0.03, "m", "plane slab thickness", "epsilon_t")
    rho_min: int = _p(50, "points", "minimum points in a slab to try a plane", "rho_min")
    eps_c: float = _p(0.95, "-", "convergence: fraction of inliers kept between iterations", "epsilon_c")
    max_em_iterations: int = _p(20, "-", "cap on EM iterations per slab")
    max_normal_tilt: float = _p(10.0, "deg", "planes tilted more than this from +Z are rejected")
    min_plane_area: float = _p(0.01, "m^2", "planes smaller than this are rejected")
    merge_height_tol: float = _p(0.02, "m", "planes closer than this in height (and overlapping) are merged")
    coverage_cell: float = _p(0.05, "m", "XY grid cell for plane connectivity, hull coverage and clearance tests")
    min_coverage: float = _p(0.5, "-", "planes whose hull cells hold inlier points less often than this are rejected (slabs through legs or walls)")
    min_clearance: float = _p(0.10, "m", "free height needed above a plane; receptacle points in (eps_t, this] above it count as covering")
    max_covered: float = _p(0.5, "-", "planes with more than this fraction of their points covered from just above are rejected (undersides)")
    clearance_radius: float = _p(0.015, "m", "XY radius within which a receptacle point above a plane point covers it")
    fit_band: float = _p(0.01, "m", "final fit and polygon use the densest layer of this half-thickness (vertical faces within eps_t excluded); 0: off")
    min_width: float = _p(0.15, "m", "support regions narrower than this are cut off (strips around a sink, points seen through a gap); real shelves are >= 0.2 m deep")
    open_cell: float = _p(0.025, "m", "XY grid cell of the min_width opening")


@dataclass(frozen=True)
class SemanticsConfig:
    """LLM backends, region map and relevance (paper section 3.4, appendix C)."""

    backend: str = _p("offline", "-", "LLM backend plugin (offline, ollama, openai, ...)")
    model: str = _p("", "-", "model name for server backends (e.g. llama3.1:8b)")
    url: str = _p("", "-", "server base URL (ollama default http://localhost:11434)")
    timeout_s: float = _p(60.0, "s", "per-request timeout")
    retries: int = _p(3, "-", "re-asks after an invalid reply / retries after a transport error")
    fallback: str = _p("offline", "-", "backend to fall back to after the retries ('' = fail)")
    window_radius: float = _p(2.5, "m", "sliding window radius (walls cut windows, so a window may span a room; bench/bench_regions.py)", "r")
    window_step: float = _p(0.5, "m", "sliding window step", "Delta d")
    region_labels: tuple[str, ...] = _p(
        ("kitchen", "living room", "bedroom", "bathroom", "office", "dining room"),
        "-", "region vocabulary offered to the region-proposal prompt")
    cache: bool = _p(True, "-", "cache LLM replies on disk")
    backoff_s: float = _p(0.5, "s", "first wait before retrying a failed request (doubles each retry)")
    temperature: float = _p(0.0, "-", "sampling temperature sent to server backends")
    seed: int = _p(0, "-", "sampling seed sent to server backends (the cache, not the seed, makes re-runs exact)")
    window_walls: bool = _p(True, "-", "walls cut windows: a window covers only the floor space connected to its centre (False: the paper's plain disc)")


@dataclass(frozen=True)
class PlaceConfig:
    """Semantic placement and physical settling (paper section 3.4)."""

    k_v: int = _p(2, "-", "variants per scene", "k_v")
    m: int = _p(3, "-", "categories sampled per (receptacle plane, region)", "m")
    max_objects: int = _p(30, "-", "cap on objects per variant")
    temperature: float = _p(1.0, "-", "softmax temperature over joint relevance")
    top_k: int = _p(8, "-", "sample among the top-k categories of each (region, receptacle)")
    min_distance: float = _p(0.05, "m", "minimum gap between object footprints")
    h_spawn: float = _p(0.3, "m", "spawn height above the plane", "h_spawn")
    spawn_mode: str = _p("paper", "-", "paper (random X/Y/Z rotation from h_spawn) or stable (stable pose, random yaw, small drop)")
    stable_drop: float = _p(0.02, "m", "drop height in stable mode")
    timestep: float = _p(0.002, "s", "physics timestep while settling")
    max_settle_time: float = _p(3.0, "s", "cap on simulated settling time")
    settle_window: float = _p(0.2, "s", "speeds must stay below thresholds this long")
    lin_vel_tol: float = _p(0.01, "m/s", "settled linear speed")
    ang_vel_tol: float = _p(0.1, "rad/s", "settled angular speed")
    resample_attempts: int = _p(2, "-", "resampling rounds for failed objects")
    support_thickness: float = _p(0.05, "m", "thickness of support prisms built from receptacle polygons (thin ones let heavy objects sink in)")
    support_hfield: bool = _p(False, "-", "use a heightfield from ray casts on the scene mesh where a plane's surface is not flat")
    hfield_resolution: float = _p(0.02, "m", "heightfield raster step")
    hfield_flatness: float = _p(0.01, "m", "surfaces whose height range is below this keep the flat prism")
    check_every: int = _p(25, "steps", "settling checks object speeds every this many physics steps")
    fell_drop: float = _p(0.1, "m", "an object whose centre ends this far below its plane (or on a floor) fell")
    sleep: bool = _p(True, "-", "let MuJoCo put resting objects to sleep while settling (faster; speeds are still checked)")
    support_condim: int = _p(6, "-", "contact dimension of support geoms: 6 adds torsional and rolling friction so round objects stop")


@dataclass(frozen=True)
class EpisodeConfig:
    """ObjectNav episode generation (paper section 3.5)."""

    k_e: int = _p(3, "-", "episodes per object category per variant", "k_e")
    viewpoint_radius: float = _p(1.0, "m", "goal view points lie within this distance of the object")
    max_viewpoints: int = _p(50, "-", "cap on view points per goal object")
    min_start_distance: float = _p(1.0, "m", "minimum geodesic distance from start to goal")
    max_start_tries: int = _p(200, "-", "start pose draws per episode")
    success_distance: float = _p(0.1, "m", "success radius around view points")
    viewpoint_step: float = _p(0.25, "m", "lattice step of view point candidates")
    vis_width: int = _p(160, "px", "width of the visibility-check segmentation render")
    vis_height: int = _p(120, "px", "height of the visibility-check segmentation render")
    pitches: tuple[float, ...] = _p((-30.0, 0.0), "deg", "pitches tried after the one aimed at the object centre")


@dataclass(frozen=True)
class NavConfig:
    """Actions, step limit and the A* baselines (appendix D); the agent's body and camera are `AgentConfig`."""

    forward_step: float = _p(0.25, "m", "MOVE_FORWARD distance")
    turn_angle: float = _p(30.0, "deg", "TURN_LEFT/TURN_RIGHT angle")
    tilt_angle: float = _p(30.0, "deg", "LOOK_UP/LOOK_DOWN angle")
    max_steps: int = _p(500, "-", "episode step limit")
    eps_nav: float = _p(0.5, "m", "navigation error tolerance", "epsilon_nav")
    d_next: float = _p(1.0, "m", "minimum distance to the next navigation point", "d_next")
    final_nav: bool = _p(True, "-", "final point-goal navigation after detection (FN)")
    depth_min: float = _p(0.5, "m", "agent depth sensor minimum")
    depth_max: float = _p(5.0, "m", "agent depth sensor maximum")
    max_tilt: float = _p(60.0, "deg", "LOOK_UP/LOOK_DOWN camera pitch limit")
    success_distance: float = _p(0.1, "m", "STOP within this geodesic distance of a view point succeeds")
    fn_viewpoint_radius: float = _p(1.0, "m", "FN: inferred view points lie within this distance of the detected object")
    fn_viewpoint_step: float = _p(0.25, "m", "FN: lattice step of inferred view points (as the episode generator's)")
    fn_max_checks: int = _p(4, "-", "FN: inferred view points walked to and checked by looking, at most")


@dataclass(frozen=True)
class RunConfig:
    """The whole pipeline: one config file for `sdovon-mj generate`."""

    seed: int = _p(0, "-", "master seed; per-scene and per-variant seeds are derived from it")
    name: str = _p("sdovon", "-", "dataset name used by exporters")
    split: str = _p("val", "-", "dataset split name")
    exporters: tuple[str, ...] = _p(("habitat", "mjcf"), "-", "exporter plugins run at the end")
    agent: AgentConfig = field(default_factory=AgentConfig)
    world: WorldConfig = field(default_factory=WorldConfig)
    convert: ConvertConfig = field(default_factory=ConvertConfig)
    observe: ObserveConfig = field(default_factory=ObserveConfig)
    perceive: PerceiveConfig = field(default_factory=PerceiveConfig)
    receptacles: ReceptacleConfig = field(default_factory=ReceptacleConfig)
    semantics: SemanticsConfig = field(default_factory=SemanticsConfig)
    place: PlaceConfig = field(default_factory=PlaceConfig)
    episodes: EpisodeConfig = field(default_factory=EpisodeConfig)
    nav: NavConfig = field(default_factory=NavConfig)


FUSION_PRESETS: dict[str, dict[str, float]] = {
    # The paper's appendix E values. The paper's text multiplies k_sem with the point-overlap term
    # and k_geo with the label term (names swapped, see research/peers.md section 0). We follow the
    # names: k_sem weighs label similarity, k_geo weighs geometric overlap.
    "paper": {"k_sem": 0.4, "k_geo": 1.6, "phi_min": 0.8},
    # ConceptGraphs: equal weights of 1 on both terms, match threshold 1.1 on the sum (of max 2).
    "conceptgraphs": {"k_sem": 1.0, "k_geo": 1.0, "phi_min": 1.1},
}


# Keys that moved to one home (issue 19: one AgentConfig, one eta_gt). Old YAML files and --set
# overrides naming them fail with a ConfigError that names the new key.
MOVED_KEYS: dict[str, str] = {
    "observe.agent_radius": "agent.radius",
    "observe.agent_height": "agent.camera_height' (camera) and 'agent.height' (body",
    "observe.hfov": "agent.hfov",
    "perceive.gt_eta": "agent.eta_gt",
    "episodes.eta_gt": "agent.eta_gt",
    "episodes.camera_height": "agent.camera_height",
    "episodes.hfov": "agent.hfov",
    "nav.eta_gt": "agent.eta_gt",
    "nav.hfov": "agent.hfov",
    "nav.agent_radius": "agent.radius",
    "nav.agent_height": "agent.height' (body) and 'agent.camera_height' (camera",
    "nav.obs_width": "agent.sensor_width",
    "nav.obs_height": "agent.sensor_height",
}

_FUSION_WEIGHTS = ("k_sem", "k_geo", "phi_min")


def _moved_error(key: str, where: str) -> ConfigError | None:
    """Return the error for a key that moved to another section (None for keys that never existed)."""
    new = MOVED_KEYS.get(key)
    return ConfigError(f"config key '{key}'{where} has moved: use '{new}'") if new else None


def to_dict(cfg: Any) -> dict[str, Any]:
    """Return a config as plain YAML-able data (tuples become lists)."""
    out: dict[str, Any] = {}
    for f in fields(cfg):
        v = getattr(cfg, f.name)
        if is_dataclass(v):
            out[f.name] = to_dict(v)
        elif isinstance(v, tuple):
            out[f.name] = list(v)
        else:
            out[f.name] = v
    return out


def _coerce(value: Any, typ: Any, key: str, source: str) -> Any:
    """Convert a YAML value to a field's declared type, or raise naming the key."""
    where = f" in {source}" if source else ""
    origin = getattr(typ, "__origin__", None)
    try:
        if typ is bool:
            if isinstance(value, bool):
                return value
            if isinstance(value, str) and value.lower() in ("true", "false", "1", "0", "yes", "no"):
                return value.lower() in ("true", "1", "yes")
            raise TypeError
        if typ is int:
            if isinstance(value, bool):
                raise TypeError
            if isinstance(value, float) and not value.is_integer():
                raise TypeError
            return int(value)
        if typ is float:
            if isinstance(value, bool):
                raise TypeError
            return float(value)
        if typ is str:
            if not isinstance(value, (str, int, float)):
                raise TypeError
            return str(value)
        if origin is tuple:
            (inner, _ellipsis) = typ.__args__
            if isinstance(value, str):
                value = [v.strip() for v in value.split(",") if v.strip()] if value else []
            if not isinstance(value, (list, tuple)):
                raise TypeError
            return tuple(_coerce(v, inner, key, source) for v in value)
    except (TypeError, ValueError):
        raise ConfigError(f"config key '{key}'{where}: cannot use {value!r} as {getattr(typ, '__name__', typ)}") from None
    raise ConfigError(f"config key '{key}'{where}: unsupported type {typ}")


def from_dict(cls: type, data: dict[str, Any], source: str = "", prefix: str = "") -> Any:
    """Build a config dataclass from plain data; unknown keys raise ConfigError naming them."""
    if not isinstance(data, dict):
        raise ConfigError(f"config section '{prefix or '<root>'}'{' in ' + source if source else ''} must be a mapping")
    hints = get_type_hints(cls)
    known = {f.name for f in fields(cls)}
    for key in data:
        if key not in known:
            full = f"{prefix}{key}"
            moved = _moved_error(full, f" in {source}" if source else "")
            if moved is not None:
                raise moved
            close = _closest(str(key), known)
            hint = f" (did you mean '{prefix}{close}'?)" if close else ""
            raise ConfigError(f"unknown config key '{full}'{' in ' + source if source else ''}{hint}")
    kwargs: dict[str, Any] = {}
    for f in fields(cls):
        if f.name not in data:
            continue
        typ = hints[f.name]
        if is_dataclass(typ):
            kwargs[f.name] = from_dict(typ, data[f.name] or {}, source, f"{prefix}{f.name}.")
        else:
            kwargs[f.name] = _coerce(data[f.name], typ, f"{prefix}{f.name}", source)
    return cls(**kwargs)


def _closest(key: str, known: set[str]) -> str:
    """Return the known key nearest to a misspelt one, or ''."""
    import difflib

    m = difflib.get_close_matches(key, sorted(known), n=1, cutoff=0.6)
    return m[0] if m else ""


def load_config(path: str | Path | None = None, overrides: list[str] | tuple[str, ...] = ()) -> RunConfig:
    """Load a RunConfig from YAML (or defaults) and apply KEY=VALUE overrides."""
    data: dict[str, Any] = {}
    source = ""
    if path is not None:
        source = str(path)
        try:
            text = Path(path).read_text(encoding="utf-8")
        except FileNotFoundError:
            raise ConfigError(f"config file not found: {path}") from None
        try:
            data = yaml.safe_load(text) or {}
        except yaml.YAMLError as e:
            raise ConfigError(f"config file {path} is not valid YAML: {e}") from None
    explicit = {f"{sec}.{k}" for sec, v in data.items() if isinstance(v, dict) for k in v} if isinstance(data, dict) else set()
    cfg = from_dict(RunConfig, data, source)
    return apply_overrides(cfg, overrides, explicit)


def apply_overrides(cfg: RunConfig, overrides: list[str] | tuple[str, ...], explicit: set[str] | frozenset[str] = frozenset()) -> RunConfig:
    """Apply dotted KEY=VALUE overrides (values parsed as YAML scalars or lists) and resolve presets.

    ``explicit`` names keys (``section.key``) the caller set besides the overrides (a YAML file's);
    an explicit fusion weight wins over the fusion preset (see `resolve_fusion_preset`).
    """
    data = to_dict(cfg)
    explicit = set(explicit)
    for item in overrides:
        if "=" not in item:
            raise ConfigError(f"override '{item}' is not KEY=VALUE")
        key, raw = item.split("=", 1)
        parts = key.strip().split(".")
        moved = _moved_error(key.strip(), f" in --set {item}")
        if moved is not None:
            raise moved
        node = data
        for i, part in enumerate(parts[:-1]):
            if part not in node or not isinstance(node[part], dict):
                raise ConfigError(f"unknown config key '{'.'.join(parts[: i + 1])}' in --set {item}")
            node = node[part]
        if parts[-1] not in node or isinstance(node[parts[-1]], dict):
            raise ConfigError(f"unknown config key '{key.strip()}' in --set {item}")
        node[parts[-1]] = yaml.safe_load(raw) if raw != "" else ""
        explicit.add(key.strip())
    out = from_dict(RunConfig, data, "--set")
    return replace(out, perceive=resolve_fusion_preset(out.perceive, {k.split(".", 1)[1] for k in explicit if k.startswith("perceive.")}))


def save_config(cfg: Any, path: str | Path) -> None:
    """Write a config as YAML (atomically)."""
    from .store import atomic_write_text

    atomic_write_text(Path(path), dump_yaml(cfg))


def dump_yaml(cfg: Any) -> str:
    """Return a config as deterministic YAML text."""
    return yaml.safe_dump(to_dict(cfg), sort_keys=True, default_flow_style=None)


def config_hash(cfg: Any) -> str:
    """Return a stable hex digest of a config (or config section)."""
    blob = json.dumps(to_dict(cfg) if is_dataclass(cfg) else cfg, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def with_fusion_preset(cfg: PerceiveConfig) -> PerceiveConfig:
    """Return the perceive config with the named fusion preset's weights applied (no weight set explicitly)."""
    return resolve_fusion_preset(cfg, ())


def resolve_fusion_preset(cfg: PerceiveConfig, explicit: set[str] | tuple[str, ...] | frozenset[str]) -> PerceiveConfig:
    """Return the perceive config with its fusion preset resolved into k_sem / k_geo / phi_min.

    Weights named in ``explicit`` (keys the user set: YAML or ``--set``) win over the preset: when one
    differs from the preset's value, the result is ``fusion_preset: custom`` holding the preset's
    other weights and the explicit ones, so the config written to the run folder says what fusion uses.
    """
    if cfg.fusion_preset == "custom":
        return cfg
    if cfg.fusion_preset not in FUSION_PRESETS:
        raise ConfigError(f"unknown fusion preset '{cfg.fusion_preset}' (known: {', '.join(FUSION_PRESETS)}, custom)")
    preset = FUSION_PRESETS[cfg.fusion_preset]
    mine = {k: getattr(cfg, k) for k in _FUSION_WEIGHTS if k in explicit and getattr(cfg, k) != preset[k]}
    if not mine:
        return replace(cfg, **preset)
    return replace(cfg, **{**preset, **mine}, fusion_preset="custom")


def describe(cls: type = RunConfig, prefix: str = "") -> list[tuple[str, Any, str, str, str]]:
    """List (key, default, unit, symbol, meaning) for every field, for docs and `--help`."""
    rows = []
    inst = cls()
    for f in dataclasses.fields(cls):
        v = getattr(inst, f.name)
        if is_dataclass(v):
            rows.extend(describe(type(v), f"{prefix}{f.name}."))
        else:
            rows.append((prefix + f.name, v, f.metadata.get("unit", ""), f.metadata.get("symbol", ""), f.metadata.get("doc", "")))
    return rows
