"""The dm_control ObjectNav task: a kinematic cylinder agent in an MJCF episode bundle.

Design (docs/background.md, "The dm_control ObjectNav task"):
- The bundle's MJCF is loaded with MjSpec and gets a mocap body ``agent`` (a cylinder of
  ``AgentConfig.radius`` x ``height``, geom group 5, no contacts) carrying the camera ``agent/camera``
  at ``camera_height``, so
  ``physics.render(camera_id="agent/camera")`` shows the agent's view too.
- Collision: the scene is visual-only (contype 0), so, as Habitat does with its navmesh, the agent's
  base must stay on the bundle's navigable grid (free space eroded by the agent radius). A forward
  move is taken only when the whole 0.25 m segment is navigable; otherwise the agent stays (Habitat's
  ``allow_sliding: false``).
- Moves are kinematic: ``Physics.step`` runs forward kinematics only, objects never integrate.
- Observations are rendered by a `sim.render.SceneRenderer` on the physics' own model/data (shadows
  and multisampling off), which is ~6x faster than dm_control's default ``physics.render``.
- Metrics follow habitat-lab (``sdovon_mj.metrics``): distance to goal is the grid geodesic to the
  nearest view point; success = STOP with d < success_distance; SPL; Soft SPL.
- A first visit (`ObjectNavTask.set_exploration`, the evaluation's exploration phase for agents with a scene
  prior): the next reset starts from a given pose with no goal, and renders hide the placed objects (the geoms of
  bodies ``obj_<n>``; articulated furniture stays): the agent sees the home, not the arrangement its episodes search.
- The reward (`get_reward`: the drop of the geodesic distance to the nearest goal view point, habitat-lab's dense
  reward) is generator knowledge: it is there for training; the evaluation never sends it to an agent.
- Articulated parts (issue 17): ``OPEN`` / ``CLOSE`` drive the part the agent looks at (hinge/slide joints
  ``art_<id>/...``; among the parts whose box lies within ``nav.open_reach`` of the camera and in its field of
  view, the one nearest to the optical axis) to its upper / lower limit, Habitat-style "magic": the joint's
  qpos is set and kinematics forwarded; objects resting in a drawer move with it. A goal's view points may have
  been computed with a part open (``Goal.open_part``), so when an episode has such a goal or a part moved, the
  success check also needs the goal object seen (>= ``agent.eta_gt`` of the pixels of a render aimed at it
  from where the agent stopped, as view points are defined).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

import mujoco
from dm_control import mujoco as dm_mujoco
from dm_control.mujoco import wrapper as dm_wrapper
from dm_control.rl import control
from dm_env import specs

from .. import metrics
from ..actions import ACTION_NAMES, CLOSE, LOOK_DOWN, LOOK_UP, MOVE_FORWARD, OPEN, STOP, TURN_LEFT, TURN_RIGHT
from ..config import AgentConfig, EpisodeConfig, NavConfig
from ..errors import InputError
from ..geometry import axis_quat, quat_mul, quat_yaw, yaw_quat
from ..records import Episode
from ..sim import GROUP_AGENT
from ..sim.articulation import part_joints
from ..sim.camera import intrinsics, pose_cv, vfov_from_hfov
from ..sim.model import OBJECT_ID_BASE, geom_segment_ids, object_segment_id
from ..sim.frames import blank_image
from ..sim.render import SceneRenderer, clip_depth_range
from ..grid import lookup, segment_free
from ..gridgraph import GeodesicField, cell_graph
from .bundle import Bundle, load_bundle

_CAM_BASE = np.array([0.5, 0.5, -0.5, -0.5])  # body +X forward -> MuJoCo camera looking along +X


def build_model(mjcf: str | Path, agent: AgentConfig = AgentConfig()) -> mujoco.MjModel:
    """Compile a bundle MJCF with the agent's mocap body, cylinder and camera added."""
    try:
        spec = mujoco.MjSpec.from_file(str(mjcf))
    except Exception as e:  # MuJoCo raises ValueError with the parser message
        raise InputError(mjcf, f"MJCF does not load: {e}") from None
    body = spec.worldbody.add_body(name="agent", mocap=True)
    body.add_geom(name="agent/body", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                  size=[agent.radius, agent.height / 2.0, 0.0], pos=[0, 0, agent.height / 2.0],
                  contype=0, conaffinity=0, group=GROUP_AGENT, rgba=[0.2, 0.4, 0.9, 0.5])
    body.add_camera(name="agent/camera", pos=[0, 0, agent.camera_height], quat=list(_CAM_BASE),
                    fovy=vfov_from_hfov(agent.hfov, agent.sensor_width, agent.sensor_height))
    try:
        return spec.compile()
    except Exception as e:
        raise InputError(mjcf, f"MJCF does not compile: {e}") from None


class Physics(dm_mujoco.Physics):
    """Kinematic physics: stepping runs forward kinematics only (objects stay where they settled)."""

    def step(self, n_sub_steps: int = 1) -> None:  # noqa: ARG002 - dm_control signature
        """Update positions of everything (the agent is moved by the task)."""
        mujoco.mj_kinematics(self.model.ptr, self.data.ptr)
        mujoco.mj_camlight(self.model.ptr, self.data.ptr)


@dataclass
class Part:
    """An articulated part of the bundle's model: its joint, body and box in the body frame (m)."""

    joint: int
    name: str
    body: int
    qpos: int
    lower: float
    upper: float
    slide: bool
    lo: np.ndarray  # (3,) box of the body's geoms, body frame
    hi: np.ndarray  # (3,)


def model_parts(model: mujoco.MjModel) -> list[Part]:
    """Return the model's articulated parts (joints ``art_<id>/...``) with the box of each part body's geoms."""
    out = []
    for j in part_joints(model):
        b = int(model.jnt_bodyid[j])
        corners = []
        for g in range(int(model.body_geomadr[b]), int(model.body_geomadr[b]) + int(model.body_geomnum[b])):
            c, h = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
            sgn = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
            local = c + sgn * h
            R = np.empty(9)
            mujoco.mju_quat2Mat(R, model.geom_quat[g])
            corners.append(local @ R.reshape(3, 3).T + model.geom_pos[g])
        if not corners:
            continue
        pts = np.concatenate(corners)
        lower, upper = (float(v) for v in model.jnt_range[j]) if model.jnt_limited[j] else (0.0, 0.0)
        out.append(Part(j, mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j), b, int(model.jnt_qposadr[j]),
                        lower, upper, int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE),
                        pts.min(axis=0), pts.max(axis=0)))
    return out


def _box_distance_at(pos: np.ndarray, mat: np.ndarray, part: Part, points: np.ndarray) -> np.ndarray:
    """Return the distances (m) of world points (N, 3) to a part's box with its body at `pos` (3,), `mat` (9,)."""
    q = (np.asarray(points, float) - pos) @ np.asarray(mat, float).reshape(3, 3)
    return np.linalg.norm(np.maximum(np.maximum(part.lo - q, 0.0), q - part.hi), axis=1)


def _box_distance(data: mujoco.MjData, part: Part, points: np.ndarray) -> np.ndarray:
    """Return the distances (m) of world points (N, 3) to a part's box in its current pose."""
    return _box_distance_at(data.xpos[part.body], data.xmat[part.body], part, points)


def _closed_poses(model: mujoco.MjModel, data: mujoco.MjData, parts: list[Part]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Return each part body's world (pos, mat) with every part at its lower limit; `data` is left as it was."""
    saved = data.qpos.copy()
    for p in parts:
        data.qpos[p.qpos] = p.lower
    mujoco.mj_kinematics(model, data)
    out = [(data.xpos[p.body].copy(), data.xmat[p.body].copy()) for p in parts]
    data.qpos[:] = saved
    mujoco.mj_kinematics(model, data)
    return out


@dataclass
class AgentState:
    """The agent's base position (on the floor), heading and camera pitch (deg)."""

    position: np.ndarray
    yaw: float
    pitch: float = 0.0


class ObjectNavTask(control.Task):
    """ObjectNav on one bundle: discrete actions, RGB-D(+seg), GPS+compass, object goal; habitat metrics.

    Parameters
    ----------
    bundle : Bundle
        The episode bundle (at least one episode).
    nav : NavConfig
        Action sizes, step budget, success distance.
    semantic : bool
        Whether observations hold the ``semantic`` image (instance ids).
    episode_order : str
        ``sequential`` (each reset the next episode) or ``random`` (drawn with `random`).
    random : int or Generator, optional
        Seed or generator of the random episode order.
    categories : list of str, optional
        The goal vocabulary (default: the bundle's categories).
    pose_observations : bool
        Whether observations hold the agent's position, heading and pitch.
    agent : AgentConfig
        The agent's body and camera.
    """

    def __init__(self, bundle: Bundle, nav: NavConfig = NavConfig(), semantic: bool = False,
                 episode_order: str = "sequential", random: int | np.random.Generator | None = None,
                 categories: list[str] | None = None, pose_observations: bool = True,
                 agent: AgentConfig = AgentConfig()) -> None:
        if not bundle.episodes:
            raise InputError(bundle.root, "bundle has no episodes")
        self.bundle = bundle
        self.nav = nav
        self.agent = agent
        self.semantic = semantic
        self.pose_observations = pose_observations
        self.episode_order = episode_order
        self.random = random if isinstance(random, np.random.Generator) else np.random.default_rng(random)
        self.categories = sorted(categories or bundle.categories())
        self.K = intrinsics(agent.sensor_width, agent.sensor_height, agent.hfov)
        self._renderer: SceneRenderer | None = None
        self._sight: SceneRenderer | None = None
        self._lut: np.ndarray | None = None
        self._graphs: dict[int, tuple] = {}
        self._next_index = 0
        self.render_frames = True
        self.render_rgb = True  # False: the rgb observation is a blank image (an agent that reads none)
        self.episode: Episode = bundle.episodes[0]
        self.state = AgentState(np.zeros(3), 0.0)
        self.frame_mask: np.ndarray | None = None
        self._parts: tuple[Any, list[Part]] | None = None
        self.part_moves: list[tuple[str, str]] = []
        self._explore_from: tuple[np.ndarray, float, int | None] | None = None
        self.exploring = False  # the current "episode" is a first visit (no goal, placed objects hidden)
        self._groups: tuple[Any, np.ndarray] | None = None  # (model, geom groups as compiled)

    # -- episodes --------------------------------------------------------------------------------

    def set_next_episode(self, index: int) -> None:
        """Make the next reset start the episode with this index."""
        self._next_index = int(index) % len(self.bundle.episodes)

    def _hide_objects(self, physics: Physics, hide: bool) -> None:
        """Move the placed objects' geoms out of the rendered groups (a first visit), or back as compiled."""
        m = physics.model.ptr
        if self._groups is None or self._groups[0] is not m:
            self._groups = (m, np.array(m.geom_group).copy())
        groups = self._groups[1]
        if hide:
            objects = geom_segment_ids(m) >= OBJECT_ID_BASE
            m.geom_group[:] = np.where(objects, GROUP_AGENT, groups)  # the agent's own camera never shows group 5
        else:
            m.geom_group[:] = groups

    def set_exploration(self, position: np.ndarray, yaw: float, floor: int | None = None) -> None:
        """Make the next reset start a first visit of the scene: from this pose (floor position, yaw in degrees) on
        `floor` (default: that of the bundle's first episode), no goal (``objectgoal_text`` ""), placed objects
        hidden from the camera, until STOP or ``nav.max_steps``."""
        self._explore_from = (np.asarray(position, float).copy(), float(yaw), floor)

    @property
    def num_episodes(self) -> int:
        """Return the number of episodes in the bundle."""
        return len(self.bundle.episodes)

    def initialize_episode(self, physics: Physics) -> None:
        """Pick the next episode, place the agent at its start and reset the metrics."""
        if physics.model.nkey > 0:
            mujoco.mj_resetDataKeyframe(physics.model.ptr, physics.data.ptr, 0)
        self.exploring = self._explore_from is not None
        if self.exploring:
            (pos, yaw, floor), self._explore_from = self._explore_from, None
            first = self.bundle.episodes[0]
            idx = -1
            ep = Episode("first-visit", first.scene, first.variant, "", pos, yaw_quat(yaw), [], math.inf, math.inf,
                         floor=first.floor if floor is None else int(floor))
        elif self.episode_order == "random":
            idx = int(self.random.integers(len(self.bundle.episodes)))
        else:
            idx = self._next_index
            self._next_index = (self._next_index + 1) % len(self.bundle.episodes)
        self.episode_index = idx
        self.episode = ep = ep if self.exploring else self.bundle.episodes[idx]
        self._hide_objects(physics, self.exploring)
        self.navmap = self.bundle.navmap(ep.floor)
        self.frame = self.navmap.frame
        if ep.floor not in self._graphs:
            self._graphs[ep.floor] = cell_graph(self.navmap.navigable)
        vps = [vp.position for g in ep.goals for vp in g.view_points]
        self.view_points = np.array(vps, dtype=float).reshape(-1, 3)
        self.geodesic = (GeodesicField(self.navmap.navigable, self.frame, self.view_points[:, :2], self._graphs[ep.floor])
                         if len(self.view_points) else None)
        self.state = AgentState(np.asarray(ep.start_position, dtype=float).copy(), quat_yaw(ep.start_rotation), 0.0)
        self.start = AgentState(self.state.position.copy(), self.state.yaw, 0.0)
        self.goal_segment_ids = np.array(sorted(object_segment_id(g.object_id) for g in ep.goals), dtype=np.int64)
        self.part_moves = []  # (action name, joint name) of every OPEN/CLOSE that moved a part
        self.goal_seen: bool | None = None  # visibility at STOP, where the success check needs it (else None)
        self._goal_fields: dict[int, GeodesicField] = {}
        self._goal_aim: dict[int, tuple[int, np.ndarray]] = {}
        mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)
        for i, g in enumerate(ep.goals):  # goal box centre relative to its body (the body may ride in a drawer)
            b = mujoco.mj_name2id(physics.model.ptr, mujoco.mjtObj.mjOBJ_BODY, g.object_id)
            if b >= 0:
                centre = np.asarray(g.bounds, float).mean(axis=0) if g.bounds is not None else np.asarray(g.position, float)
                self._goal_aim[i] = (b, centre - physics.data.ptr.xpos[b])
        self.stop_called = False
        self.steps = 0
        self.collisions = 0
        self.trajectory = [self.state.position.copy()]
        self.shortest = self.geodesic.distance(self.state.position) if self.geodesic is not None else math.inf
        self.distance = self.shortest
        self._prev_distance = self.distance
        self._apply_agent(physics)

    # -- dynamics --------------------------------------------------------------------------------

    def _apply_agent(self, physics: Physics) -> None:
        """Write the agent state to the mocap body and camera, then update kinematics."""
        m, d = physics.model.ptr, physics.data.ptr
        bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "agent")
        mid = int(m.body_mocapid[bid])
        d.mocap_pos[mid] = self.state.position
        d.mocap_quat[mid] = yaw_quat(self.state.yaw)
        cid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "agent/camera")
        m.cam_quat[cid] = quat_mul(axis_quat(1, -math.radians(self.state.pitch)), _CAM_BASE)  # pitch up = about -Y
        physics.step()

    def can_stand(self, xy: np.ndarray) -> bool:
        """Return whether the agent's base may stand at a world XY point."""
        return bool(lookup(self.navmap.navigable, self.frame, np.asarray(xy, float)[None, :2])[0])

    def before_step(self, action, physics: Physics) -> None:
        """Apply one discrete action kinematically (collision: the base stays on navigable cells)."""
        a = int(np.asarray(action).reshape(-1)[0])
        if not 0 <= a < len(ACTION_NAMES):
            raise ValueError(f"action {a} outside 0..{len(ACTION_NAMES) - 1}")
        s = self.state
        if a == STOP:
            self.stop_called = True
        elif a in (OPEN, CLOSE):
            self.move_part(physics, opening=a == OPEN)
        elif a == MOVE_FORWARD:
            yaw = math.radians(s.yaw)
            new = s.position + self.nav.forward_step * np.array([math.cos(yaw), math.sin(yaw), 0.0])
            if segment_free(self.navmap.navigable, self.frame, s.position, new):
                s.position = new
            else:
                self.collisions += 1
        elif a == TURN_LEFT:
            s.yaw = (s.yaw + self.nav.turn_angle + 180.0) % 360.0 - 180.0
        elif a == TURN_RIGHT:
            s.yaw = (s.yaw - self.nav.turn_angle + 180.0) % 360.0 - 180.0
        elif a == LOOK_UP:
            s.pitch = min(self.nav.max_tilt, s.pitch + self.nav.tilt_angle)
        elif a == LOOK_DOWN:
            s.pitch = max(-self.nav.max_tilt, s.pitch - self.nav.tilt_angle)
        self._apply_agent(physics)
        if a == STOP and self.distance < self.nav.success_distance and self.needs_sight():
            self.goal_seen = self.sees_goal(physics)

    # -- articulated parts -----------------------------------------------------------------------

    def parts(self, physics: Physics) -> list[Part]:
        """Return the articulated parts of the physics' model (cached per model)."""
        if self._parts is None or self._parts[0] is not physics.model.ptr:
            self._parts = (physics.model.ptr, model_parts(physics.model.ptr))
        return self._parts[1]

    def part_in_reach(self, physics: Physics, opening: bool = True) -> Part | None:
        """Return the part OPEN (or CLOSE) would move now: in reach and view, nearest the optical axis; else None.

        A part qualifies when the nearest point of its box (where it is now or closed, whichever is nearer) is within
        ``nav.open_reach`` of the camera, the centre of its closed box (the opening it covers, where the agent looks
        to open or close it) lies within the camera's field of view and it is not already at the limit the action
        drives it to; the one whose closed box is nearest the optical axis is chosen.
        """
        d = physics.data.ptr
        cam = self.state.position + np.array([0.0, 0.0, self.agent.camera_height])
        yaw, pitch = math.radians(self.state.yaw), math.radians(self.state.pitch)
        axis = np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch)])
        half_h = math.radians(self.agent.hfov) / 2.0
        half_v = math.atan(math.tan(half_h) * self.agent.sensor_height / self.agent.sensor_width)
        reach = float(self.nav.open_reach)
        ray = cam + np.linspace(0.0, reach, max(2, int(math.ceil(reach / 0.01)) + 1))[:, None] * axis
        best: tuple[float, float, int] | None = None
        parts = self.parts(physics)
        mujoco.mj_kinematics(physics.model.ptr, d)
        closed = _closed_poses(physics.model.ptr, d, parts)
        for i, p in enumerate(parts):
            target = p.upper if opening else p.lower
            if abs(float(d.qpos[p.qpos]) - target) < 1e-6:
                continue
            cpos, cmat = closed[i]
            near = min(float(_box_distance(d, p, cam[None])[0]), float(_box_distance_at(cpos, cmat, p, cam[None])[0]))
            if near > reach:
                continue
            centre = cpos + cmat.reshape(3, 3) @ ((p.lo + p.hi) / 2.0)
            rel = pose_cv(cam, self.state.yaw, self.state.pitch)[:3, :3].T @ (centre - cam)  # OpenCV camera frame
            if rel[2] <= 0 or abs(math.atan2(rel[0], rel[2])) > half_h or abs(math.atan2(rel[1], rel[2])) > half_v:
                continue
            key = (float(_box_distance_at(cpos, cmat, p, ray).min()), near, i)
            if best is None or key < best:
                best = key
        return None if best is None else parts[best[2]]

    def move_part(self, physics: Physics, opening: bool) -> str | None:
        """OPEN / CLOSE: drive the part in reach (`part_in_reach`) to its upper / lower limit; return its joint name.

        Habitat-style "magic" interaction: the joint's qpos is set and kinematics forwarded (the suite's physics is
        kinematic). Free bodies whose centre lies in a sliding part's box (objects in a drawer) move with it.
        Nothing happens (None) when no part qualifies.
        """
        p = self.part_in_reach(physics, opening)
        if p is None:
            return None
        m, d = physics.model.ptr, physics.data.ptr
        mujoco.mj_kinematics(m, d)
        riders = []
        if p.slide:
            for j in range(m.njnt):
                if int(m.jnt_type[j]) != int(mujoco.mjtJoint.mjJNT_FREE):
                    continue
                b = int(m.jnt_bodyid[j])
                if _box_distance(d, p, d.xpos[b][None])[0] <= 1e-3:
                    riders.append(int(m.jnt_qposadr[j]))
        before = d.xpos[p.body].copy()
        d.qpos[p.qpos] = p.upper if opening else p.lower
        mujoco.mj_kinematics(m, d)
        shift = d.xpos[p.body] - before
        for a in riders:
            d.qpos[a:a + 3] += shift
        self.part_moves.append(("OPEN" if opening else "CLOSE", p.name))
        return p.name

    def needs_sight(self) -> bool:
        """Return whether success needs the goal seen: a goal's view points had a part open, or a part moved."""
        return bool(self.part_moves) or any(g.open_part for g in self.episode.goals)

    def sees_goal(self, physics: Physics) -> bool:
        """Return whether a goal within success distance of its own view points is seen from where the agent stands.

        Seen: its segment covers at least ``eta_gt`` of a segmentation render from the agent camera aimed at the
        goal's box centre (pitch clipped to +-80 deg), the way episode view points are defined: at the episodes'
        visibility resolution and ``eta_gt`` (the bundle's ``visibility``; the episodes config's defaults and
        ``agent.eta_gt`` for bundles that do not record it), not at the agent's sensor size, where a small object's
        pixel share differs by rasterisation.
        """
        pos = self.state.position
        cam = pos + np.array([0.0, 0.0, self.agent.camera_height])
        mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)
        for i, g in enumerate(self.episode.goals):
            if i not in self._goal_aim or not g.view_points:
                continue
            vps = np.array([vp.position for vp in g.view_points], float).reshape(-1, 3)
            if np.min(np.linalg.norm(vps[:, :2] - pos[:2], axis=1)) > self.nav.success_distance:
                continue
            if i not in self._goal_fields:
                self._goal_fields[i] = GeodesicField(self.navmap.navigable, self.frame, vps[:, :2], self._graphs[self.episode.floor])
            if not self._goal_fields[i].distance(pos) < self.nav.success_distance:
                continue
            b, off = self._goal_aim[i]
            target = physics.data.ptr.xpos[b] + off
            dv = target - cam
            yaw = math.degrees(math.atan2(dv[1], dv[0]))
            pitch = float(np.clip(math.degrees(math.atan2(dv[2], math.hypot(dv[0], dv[1]))), -80.0, 80.0))
            if self._goal_pixels(physics, cam, yaw, pitch, [object_segment_id(g.object_id)]):
                return True
        return False

    def _goal_pixels(self, physics: Physics, cam: np.ndarray, yaw: float, pitch: float, ids: list[int]) -> bool:
        """Return whether one of the segments `ids` covers at least ``eta_gt`` of a segmentation render from `cam`
        (yaw, pitch in degrees) at the episodes' visibility size, as their view points are defined."""
        r = self.sight_renderer(physics)
        T = pose_cv(cam, yaw, pitch)
        # a segment whose geoms all lie outside the view covers no pixel (`SceneRenderer.outside_view`): no render
        if np.isin(np.flatnonzero(np.isin(self._lut, ids)), r.outside_view(T)).all():
            return False
        seg = r.render(T, rgb=False, depth=False, segmentation=True, labels=self._lut).segmentation
        eta = float(self.bundle.visibility.get("eta_gt", self.agent.eta_gt))
        need = max(int(math.ceil(eta * seg.size - 1e-9)), 1)  # as the episodes' VisibilityChecker
        return any(np.count_nonzero(seg == i) >= need for i in ids)

    def start_visibility(self, physics: Physics, yaws: int = 12) -> tuple[bool, bool]:
        """Return whether a goal is visible from the episode's start pose (its yaw, pitch 0), and from its start
        point at any of `yaws` headings (turning in place), by the episodes' own visibility definition.

        How hard an episode is, for the tables: the evaluator computes it after the reset, the agent never sees it.
        """
        if not len(self.goal_segment_ids):
            return False, False
        mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)
        cam = self.start.position + np.array([0.0, 0.0, self.agent.camera_height])
        ids = [int(i) for i in self.goal_segment_ids]
        ahead = self._goal_pixels(physics, cam, self.start.yaw, 0.0, ids)
        around = ahead or any(self._goal_pixels(physics, cam, self.start.yaw + k * 360.0 / yaws, 0.0, ids)
                              for k in range(1, yaws))
        return ahead, around

    def after_step(self, physics: Physics) -> None:
        """Update the trajectory, step count and distance to goal."""
        self.steps += 1
        self.trajectory.append(self.state.position.copy())
        self._prev_distance = self.distance
        if self.geodesic is not None and np.linalg.norm(self.trajectory[-1] - self.trajectory[-2]) > 1e-4:
            self.distance = self.geodesic.distance(self.state.position)

    # -- specs and observations -------------------------------------------------------------------

    def action_spec(self, physics: Physics) -> specs.DiscreteArray:
        """Return the discrete action spec: STOP, MOVE_FORWARD, TURN_LEFT, TURN_RIGHT, LOOK_UP, LOOK_DOWN, OPEN, CLOSE."""
        return specs.DiscreteArray(num_values=len(ACTION_NAMES), dtype=np.int64, name="action")

    def observation_spec(self, physics: Physics) -> dict:
        """Return the observation specs (defined explicitly, valid before the first reset)."""
        h, w = self.agent.sensor_height, self.agent.sensor_width
        out = {
            "rgb": specs.Array((h, w, 3), np.uint8, name="rgb"),
            "depth": specs.BoundedArray((h, w, 1), np.float32, self.nav.depth_min, self.nav.depth_max, name="depth"),
            "gps": specs.Array((2,), np.float32, name="gps"),
            "compass": specs.BoundedArray((1,), np.float32, -math.pi, math.pi, name="compass"),
            "objectgoal": specs.BoundedArray((1,), np.int64, 0, max(len(self.categories) - 1, 0), name="objectgoal"),
            "objectgoal_text": specs.StringArray((), name="objectgoal_text"),
        }
        if self.semantic:
            out["semantic"] = specs.Array((h, w), np.int32, name="semantic")
        if self.pose_observations:
            out["position"] = specs.Array((3,), np.float32, name="position")
            out["heading"] = specs.BoundedArray((1,), np.float32, -math.pi, math.pi, name="heading")
            out["pitch"] = specs.Array((1,), np.float32, name="pitch")
        return out

    def renderer(self, physics: Physics) -> SceneRenderer:
        """Return the (lazily built) offscreen renderer bound to this physics."""
        if self._renderer is None or self._renderer.model is not physics.model.ptr:
            if self._renderer is not None:
                self._renderer.close()
            self._renderer = SceneRenderer(physics.model.ptr, physics.data.ptr, self.agent.sensor_width,
                                           self.agent.sensor_height, self.agent.hfov, znear=0.05, zfar=50.0)
            self._lut = geom_segment_ids(physics.model.ptr)
        return self._renderer

    def sight_renderer(self, physics: Physics) -> SceneRenderer:
        """Return the (lazily built) segmentation renderer of the "goal seen" check (the episodes' visibility size)."""
        self.renderer(physics)  # the segment lookup table, bound to this physics
        if self._sight is None or self._sight.model is not physics.model.ptr:
            if self._sight is not None:
                self._sight.close()
            defaults = EpisodeConfig()
            w = int(self.bundle.visibility.get("width", defaults.vis_width))
            h = int(self.bundle.visibility.get("height", defaults.vis_height))
            # drawn with the agent camera's GL context when it fits in its framebuffer: no second upload of the scene
            self._sight = SceneRenderer(physics.model.ptr, physics.data.ptr, w, h, self.agent.hfov, znear=0.05,
                                        zfar=50.0, share=self._renderer)
        return self._sight

    def camera_pose(self) -> np.ndarray:
        """Return T_cam (world <- OpenCV camera) of the agent camera now."""
        p = self.state.position + np.array([0.0, 0.0, self.agent.camera_height])
        return pose_cv(p, self.state.yaw, self.state.pitch)

    def render(self, physics: Physics, segmentation: bool | None = None,
               rgb: bool = True) -> tuple[np.ndarray | None, np.ndarray, np.ndarray | None]:
        """Render rgb (H,W,3) (None when `rgb` is False), depth (H,W) metres clipped to the sensor range, and
        segment ids (or None)."""
        seg = self.semantic if segmentation is None else segmentation
        r = self.renderer(physics)
        f = r.render(self.camera_pose(), rgb=rgb, depth=True, segmentation=seg, labels=self._lut)
        depth = clip_depth_range(f.depth, self.nav.depth_min, self.nav.depth_max)
        return f.rgb, depth, (f.segmentation if seg else None)

    def get_observation(self, physics: Physics) -> dict:
        """Return the observation dict matching `observation_spec` (blank frames when rendering is off)."""
        h, w = self.agent.sensor_height, self.agent.sensor_width
        if self.render_frames:
            rgb, depth, ids = self.render(physics, rgb=self.render_rgb)
            if rgb is None:
                rgb = blank_image((h, w, 3), np.uint8, 0)
        else:  # the shared read-only blanks, as a sealed agent gets them
            rgb = blank_image((h, w, 3), np.uint8, 0)
            depth = blank_image((h, w), np.float32, self.nav.depth_min)
            ids = blank_image((h, w), np.int32, -1) if self.semantic else None
        yaw0 = math.radians(self.start.yaw)
        d = self.state.position[:2] - self.start.position[:2]
        c, s = math.cos(yaw0), math.sin(yaw0)
        gps = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]], dtype=np.float32)  # start frame: x fwd, y left
        comp = (math.radians(self.state.yaw) - yaw0 + math.pi) % (2 * math.pi) - math.pi
        cat = self.episode.object_category
        obs = {
            "rgb": rgb,
            "depth": depth[..., None],
            "gps": gps,
            "compass": np.array([comp], dtype=np.float32),
            "objectgoal": np.array([self.categories.index(cat) if cat in self.categories else 0], dtype=np.int64),
            "objectgoal_text": np.array(cat, dtype=object),
        }
        if self.semantic:
            obs["semantic"] = ids
        if self.pose_observations:
            obs["position"] = self.state.position.astype(np.float32)
            obs["heading"] = np.array([(math.radians(self.state.yaw) + math.pi) % (2 * math.pi) - math.pi], np.float32)
            obs["pitch"] = np.array([math.radians(self.state.pitch)], np.float32)
        return obs

    # -- reward, termination, metrics --------------------------------------------------------------

    def get_reward(self, physics: Physics) -> float:
        """Return habitat's distance-to-goal reward: the decrease of the geodesic distance to goal.

        Generator knowledge (it is computed from the goals' view points): for training; the evaluation never sends it
        to an agent, and an agent that declared it would be an oracle.
        """
        if not (math.isfinite(self.distance) and math.isfinite(self._prev_distance)):
            return 0.0
        return float(self._prev_distance - self.distance)

    def get_termination(self, physics: Physics) -> float | None:
        """Return 0.0 on STOP (terminal), 1.0 at the step limit (truncation), else None."""
        if self.stop_called:
            return 0.0
        if self.steps >= self.nav.max_steps:
            return 1.0
        return None

    def metrics(self) -> metrics.EpisodeMetrics:
        """Return the episode's habitat metrics so far (final after the last step)."""
        p = metrics.path_length(np.array(self.trajectory))
        s = metrics.success(self.stop_called, self.distance, self.nav.success_distance)
        if s and self.goal_seen is False:  # a part hid the goal (see `needs_sight`)
            s = 0.0
        return metrics.EpisodeMetrics(success=s, spl=metrics.spl(s, self.shortest, p), soft_spl=metrics.soft_spl(self.distance, self.shortest, p),
                                distance_to_goal=float(self.distance), shortest=float(self.shortest), path_length=p,
                                steps=self.steps, stop_called=self.stop_called)

    def close(self) -> None:
        """Free the renderer."""
        for r in (self._renderer, self._sight):
            if r is not None:
                r.close()
        self._renderer = self._sight = None


def make_physics(bundle: Bundle, agent: AgentConfig = AgentConfig()) -> Physics:
    """Return the kinematic Physics of a bundle with the agent added."""
    model = build_model(bundle.mjcf, agent)
    return Physics.from_model(dm_wrapper.MjModel(model))


def make_environment(bundle: str | Path | Bundle, nav: NavConfig | None = None, semantic: bool = False,
                     episode_order: str = "sequential", random: int | None = None, width: int | None = None,
                     height: int | None = None, max_steps: int | None = None, pose_observations: bool = True,
                     agent: AgentConfig | None = None, rgb: bool = True, **environment_kwargs: Any) -> control.Environment:
    """Return a dm_control Environment running ObjectNav episodes of one bundle.

    Parameters
    ----------
    bundle
        Variant folder (or loaded `Bundle`) with its MJCF, episodes and navmaps.
    nav
        Actions, step limit and success radius (default `NavConfig()`).
    semantic
        Add the ``semantic`` (segment id per pixel) observation.
    episode_order
        ``sequential`` or ``random`` episode order across resets.
    random
        Seed of the random episode order.
    width, height
        Camera image size in pixels; overrides ``agent.sensor_width`` / ``sensor_height``.
    max_steps
        Episode step limit; overrides ``nav.max_steps``.
    pose_observations
        Add ``position`` (m, world), ``heading`` and ``pitch`` (rad) observations.
    agent
        The agent's body and camera (default `AgentConfig()`).
    rgb
        Render the ``rgb`` observation (False: a blank image, for an agent that declares it reads none:
        `Knowledge.rgb`; the depth and segmentation then cost one flat render pass).
    **environment_kwargs
        Passed on to ``dm_control.rl.control.Environment``.
    """
    b = bundle if isinstance(bundle, Bundle) else load_bundle(bundle)
    nav = nav or NavConfig()
    agent = agent or AgentConfig()
    if max_steps is not None:
        nav = replace(nav, max_steps=max_steps)
    size = {k: v for k, v in (("sensor_width", width), ("sensor_height", height)) if v is not None}
    agent = replace(agent, **size) if size else agent
    physics = make_physics(b, agent)
    task = ObjectNavTask(b, nav, semantic=semantic, episode_order=episode_order, random=random,
                         pose_observations=pose_observations, agent=agent)
    task.render_rgb = bool(rgb)
    environment_kwargs.setdefault("time_limit", float("inf"))
    return control.Environment(physics, task, **environment_kwargs)
