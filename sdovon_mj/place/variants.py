"""Scene variants: sample, settle, resample failures, keep what rests on its plane, write the model.

`place_variant` is deterministic: the same inputs and seed give the same records and bytes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..config import PlaceConfig
from ..geometry import points_in_polygon
from ..records import ObjectAsset, Placement, ReceptaclePlane, Relevance, SceneAsset, SceneVariant, save_json
from ..runview import RunLayout
from ..seeds import variant_seed
from .compose import compose, write_mjcf
from .sample import object_radius, plane_headrooms, resample_pose, sample_placements
from .settle import RESTING, Settler


@dataclass
class VariantStats:
    """Wall seconds and physics figures of one variant (kept out of the records: they vary run to run)."""

    sample_s: float = 0.0
    compose_s: float = 0.0
    settle_s: float = 0.0
    write_s: float = 0.0
    sim_time: float = 0.0
    steps: int = 0
    rounds: int = 0
    cpu_s: float = 0.0  # process CPU seconds of sampling + composing + settling (robust to a loaded machine)
    settled: bool = True
    counts: dict[str, int] = field(default_factory=dict)

    @property
    def place_s(self) -> float:
        """Return the wall seconds of sampling + composing + settling (no writing)."""
        return self.sample_s + self.compose_s + self.settle_s


def variant_paths(scene_name: str, index: int) -> tuple[str, str]:
    """Return the store-relative paths of a variant's composed MJCF and its record (the run layout's)."""
    name = RunLayout.variant_name(scene_name, index)
    return RunLayout.variant_mjcf(scene_name, name), RunLayout.variant_record(scene_name, name)


def run_variant(scene: SceneAsset, planes: list[ReceptaclePlane], relevance: Relevance, objects: list[ObjectAsset],
                store_root: str | Path, cfg: PlaceConfig, seed: int, index: int, write: bool = True,
                out_root: str | Path | None = None, open_parts: float = 1.0) -> tuple[SceneVariant, VariantStats]:
    """Place and settle one variant; return it with its timing (writes model + record under out_root when `write`).

    Steps: sample placements; compose the scene with the objects at their spawn poses; settle, judge
    and resample until nothing more can be retried; keep the settled poses of what rests; build the
    record; write model and record.

    Parameters
    ----------
    scene : SceneAsset
        The converted scene (world metres, Z up).
    planes : list of ReceptaclePlane
        The scene's receptacle planes objects are placed on.
    relevance : Relevance
        Object-category relevance per receptacle and region (weights of the category draw).
    objects : list of ObjectAsset
        The object library to draw instances from.
    store_root : str or Path
        Store root the scene's and objects' files are relative to.
    cfg : PlaceConfig
        Placement settings (objects per plane, spawn mode, settle limits, resample attempts).
    seed : int
        Seed of the variant's random generator (see ``seeds.variant_seed``).
    index : int
        Variant index within the scene (names ``<scene>_v<index:03d>``).
    write : bool
        Write the composed MJCF and the record.
    out_root : str or Path, optional
        Folder written into (default: `store_root`).
    open_parts : float
        Articulated scenes: fraction of their range the parts were open when the planes were found
        (``observe.open_parts``); `place.inside.articulate_variant` then sets the variant's door/drawer states.
    """
    stats = VariantStats()
    c0 = time.process_time()
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    sampled = sample_placements(planes, relevance, objects, cfg, rng)
    notes = list(sampled.notes)
    placements = sampled.placements
    stats.sample_s = time.perf_counter() - t0
    if placements:
        t1 = time.perf_counter()
        assets = {a.name: a for a in objects}
        settler = _spawned(scene, planes, assets, placements, store_root, cfg)
        stats.compose_s = time.perf_counter() - t1
        t2 = time.perf_counter()
        stats.rounds, stats.sim_time, stats.steps, stats.settled = _settle_rounds(settler, placements, assets, planes, cfg, rng)
        stats.settle_s = time.perf_counter() - t2
        _keep_settled_poses(settler, placements)
        notes += _dropped_notes(placements)
    stats.cpu_s = time.process_time() - c0
    stats.counts = _status_counts(placements)
    variant = _variant_record(scene.name, index, seed, placements, notes)
    if scene.articulated and placements:  # doors and drawers open / closed / ajar, objects settled again
        from .inside import articulate_variant

        articulate_variant(variant, scene, planes, objects, store_root, cfg, open_parts)
    if write:
        t3 = time.perf_counter()
        out = Path(out_root) if out_root is not None else Path(store_root)
        write_variant_model(variant, scene, planes, objects, store_root, cfg, out)
        save_json(variant, out / variant_paths(scene.name, index)[1])
        stats.write_s = time.perf_counter() - t3
    return variant, stats


def _spawned(scene: SceneAsset, planes: list[ReceptaclePlane], assets: dict[str, ObjectAsset],
             placements: list[Placement], store_root: str | Path, cfg: PlaceConfig) -> Settler:
    """Compose the scene's physics with the placed objects and return its settler, objects at their spawn poses."""
    composed = compose(placements, assets, planes, scene, store_root, cfg)
    settler = Settler(composed, placements, planes, cfg)
    for i, p in enumerate(placements):
        settler.set_pose(i, p.spawn_pos, p.spawn_quat)
    return settler


def _settle_rounds(settler: Settler, placements: list[Placement], assets: dict[str, ObjectAsset],
                   planes: list[ReceptaclePlane], cfg: PlaceConfig,
                   rng: np.random.Generator) -> tuple[int, float, int, bool]:
    """Settle, judge and resample until a round resamples nothing; return (rounds, sim seconds, steps, all settled)."""
    rounds, sim_time, steps, settled = 0, 0.0, 0, True
    while True:
        rounds += 1
        st = settler.run()
        sim_time += st.sim_time
        steps += st.steps
        settled = settled and st.settled
        if not _judge_round(settler, placements, assets, planes, cfg, rng):
            return rounds, sim_time, steps, settled
        settler.zero_velocities()


def _judge_round(settler: Settler, placements: list[Placement], assets: dict[str, ObjectAsset],
                 planes: list[ReceptaclePlane], cfg: PlaceConfig, rng: np.random.Generator) -> bool:
    """Set each judged object's status; respawn or drop those not resting; return whether any was respawned."""
    judged = [i for i in range(len(placements)) if settler.live[i] or i in settler.fell_early]
    verdicts = {i: settler.classify(i) for i in judged}
    resampled = False
    for i in judged:
        p, v = placements[i], verdicts[i]
        p.status, p.reason = v.status, v.reason
        if v.status == RESTING:
            continue
        if p.attempts <= cfg.resample_attempts:
            pose = _respawn_pose(settler, placements, assets, planes, cfg, rng, i)
            if pose is not None:
                settler.unpark(i)
                settler.set_pose(i, *pose)
                p.spawn_pos, p.spawn_quat = pose
                p.attempts += 1
                resampled = True
                continue
            p.reason = f"{v.status} ({v.reason}); no free spot left on its plane to retry"
        else:
            p.reason = f"{v.status} ({v.reason}) after {p.attempts} attempts"
        p.status = "dropped"
        settler.park(i)
        settler.fell_early.pop(i, None)
    return resampled


def _respawn_pose(settler: Settler, placements: list[Placement], assets: dict[str, ObjectAsset],
                  planes: list[ReceptaclePlane], cfg: PlaceConfig, rng: np.random.Generator,
                  i: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Draw a new spawn pose for object `i` on its plane, clear of the objects there now (None: no free spot)."""
    p = placements[i]
    others = _occupied(settler, placements, assets, cfg, p.plane_id, exclude=i)
    plane = {q.id: q for q in planes}[p.plane_id]
    return resample_pose(assets[p.asset], plane, others, cfg, rng, plane_headrooms(planes, cfg.support_thickness)[plane.id])


def _keep_settled_poses(settler: Settler, placements: list[Placement]) -> None:
    """Record where each resting object came to rest."""
    for i, p in enumerate(placements):
        if p.status == RESTING:
            p.settled_pos, p.settled_quat = settler.pose(i)


def _dropped_notes(placements: list[Placement]) -> list[str]:
    """Return the note on the dropped objects and why each was dropped (none when nothing was)."""
    dropped = [p for p in placements if p.status == "dropped"]
    if not dropped:
        return []
    return [f"dropped {len(dropped)} of {len(placements)} objects that did not come to rest on their plane: "
            + "; ".join(f"{p.object_id} {p.category}: {p.reason}" for p in dropped)]


def _status_counts(placements: list[Placement]) -> dict[str, int]:
    """Return status -> number of placements (in order of first appearance)."""
    counts: dict[str, int] = {}
    for p in placements:
        counts[p.status] = counts.get(p.status, 0) + 1
    return counts


def _variant_record(scene_name: str, index: int, seed: int, placements: list[Placement], notes: list[str]) -> SceneVariant:
    """Return the variant record; its qpos holds (position, quaternion) of each resting object in order."""
    kept = [p for p in placements if p.status == RESTING]
    if placements and not kept:
        notes = notes + ["no object came to rest on its intended plane"]
    variant = SceneVariant(scene=scene_name, index=index, seed=int(seed), placements=placements, notes=notes)
    variant.qpos = np.concatenate([np.concatenate([p.settled_pos, p.settled_quat]) for p in kept]).astype(np.float64) if kept else np.zeros(0)
    return variant


def _occupied(settler: Settler, placements: list[Placement], assets: dict[str, ObjectAsset], cfg: PlaceConfig,
              plane_id: int, exclude: int) -> list[tuple[np.ndarray, float]]:
    """Return (xy, radius) of the live objects on a plane, where they are now."""
    out = []
    for j, q in enumerate(placements):
        if j == exclude or not settler.live[j] or q.plane_id != plane_id:
            continue
        com = settler.d.xipos[settler.c.body_ids[j]]
        out.append((com[:2].copy(), object_radius(assets[q.asset], cfg.spawn_mode)))
    return out


def write_variant_model(variant: SceneVariant, scene: SceneAsset, planes: list[ReceptaclePlane], objects: list[ObjectAsset],
                        store_root: str | Path, cfg: PlaceConfig, out_root: str | Path | None = None,
                        rel: str | None = None) -> Path:
    """Write the composed MJCF (scene + support + resting objects at their settled poses); set variant.mjcf.

    Parameters
    ----------
    variant : SceneVariant
        The settled variant (its ``mjcf`` is set here).
    scene : SceneAsset
        The converted scene.
    planes : list of ReceptaclePlane
        The scene's receptacle planes.
    objects : list of ObjectAsset
        The object library.
    store_root : str or Path
        Store root the scene's and objects' files are relative to.
    cfg : PlaceConfig
        Placement and physics settings.
    out_root : str or Path, optional
        Folder written into (default: `store_root`).
    rel : str, optional
        The model's path relative to `out_root` (default: the variant's, `variant_paths`; a day of a chain: its own).
    """
    kept = [p for p in variant.placements if p.status == RESTING]
    assets = {a.name: a for a in objects}
    if scene.articulated:  # planes inside a door or drawer: the piece's own shelves hold the objects
        planes = [p for p in planes if p.part is None]
    composed = compose(kept, assets, planes, scene, store_root, cfg, with_scene=True, visual=True)
    rel = rel if rel is not None else variant_paths(scene.name, variant.index)[0]
    path = write_mjcf(composed.spec, Path(out_root if out_root is not None else store_root) / rel)
    variant.mjcf = rel
    return path


def place_variant(scene: SceneAsset, planes: list[ReceptaclePlane], relevance: Relevance, objects: list[ObjectAsset],
                  store_root: str | Path, cfg: PlaceConfig, seed: int, index: int, open_parts: float = 1.0) -> SceneVariant:
    """Place and settle one scene variant; write its model and record under `store_root`.

    Parameters are those of `run_variant`.
    """
    return run_variant(scene, planes, relevance, objects, store_root, cfg, seed, index, open_parts=open_parts)[0]


def place_variants(scene: SceneAsset, planes: list[ReceptaclePlane], relevance: Relevance, objects: list[ObjectAsset],
                   store_root: str | Path, cfg: PlaceConfig, scene_seed: int) -> list[SceneVariant]:
    """Place cfg.k_v variants of a scene, each with its seed derived from the scene seed.

    Parameters
    ----------
    scene, planes, relevance, objects, store_root, cfg : as in `run_variant`
    scene_seed : int
        Seed of the scene; each variant's seed derives from it.
    """
    return [place_variant(scene, planes, relevance, objects, store_root, cfg, variant_seed(scene_seed, k), k)
            for k in range(cfg.k_v)]


def planes_from_scene(scene: SceneAsset) -> list[ReceptaclePlane]:
    """Return ground-truth receptacle planes from a scene's support surfaces (region = its room type).

    An instance missing from the scene's list leaves the label empty; the region then comes from the
    room whose polygon holds the surface's centre on the nearest floor below it.
    """
    rooms = {r.id: r for r in scene.rooms}
    floors = sorted(scene.floors, key=lambda f: f.height)
    out = []
    for k, s in enumerate(scene.support_surfaces):
        try:
            inst = scene.instance(s.instance_id)
            label, room, floor = inst.label, inst.room, inst.floor
        except KeyError:
            label, room, floor = "", -1, -1
        poly = np.asarray(s.polygon, float)
        if floor < 0:
            below = [f for f in floors if f.height <= s.height + 1e-6]
            floor = below[-1].index if below else 0
        if room not in rooms:
            c = poly.mean(axis=0)
            inside = [r for r in scene.rooms if r.floor == floor and points_in_polygon(r.polygon, c)[0]]
            room = inside[0].id if inside else -1
        region = rooms[room].type if room in rooms else ""
        out.append(ReceptaclePlane(id=k, instance_id=s.instance_id, label=label, height=float(s.height),
                                   polygon=poly, normal=np.array([0.0, 0.0, 1.0]), region=region, floor=max(floor, 0)))
    return out


__all__ = ["place_variant", "place_variants", "run_variant", "variant_paths", "planes_from_scene",
           "write_variant_model", "VariantStats"]
