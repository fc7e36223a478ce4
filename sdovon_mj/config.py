"""Every hyperparameter of the pipeline: the paper's appendix E table plus ours.

Configs are frozen dataclasses grouped by stage. Each field carries its unit, a one-line meaning,
where the paper names it its symbol, and its allowed range or choices (``field.metadata``). YAML in and
out; an unknown key, a value outside its declared range and values that contradict each other
(`check_cross_fields`, e.g. ``observe.r_min < observe.r_max``) are errors that name the key, the value,
what is allowed and the file (or ``--set``), raised at load before any work (`validate`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field, fields, is_dataclass, replace
from pathlib import Path
from typing import Any, get_type_hints

import yaml

from .errors import UsageError


class ConfigError(UsageError, ValueError):
    """A config file or override that cannot be applied (unknown key, wrong type)."""


def _p(default: Any, unit: str, doc: str, symbol: str = "", *, ge: float | None = None, gt: float | None = None,
       le: float | None = None, lt: float | None = None, choices: tuple[Any, ...] | None = None,
       min_len: int | None = None, max_len: int | None = None, quiet: bool = False) -> Any:
    """Declare a config field with its unit, one-line meaning, paper symbol and allowed values.

    ``ge``/``gt``/``le``/``lt`` bound a number (each element of a tuple field); ``choices`` lists the
    allowed values; ``min_len``/``max_len`` bound a tuple's length. `validate` checks them at load.
    ``quiet``: a key added after runs were made with its section; `to_dict` leaves it out while it holds its default,
    so the config files and fingerprints of runs that do not use it keep their bytes.
    """
    if isinstance(default, (list, dict)):
        raise TypeError("use tuples for sequence defaults so configs stay frozen and hashable")
    limits = {k: v for k, v in (("ge", ge), ("gt", gt), ("le", le), ("lt", lt)) if v is not None}
    return field(default=default, metadata={"unit": unit, "doc": doc, "symbol": symbol, "limits": limits,
                                            "choices": tuple(choices) if choices is not None else None,
                                            "min_len": min_len, "max_len": max_len, "quiet": quiet})


@dataclass(frozen=True)
class AgentConfig:
    """The ObjectNav agent's body and camera: one home for observe, episodes, nav, suite and world.

    Habitat ObjectNav defaults. The ground-truth detector's threshold ``eta_gt`` lives here too: it
    defines when the agent's camera sees an object (perceive's gt detector, episode view points and
    the A* agents' gt detector all use it).
    """

    radius: float = _p(0.18, "m", "agent cylinder radius; the navigable map is eroded by it", gt=0)
    height: float = _p(0.88, "m", "agent cylinder height: geometry from the floor up to this blocks the agent", gt=0)
    camera_height: float = _p(0.88, "m", "agent camera height above the floor (observation renders, episode view points, the suite)", gt=0)
    hfov: float = _p(79.0, "deg", "agent camera horizontal field of view (Habitat ObjectNav default)", gt=0,lt=180)
    sensor_width: int = _p(640, "px", "agent camera image width in the suite", ge=1)
    sensor_height: int = _p(480, "px", "agent camera image height in the suite", ge=1)
    eta_gt: float = _p(1e-4, "-", "ground-truth detector: an object is seen when its pixels cover at least this fraction of the image", "eta_gt", ge=0,le=1)


@dataclass(frozen=True)
class WorldConfig:
    """The embedded default world: procedural homes (apartments or houses: docs/world.md) and objects."""

    preset: str = _p("apartment", "-", "the homes used as scenes: apartment (3-6 rooms on 1-2 storeys) or house (8-16 rooms on 1-3 storeys with stairs, hallways, garage, clutter)", choices=("apartment","house"))
    scene_seeds: tuple[int, ...] = _p((0,), "-", "seeds of the default homes used as scenes (k_s = len)", "k_s", ge=0,min_len=1)
    scene_mode: str = _p("clean", "-", "clean (artist-like GLB) or scan (noisy fused PLY, ScanNet style)", choices=("clean","scan"))
    floors: int = _p(0, "-", "storeys per home: 1, 2 (3: houses), or 0 for the seeded choice", choices=(0,1,2,3))
    object_seed: int = _p(0, "-", "seed of the procedural object library", ge=0)
    object_variants: int = _p(3, "-", "shape variants per object category", ge=1)
    object_categories: tuple[str, ...] = _p((), "-", "restrict the object library to these categories (empty = all)")
    articulated: bool = _p(False, "-", "articulated furniture (cabinets, dressers, wardrobes, fridges, microwaves as URDF with doors and drawers) in the apartments")


@dataclass(frozen=True)
class ConvertConfig:
    """Mesh -> MJCF conversion (assets_convert)."""

    units: str = _p("auto", "-", "auto, m, cm, mm, or a number: metres per file unit")
    up: str = _p("auto", "-", "auto (glTF: +Y, else +Z), +Y, +Z, -Y, ...")
    target_size: float = _p(0.0, "m", "rescale objects of unknown units so the largest extent equals this (0: off)", ge=0)
    coacd_threshold: float = _p(0.05, "-", "CoACD concavity threshold", gt=0,le=1)
    coacd_max_hulls: int = _p(32, "-", "maximum convex hulls per object", ge=1)
    coacd_max_hull_vertices: int = _p(64, "-", "maximum vertices per hull", ge=4)
    coacd_preprocess_resolution: int = _p(50, "-", "CoACD manifold preprocessing resolution", ge=1)
    coacd_seed: int = _p(0, "-", "CoACD random seed", ge=0)
    coacd_mcts_iterations: int = _p(60, "-", "CoACD MCTS iterations per cut (CoACD default 150: 2-3x slower, same hulls on our objects)", ge=1)
    coacd_mcts_nodes: int = _p(10, "-", "CoACD MCTS child nodes per level (CoACD default 20)", ge=1)
    coacd_mcts_max_depth: int = _p(2, "-", "CoACD MCTS search depth (CoACD default 3)", ge=1)
    coacd_resolution: int = _p(1000, "-", "CoACD surface samples for its concavity metric (CoACD default 2000)", ge=1)
    remesh_resolution: int = _p(80, "-", "open meshes: offset-surface grid steps across the largest extent before CoACD (closed manifolds are used as they are)", ge=2)
    remesh_offset: float = _p(0.45, "grid steps", "open meshes: the CoACD input surface lies this far outside the triangles (>= 0.44 keeps sheets of any thickness)", gt=0)
    default_density: float = _p(500.0, "kg/m^3", "density for categories without a known one", gt=0)
    texture_max_size: int = _p(1024, "px", "textures are downscaled to at most this edge length", ge=1)
    timeout_s: float = _p(300.0, "s", "per-object conversion timeout in a batch", gt=0)
    coacd_closed_budget_s: float = _p(30.0, "s", "CoACD on a thin-walled closed mesh as it is runs in a child process for this much processor time at most (one thread; wall time does not count, so a busy machine gets the same hulls); when it crashes or runs out, the offset surface goes to CoACD instead", ge=0)
    jobs: int = _p(0, "-", "worker processes for batch conversion (0: number of cores)", ge=0)
    add_floor: bool = _p(False, "-", "scenes: add a ground slab under the footprint (+0.5 m) for scenes modelled without a floor")


@dataclass(frozen=True)
class ObserveConfig:
    """Floors, navigable maps, coverage sampling and rendering (paper section 3.1)."""

    h_map: float = _p(0.3, "m", "slice height above the floor for the top-down map", "h_map", gt=0)
    map_resolution: float = _p(0.05, "m/cell", "navigable map grid resolution", gt=0)
    floor_cluster_tol: float = _p(0.15, "m", "heights closer than this belong to one floor", gt=0)
    min_floor_area: float = _p(2.0, "m^2", "smallest horizontal area that counts as a floor", ge=0)
    min_component_area: float = _p(1.0, "m^2", "navigable components smaller than this are dropped", ge=0)
    eps_p_obs: float = _p(0.5, "-", "strong observation threshold on M_P", "epsilon_p_obs", gt=0,le=1)
    r_min: float = _p(0.5, "m", "invalid observation radius (depth too close)", "r_min", ge=0)
    r_max: float = _p(1.5, "m", "observation range; sigma of the coverage Gaussian (1.5: enough viewpoints that receptacle surfaces are seen from several sides, bench/bench_perceive.py --world)", "r_max", gt=0)
    coverage_threshold: float = _p(0.95, "-", "stop when this fraction of navigable cells has M_P >= eps_p_obs (0.9 leaves small rooms unseen)", gt=0,le=1)
    max_iterations: int = _p(500, "-", "maximum candidate draws of the coverage sampler", ge=1)
    # The two stall rules of the coverage sampler (observe/coverage.py) must bite only where it is stuck (the goal
    # out of reach: cells within r_min of every spot the draw favours), never on a floor that reaches the goal, so
    # the default world keeps its view points. Stuck, a view point adds exactly nothing; on the default world's
    # floors (apartments of seeds 0-9 with 1 and 2 storeys, houses 0-2: 35 floors) three view points in a row
    # always added >= 0.32 % coverage together and no floor needed more than 3 view points per r_max disc of its
    # navigable area. 0.1 % of the goal over 3 points (3.4x below that) and 8 per disc (2.7x above) leave margin.
    coverage_min_gain: float = _p(0.001, "-", "the coverage sampler stops when coverage_patience view points in a row add together less than this share of coverage_threshold (the goal is out of reach: small or cluttered floors); 0: never", ge=0, le=1, quiet=True)
    coverage_patience: int = _p(3, "-", "view points in a row whose coverage gain coverage_min_gain judges", ge=1, quiet=True)
    max_viewpoints_per_disc: float = _p(8.0, "-", "the coverage sampler accepts at most this many view points per disc of radius r_max that the navigable area would fill (rounded up to whole discs: the bound grows with the floor area); 0: no bound", ge=0, quiet=True)
    open_parts: float = _p(1.0, "-", "articulated scene pieces (world.articulated): observe/perceive render every door and drawer open this fraction of its range", ge=0, le=1)
    min_obstacle_distance: float = _p(0.3, "m", "candidates closer than this to an obstacle are rejected", ge=0)
    yaw_steps: int = _p(6, "-", "camera yaw steps per viewpoint (360 deg / yaw_steps)", ge=1)
    pitch_angles: tuple[float, ...] = _p((-30.0, 0.0), "deg", "camera pitch angles per yaw (negative looks down)", ge=-90,le=90,min_len=1)
    width: int = _p(640, "px", "image width of the observation renders (field of view: agent.hfov)", ge=1)
    height: int = _p(480, "px", "image height of the observation renders", ge=1)
    depth_min: float = _p(0.1, "m", "depth below this is invalid (0)", ge=0)
    depth_max: float = _p(10.0, "m", "depth above this is invalid (0)", gt=0)
    shadows: bool = _p(False, "-", "render shadows (off for data generation: speed)")
    seed: int = _p(0, "-", "coverage sampling seed offset (combined with the scene seed)", ge=0)
    nav_slice: str = _p("band", "-", "obstacles: band (all geometry between obstacle_min_height and obstacle_max_height) or plane (the paper's single slice at h_map)", choices=("band","plane"))
    obstacle_min_height: float = _p(0.1, "m", "geometry above floor + this blocks the agent (band mode)", ge=0)
    obstacle_max_height: float = _p(0.0, "m", "geometry below floor + this blocks the agent (band mode; 0: agent.height)", ge=0)
    coverage_combine: str = _p("add", "-", "how a viewpoint's Gaussian is overlaid on M_P: add (sum, clipped to 1) or max", choices=("add","max"))
    frames_per_shard: int = _p(24, "-", "observations per compressed npz shard", ge=1)
    camera_heights: tuple[float, ...] = _p((2.0,), "m", "extra camera heights above the floor, rendered at every viewpoint and yaw with camera_height_pitches besides agent.camera_height (the agent camera cannot see the tops of shelves above it); empty: agent.camera_height only", gt=0)
    camera_height_pitches: tuple[float, ...] = _p((-40.0,), "deg", "camera pitch angles at the extra camera_heights (negative looks down)", ge=-90,le=90,min_len=1)
    targeted_views: int = _p(2, "-", "targeted views per receptacle surface after a first perception pass: cameras around it that show most of what no view showed yet (0: coverage views only, as in the paper)", ge=0)
    targeted_distance: tuple[float, ...] = _p((0.4, 2.0), "m", "targeted cameras stand on navigable cells this far (min, max) from the surface's XY box", ge=0,min_len=2,max_len=2)
    targeted_spacing: float = _p(0.3, "m", "lattice spacing of targeted camera candidates", gt=0)
    targeted_candidates: int = _p(24, "-", "at most this many candidate positions per surface (each tried at every camera height)", ge=1)
    targeted_cell: float = _p(0.03, "m", "grid cell for what part of a surface a view shows", gt=0)
    targeted_min_gain: float = _p(0.03, "-", "a targeted view must show at least this fraction of the surface's box unseen so far", ge=0,le=1)
    targeted_width: int = _p(128, "px", "image width of the depth renders that score candidates (height keeps the aspect ratio)", ge=1)


@dataclass(frozen=True)
class PerceiveConfig:
    """2D detection, back-projection, instance fusion and error correction (paper section 3.2)."""

    detector: str = _p("gt", "-", "detector plugin name (entry point group sdovon_mj.detectors)")
    detector_weights: str = _p("", "path", "local weights folder for open-vocabulary detectors")
    score_threshold: float = _p(0.3, "-", "detections below this score are dropped", ge=0,le=1)
    gt_score_noise: float = _p(0.0, "-", "std of noise added to gt detection scores (0: score 1.0)", ge=0)
    depth_noise_sigma: float = _p(0.0, "m", "Gaussian noise added to depth before back-projection (robustness tests)", ge=0)
    fusion_preset: str = _p("paper", "-", "paper (k_sem 0.4 / k_geo 1.6 / phi_min 0.8), conceptgraphs, or custom (use k_sem/k_geo/phi_min as given)", choices=("paper","conceptgraphs","custom"))
    k_sem: float = _p(0.4, "-", "weight of the label-embedding similarity term", "k_sem", ge=0)
    k_geo: float = _p(1.6, "-", "weight of the point-overlap term", "k_geo", ge=0)
    phi_min: float = _p(0.8, "-", "minimum similarity for a match", "phi_min", ge=0)
    overlap_radius: float = _p(0.025, "m", "points closer than this count as overlapping", gt=0)
    voxel_size: float = _p(0.02, "m", "voxel downsampling of fused instances", gt=0)
    iou_min: float = _p(0.9, "-", "3D box IoU for fusion error correction", "IoU_min", ge=0,le=1)
    min_points: int = _p(30, "-", "instances with fewer points are dropped", ge=1)
    depth_min: float = _p(0.1, "m", "depth below this is not back-projected", ge=0)
    depth_max: float = _p(10.0, "m", "depth above this is not back-projected", gt=0)
    label_similarity: str = _p("minilm", "-", "label term of fusion: minilm (cosine of all-MiniLM-L6-v2 sentence embeddings, clipped to [0, 1]) or exact (1 if equal else 0)", choices=("minilm","exact"))
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
    llm_share: float = _p(0.05, "-", "when fewer than this share of the fused instances match labels (node-named artist scenes), the LLM backend also names receptacles among the instance labels (prompt C.1); 0: never", ge=0, le=1)
    eps_t: float = _p(0.03, "m", "plane slab thickness", "epsilon_t", gt=0)
    rho_min: int = _p(50, "points", "minimum points in a slab to try a plane", "rho_min", ge=1)
    eps_c: float = _p(0.95, "-", "convergence: fraction of inliers kept between iterations", "epsilon_c", gt=0,le=1)
    max_em_iterations: int = _p(20, "-", "cap on EM iterations per slab", ge=1)
    max_normal_tilt: float = _p(10.0, "deg", "planes tilted more than this from +Z are rejected", ge=0,le=90)
    min_plane_area: float = _p(0.01, "m^2", "planes smaller than this are rejected", ge=0)
    merge_height_tol: float = _p(0.02, "m", "planes closer than this in height (and overlapping) are merged", ge=0)
    coverage_cell: float = _p(0.05, "m", "XY grid cell for plane connectivity, hull coverage and clearance tests", gt=0)
    min_coverage: float = _p(0.5, "-", "planes whose hull cells hold inlier points less often than this are rejected (slabs through legs or walls)", ge=0,le=1)
    min_clearance: float = _p(0.10, "m", "free height needed above a plane; receptacle points in (eps_t, this] above it count as covering", ge=0)
    max_covered: float = _p(0.5, "-", "planes with more than this fraction of their points covered from just above are rejected (undersides)", ge=0,le=1)
    clearance_radius: float = _p(0.015, "m", "XY radius within which a receptacle point above a plane point covers it", gt=0)
    fit_band: float = _p(0.01, "m", "final fit and polygon use the densest layer of this half-thickness (vertical faces within eps_t excluded); 0: off", ge=0)
    min_width: float = _p(0.15, "m", "support regions narrower than this are cut off (strips around a sink, points seen through a gap); real shelves are >= 0.2 m deep", ge=0)
    open_cell: float = _p(0.025, "m", "XY grid cell of the min_width opening", gt=0)
    min_seen_above: float = _p(0.5, "-", "planes whose inliers were seen from above (by a camera centre more than seen_above_margin higher than the point) less often than this are rejected: an up-facing surface is visible only from above, so a closed box's underside (a wall cabinet's bottom) is no support surface; instances without recorded view heights are not tested; 0: off", ge=0, le=1)
    seen_above_margin: float = _p(0.02, "m", "a camera centre counts as above a point when higher than it by more than this (depth noise on grazing views)", ge=0)


@dataclass(frozen=True)
class SemanticsConfig:
    """LLM backends, region map and relevance (paper section 3.4, appendix C)."""

    backend: str = _p("offline", "-", "LLM backend plugin (offline, ollama, openai, ...)")
    model: str = _p("", "-", "model name for server backends (e.g. llama3.1:8b)")
    url: str = _p("", "-", "server base URL (ollama default http://localhost:11434)")
    timeout_s: float = _p(60.0, "s", "per-request timeout", gt=0)
    retries: int = _p(3, "-", "re-asks after an invalid reply / retries after a transport error", ge=0)
    fallback: str = _p("offline", "-", "backend to fall back to after the retries ('' = fail)")
    offline_model: str = _p("learned", "-", "offline relevance: learned (trained on human votes, tools/train_semantics.py) or table (the curated priors)", choices=("learned", "table"))
    window_radius: float = _p(2.5, "m", "sliding window radius (walls cut windows, so a window may span a room; bench/bench_regions.py)", "r", gt=0)
    window_step: float = _p(0.5, "m", "sliding window step", "Delta d", gt=0)
    region_labels: tuple[str, ...] = _p(
        ("kitchen", "living room", "bedroom", "bathroom", "office", "dining room"),
        "-", "region vocabulary offered to the region-proposal prompt", min_len=1)
    cache: bool = _p(True, "-", "cache LLM replies on disk")
    backoff_s: float = _p(0.5, "s", "first wait before retrying a failed request (doubles each retry)", ge=0)
    temperature: float = _p(0.0, "-", "sampling temperature sent to server backends", ge=0)
    seed: int = _p(0, "-", "sampling seed sent to server backends (the cache, not the seed, makes re-runs exact)", ge=0)
    window_walls: bool = _p(True, "-", "walls cut windows: a window covers only the floor space connected to its centre (False: the paper's plain disc)")
    region_votes: str = _p("walking", "-", "region-map window votes weighed by walking distance on the floor space from the window centre (walking; the window is the cells within r walk) or by straight-line distance (euclidean; always with window_walls=False; bench/bench_regions.py)", choices=("walking", "euclidean"))
    regions: str = _p("window", "-", "region map: window (LLM sliding window, the paper) or input (the scene's own region annotations: HM3D/MP3D regions, Habitat region_annotations)", choices=("window", "input"))


# The habit model's default table (place.day_rates): overnight (move, leave) probabilities per category of the default
# world. Things used and put down through the day (cups, mugs, phones, remotes) move most; furnishings (lamps, vases,
# plants, pillows) and shelved things (books) stay; food and disposables (fruit, cans, bottles) leave most.
DAY_RATES: tuple[str, ...] = (
    "alarm_clock: 0.03 0.01", "apple: 0.10 0.30", "banana: 0.10 0.30", "book: 0.05 0.02", "bottle: 0.20 0.15",
    "bowl: 0.25 0.05", "can: 0.20 0.25", "candle: 0.05 0.05", "cereal_box: 0.10 0.10", "cup: 0.35 0.05",
    "keyboard: 0.03 0.01", "knife: 0.25 0.03", "lamp: 0.02 0.01", "laptop: 0.30 0.05", "mug: 0.35 0.05",
    "phone: 0.40 0.10", "pillow: 0.10 0.01", "plate: 0.25 0.03", "potted_plant: 0.02 0.01", "remote: 0.35 0.02",
    "shoe: 0.20 0.10", "soap_dispenser: 0.02 0.02", "spoon: 0.25 0.03", "stuffed_toy: 0.20 0.05", "teapot: 0.10 0.02",
    "toothbrush: 0.03 0.02", "towel: 0.15 0.10", "vase: 0.02 0.01", "wine_glass: 0.25 0.03",
)


def day_rates(cfg: "PlaceConfig", source: str = "") -> dict[str, tuple[float, float]]:
    """Return category -> (move, leave) overnight probabilities from ``place.day_rates``; raise ConfigError naming a
    malformed entry (``category: move leave``, both in [0, 1], their sum at most 1)."""
    where = f" in {source}" if source else ""
    out: dict[str, tuple[float, float]] = {}
    for entry in cfg.day_rates:
        head, _, tail = str(entry).partition(":")
        try:
            move, leave = (float(x) for x in tail.split())
        except ValueError:
            raise ConfigError(f"config key 'place.day_rates'{where}: entry {entry!r} is not 'category: move leave'") from None
        if not head.strip() or not (0 <= move <= 1 and 0 <= leave <= 1 and move + leave <= 1):
            raise ConfigError(f"config key 'place.day_rates'{where}: entry {entry!r} needs a category and move, leave in "
                              "[0, 1] with move + leave <= 1")
        out[head.strip()] = (move, leave)
    return out


@dataclass(frozen=True)
class PlaceConfig:
    """Semantic placement and physical settling (paper section 3.4)."""

    k_v: int = _p(2, "-", "variants per scene", "k_v", ge=1)
    m: int = _p(3, "-", "categories sampled per (receptacle plane, region)", "m", ge=1)
    max_objects: int = _p(30, "-", "cap on objects per variant", ge=1)
    temperature: float = _p(1.0, "-", "softmax temperature over joint relevance", gt=0)
    top_k: int = _p(8, "-", "sample among the top-k categories of each (region, receptacle)", ge=1)
    top_pairs: int = _p(3, "-", "each category goes only to the k (region, receptacle) pairs of the scene where it belongs most (Relevance.top_pairs; a pair no category counts among its k takes any); 0: anywhere", ge=0)
    min_distance: float = _p(0.05, "m", "minimum gap between object footprints", ge=0)
    h_spawn: float = _p(0.3, "m", "spawn height above the plane", "h_spawn", ge=0)
    spawn_mode: str = _p("paper", "-", "paper (random X/Y/Z rotation from h_spawn) or stable (stable pose, random yaw, small drop)", choices=("paper","stable"))
    stable_drop: float = _p(0.02, "m", "drop height in stable mode", ge=0)
    timestep: float = _p(0.002, "s", "physics timestep while settling", gt=0)
    max_settle_time: float = _p(3.0, "s", "cap on simulated settling time", gt=0)
    settle_window: float = _p(0.2, "s", "speeds must stay below thresholds this long", gt=0)
    lin_vel_tol: float = _p(0.01, "m/s", "settled linear speed", gt=0)
    ang_vel_tol: float = _p(0.1, "rad/s", "settled angular speed", gt=0)
    resample_attempts: int = _p(2, "-", "resampling rounds for failed objects", ge=0)
    support_thickness: float = _p(0.05, "m", "thickness of support prisms built from receptacle polygons (thin ones let heavy objects sink in)", gt=0)
    support_hfield: bool = _p(False, "-", "use a heightfield from ray casts on the scene mesh where a plane's surface is not flat")
    hfield_resolution: float = _p(0.02, "m", "heightfield raster step", gt=0)
    hfield_flatness: float = _p(0.01, "m", "surfaces whose height range is below this keep the flat prism", ge=0)
    check_every: int = _p(25, "steps", "settling checks object speeds every this many physics steps", ge=1)
    fell_drop: float = _p(0.1, "m", "an object whose centre ends this far below its plane (or on a floor) fell", gt=0)
    sleep: bool = _p(True, "-", "let MuJoCo put resting objects to sleep while settling (faster; speeds are still checked)")
    support_condim: int = _p(6, "-", "contact dimension of support geoms: 6 adds torsional and rolling friction so round objects stop", choices=(1,3,4,6))
    part_open_p: float = _p(0.3, "-", "articulated scenes: probability that a variant leaves a door/drawer open (relative to part_closed_p and part_ajar_p)", ge=0)
    part_closed_p: float = _p(0.5, "-", "articulated scenes: probability that a variant closes a door/drawer", ge=0)
    part_ajar_p: float = _p(0.2, "-", "articulated scenes: probability that a variant leaves a door/drawer ajar", ge=0)
    part_ajar: tuple[float, float] = _p((0.15, 0.5), "-", "an ajar part is open a uniform fraction of its range in this interval", ge=0, le=1, min_len=2)
    part_settle_time: float = _p(0.5, "s", "articulated scenes: simulated time objects settle on the real shelves with the parts open, and again after the parts moved to the variant's state", gt=0)
    part_move_tol: float = _p(0.05, "m", "articulated scenes: an object that moves more than this relative to its shelf or drawer when the parts move is classified displaced (or tunnelled, when it left the piece)", gt=0)
    days: int = _p(0, "-", "days in each scene's chain of days (docs/days.md): day 0 is placed as a variant, each next day derives from the one before by the habit model (objects stay, move, leave, arrive); 0: no chain", ge=0, quiet=True)
    day_move: float = _p(0.15, "-", "days: probability that an object of a category day_rates does not name moves to another receptacle overnight", ge=0, le=1, quiet=True)
    day_leave: float = _p(0.05, "-", "days: probability that an object of a category day_rates does not name leaves overnight", ge=0, le=1, quiet=True)
    day_arrive: float = _p(0.05, "-", "days: new objects arriving overnight per object present (each present object brings one with this probability; category and receptacle drawn as place draws them)", ge=0, le=1, quiet=True)
    day_rates: tuple[str, ...] = _p(DAY_RATES, "-", "days: per category 'category: move leave' (overnight probabilities; a category not named takes day_move and day_leave)", quiet=True)


@dataclass(frozen=True)
class EpisodeConfig:
    """ObjectNav episode generation (paper section 3.5)."""

    k_e: int = _p(3, "-", "episodes per object category per variant", "k_e", ge=1)
    viewpoint_radius: float = _p(1.0, "m", "goal view points lie within this distance of the object", gt=0)
    max_viewpoints: int = _p(0, "-", "cap on view points per goal object (0: none; a cap thins the dense lattice, so a fair stop near the object may miss every view point)", ge=0)
    min_start_distance: float = _p(1.0, "m", "start filter (Habitat closest_dist_limit): minimum geodesic distance from start to the nearest view point", ge=0)
    max_start_distance: float = _p(30.0, "m", "start filter (Habitat furthest_dist_limit): maximum geodesic distance from start to the nearest view point", gt=0)
    start_ratio_threshold: float = _p(1.05, "-", "start filter (Habitat geodesic_to_euclid_min_ratio): a start whose geodesic / Euclidean distance to the nearest view point is below this is kept only with probability 20 * (ratio - 0.98)^2; 1 or less: off", ge=0)
    max_start_tries: int = _p(200, "-", "start pose draws per episode", ge=1)
    success_distance: float = _p(0.1, "m", "success radius around view points", gt=0)
    viewpoint_step: float = _p(0.0, "m", "lattice step of view point candidates; 0: the sparsest lattice of navmap cells that puts every cell within success_distance of a lattice point (0.15 m on a 0.05 m map for 0.1 m); cells near the edge of the seen area are tested at the map resolution too", ge=0)
    vis_width: int = _p(160, "px", "width of the visibility-check segmentation render", ge=1)
    vis_height: int = _p(120, "px", "height of the visibility-check segmentation render", ge=1)
    pitches: tuple[float, ...] = _p((-30.0, 0.0), "deg", "pitches tried after the one aimed at the object centre", ge=-90,le=90)


@dataclass(frozen=True)
class NavConfig:
    """Actions, step limit and the A* baselines (appendix D); the agent's body and camera are `AgentConfig`."""

    forward_step: float = _p(0.25, "m", "MOVE_FORWARD distance", gt=0)
    turn_angle: float = _p(30.0, "deg", "TURN_LEFT/TURN_RIGHT angle", gt=0,le=180)
    tilt_angle: float = _p(30.0, "deg", "LOOK_UP/LOOK_DOWN angle", gt=0,le=90)
    max_steps: int = _p(500, "-", "episode step limit", ge=1)
    eps_nav: float = _p(0.5, "m", "navigation error tolerance", "epsilon_nav", gt=0)
    d_next: float = _p(1.0, "m", "minimum distance to the next navigation point", "d_next", ge=0)
    final_nav: bool = _p(True, "-", "final point-goal navigation after detection (FN)")
    look_yaws: int = _p(6, "-", "A* agents: views around the yaw axis at each navigation point, the paper's Observe o ~ O(p|s) (section 3.1: the camera rotated at predefined yaw and pitch intervals): 360 deg / look_yaws apart, the first facing the receptacle, each at pitches 0 and -tilt_angle, until the goal is detected; 1: facing the receptacle only", ge=1)
    depth_min: float = _p(0.5, "m", "agent depth sensor minimum", ge=0)
    depth_max: float = _p(5.0, "m", "agent depth sensor maximum", gt=0)
    max_tilt: float = _p(60.0, "deg", "LOOK_UP/LOOK_DOWN camera pitch limit", ge=0,le=90)
    success_distance: float = _p(0.1, "m", "STOP within this geodesic distance of a view point succeeds", gt=0)
    fn_viewpoint_radius: float = _p(1.0, "m", "FN: inferred view points (lattice) and the places the retry FN tries when the object is not in view lie within this distance of the detected object", gt=0)
    fn_viewpoint_step: float = _p(0.25, "m", "FN: lattice step of inferred view points (as the episode generator's)", gt=0)
    fn_max_checks: int = _p(4, "-", "FN: places walked to and checked by looking, at most (lattice: inferred view points; retry: where Navigate stopped, then other places within fn_viewpoint_radius of the object)", ge=1)
    fn_mode: str = _p("paper", "-", "FN after a detection: paper (the paper's: Navigate(p_g | eps_nav) to the detected object's centre, then STOP), retry (ours: Navigate, then STOP where the object is in view within the view radius, trying up to fn_max_checks places) or lattice (ours: walk to inferred view points on the episode generator's lattice and check each by looking)", choices=("paper", "retry", "lattice"))
    map_size: float = _p(40.0, "m", "side of the square map an agent builds around where it starts (its own frame)", gt=0)
    map_resolution: float = _p(0.05, "m", "cell size of the agent's own occupancy map", gt=0)
    frontier_radius: float = _p(2.0, "m", "no-prior agent: labels detected within this distance of a frontier score it", gt=0)
    open_reach: float = _p(1.5, "m", "OPEN/CLOSE: an articulated part (door, drawer) is within reach when the nearest point of its box is this close to the agent camera", gt=0)


@dataclass(frozen=True)
class RunConfig:
    """The whole pipeline: one config file for `sdovon-mj generate`."""

    seed: int = _p(0, "-", "master seed; per-scene and per-variant seeds are derived from it", ge=0)
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
    # and k_geo with the label term (names swapped, see docs/choices.md). We follow the
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


def to_dict(cfg: Any, full: bool = False) -> dict[str, Any]:
    """Return a config as plain YAML-able data (tuples become lists); quiet keys at their default left out (`_p`)
    unless `full`."""
    out: dict[str, Any] = {}
    for f in fields(cfg):
        v = getattr(cfg, f.name)
        if not full and f.metadata.get("quiet") and v == f.default:  # a later key at its default: older bytes kept
            continue
        if is_dataclass(v):
            out[f.name] = to_dict(v, full)
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
    out = cls(**kwargs)
    _check_fields(out, source, prefix)  # declared ranges and choices (cross-field rules: `validate`)
    return out


def _closest(key: str, known: set[str]) -> str:
    """Return the known key nearest to a misspelt one, or ''."""
    import difflib

    m = difflib.get_close_matches(key, sorted(known), n=1, cutoff=0.6)
    return m[0] if m else ""


# unit names the converter knows (assets_convert.load.UNIT_NAMES; the core may not import it)
_UNIT_WORDS = ("auto", "m", "cm", "mm", "in", "ft")
_UP_WORDS = ("auto", "x", "y", "z", "+x", "-x", "+y", "-y", "+z", "-z")


def _allowed(meta: Any) -> str:
    """Return the allowed values of a field's metadata as text (e.g. '>= 0 and <= 1', 'one of: a, b')."""
    if meta.get("choices") is not None:
        return "one of: " + ", ".join(str(c) for c in meta["choices"])
    ops = {"ge": ">=", "gt": ">", "le": "<=", "lt": "<"}
    return " and ".join(f"{ops[k]} {v:g}" for k, v in meta.get("limits", {}).items())


def allowed_text(key: str, meta: Any) -> str:
    """Return what a field accepts, as the configuration reference prints it ('' when anything of its type goes).

    ``key`` is the dotted key (``convert.units``), ``meta`` the field's metadata: its range or choices (for a tuple,
    each element's), the tuple's length bounds, and the words `validate` accepts for ``convert.units`` / ``convert.up``.
    """
    if key == "convert.units":
        return ", ".join(_UNIT_WORDS) + " or a positive number of metres per file unit"
    if key == "convert.up":
        return ", ".join(_UP_WORDS) + " (any case)"
    parts = [_allowed(meta)] if (meta.get("choices") is not None or meta.get("limits")) else []
    lo, hi = meta.get("min_len"), meta.get("max_len")
    if lo is not None and lo == hi:
        parts.append(f"{lo} values")
    elif lo is not None or hi is not None:
        parts.append(" and ".join(t for t in (f"at least {lo} value{'s' if lo != 1 else ''}" if lo is not None else "",
                                              f"at most {hi} values" if hi is not None else "") if t))
    return "; ".join(parts)


def _field_problem(value: Any, meta: Any) -> str:
    """Return what is wrong with a field value under its declared range/choices ('' when it is allowed)."""
    items = value if isinstance(value, tuple) else (value,)
    if isinstance(value, tuple):
        lo, hi = meta.get("min_len"), meta.get("max_len")
        if lo is not None and len(value) < lo:
            return f"needs at least {lo} value{'s' if lo > 1 else ''}" + (f" and at most {hi}" if hi is not None else "")
        if hi is not None and len(value) > hi:
            return f"takes at most {hi} value{'s' if hi > 1 else ''}"
    choices = meta.get("choices")
    limits = meta.get("limits") or {}
    for v in items:
        if choices is not None and v not in choices:
            return f"allowed: {_allowed(meta)}"
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            if v != v or v in (float("inf"), float("-inf")):
                return "must be a finite number"
            bad = (("ge" in limits and not v >= limits["ge"]) or ("gt" in limits and not v > limits["gt"])
                   or ("le" in limits and not v <= limits["le"]) or ("lt" in limits and not v < limits["lt"]))
            if bad:
                return f"allowed: {_allowed(meta)}"
    return ""


def _check_fields(cfg: Any, source: str, prefix: str) -> None:
    """Raise ConfigError for the first field of one config section outside its declared range or choices."""
    where = f" in {source}" if source else ""
    for f in fields(cfg):
        v = getattr(cfg, f.name)
        if is_dataclass(v):
            continue
        problem = _field_problem(v, f.metadata)
        if problem:
            shown = list(v) if isinstance(v, tuple) else v
            raise ConfigError(f"config key '{prefix}{f.name}'{where}: value {shown!r} is out of range ({problem})")
    if isinstance(cfg, ConvertConfig):
        u = cfg.units.strip().lower()
        if u not in _UNIT_WORDS:
            try:
                ok = 0.0 < float(u) < float("inf")
            except ValueError:
                ok = False
            if not ok:
                raise ConfigError(f"config key '{prefix}units'{where}: value {cfg.units!r} is out of range "
                                  f"(allowed: {', '.join(_UNIT_WORDS)} or a positive number of metres per file unit)")
        if cfg.up.strip().lower() not in _UP_WORDS:
            raise ConfigError(f"config key '{prefix}up'{where}: value {cfg.up!r} is out of range "
                              "(allowed: auto, +X, -X, +Y, -Y, +Z, -Z)")


def check_cross_fields(cfg: RunConfig, source: str = "") -> None:
    """Raise ConfigError when values that constrain each other disagree (e.g. ``observe.r_min < observe.r_max``).

    ``source`` names where the values came from (a file, ``--set``), for the message.
    """
    where = f" in {source}" if source else ""
    o, a = cfg.observe, cfg.agent

    def need(ok: bool, keys: str, what: str) -> None:
        if not ok:
            raise ConfigError(f"config keys {keys}{where}: {what}")

    need(o.r_min < o.r_max, "'observe.r_min', 'observe.r_max'", f"r_min ({o.r_min:g}) must be below r_max ({o.r_max:g})")
    pl = cfg.place
    day_rates(pl, source)
    need(pl.day_move + pl.day_leave <= 1, "'place.day_move', 'place.day_leave'",
         f"their sum ({pl.day_move + pl.day_leave:g}) must not exceed 1")
    for sec in ("observe", "perceive", "nav"):
        s = getattr(cfg, sec)
        need(s.depth_min < s.depth_max, f"'{sec}.depth_min', '{sec}.depth_max'",
             f"depth_min ({s.depth_min:g}) must be below depth_max ({s.depth_max:g})")
    lo, hi = o.targeted_distance
    need(lo <= hi, "'observe.targeted_distance'", f"the minimum ({lo:g}) must not exceed the maximum ({hi:g})")
    band = o.obstacle_min_height
    need(a.height > band, "'agent.height', 'observe.obstacle_min_height'",
         f"the agent height ({a.height:g} m) must lie above the floor band ({band:g} m)")
    need(a.camera_height > band, "'agent.camera_height', 'observe.obstacle_min_height'",
         f"the camera height ({a.camera_height:g} m) must lie above the floor band ({band:g} m)")
    for h in o.camera_heights:
        need(h > band, "'observe.camera_heights', 'observe.obstacle_min_height'",
             f"camera height {h:g} m must lie above the floor band ({band:g} m)")
    need(o.obstacle_max_height == 0 or o.obstacle_max_height > band,
         "'observe.obstacle_max_height', 'observe.obstacle_min_height'",
         f"the obstacle band top ({o.obstacle_max_height:g} m; 0 = agent.height) must lie above its bottom ({band:g} m)")
    need(o.h_map > 0 and (o.nav_slice != "plane" or o.h_map < a.height), "'observe.h_map', 'agent.height'",
         f"the map slice ({o.h_map:g} m) must lie below the agent height ({a.height:g} m)")
    pc = cfg.place
    need(pc.part_open_p + pc.part_closed_p + pc.part_ajar_p > 0, "'place.part_open_p', 'place.part_closed_p', 'place.part_ajar_p'",
         "the part state probabilities must not all be 0")
    need(len(pc.part_ajar) == 2 and 0 <= pc.part_ajar[0] <= pc.part_ajar[1] <= 1, "'place.part_ajar'",
         f"must be two fractions 0 <= lo <= hi <= 1, got {list(pc.part_ajar)}")
    w = cfg.world
    need(w.floors != 3 or w.preset == "house", "'world.floors', 'world.preset'",
         f"3 storeys are a house's, not an {w.preset}'s (apartments have 1 or 2)")
    e = cfg.episodes
    need(e.min_start_distance < e.max_start_distance, "'episodes.min_start_distance', 'episodes.max_start_distance'",
         f"min_start_distance ({e.min_start_distance:g} m) must be below max_start_distance ({e.max_start_distance:g} m)")


def validate(cfg: RunConfig, source: str = "") -> RunConfig:
    """Check every field's declared range/choices and the cross-field rules; return `cfg` or raise ConfigError.

    `load_config` and `apply_overrides` call it; the message names the key, the value, what is allowed
    and ``source`` (the file or ``--set``).
    """
    def walk(c: Any, prefix: str) -> None:
        _check_fields(c, source, prefix)
        for f in fields(c):
            v = getattr(c, f.name)
            if is_dataclass(v):
                walk(v, f"{prefix}{f.name}.")

    walk(cfg, "")
    check_cross_fields(cfg, source)
    return cfg


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
        except UnicodeDecodeError as e:
            raise ConfigError(f"config file {path} is not UTF-8 text ({e.reason} at byte {e.start})") from None
        except OSError as e:
            raise ConfigError(f"config file {path} cannot be read: {e.strerror or e}") from None
        try:
            data = yaml.safe_load(text) or {}
        except yaml.YAMLError as e:
            raise ConfigError(f"config file {path} is not valid YAML: {e}") from None
    explicit = {f"{sec}.{k}" for sec, v in data.items() if isinstance(v, dict) for k in v} if isinstance(data, dict) else set()
    cfg = from_dict(RunConfig, data, source)
    return apply_overrides(cfg, overrides, explicit, source=source)


def apply_overrides(cfg: RunConfig, overrides: list[str] | tuple[str, ...], explicit: set[str] | frozenset[str] = frozenset(),
                    source: str = "") -> RunConfig:
    """Apply dotted KEY=VALUE overrides (values parsed as YAML scalars or lists), resolve presets, validate.

    ``explicit`` names keys (``section.key``) the caller set besides the overrides (a YAML file's);
    an explicit fusion weight wins over the fusion preset (see `resolve_fusion_preset`). Each override is
    checked against its field's declared range/choices (the error names it), then the whole config against
    the cross-field rules (`validate`; ``source``, the config file, is named in their messages).
    """
    data = to_dict(cfg, full=True)
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
        try:
            from_dict(RunConfig, data, f"--set {item}")
        except ConfigError as e:
            if key.strip() in str(e):  # this override is the bad value; other keys are checked below
                raise
    out = from_dict(RunConfig, data, "--set")
    out = replace(out, perceive=resolve_fusion_preset(out.perceive, {k.split(".", 1)[1] for k in explicit if k.startswith("perceive.")}))
    labels = [s for s in (source, "--set " + " ".join(overrides) if overrides else "") if s]
    return validate(out, " with ".join(labels))


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
