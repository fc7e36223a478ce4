"""RGB-D(+segmentation) observations at viewpoints: yaw/pitch sweeps with one reused renderer.

Camera: OpenCV pose from ``camera.pose_cv`` at the viewpoint (floor + agent_height), yaw steps of
360/yaw_steps degrees and each of ``pitch_angles``; then, at each extra height of ``camera_heights``
above the floor, the same yaws with each of ``camera_height_pitches`` (a raised camera looking down
sees the tops of shelves and counters above the agent camera); image ``width`` x ``height`` with horizontal
field of view ``hfov`` (MuJoCo's fovy is vertical: the renderer converts). Depth is metric z-depth
along the optical axis, 0 outside [depth_min, depth_max]. Segmentation holds scene instance ids
(``geom_segment_ids``), -1 for none. Geom groups 0 (scene), 1 (ceilings: the agent sees them) and
2 (object visuals) are drawn.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

import numpy as np

from ..config import AgentConfig, ObserveConfig
from ..errors import InputError
from ..records import CoverageCamera, Observation, SceneAsset

import mujoco

from ..sim import GROUP_CEILING, GROUP_OBJECT_VISUAL, GROUP_SCENE
from ..sim.articulation import set_parts
from ..sim.camera import pose_cv
from ..sim.model import geom_segment_ids
from ..sim.render import SceneRenderer, clip_depth


def load_model(scene: SceneAsset | str | Path, store_root: str | Path | None = None) -> mujoco.MjModel:
    """Compile a scene's MJCF (a SceneAsset resolved against store_root, or a path)."""
    if isinstance(scene, SceneAsset):
        path = Path(store_root or ".") / scene.mjcf
    else:
        path = Path(scene)
    if not path.exists():
        raise InputError(path, "scene MJCF not found")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as e:
        raise InputError(path, f"MuJoCo cannot compile the scene: {e}") from None


def view_poses(cfg: ObserveConfig, agent: AgentConfig = AgentConfig()) -> list[tuple[float, float, float]]:
    """Return the (yaw deg, pitch deg, height offset m above the viewpoint at agent.camera_height) rendered at every viewpoint, in render order."""
    steps = max(1, int(cfg.yaw_steps))
    yaws = [360.0 * k / steps for k in range(steps)]
    out = [(y, float(p), 0.0) for y in yaws for p in cfg.pitch_angles]
    for h in cfg.camera_heights:
        dz = float(h) - float(agent.camera_height)
        out.extend((y, float(p), dz) for y in yaws for p in cfg.camera_height_pitches)
    return out


def view_angles(cfg: ObserveConfig) -> list[tuple[float, float]]:
    """Return the (yaw, pitch) degrees rendered at every viewpoint, in render order (heights: view_poses)."""
    return [(y, p) for y, p, _dz in view_poses(cfg)]


def make_renderer(model: mujoco.MjModel, cfg: ObserveConfig, agent: AgentConfig = AgentConfig()) -> SceneRenderer:
    """Return a SceneRenderer set up for observation rendering (speed flags, the agent camera's hfov, groups)."""
    znear = min(0.05, cfg.depth_min / 2.0) if cfg.depth_min > 0 else 0.02
    zfar = max(cfg.depth_max * 2.0, 20.0)
    r = SceneRenderer(model, width=cfg.width, height=cfg.height, hfov=agent.hfov, znear=znear, zfar=zfar,
                      shadows=cfg.shadows, groups=(GROUP_SCENE, GROUP_CEILING, GROUP_OBJECT_VISUAL))
    set_parts(model, r.data, cfg.open_parts)  # articulated pieces: doors and drawers open (none: nothing happens)
    return r


def segment_lut(model: mujoco.MjModel) -> np.ndarray:
    """Return geom id -> instance id (-1 for none), indexable with MuJoCo's geom id -1 for background."""
    return np.append(geom_segment_ids(model), -1).astype(np.int32)


def observation_at(renderer: SceneRenderer, T: np.ndarray, cfg: ObserveConfig, seg_lut: np.ndarray, view_id: int,
                   viewpoint: int, yaw: float, pitch: float, rgb: bool = True, depth: bool = True,
                   segmentation: bool = True) -> Observation:
    """Render one Observation from camera pose T (depth clipped to the config's range, instance segmentation).

    Parameters
    ----------
    renderer : SceneRenderer
        The renderer of the scene model.
    T : (4, 4) float
        Camera pose T_cam (world <- OpenCV camera), metres.
    cfg : ObserveConfig
        Image size and depth range (metres).
    seg_lut : (G + 1,) int32
        Geom id -> instance id (last entry: background), from ``segment_lut``.
    view_id : int
        Id of the observation.
    viewpoint : int
        Index of the view point it was taken from.
    yaw, pitch : float
        Camera yaw and pitch, degrees.
    rgb, depth, segmentation : bool
        Which images to render (a skipped one is left zero or None).
    """
    fr = renderer.render(T, rgb=rgb, depth=depth, segmentation=segmentation)
    d = clip_depth(fr.depth, cfg.depth_min, cfg.depth_max) if fr.depth is not None else np.zeros((cfg.height, cfg.width), np.float32)
    seg = seg_lut[fr.segmentation] if fr.segmentation is not None else None
    img = fr.rgb if fr.rgb is not None else np.zeros((cfg.height, cfg.width, 3), np.uint8)
    return Observation(rgb=img, depth=d, K=renderer.K.copy(), T_cam=T, segmentation=seg, view_id=int(view_id),
                       viewpoint=int(viewpoint), yaw=float(yaw), pitch=float(pitch))


def render_observations(scene: SceneAsset | str | Path | mujoco.MjModel, viewpoints: list[CoverageCamera],
                        cfg: ObserveConfig, store_root: str | Path | None = None, rgb: bool = True,
                        depth: bool = True, segmentation: bool = True, start_view_id: int = 0,
                        renderer: SceneRenderer | None = None, agent: AgentConfig = AgentConfig()) -> Iterator[Observation]:
    """Yield one Observation per (viewpoint, yaw, pitch, camera height), rendered with one reused renderer.

    Parameters
    ----------
    scene : SceneAsset or str or Path or mujoco.MjModel
        The scene (asset, MJCF path or compiled model); unused when `renderer` is given.
    viewpoints : list of CoverageCamera
        View points (world metres) to render from.
    cfg : ObserveConfig
        Yaws, pitches, image size and depth range.
    store_root : str or Path, optional
        Store root the scene's files are relative to.
    rgb, depth, segmentation : bool
        Which images to render.
    start_view_id : int
        Id of the first observation (the next ones count up).
    renderer : SceneRenderer, optional
        A renderer to reuse (left open); default: one made and closed here.
    agent : AgentConfig
        The agent's body (radius, height) and camera (height, HFOV), metres and degrees.
    """
    own = renderer is None
    if renderer is None:
        model = scene if isinstance(scene, mujoco.MjModel) else load_model(scene, store_root)
        renderer = make_renderer(model, cfg, agent)
    lut = segment_lut(renderer.model)
    poses = view_poses(cfg, agent)
    view_id = int(start_view_id)
    try:
        for vi, vp in enumerate(viewpoints):
            pos = np.asarray(vp.position, dtype=np.float64)
            for yaw, pitch, dz in poses:
                T = pose_cv(pos + np.array([0.0, 0.0, dz]), yaw, pitch)
                yield observation_at(renderer, T, cfg, lut, view_id, vi, yaw, pitch, rgb, depth, segmentation)
                view_id += 1
    finally:
        if own:
            renderer.close()
