"""Objects inside articulated pieces: settle on the real shelves with the parts open, then set each variant's doors
and drawers open / closed / ajar and settle again.

Objects are first placed and settled as everywhere else (support prisms from the detected planes, parts open as
perception saw them). Then, for a scene with articulated pieces (`SceneAsset.articulated`), the resting objects are
composed with the scene itself (its articulated bodies collide; planes inside a part get no prism, the shelf or
drawer holds the object), the parts are held at the perception state (``observe.open_parts``) for
``place.part_settle_time``, and each part is driven (prescribed joint motion, so a door pushes what is in its way) to
its state for this variant, drawn from the variant seed: open (upper limit), closed (lower limit) or ajar (a uniform
fraction in ``place.part_ajar``) with the probabilities ``place.part_*_p``. The model runs on for
``place.part_settle_time``. An object that moved more than ``place.part_move_tol`` relative to what holds it (its
drawer, the piece's carcass, or the world for an object outside any piece) is classified: ``tunnelled`` when it
left the piece's closed box while a part closed, else ``displaced``; either way it leaves the variant. The variant
records the parts' positions (`SceneVariant.articulation`) and its qpos holds them first (the scene's joints come
first in the composed model), then the resting objects' poses.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mujoco

from ..config import PlaceConfig
from ..records import ObjectAsset, ReceptaclePlane, SceneAsset, SceneVariant
from ..sim.articulation import drive_parts, open_value, part_instance, part_joints, set_parts
from .compose import compose
from .settle import RESTING

DISPLACED = "displaced"
TUNNELLED = "tunnelled"
STATES = ("open", "closed", "ajar")


def draw_states(model: mujoco.MjModel, cfg: PlaceConfig, seed: int) -> tuple[dict[str, float], dict[str, str]]:
    """Draw each part's state for a variant: (joint name -> position, joint name -> open/closed/ajar), seeded."""
    rng = np.random.default_rng([int(seed), 17])
    p = np.array([cfg.part_open_p, cfg.part_closed_p, cfg.part_ajar_p], dtype=float)
    p = p / p.sum()
    target, kind = {}, {}
    for j in part_joints(model):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        k = STATES[int(rng.choice(3, p=p))]
        frac = {"open": 1.0, "closed": 0.0}.get(k)
        if frac is None:
            frac = float(rng.uniform(*cfg.part_ajar))
        target[name], kind[name] = open_value(model, j, frac), k
    return target, kind


def _holder(model: mujoco.MjModel, plane: ReceptaclePlane | None) -> int:
    """Return the body an object on `plane` moves with: its drawer (slide part), the piece (hinged part), or world."""
    if plane is None or plane.part is None:
        return 0
    j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, plane.part)
    if j < 0:
        return 0
    b = int(model.jnt_bodyid[j])
    return b if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE) else int(model.body_parentid[b])


def _local(data: mujoco.MjData, body: int, p: np.ndarray) -> np.ndarray:
    """Return world point `p` in body `body`'s frame."""
    return data.xmat[body].reshape(3, 3).T @ (p - data.xpos[body])


def articulate_variant(variant: SceneVariant, scene: SceneAsset, planes: list[ReceptaclePlane], objects: list[ObjectAsset],
                       store_root: str | Path, cfg: PlaceConfig, open_parts: float) -> None:
    """Set the variant's articulation state and settle its objects again (in place; nothing for rigid scenes).

    Parameters
    ----------
    variant : SceneVariant
        The settled variant; its placements' statuses and settled poses, `articulation` and `qpos` are updated.
    scene : SceneAsset
        The converted scene (its `articulated` pieces).
    planes : list of ReceptaclePlane
        The scene's planes (`part` set for those inside a piece).
    objects : list of ObjectAsset
        The object library.
    store_root : str or Path
        Store root the scene's and objects' files are relative to.
    cfg : PlaceConfig
        Part state probabilities, settle time and tolerance, physics settings.
    open_parts : float
        Fraction of their range the parts were open at when the planes were found (``observe.open_parts``).
    """
    if not scene.articulated:
        return
    kept = [p for p in variant.placements if p.status == RESTING]
    assets = {a.name: a for a in objects}
    by_id = {q.id: q for q in planes}
    composed = compose(kept, assets, support_planes(planes), scene, store_root, cfg, with_scene=True)
    model = composed.model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    opened = set_parts(model, data, open_parts)
    drive_parts(model, data, opened, cfg.part_settle_time, steps_per_move=1)
    target, kind = draw_states(model, cfg, variant.seed)
    holders = [_holder(model, by_id.get(p.plane_id)) for p in kept]
    before = [_local(data, h, data.xpos[b].copy()) for h, b in zip(holders, composed.body_ids)]
    drive_parts(model, data, target, cfg.part_settle_time)
    boxes = {fx.instance_id: scene.instance(fx.instance_id).bounds for fx in scene.articulated}
    for i, p in enumerate(kept):
        b, h = composed.body_ids[i], holders[i]
        plane_i = by_id.get(p.plane_id)
        p.part = plane_i.part if plane_i is not None else None
        moved = float(np.linalg.norm(_local(data, h, data.xpos[b].copy()) - before[i]))
        if moved > cfg.part_move_tol:
            plane = by_id.get(p.plane_id)
            box = boxes.get(part_instance(plane.part)) if plane is not None and plane.part is not None else None
            out = box is not None and not bool(np.all((data.xpos[b] >= box[0] - 0.01) & (data.xpos[b] <= box[1] + 0.01)))
            p.status = TUNNELLED if out else DISPLACED
            state = f"{plane.part} {kind.get(plane.part, '')}" if plane is not None and plane.part else "the parts"
            p.reason = f"moved {moved:.3f} m relative to its support when {state} moved"
            continue
        a = composed.qpos_adr[i]
        p.settled_pos, p.settled_quat = data.qpos[a:a + 3].copy(), data.qpos[a + 3:a + 7].copy()
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in part_joints(model)]
    variant.articulation = {n: float(target[n]) for n in names}
    resting = [p for p in variant.placements if p.status == RESTING]
    q_obj = [np.concatenate([p.settled_pos, p.settled_quat]) for p in resting]
    variant.qpos = np.concatenate([np.array([target[n] for n in names], dtype=np.float64), *q_obj]).astype(np.float64)
    gone = [p for p in kept if p.status in (DISPLACED, TUNNELLED)]
    if gone:
        variant.notes = list(variant.notes) + [
            f"{len(gone)} of {len(kept)} objects moved when the doors and drawers were set: "
            + "; ".join(f"{p.object_id} {p.category}: {p.status} ({p.reason})" for p in gone)]


def support_planes(planes: list[ReceptaclePlane]) -> list[ReceptaclePlane]:
    """Return the planes that get support prisms in a model with the scene's articulated pieces (not those inside)."""
    return [p for p in planes if p.part is None]


def inside_share(variant: SceneVariant, planes: list[ReceptaclePlane]) -> tuple[int, int]:
    """Return (resting objects on a plane inside an articulated part, resting objects) of a variant."""
    inside = {p.id for p in planes if p.part is not None}
    resting = variant.resting
    return sum(1 for p in resting if p.plane_id in inside), len(resting)


__all__ = ["DISPLACED", "STATES", "TUNNELLED", "articulate_variant", "draw_states", "inside_share", "support_planes"]
