"""Small hand-built MuJoCo scenes with known receptacle surfaces, rendered from a few poses (test helper)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from sdovon_mj.records import Observation, SceneAsset, SemanticInstance, SupportSurface


@dataclass
class BoxPart:
    """One box geom of an instance: centre and half sizes (world, axis aligned)."""

    center: tuple[float, float, float]
    half: tuple[float, float, float]


@dataclass
class RoomInstance:
    """A labelled instance made of boxes, with its ground-truth support surfaces."""

    id: int
    label: str
    parts: list[BoxPart]
    supports: list[tuple[float, np.ndarray]] = field(default_factory=list)  # (height, CCW polygon)

    @property
    def bounds(self) -> np.ndarray:
        lo = np.min([np.subtract(p.center, p.half) for p in self.parts], axis=0)
        hi = np.max([np.add(p.center, p.half) for p in self.parts], axis=0)
        return np.stack([lo, hi])


def _rect(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


def table(iid: int, cx: float, cy: float, w: float = 1.2, d: float = 0.8, h: float = 0.75, t: float = 0.04) -> RoomInstance:
    """A table: a top of thickness t with its upper face at h, and four legs."""
    parts = [BoxPart((cx, cy, h - t / 2), (w / 2, d / 2, t / 2))]
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(BoxPart((cx + sx * (w / 2 - 0.05), cy + sy * (d / 2 - 0.05), (h - t) / 2), (0.025, 0.025, (h - t) / 2)))
    return RoomInstance(iid, "table", parts, [(h, _rect(cx - w / 2, cy - d / 2, cx + w / 2, cy + d / 2))])


def bookshelf(iid: int, cx: float, cy: float, w: float = 0.8, d: float = 0.32, levels: tuple[float, ...] = (0.06, 0.38, 0.70, 1.02),
              t: float = 0.02) -> RoomInstance:
    """A bookshelf open towards -Y: side panels, back panel, boards whose upper faces are at `levels`."""
    top = levels[-1]
    parts = [
        BoxPart((cx - w / 2 + t / 2, cy, top / 2), (t / 2, d / 2, top / 2)),
        BoxPart((cx + w / 2 - t / 2, cy, top / 2), (t / 2, d / 2, top / 2)),
        BoxPart((cx, cy + d / 2 - t / 2, top / 2), (w / 2 - t, t / 2, top / 2)),
    ]
    supports = []
    for z in levels:
        parts.append(BoxPart((cx, cy - t / 2, z - t / 2), (w / 2 - t, d / 2 - t / 2, t / 2)))
        if z == top:
            supports.append((z, _rect(cx - w / 2, cy - d / 2, cx + w / 2, cy + d / 2)))
        else:
            supports.append((z, _rect(cx - w / 2 + t, cy - d / 2, cx + w / 2 - t, cy + d / 2 - t)))
    # The top board spans the whole footprint.
    parts[-1] = BoxPart((cx, cy, top - t / 2), (w / 2, d / 2, t / 2))
    return RoomInstance(iid, "bookshelf", parts, supports)


def sofa(iid: int, cx: float, cy: float, w: float = 1.8, d: float = 0.85, seat: float = 0.42) -> RoomInstance:
    """A sofa facing -Y: seat block, backrest, two armrests; the support surface is the seat."""
    arm, back = 0.15, 0.2
    parts = [
        BoxPart((cx, cy - back / 2, seat / 2), (w / 2 - arm, (d - back) / 2, seat / 2)),
        BoxPart((cx, cy + d / 2 - back / 2, 0.85 / 2), (w / 2, back / 2, 0.85 / 2)),
        BoxPart((cx - w / 2 + arm / 2, cy - back / 2, 0.3), (arm / 2, (d - back) / 2, 0.3)),
        BoxPart((cx + w / 2 - arm / 2, cy - back / 2, 0.3), (arm / 2, (d - back) / 2, 0.3)),
    ]
    poly = _rect(cx - w / 2 + arm, cy - d / 2, cx + w / 2 - arm, cy + d / 2 - back)
    return RoomInstance(iid, "sofa", parts, [(seat, poly)])


def chair(iid: int, cx: float, cy: float) -> RoomInstance:
    """A plain chair block (not a receptacle)."""
    return RoomInstance(iid, "chair", [BoxPart((cx, cy, 0.23), (0.22, 0.22, 0.23)), BoxPart((cx, cy + 0.2, 0.65), (0.22, 0.02, 0.2))])


def default_instances() -> list[RoomInstance]:
    """The test room: a table, a bookshelf, a sofa and a chair around the origin."""
    return [table(1, 0.0, 0.0), bookshelf(2, -1.6, 1.6), sofa(3, 1.4, 1.7), chair(4, 0.0, -0.9)]


def mjcf(instances: list[RoomInstance], room: float = 3.0) -> str:
    """Return an MJCF string: a floor (inst_0) and the instances' boxes named inst_<k>_<j>."""
    rgba = ["0.6 0.4 0.2 1", "0.3 0.5 0.7 1", "0.7 0.2 0.2 1", "0.2 0.6 0.3 1", "0.5 0.5 0.5 1"]
    geoms = [f'<geom name="inst_0" type="plane" size="{room} {room} 0.1" rgba="0.8 0.8 0.8 1"/>']
    for inst in instances:
        for j, p in enumerate(inst.parts):
            c = " ".join(f"{v:.4f}" for v in p.center)
            h = " ".join(f"{v:.4f}" for v in p.half)
            geoms.append(f'<geom name="inst_{inst.id}_{j}" type="box" pos="{c}" size="{h}" rgba="{rgba[inst.id % 5]}"/>')
    body = "\n    ".join(geoms)
    return f"""<mujoco model="perceive_test">
  <visual><global offwidth="640" offheight="480"/></visual>
  <worldbody>
    <light pos="0 0 4" dir="0 0 -1" directional="true"/>
    {body}
  </worldbody>
</mujoco>"""


def scene_asset(instances: list[RoomInstance]) -> SceneAsset:
    """Return a SceneAsset naming the instances, with their ground-truth support surfaces."""
    sem = [SemanticInstance(id=0, label="floor", geoms=["inst_0"])]
    sups = []
    for inst in instances:
        sem.append(SemanticInstance(id=inst.id, label=inst.label, geoms=[f"inst_{inst.id}_{j}" for j in range(len(inst.parts))],
                                    bounds=inst.bounds))
        sups += [SupportSurface(instance_id=inst.id, height=h, polygon=poly) for h, poly in inst.supports]
    return SceneAsset(name="perceive_test", mjcf="", instances=sem, support_surfaces=sups)


def camera_poses(instances: list[RoomInstance]) -> list[np.ndarray]:
    """Return OpenCV poses looking at every instance from several sides and heights."""
    from sdovon_mj.sim.camera import pose_cv

    poses = []
    for inst in instances:
        b = inst.bounds
        c = (b[0] + b[1]) / 2
        for k in range(6):
            ang = math.radians(-90 + k * 60 + 15 * (inst.id % 2))
            dist = 1.9
            pos = np.array([c[0] + dist * math.cos(ang), c[1] + dist * math.sin(ang), 0.0])
            for height, pitch in ((1.3, -30.0), (1.6, -45.0)):
                pos[2] = height
                yaw = math.degrees(math.atan2(c[1] - pos[1], c[0] - pos[0]))
                poses.append(pose_cv(pos.copy(), yaw, pitch))
    return poses


def render_observations(xml: str, poses: list[np.ndarray], width: int = 320, height: int = 240) -> list[Observation]:
    """Render RGB, depth and instance segmentation from every pose."""
    import mujoco

    from sdovon_mj.sim.model import geom_segment_ids, segment_image
    from sdovon_mj.sim.render import SceneRenderer

    model = mujoco.MjModel.from_xml_string(xml)
    lut = geom_segment_ids(model)
    out = []
    with SceneRenderer(model, width=width, height=height, hfov=79.0, znear=0.05, zfar=20.0) as r:
        for v, T in enumerate(poses):
            f = r.render(T, rgb=True, depth=True, segmentation=True)
            out.append(Observation(rgb=f.rgb, depth=f.depth, K=r.K.copy(), T_cam=np.asarray(T, float),
                                   segmentation=segment_image(f.segmentation, lut), view_id=v))
    return out


@functools.lru_cache(maxsize=None)
def rendered_room() -> tuple[list[RoomInstance], SceneAsset, list[Observation]]:
    """The default test room and its rendered observations (cached per process)."""
    insts = default_instances()
    obs = render_observations(mjcf(insts), camera_poses(insts))
    return insts, scene_asset(insts), obs


@functools.lru_cache(maxsize=None)
def fused_room(depth_noise_sigma: float = 0.0, seed: int = 0) -> list:
    """The test room's fused instances from the gt detector (cached per process)."""
    from sdovon_mj.config import PerceiveConfig
    from sdovon_mj.perceive import perceive_scene

    _insts, scene, obs = rendered_room()
    return perceive_scene(obs, scene, PerceiveConfig(depth_noise_sigma=depth_noise_sigma), seed=seed)


def match_instances(fused: list, truth: list[RoomInstance], labels: tuple[str, ...], iou_min: float = 0.5) -> tuple[float, float]:
    """Precision and recall of fused receptacle instances vs ground truth at 3D box IoU >= iou_min."""
    from sdovon_mj.perceive.correction import box_iou_3d
    from sdovon_mj.receptacles.identify import receptacle_instances

    pred = receptacle_instances(fused, labels)
    gt = [t for t in truth if t.label in labels]
    used: set[int] = set()
    tp = 0
    for t in gt:
        best = max(((box_iou_3d(p.bounds, t.bounds), k) for k, p in enumerate(pred)
                    if k not in used and p.label == t.label), default=(0.0, -1))
        if best[0] >= iou_min:
            tp += 1
            used.add(best[1])
    return tp / max(len(pred), 1), tp / max(len(gt), 1)


def match_surfaces(planes: list, scene: SceneAsset, height_tol: float) -> list[tuple[int, float, float, float]]:
    """For every true support surface: (instance id, true height, height error, best polygon IoU) of the best plane."""
    from sdovon_mj.geometry import polygon_iou

    out = []
    for s in scene.support_surfaces:
        cands = [(polygon_iou(p.polygon, s.polygon), abs(p.height - s.height)) for p in planes
                 if p.instance_id >= 0 and abs(p.height - s.height) <= height_tol]
        iou, err = max(cands, default=(0.0, float("inf")))
        out.append((s.instance_id, float(s.height), float(err), float(iou)))
    return out
