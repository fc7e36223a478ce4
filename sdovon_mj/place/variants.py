"""Scene variants: sample, settle, resample failures, keep what rests on its plane, write the model.

`place_variant` is deterministic: the same inputs and seed give the same records and bytes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..config import PlaceConfig
from ..records import ObjectAsset, Placement, ReceptaclePlane, Relevance, SceneAsset, SceneVariant, save_json
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


def variant_seed(scene_seed: int, index: int) -> int:
    """Return the seed of variant `index` of a scene, derived from the scene seed."""
    return int(np.random.SeedSequence([int(scene_seed) & 0xFFFFFFFF, int(index), 0x5D0]).generate_state(1)[0])


def variant_paths(scene_name: str, index: int) -> tuple[str, str]:
    """Return the store-relative paths of a variant's composed MJCF and its record."""
    name = f"{scene_name}_v{index:03d}"
    return f"scenes/{scene_name}/variants/{name}/variant.xml", f"scenes/{scene_name}/variants/{name}/variant.json"


def run_variant(scene: SceneAsset, planes: list[ReceptaclePlane], relevance: Relevance, objects: list[ObjectAsset],
                store_root: str | Path, cfg: PlaceConfig, seed: int, index: int, write: bool = True,
                out_root: str | Path | None = None) -> tuple[SceneVariant, VariantStats]:
    """Place and settle one variant; return it with its timing (writes model + record under out_root when `write`)."""
    stats = VariantStats()
    c0 = time.process_time()
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    sampled = sample_placements(planes, relevance, objects, cfg, rng)
    notes = list(sampled.notes)
    placements = sampled.placements
    stats.sample_s = time.perf_counter() - t0
    assets = {a.name: a for a in objects}
    plane_by_id = {p.id: p for p in planes}
    kept: list[Placement] = []
    if placements:
        t1 = time.perf_counter()
        composed = compose(placements, assets, planes, scene, store_root, cfg)
        settler = Settler(composed, placements, planes, cfg)
        for i, p in enumerate(placements):
            settler.set_pose(i, p.spawn_pos, p.spawn_quat)
        stats.compose_s = time.perf_counter() - t1
        t2 = time.perf_counter()
        while True:
            stats.rounds += 1
            st = settler.run()
            stats.sim_time += st.sim_time
            stats.steps += st.steps
            stats.settled = stats.settled and st.settled
            judged = [i for i in range(len(placements)) if settler.live[i] or i in settler.fell_early]
            verdicts = {i: settler.classify(i) for i in judged}
            resampled = False
            for i in judged:
                p, v = placements[i], verdicts[i]
                p.status, p.reason = v.status, v.reason
                if v.status == RESTING:
                    continue
                if p.attempts <= cfg.resample_attempts:
                    others = _occupied(settler, placements, assets, cfg, p.plane_id, exclude=i)
                    plane = plane_by_id[p.plane_id]
                    pose = resample_pose(assets[p.asset], plane, others, cfg, rng, plane_headrooms(planes, cfg.support_thickness)[plane.id])
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
            if not resampled:
                break
            settler.zero_velocities()
        stats.settle_s = time.perf_counter() - t2
        for i, p in enumerate(placements):
            if p.status == RESTING:
                p.settled_pos, p.settled_quat = settler.pose(i)
                kept.append(p)
        dropped = [p for p in placements if p.status == "dropped"]
        if dropped:
            notes.append(f"dropped {len(dropped)} of {len(placements)} objects that did not come to rest on their plane: "
                         + "; ".join(f"{p.object_id} {p.category}: {p.reason}" for p in dropped))
    stats.cpu_s = time.process_time() - c0
    for p in placements:
        stats.counts[p.status] = stats.counts.get(p.status, 0) + 1
    if placements and not kept:
        notes.append("no object came to rest on its intended plane")
    variant = SceneVariant(scene=scene.name, index=index, seed=int(seed), placements=placements, notes=notes)
    variant.qpos = np.concatenate([np.concatenate([p.settled_pos, p.settled_quat]) for p in kept]).astype(np.float64) if kept else np.zeros(0)
    if write:
        t3 = time.perf_counter()
        out = Path(out_root) if out_root is not None else Path(store_root)
        write_variant_model(variant, scene, planes, objects, store_root, cfg, out)
        save_json(variant, out / variant_paths(scene.name, index)[1])
        stats.write_s = time.perf_counter() - t3
    return variant, stats


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
                        store_root: str | Path, cfg: PlaceConfig, out_root: str | Path | None = None) -> Path:
    """Write the composed MJCF (scene + support + resting objects at their settled poses); set variant.mjcf."""
    kept = [p for p in variant.placements if p.status == RESTING]
    assets = {a.name: a for a in objects}
    composed = compose(kept, assets, planes, scene, store_root, cfg, with_scene=True, visual=True)
    rel = variant_paths(scene.name, variant.index)[0]
    path = write_mjcf(composed.spec, Path(out_root if out_root is not None else store_root) / rel)
    variant.mjcf = rel
    return path


def place_variant(scene: SceneAsset, planes: list[ReceptaclePlane], relevance: Relevance, objects: list[ObjectAsset],
                  store_root: str | Path, cfg: PlaceConfig, seed: int, index: int) -> SceneVariant:
    """Place and settle one scene variant; write its model and record under `store_root`."""
    return run_variant(scene, planes, relevance, objects, store_root, cfg, seed, index)[0]


def place_variants(scene: SceneAsset, planes: list[ReceptaclePlane], relevance: Relevance, objects: list[ObjectAsset],
                   store_root: str | Path, cfg: PlaceConfig, scene_seed: int) -> list[SceneVariant]:
    """Place cfg.k_v variants of a scene, each with its seed derived from the scene seed."""
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
            inside = [r for r in scene.rooms if r.floor == floor and _in_polygon(np.asarray(r.polygon, float), c)]
            room = inside[0].id if inside else -1
        region = rooms[room].type if room in rooms else ""
        out.append(ReceptaclePlane(id=k, instance_id=s.instance_id, label=label, height=float(s.height),
                                   polygon=poly, normal=np.array([0.0, 0.0, 1.0]), region=region, floor=max(floor, 0)))
    return out


def _in_polygon(polygon: np.ndarray, xy: np.ndarray) -> bool:
    """Return whether a point lies in a (possibly non-convex) polygon (even-odd rule)."""
    x, y = float(xy[0]), float(xy[1])
    inside = False
    n = len(polygon)
    for i in range(n):
        x1, y1 = polygon[i]
        x2, y2 = polygon[(i + 1) % n]
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


__all__ = ["place_variant", "place_variants", "run_variant", "variant_seed", "variant_paths", "planes_from_scene",
           "write_variant_model", "VariantStats"]
