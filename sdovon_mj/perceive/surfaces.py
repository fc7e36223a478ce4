"""Perceive a scene and find its receptacle surfaces, looking again at them (targeted views, our addition).

After a first perception pass over the coverage views, every receptacle surface (each plane; the top of a
receptacle without planes) gets cameras on navigable cells around it (`sdovon_mj.observe.targeted`); their
observations are fused into the same instances, then the planes are found again. With
``observe.targeted_views = 0`` this is perceive + planes on the coverage views alone (the paper's).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from ..config import RunConfig
from ..records import Instance, NavMap, Observation, ReceptaclePlane, SceneAsset
from ..store import atomic_write_text


def receptacle_labels(instances: list[Instance], cfg: RunConfig, backend: Any = None,
                      scene: SceneAsset | None = None) -> tuple[str, ...]:
    """Return the receptacle labels (a `receptacles.identify.ReceptacleLabels`) for a scene's fused instances.

    The configured labels; when they are empty, or when fewer than ``receptacles.llm_share`` of the instances
    are receptacles by them (an artist scene named 'Countertop_Marble', 'Kitchen_Island'), the LLM backend
    also names receptacles among the instance labels (prompt C.1). The scene's own decisions
    (``SemanticInstance.receptacle``, from ``assets.yaml``) ride along and win over the labels.
    """
    from ..receptacles.identify import ReceptacleLabels, matched_share

    forced = {int(s.id): bool(s.receptacle) for s in (scene.instances if scene is not None else [])
              if s.receptacle is not None}
    labels = ReceptacleLabels(cfg.receptacles.labels, forced)
    share = float(cfg.receptacles.llm_share)
    if labels and not (share > 0 and instances and matched_share(instances, labels) < share):
        return labels
    from ..semantics import get_backend, identify_receptacles

    ask = sorted({i.label for i in instances if forced.get(int(i.gt_id)) is None})
    named = identify_receptacles(ask, backend or get_backend(cfg.semantics)) if ask else []
    return ReceptacleLabels(list(labels) + [n for n in named if n not in labels], forced)


def view_targets(instances: list[Instance], planes: list[ReceptaclePlane], navmaps: list[NavMap],
                 labels: tuple[str, ...]) -> list[Any]:
    """Return a ViewTarget per receptacle plane, and per receptacle instance without planes (its top)."""
    from ..observe.floors import floor_below
    from ..observe.targeted import ViewTarget
    from ..receptacles import receptacle_instances

    by_id = {i.id: i for i in instances}
    out = []
    surfaces = [(by_id[p.instance_id], float(p.height)) for p in planes if p.instance_id in by_id]
    with_planes = {p.instance_id for p in planes}
    for inst in receptacle_instances(instances, labels):
        if inst.id not in with_planes and len(inst.points):
            surfaces.append((inst, float(inst.world_points[:, 2].max())))
    for inst, h in surfaces:
        nm = floor_below(h, navmaps)
        if nm is None:
            continue
        wp = inst.world_points
        lo, hi = wp[:, :2].min(axis=0), wp[:, :2].max(axis=0)
        out.append(ViewTarget(lo=lo, hi=hi, height=h, floor=nm.floor, seen_points=wp))
    return out


def perceive_and_find_planes(observations: Iterable[Observation], scene: SceneAsset, store_root: str | Path,
                             navmaps: list[NavMap], cfg: RunConfig, seed: int, backend: Any = None
                             ) -> tuple[list[Instance], list[ReceptaclePlane], list[Any]]:
    """Perceive a scene's observations, look again at its receptacle surfaces (targeted views), find their planes.

    Parameters
    ----------
    observations : iterable of Observation
        The coverage observations (RGB-D(+seg), intrinsics, camera poses), in view order.
    scene : SceneAsset
        The converted scene (its MJCF renders the targeted views; its labels feed the gt detector).
    store_root : str or Path
        The folder the scene's record paths are relative to.
    navmaps : list of NavMap
        The scene's navigable maps, one per floor (targeted cameras stand on navigable cells).
    cfg : RunConfig
        The run's config (sections perceive, receptacles, observe; semantics when receptacles.labels is empty).
    seed : int
        The scene's seed (noise models of the detector).
    backend : optional
        The LLM backend that names receptacles when ``receptacles.labels`` is empty (default: the semantics
        config's).

    Returns
    -------
    instances, planes, poses
        The fused instances, the receptacle planes and the targeted camera poses (4x4 T_cam, world <- OpenCV).
    """
    from ..observe import load_model, make_renderer
    from ..observe.targeted import plan_target_views, render_poses
    from ..receptacles import find_receptacle_planes
    from . import perceive_scene

    ocfg = cfg.observe
    poses: list[Any] = []

    def look_again(first: list[Instance], next_view: int) -> Any:
        labels = receptacle_labels(first, cfg, backend, scene)
        targets = view_targets(first, find_receptacle_planes(first, cfg.receptacles, labels), navmaps, labels)
        if not targets:
            return
        model = load_model(scene, store_root)
        small = dataclasses.replace(ocfg, width=int(ocfg.targeted_width),
                                    height=max(1, round(ocfg.targeted_width * ocfg.height / ocfg.width)))
        r = make_renderer(model, small, cfg.agent)
        try:
            poses.extend(plan_target_views(r, navmaps, targets, ocfg, cfg.agent))
        finally:
            r.close()
        if not poses:
            return
        r = make_renderer(model, ocfg, cfg.agent)
        try:
            yield from render_poses(r, poses, ocfg, start_view_id=next_view)
        finally:
            r.close()

    instances = perceive_scene(observations, scene, cfg.perceive, seed=seed, agent=cfg.agent,
                               look_again=look_again if ocfg.targeted_views > 0 else None)
    return instances, find_receptacle_planes(instances, cfg.receptacles, receptacle_labels(instances, cfg, backend, scene)), poses


def save_targeted_views(poses: list[Any], path: Path) -> None:
    """Write targeted camera poses (T_cam rows, each value rounded to 6 decimals) as JSON."""
    rows = [[[round(float(x), 6) for x in row] for row in np.asarray(T, float)] for T in poses]
    atomic_write_text(path, json.dumps({"T_cam": rows}, indent=None) + "\n")


__all__ = ["perceive_and_find_planes", "receptacle_labels", "save_targeted_views", "view_targets"]
