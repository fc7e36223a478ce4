"""Articulated scene parts in a compiled model: the hinge/slide joints of a converted scene's articulated pieces.

A converted scene with ``world.articulated`` pieces (``SceneAsset.articulated``) holds, besides its static geometry,
bodies ``art_<id>/...`` with hinge and slide joints (doors, drawers). Here: find those joints in any model composed
from the scene (placed objects' free joints are not parts), set them to a fraction of their range or to recorded
values, and read their state back (``SceneVariant.articulation``).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

import mujoco

PART_PREFIX = "art_"  # body/joint name prefix of a scene's articulated pieces (assets_convert.articulated_scene)


def part_joints(model: mujoco.MjModel) -> list[int]:
    """Return the ids of the model's articulated-part joints (hinge/slide joints named ``art_<id>/...``), in id order."""
    out = []
    for j in range(model.njnt):
        if int(model.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            continue
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
        if name.startswith(PART_PREFIX):
            out.append(j)
    return out


def open_value(model: mujoco.MjModel, joint: int, fraction: float) -> float:
    """Return the joint position `fraction` of the way from its lower to its upper limit (rad or m)."""
    lo, hi = (float(v) for v in model.jnt_range[joint]) if model.jnt_limited[joint] else (0.0, 0.0)
    return lo + float(fraction) * (hi - lo)


def set_parts(model: mujoco.MjModel, data: mujoco.MjData, state: float | Mapping[str, float]) -> dict[str, float]:
    """Set every articulated part: a fraction of its range (float) or joint name -> position; run forward kinematics.

    Joints missing from a mapping keep their position. Returns the joint name -> position now set.
    """
    out = {}
    for j in part_joints(model):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        if isinstance(state, Mapping):
            if name not in state:
                continue
            value = float(state[name])
        else:
            value = open_value(model, j, float(state))
        data.qpos[model.jnt_qposadr[j]] = value
        data.qvel[model.jnt_dofadr[j]] = 0.0
        out[name] = value
    if out:
        mujoco.mj_forward(model, data)
    return out


def part_state(model: mujoco.MjModel, data: mujoco.MjData) -> dict[str, float]:
    """Return joint name -> position of every articulated part (rad or m)."""
    return {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j): float(data.qpos[model.jnt_qposadr[j]])
            for j in part_joints(model)}


def drive_parts(model: mujoco.MjModel, data: mujoco.MjData, target: Mapping[str, float], seconds: float,
                steps_per_move: int = 200) -> None:
    """Move the named parts to `target` positions kinematically over `steps_per_move` steps, then simulate `seconds`.

    The joints are prescribed (position and velocity set each step, so a door pushes what is in its way as a
    moving body would), then released and the model runs on for `seconds` (s of simulated time).

    Parameters
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
        The model (parts named ``art_<id>/...``) and its state.
    target : mapping of str to float
        Joint name -> final position (rad or m).
    seconds : float
        Simulated time after the move, s.
    steps_per_move : int
        Physics steps the move takes.
    """
    joints = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j): j for j in part_joints(model)}
    moves = [(joints[n], float(v)) for n, v in target.items() if n in joints]
    start = {j: float(data.qpos[model.jnt_qposadr[j]]) for j, _v in moves}
    dt = float(model.opt.timestep)
    n = max(1, int(steps_per_move))
    for k in range(1, n + 1):
        for j, v in moves:
            a, d = model.jnt_qposadr[j], model.jnt_dofadr[j]
            data.qpos[a] = start[j] + (v - start[j]) * k / n
            data.qvel[d] = (v - start[j]) / (n * dt)
        mujoco.mj_step(model, data)
    for j, v in moves:
        data.qpos[model.jnt_qposadr[j]] = v
        data.qvel[model.jnt_dofadr[j]] = 0.0
    for _ in range(int(round(float(seconds) / dt))):
        for j, v in moves:  # parts hold their state (a real door stays where it was left)
            data.qpos[model.jnt_qposadr[j]] = v
            data.qvel[model.jnt_dofadr[j]] = 0.0
        mujoco.mj_step(model, data)


def part_instance(joint: str) -> int:
    """Return the scene instance id of an articulated part's joint name (``art_<id>/...``)."""
    head = joint.split("/", 1)[0]
    if not head.startswith(PART_PREFIX) or not head[len(PART_PREFIX):].isdigit():
        raise ValueError(f"{joint!r} is not an articulated part joint (art_<id>/...)")
    return int(head[len(PART_PREFIX):])


def joint_range(model: mujoco.MjModel, name: str) -> np.ndarray:
    """Return (lower, upper) of a named joint (zeros when unlimited)."""
    j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
    if j < 0:
        raise KeyError(f"model has no joint {name!r}")
    return np.asarray(model.jnt_range[j], dtype=float) if model.jnt_limited[j] else np.zeros(2)


__all__ = ["PART_PREFIX", "drive_parts", "joint_range", "open_value", "part_instance", "part_joints", "part_state", "set_parts"]
