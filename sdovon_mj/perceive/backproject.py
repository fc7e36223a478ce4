"""Back-projection of 2D detections with depth, K and T_cam into 3D instances (paper equations 1-2)."""

from __future__ import annotations

import numpy as np

from .. import native
from ..config import PerceiveConfig
from ..records import Detection, Instance, Observation
from ..sim.camera import backproject, valid_depth


_OFF = 1 << 20  # voxel index offset: keys cover +-2^20 voxels per axis


def voxel_keys(points: np.ndarray, voxel: float) -> np.ndarray:
    """Return one int64 key per point naming its voxel (21 bits per axis)."""
    ijk = np.floor(np.asarray(points, dtype=np.float64) / voxel).astype(np.int64) + _OFF
    return (ijk[:, 0] << 42) | (ijk[:, 1] << 21) | ijk[:, 2]


def voxel_sums(points: np.ndarray, voxel: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return sorted voxel keys, per-voxel point sums (n, 3) and counts (n,)."""
    uniq, sums, counts, _vmax = voxel_stats(points, voxel)
    return uniq, sums, counts


def voxel_stats(points: np.ndarray, voxel: float, values: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Return sorted voxel keys, per-voxel point sums (n, 3), counts (n,) and the per-voxel max of `values` (NaN ignored; None without values)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    v = None
    if values is not None:
        v = np.asarray(values, dtype=np.float64).reshape(-1)
        if len(v) != len(p):
            raise ValueError(f"voxel_stats: {len(v)} values for {len(p)} points")
    lib = native.library() if len(p) else None
    if lib is not None:  # the same arrays in one compiled pass (native sdv_voxel_stats: sums added in input order)
        p = np.ascontiguousarray(p)
        n = len(p)
        order, uniq, starts = (np.empty(n, dtype=np.int64) for _ in range(3))
        counts, sums = np.empty(n), np.empty((n, 3))
        m = lib.sdv_voxel_stats(p.ctypes.data, n, float(voxel), order.ctypes.data, uniq.ctypes.data,
                                starts.ctypes.data, counts.ctypes.data, sums.ctypes.data)
        if m == -1:
            raise MemoryError("voxel_stats: out of memory")
        if m >= 0:
            vmax = None if v is None else np.fmax.reduceat(v[order], starts[:m])
            return uniq[:m], sums[:m], counts[:m], vmax
    keys = voxel_keys(p, voxel)
    # np.unique(keys, return_inverse=True, return_counts=True) by one stable sort, whose order the values' maxima
    # reuse (sorting by the inverse, as they did, is the same permutation: the inverse ranks the keys)
    order = np.argsort(keys, kind="stable")
    sk = keys[order]
    first = np.empty(len(sk), dtype=bool)
    first[:1] = True
    np.not_equal(sk[1:], sk[:-1], out=first[1:])
    starts = np.flatnonzero(first)
    uniq = sk[starts]
    counts = np.diff(np.append(starts, len(sk)))
    inv = np.empty(len(sk), dtype=np.int64)
    inv[order] = np.cumsum(first) - 1
    sums = np.zeros((len(uniq), 3))
    for d in range(3):  # bincount adds each voxel's points in their input order, as before
        sums[:, d] = np.bincount(inv, weights=p[:, d], minlength=len(uniq))
    vmax = None
    if v is not None:
        vmax = np.full(len(uniq), np.nan)
        if len(v):
            vmax = np.fmax.reduceat(v[order], starts)
    return uniq, sums, counts.astype(np.float64), vmax


def voxel_downsample(points: np.ndarray, voxel: float) -> np.ndarray:
    """Return the mean point of every occupied voxel, in voxel-key order."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if voxel <= 0 or len(p) == 0:
        return p
    _keys, sums, counts = voxel_sums(p, voxel)
    return sums / counts[:, None]


def voxel_downsample_heights(points: np.ndarray, voxel: float, camera_z: float) -> tuple[np.ndarray, np.ndarray]:
    """Return `voxel_downsample(points, voxel)` and, per voxel, the greatest height of the camera above its points (m).

    ``camera_z`` is the world height of the camera centre that saw the points; a voxel's value is
    ``camera_z - min z`` of its points (positive: seen from above). The points are the same bytes as
    `voxel_downsample` returns.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    h = float(camera_z) - p[:, 2]
    if voxel <= 0 or len(p) == 0:
        return p, h
    _keys, sums, counts, vmax = voxel_stats(p, voxel, h)
    return sums / counts[:, None], vmax  # type: ignore[return-value]


def make_instance(world_points: np.ndarray, label: str, confidences: list[float], source_views: list[int],
                  gt_id: int = -1, instance_id: int = -1, view_height: np.ndarray | None = None) -> Instance:
    """Decompose world points into centre and centred points (paper equation 2) as an Instance.

    Parameters
    ----------
    world_points : (N, 3) float
        Points of the instance, world metres.
    label : str
        Category label.
    confidences : list of float
        Detection scores.
    source_views : list of int
        Ids of the views it was seen in.
    gt_id : int
        Ground-truth instance id (-1: unknown).
    instance_id : int
        Id of the instance (-1: not yet numbered).
    view_height : (N,) float, optional
        Per point, the greatest height of an observing camera centre above it, metres (NaN: unknown;
        see `Instance.view_height`); None: not recorded.
    """
    p = np.asarray(world_points, dtype=np.float64)
    c = p.mean(axis=0) if len(p) else np.zeros(3)
    vh = None
    if view_height is not None:
        vh = np.asarray(view_height, dtype=np.float32).reshape(-1)
        if len(vh) != len(p):
            raise ValueError(f"make_instance: {len(vh)} view heights for {len(p)} points")
    return Instance(id=int(instance_id), label=label, points=(p - c).astype(np.float32), center=c,
                    confidences=[float(s) for s in confidences], source_views=[int(v) for v in source_views],
                    gt_id=int(gt_id), view_height=vh)


def noisy_depth(obs: Observation, sigma: float, seed: int = 0) -> np.ndarray:
    """Return the depth image with Gaussian noise of std `sigma` on valid pixels (seeded per view)."""
    depth = np.asarray(obs.depth, dtype=np.float32)
    if sigma <= 0:
        return depth
    rng = np.random.default_rng([int(seed), int(obs.view_id) & 0x7FFFFFFF, 0x5D0])
    noise = rng.normal(0.0, sigma, size=depth.shape).astype(np.float32)
    return np.where(depth > 0, np.maximum(depth + noise, 0.0), 0.0).astype(np.float32)


def backproject_detections(obs: Observation, detections: list[Detection], cfg: PerceiveConfig,
                           seed: int = 0, depth_noise_sigma: float | None = None) -> list[Instance]:
    """Return one 3D instance per detection: masked valid depth lifted to world, voxel-downsampled.

    Each instance records per point the height of the camera centre above it (``view_height``).

    Parameters
    ----------
    obs : Observation
        The view: depth (H, W) metres, intrinsics K (3, 3), pose T_cam (4, 4) world <- camera.
    detections : list of Detection
        Detections of the view, masks (H, W) bool.
    cfg : PerceiveConfig
        Depth range, voxel size and minimum points per instance.
    seed : int
        Seed of the depth noise.
    depth_noise_sigma : float, optional
        Depth noise std, metres (default: the config's).
    """
    sigma = cfg.depth_noise_sigma if depth_noise_sigma is None else float(depth_noise_sigma)
    depth = noisy_depth(obs, sigma, seed)
    K = np.asarray(obs.K, dtype=np.float64)
    T = np.asarray(obs.T_cam, dtype=np.float64)
    out: list[Instance] = []
    valid = valid_depth(depth, cfg.depth_min, cfg.depth_max) if detections else None  # once per view
    for det in detections:
        mask = np.asarray(det.mask, dtype=bool)
        if mask.shape != depth.shape:
            raise ValueError(f"detection mask {mask.shape} does not match depth {depth.shape} in view {obs.view_id}")
        pts = backproject(depth, K, T, mask=mask, depth_min=cfg.depth_min, depth_max=cfg.depth_max, valid=valid)
        # per voxel, how high the camera was above it: an up-facing surface is only seen from above
        pts, vh = voxel_downsample_heights(pts, cfg.voxel_size, float(T[2, 3]))
        if len(pts) < max(cfg.min_points, 1):
            continue
        out.append(make_instance(pts, det.label, [det.score], [det.view_id if det.view_id else obs.view_id], det.gt_id,
                                 view_height=vh))
    return out
