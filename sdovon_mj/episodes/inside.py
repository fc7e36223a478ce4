"""Goals hidden inside articulated pieces: view points computed with the enclosing part open.

An object that rests inside a door or drawer (`Placement.part`) that is closed (or too little ajar to see it) in its
variant has no view point in the variant's state. Its view points are then computed with that part fully open (a
drawer carries the object out with it), and the goal names the part (`Goal.open_part`): an agent must open it
(the suite's OPEN action) before it can see the object.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

import numpy as np

import mujoco

from ..config import AgentConfig, EpisodeConfig
from ..records import Goal, NavMap, ViewPoint
from .viewpoints import ObjectBox, VisibilityChecker, facing, object_box, object_view_points


@contextmanager
def part_opened(model: mujoco.MjModel, data: mujoco.MjData, part: str, object_id: str) -> Iterator[bool]:
    """Within the block, joint `part` is at its upper limit (a drawer carries `object_id` out); `data` restored after.

    Yields whether the part and the object exist in the model.
    """
    j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, part)
    ob = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, object_id)
    if j < 0 or ob < 0:
        yield False
        return
    saved = data.qpos.copy()
    body = int(model.jnt_bodyid[j])
    before = data.xpos[body].copy()
    a = int(model.jnt_qposadr[j])
    data.qpos[a] = model.jnt_range[j][1] if model.jnt_limited[j] else saved[a]
    mujoco.mj_forward(model, data)
    if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE):  # a drawer carries what is in it
        fj = int(model.body_jntadr[ob])
        if fj >= 0:
            q = int(model.jnt_qposadr[fj])
            data.qpos[q:q + 3] += data.xpos[body] - before
            mujoco.mj_forward(model, data)
    try:
        yield True
    finally:
        data.qpos[:] = saved
        mujoco.mj_forward(model, data)


def seen_fraction(model: mujoco.MjModel, data: mujoco.MjData, goal: Goal, view: ViewPoint, agent: AgentConfig,
                  size: tuple[int, int] | None = None) -> float:
    """Return the goal object's pixel fraction in a render of everything from a view point (aimed at the object).

    Every scene, ceiling and object geom is drawn (no culling, no ray shortcut): an independent check of the stored
    view points. Pass the episodes' visibility size (``episodes.vis_width``, ``vis_height``) to check them by their
    own definition (the suite's "goal seen" check renders so); the agent's sensor size otherwise.

    Parameters
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
        The variant's model and the state to render (e.g. inside `part_opened`).
    goal : Goal
        The goal (its object's body name).
    view : ViewPoint
        Agent base position on the floor (m); the camera sits `agent.camera_height` above it, aimed at the object.
    agent : AgentConfig
        Camera height (m), HFOV (degrees) and sensor size (px).
    size : (int, int), optional
        Render width and height (px); default the agent's sensor size.
    """
    from ..sim import GROUP_CEILING, GROUP_OBJECT_VISUAL, GROUP_SCENE
    from ..sim.camera import pose_cv
    from ..sim.model import geom_segment_ids, object_segment_id, segment_image
    from ..sim.render import SceneRenderer

    box = object_box(model, data, goal.object_id)
    if box is None:
        return 0.0
    cam = np.asarray(view.position, float) + np.array([0.0, 0.0, agent.camera_height])
    yaw, pitch = facing(cam, box.center)
    width, height = size if size is not None else (agent.sensor_width, agent.sensor_height)
    with SceneRenderer(model, data, width=width, height=height, hfov=agent.hfov,
                       groups=(GROUP_SCENE, GROUP_CEILING, GROUP_OBJECT_VISUAL)) as r:
        frame = r.render(pose_cv(cam, yaw, float(np.clip(pitch, -80.0, 80.0))), rgb=False, depth=False, segmentation=True)
    seg = segment_image(frame.segmentation, geom_segment_ids(model))
    return float(np.count_nonzero(seg == object_segment_id(goal.object_id))) / seg.size


def view_points_with_part_open(model: mujoco.MjModel, data: mujoco.MjData, part: str, object_id: str, nm: NavMap,
                               cfg: EpisodeConfig, agent: AgentConfig) -> tuple[list[ViewPoint], ObjectBox | None]:
    """Return the object's view points (and its box) with joint `part` at its upper limit; `data` is restored after.

    Parameters
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
        The variant's model and its settled state.
    part : str
        The enclosing part's joint name (``art_<id>/...``).
    object_id : str
        The goal object's body name.
    nm : NavMap
        The navigation map of the object's floor.
    cfg : EpisodeConfig
        View-point settings.
    agent : AgentConfig
        The agent's body and camera.
    """
    with part_opened(model, data, part, object_id) as ok:
        if not ok:
            return [], None
        checker = VisibilityChecker(model, data, cfg, agent)
        try:
            box = object_box(model, data, object_id)
            vps = object_view_points(checker, nm, box, cfg, agent, exhaustive=True) if box is not None else []
        finally:
            checker.close()
    return vps, box


__all__ = ["part_opened", "seen_fraction", "view_points_with_part_open"]
