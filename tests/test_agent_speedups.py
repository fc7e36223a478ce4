"""Issue 47's agent speed-ups give the same results: each optimised function against the straightforward code it
replaced (kept here verbatim as the reference), exact equality on random inputs; and the bench's environment-step
split prints positive figures on the fixture apartment (no timing is asserted).
"""

from __future__ import annotations

import heapq
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from sdovon_mj.actions import MOVE_FORWARD, TURN_LEFT, TURN_RIGHT
from sdovon_mj.config import AgentConfig, NavConfig
from sdovon_mj.geometry import axis_bounds, boxes_apart, in_box, points_in_polygon
from sdovon_mj.grid import GridFrame
from sdovon_mj.nav.control import goal_field, lattice_plan
from sdovon_mj.nav.frontier import FREE, OCCUPIED, OccupancyMap
from sdovon_mj.nav.memory import sample_nav_points
from sdovon_mj.records import ReceptaclePlane
from sdovon_mj.sim.camera import backproject, intrinsics, pose_cv

ROOT = Path(__file__).resolve().parents[1]


def _reference_integrate(occ: OccupancyMap, depth: np.ndarray, K: np.ndarray, T_cam: np.ndarray, depth_max: float,
                         stride: int = 2) -> None:
    """`OccupancyMap.integrate` before issue 47: every ray's samples as one (rays, n, 2) array, whole-grid masks."""
    d = np.asarray(depth, dtype=np.float32)
    d = d[::stride, ::stride]
    Ks = K.copy()
    Ks[0, 0] /= stride
    Ks[1, 1] /= stride
    Ks[0, 2] /= stride
    Ks[1, 2] /= stride
    far = d >= depth_max - 1e-3
    pts = backproject(np.where(far, depth_max, d), Ks, T_cam, depth_min=0.01, depth_max=depth_max + 1.0)
    farv = far[np.nonzero((np.where(far, depth_max, d) > 0.01))]
    cam = T_cam[:3, 3]
    z = pts[:, 2] - occ.floor_z
    hit_obstacle = (~farv) & (z > occ.obstacle_min) & (z < occ.agent.height + 0.1)
    res = occ.frame.resolution
    vec = pts[:, :2] - cam[None, :2]
    length = np.linalg.norm(vec, axis=1)
    n = int(np.ceil(length.max() / res)) if len(length) else 0
    if n > 0:
        t = np.arange(n)[None, :] * res
        valid = t < (length[:, None] - res)
        unit = vec / np.maximum(length[:, None], 1e-9)
        samples = cam[None, None, :2] + unit[:, None, :] * t[..., None]
        cells = occ.frame.to_cell(samples[valid])
        cells = cells[occ.frame.inside(cells)]
        free = np.zeros(occ.frame.shape, bool)
        free[cells[:, 0], cells[:, 1]] = True
        occ.state[free & (occ.state != OCCUPIED)] = FREE
    floor_hits = (~farv) & (np.abs(z) <= occ.obstacle_min)
    fc = occ.frame.to_cell(pts[floor_hits, :2])
    fc = fc[occ.frame.inside(fc)]
    mark = np.zeros(occ.frame.shape, bool)
    mark[fc[:, 0], fc[:, 1]] = True
    occ.state[mark & (occ.state != OCCUPIED)] = FREE
    oc = occ.frame.to_cell(pts[hit_obstacle, :2])
    oc = oc[occ.frame.inside(oc)]
    occ.state[oc[:, 0], oc[:, 1]] = OCCUPIED


def test_occupancy_integrate_equals_the_full_array_reference():
    """Frames of random depth (near, far, floor and obstacle hits, some rays leaving the map) integrated one after
    another give the same occupancy map, cell for cell, as the replaced code."""
    rng = np.random.default_rng(47)
    frame = GridFrame(np.array([-3.0, -3.0]), 0.05, (120, 120))  # 6 m: rays of a 5 m depth range leave it
    K = intrinsics(64, 48, 79.0)
    for trial in range(3):
        new, ref = (OccupancyMap(frame, floor_z=0.0, agent=AgentConfig()) for _ in range(2))
        for _ in range(6):
            depth = rng.uniform(0.3, 5.5, size=(48, 64)).astype(np.float32)
            depth[rng.random(depth.shape) < 0.2] = 5.0  # far: carved, never an obstacle
            pos = np.append(rng.uniform(-1.5, 1.5, 2), 0.88)
            T = pose_cv(pos, float(rng.uniform(0, 360)), float(rng.choice([-30.0, 0.0])))
            new.integrate(depth, K, T, 5.0)
            _reference_integrate(ref, depth, K, T, 5.0)
            assert np.array_equal(new.state, ref.state), trial
        assert (new.state == FREE).any() and (new.state == OCCUPIED).any()


def test_occupancy_traversable_equals_the_whole_map_reference():
    """Traversable cells of random maps (free rooms, occupied specks and walls, unknown, refused cells; free cells at
    the map's edge) are the whole-map computation's, cell for cell."""
    from sdovon_mj.grid import dilate

    rng = np.random.default_rng(4748)
    frame = GridFrame(np.zeros(2), 0.05, (150, 170))
    for k in range(10):
        occ = OccupancyMap(frame, agent=AgentConfig())
        for _ in range(int(rng.integers(1, 4))):
            r, c = rng.integers(-10, 140, 2)
            occ.state[max(r, 0):r + int(rng.integers(10, 60)), max(c, 0):c + int(rng.integers(10, 60))] = FREE
        occ.state[(rng.random(frame.shape) < 0.02) & (occ.state == FREE)] = OCCUPIED
        occ.state[int(rng.integers(0, 150)), :] = OCCUPIED  # a wall across the map
        if k % 2:
            occ.mark_blocked(rng.integers(0, 150, size=(20, 2)))
        want = (occ.state == FREE) & ~dilate(occ.state == OCCUPIED, occ.agent.radius, frame.resolution)
        want = want if occ.blocked is None else want & ~occ.blocked
        assert np.array_equal(occ.traversable(), want), k
        assert want.any()
    empty = OccupancyMap(frame, agent=AgentConfig())
    assert not empty.traversable().any()


# `lattice_plan` before issue 47 (verbatim but the name): the whole field and mask listed on every call.
def _reference_lattice_plan(pos: np.ndarray, yaw: float, target: np.ndarray, tolerance: float, mask: np.ndarray,
                 frame: GridFrame, nav, max_nodes: int = 20000, weight: float = 1.2) -> list[int] | None:
    """Return an action list (forward/turn) ending within `tolerance` of target with every move on the mask, or None.

    A* over the poses the agent can reach (0.25 m steps, 30-degree headings, positions keyed at 1 cm);
    the heuristic is the grid geodesic distance to the goal region in steps (weighted by `weight`,
    ties to the deeper node), so the search hugs the shortest grid path and threads doorways the
    agent's heading lattice can pass.
    """
    step, turn = nav.forward_step, nav.turn_angle
    n_head = int(round(360.0 / turn))
    tx, ty = float(target[0]), float(target[1])
    field = goal_field(mask, frame, np.array([tx, ty]), tolerance)
    h_, w_ = mask.shape
    ox, oy, res = float(frame.origin[0]), float(frame.origin[1]), float(frame.resolution)
    fl = (field / step).tolist()
    ml = np.asarray(mask, dtype=bool).tolist()
    tol2 = tolerance * tolerance
    floor = math.floor

    def heur(x: float, y: float) -> float:
        if (tx - x) ** 2 + (ty - y) ** 2 <= tol2:
            return 0.0
        col, row = floor((x - ox) / res), floor((y - oy) / res)
        if not (0 <= row < h_ and 0 <= col < w_):
            return math.inf
        return fl[row][col]

    n_s = max(1, int(math.ceil(step / (res / 2.0))))
    dirs, samples = [], []
    for k in range(n_head):
        c, s_ = math.cos(math.radians(yaw + k * turn)), math.sin(math.radians(yaw + k * turn))
        dirs.append((step * c, step * s_))
        samples.append([(step * c * i / n_s, step * s_ * i / n_s) for i in range(n_s + 1)])

    def free(x: float, y: float, k: int) -> bool:
        for dx, dy in samples[k]:
            col, row = floor((x + dx - ox) / res), floor((y + dy - oy) / res)
            if not (0 <= row < h_ and 0 <= col < w_) or not ml[row][col]:
                return False
        return True

    x0, y0 = float(pos[0]), float(pos[1])
    if (tx - x0) ** 2 + (ty - y0) ** 2 <= tol2:
        return []
    h0 = heur(x0, y0)
    if not math.isfinite(h0):
        return None
    start = (round(x0 * 100.0), round(y0 * 100.0), 0)
    pose = {start: (x0, y0)}
    parent: dict[tuple, tuple] = {start: (None, -1)}
    gbest = {start: 0}
    heap = [(weight * h0, 0, 0, start)]
    counter = 0
    nodes = 0
    while heap and nodes < max_nodes:
        _f, ng, _c, kk = heapq.heappop(heap)
        g = -ng
        if gbest.get(kk, math.inf) < g:
            continue
        nodes += 1
        x, y = pose[kk]
        k = kk[2]
        if (tx - x) ** 2 + (ty - y) ** 2 <= tol2:
            acts = []
            while parent[kk][0] is not None:
                kk, a = parent[kk]
                acts.append(a)
            return acts[::-1]
        succ = [(x, y, (k + 1) % n_head, TURN_LEFT), (x, y, (k - 1) % n_head, TURN_RIGHT)]
        if free(x, y, k):
            succ.append((x + dirs[k][0], y + dirs[k][1], k, MOVE_FORWARD))
        for sx, sy, sk_, act in succ:
            hs = heur(sx, sy)
            if hs == math.inf:
                continue
            sk = (round(sx * 100.0), round(sy * 100.0), sk_)
            if g + 1 < gbest.get(sk, math.inf):
                gbest[sk] = g + 1
                parent[sk] = (kk, act)
                pose[sk] = (sx, sy)
                counter += 1
                heapq.heappush(heap, (g + 1 + weight * hs, -(g + 1), counter, sk))
    return None




def test_frontiers_equal_the_whole_map_reference():
    """Frontier clusters of random maps (free rooms with unknown around them, occupied specks, free cells on the map's
    edge, refused cells) are the whole-map computation's: the same clusters, cells in the same order, same order."""
    rng = np.random.default_rng(4749)
    frame = GridFrame(np.zeros(2), 0.05, (130, 150))
    found = 0
    for k in range(12):
        occ = OccupancyMap(frame, agent=AgentConfig())
        for _ in range(int(rng.integers(1, 5))):
            r, c = rng.integers(-10, 120, 2)
            occ.state[max(r, 0):r + int(rng.integers(10, 70)), max(c, 0):c + int(rng.integers(10, 70))] = FREE
        occ.state[(rng.random(frame.shape) < 0.01) & (occ.state == FREE)] = OCCUPIED
        if k % 3 == 0:
            occ.state[:, -1] = FREE  # free cells on the map's edge: the edge counts as known
        if k % 2:
            occ.mark_blocked(rng.integers(0, 130, size=(20, 2)))
        trav = occ.traversable()
        near_unknown = ndimage.binary_dilation(occ.state == 0, structure=np.ones((3, 3), bool))
        lab, n = ndimage.label(trav & near_unknown, structure=np.ones((3, 3), bool))
        want = [c for c in (np.argwhere(lab == j) for j in range(1, n + 1)) if len(c) >= 4]
        got = occ.frontiers()
        assert len(got) == len(want) and all(np.array_equal(a, b) and a.dtype == b.dtype for a, b in zip(got, want)), k
        found += len(want)
    assert found > 12

def test_lattice_plan_equals_the_whole_grid_reference():
    """Plans on random room-like masks (a few open rectangles in a larger grid, as an agent's map around what it saw)
    are the same action lists as the replaced code's, reachable targets and not."""
    rng = np.random.default_rng(470)
    nav = NavConfig()
    frame = GridFrame(np.zeros(2), 0.05, (160, 160))
    plans = 0
    for _ in range(12):
        mask = np.zeros(frame.shape, bool)
        for _ in range(int(rng.integers(1, 4))):
            r, c = rng.integers(20, 110, 2)
            mask[r:r + int(rng.integers(15, 45)), c:c + int(rng.integers(15, 45))] = True
        cells = np.argwhere(mask)
        a, b = cells[rng.integers(len(cells), size=2)]
        start, goal = frame.to_world(np.array([a, b]))
        yaw = float(rng.uniform(0, 360))
        got = lattice_plan(start, yaw, goal, 0.2, mask, frame, nav, max_nodes=4000)
        want = _reference_lattice_plan(start, yaw, goal, 0.2, mask, frame, nav, max_nodes=4000)
        assert got == want
        plans += got is not None
    assert plans > 0  # some targets were reached: the equality covers found plans, not only failures


# `memory.sample_nav_points` before issue 47 (verbatim but the name): the whole map's cells tested and transformed.
def _reference_sample_nav_points(plane: ReceptaclePlane, traversable: np.ndarray, frame: GridFrame, near: float = 0.25,
                      far: float = 1.0, spacing: float = 0.5) -> np.ndarray:
    """Return navigation points (K, 2): traversable cells `near`..`far` m from the plane, `spacing` apart."""
    h, w = traversable.shape
    rows, cols = np.mgrid[0:h, 0:w]
    centres = frame.to_world(np.stack([rows.ravel(), cols.ravel()], 1))
    inside = points_in_polygon(plane.polygon, centres).reshape(h, w)
    if not inside.any():
        c = frame.to_cell(np.asarray(plane.polygon, float).mean(axis=0)[None])[0]
        if frame.inside(c[None])[0]:
            inside[c[0], c[1]] = True
    dist = ndimage.distance_transform_edt(~inside) * frame.resolution
    cand = np.argwhere(traversable & (dist >= near) & (dist <= far))
    if len(cand) == 0:
        cand = np.argwhere(traversable & (dist <= far + 1.0))
    if len(cand) == 0:
        return np.zeros((0, 2))
    order = np.argsort(dist[cand[:, 0], cand[:, 1]], kind="stable")
    xy = frame.to_world(cand[order])
    keep: list[np.ndarray] = []
    for p in xy:
        if all(np.linalg.norm(p - q) >= spacing for q in keep):
            keep.append(p)
    return np.array(keep)


def test_sample_nav_points_equals_the_whole_map_reference():
    """Navigation points around random receptacle polygons (inside the map, across its edge, off it, a sliver with no
    cell centre inside) on random traversable maps are the same points in the same order as the replaced code's."""
    rng = np.random.default_rng(4747)
    frame = GridFrame(np.array([-1.0, -2.0]), 0.05, (140, 180))
    found = 0
    for k in range(16):
        trav = rng.random(frame.shape) < 0.8
        centre = rng.uniform([-2.0, -3.0], [9.0, 6.0]) if k % 4 else rng.uniform([1.0, 0.0], [7.0, 4.0])
        poly = centre + rng.uniform(-0.6, 0.6, size=(int(rng.integers(3, 7)), 2))
        if k == 5:
            poly = centre + np.array([[0.0, 0.0], [0.5, 0.001], [0.0, 0.002]])  # a sliver: the centroid's cell
        plane = ReceptaclePlane(id=0, instance_id=0, label="table", height=0.7, polygon=poly,
                                normal=np.array([0.0, 0.0, 1.0]))
        got = sample_nav_points(plane, trav, frame)
        want = _reference_sample_nav_points(plane, trav, frame)
        assert got.shape == want.shape and np.array_equal(got, want), k
        found += len(got) > 0
    assert found > 0


def test_bench_suite_prints_the_environment_step_split():
    """`bench/bench_suite.py` prints the step split at a tiny size on the fixture apartment, both modes, every phase
    a positive figure (the figures themselves are not asserted: speed is measured, not tested)."""
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), LP_NUM_THREADS="1")
    out = subprocess.run([sys.executable, str(ROOT / "bench" / "bench_suite.py"), "--no-env", "--agents",
                          "--split-sizes", "32x24", "--split-steps", "3"], capture_output=True, text=True, env=env,
                         timeout=600, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-2000:]
    rows = [l for l in out.stdout.splitlines() if re.match(r"\| \S+ \| 32x24 \| ", l)]
    assert [r.split("|")[3].strip() for r in rows] == ["in-process", "sealed"], out.stdout
    for r in rows:
        figures = [float(v) for v in r.strip().strip("|").split("|")[3:]]
        assert len(figures) == 6 and all(f > 0 for f in figures), r


# `CategoryDetector.detect` before this change (verbatim but the name): each category labelled over the whole image.
def _reference_detect(det, cat: np.ndarray, view_id: int = 0) -> list[tuple[str, np.ndarray]]:
    need = det.eta * cat.size
    out = []
    ids, counts = np.unique(cat[cat >= 0], return_counts=True)
    for c, n in zip(ids.tolist(), counts.tolist()):
        if n < need or not 0 <= c < len(det.labels):
            continue
        regions, k = ndimage.label(cat == c, structure=np.ones((3, 3), bool))
        sizes = np.bincount(regions.ravel(), minlength=k + 1)
        for r in range(1, k + 1):
            if sizes[r] >= need:
                out.append((det.labels[c], regions == r))
    return out


def test_category_detections_equal_the_whole_image_labelling():
    """Random category images (blobs of several categories, touching and apart, at the image's edges, specks below
    eta, unknown ids): the same detections in the same order, masks pixel for pixel."""
    from sdovon_mj.nav.sensing import CategoryDetector
    from sdovon_mj.records import Observation

    rng = np.random.default_rng(4749)
    det = CategoryDetector(("chair", "table", "bed", "sofa"), eta=0.002)
    found = 0
    for trial in range(25):
        cat = np.full((48, 64), -1, np.int16)
        for _ in range(int(rng.integers(0, 9))):
            r, c = rng.integers(-5, 48, 2)
            cat[max(r, 0):r + int(rng.integers(1, 15)), max(c, 0):c + int(rng.integers(1, 20))] = rng.integers(0, 5)
        obs = Observation(view_id=trial, rgb=np.zeros((48, 64, 3), np.uint8), depth=np.ones((48, 64), np.float32),
                          K=np.eye(3), T_cam=np.eye(4), segmentation=cat)
        got = [(d.label, d.mask) for d in det.detect(obs)]
        want = _reference_detect(det, cat)
        assert len(got) == len(want), trial
        assert all(a[0] == b[0] and np.array_equal(a[1], b[1]) for a, b in zip(got, want)), trial
        found += len(want)
    assert found > 20


# `sim.camera.backproject` before it cut masked images to the mask's bounding box (verbatim but the name).
def _reference_backproject(depth, K, T_cam, mask=None, depth_min=0.0, depth_max=np.inf, valid=None):
    from sdovon_mj.sim.camera import valid_depth

    valid = valid_depth(depth, depth_min, depth_max) if valid is None else valid
    valid = valid & mask if mask is not None else valid
    v, u = np.nonzero(valid)
    z = depth[v, u].astype(np.float64)
    x = (u + 0.5 - K[0, 2]) * z / K[0, 0]
    y = (v + 0.5 - K[1, 2]) * z / K[1, 1]
    pc = np.stack([x, y, z], axis=1)
    return pc @ T_cam[:3, :3].T + T_cam[:3, 3]


# `nav.goal.goal_points` (verbatim but the name) over the whole-image back-projection.
def _reference_goal_points(depth, mask, K, T_cam, depth_min, depth_max):
    d = np.asarray(depth, dtype=np.float64)
    if d.ndim == 3:
        d = d[..., 0]
    m = np.asarray(mask, dtype=bool)
    pts = _reference_backproject(d, K, T_cam, mask=m, depth_min=depth_min + 1e-3, depth_max=depth_max - 1e-3)
    if len(pts) or not m.any():
        return pts
    near = m & (d <= depth_min + 1e-3)
    if not near.any():
        return np.zeros((0, 3))
    return _reference_backproject(np.full_like(d, depth_min), K, T_cam, mask=near, depth_min=0.0)


def test_goal_points_equal_the_whole_image_back_projection():
    """Masks anywhere in the image (edges, empty), depth with near- and far-clipped pixels: the same points, bit for
    bit, as back-projecting the whole image under the mask."""
    from sdovon_mj.nav.goal import goal_points

    rng = np.random.default_rng(4750)
    K = intrinsics(64, 48, 79.0)
    nonempty = 0
    for trial in range(30):
        depth = rng.uniform(0.0, 5.0, size=(48, 64, 1)).astype(np.float32)
        depth[rng.random(depth.shape) < 0.15] = 5.0
        if trial % 3 == 0:
            depth[...] = 0.1  # everything at the near limit: the mask's ray stands in
        mask = np.zeros((48, 64), bool)
        if trial % 7:
            r, c = rng.integers(-4, 48, 2)
            mask[max(r, 0):r + int(rng.integers(1, 20)), max(c, 0):c + int(rng.integers(1, 30))] = True
        T = pose_cv(np.append(rng.uniform(-2, 2, 2), 0.88), float(rng.uniform(0, 360)), float(rng.uniform(-30, 10)))
        got = goal_points(depth, mask, K, T, 0.1, 5.0)
        want = _reference_goal_points(depth, mask, K, T, 0.1, 5.0)
        assert got.shape == want.shape and np.array_equal(got, want), trial
        nonempty += len(got) > 0
    assert nonempty > 10


def _reference_geodesic_distance(gf, xy: np.ndarray) -> float:
    """`GeodesicField.distance` before this change (verbatim but the name): the 9 cells one at a time."""
    import math

    from sdovon_mj.grid import segment_free

    p = np.asarray(xy, dtype=float)[:2]
    if len(gf.targets) == 0:
        return math.inf
    best = math.inf
    eu = np.linalg.norm(gf.targets - p[None], axis=1)
    for k in np.argsort(eu, kind="stable")[:8]:
        if eu[k] >= best:
            break
        if segment_free(gf.mask, gf.frame, p, gf.targets[k]):
            best = float(eu[k])
            break
    rc = gf.frame.to_cell(p[None])[0]
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            c = np.array([rc[0] + dr, rc[1] + dc])
            if not gf.frame.inside(c[None])[0] or not gf.mask[c[0], c[1]]:
                continue
            centre = gf.frame.to_world(c[None])[0]
            if (dr or dc) and not segment_free(gf.mask, gf.frame, p, centre):
                continue
            best = min(best, float(gf.field[c[0], c[1]] + np.linalg.norm(centre - p)))
    return best


def test_geodesic_distance_equals_the_cell_by_cell_reference():
    """Points anywhere (on the mask, beside walls, at the grid's edge and off it) to targets behind walls and in
    sight: the same distance, bit for bit, as testing the 9 cells one at a time."""
    from sdovon_mj.gridgraph import GeodesicField

    rng = np.random.default_rng(4752)
    frame = GridFrame(np.array([0.31, -0.77]), 0.05, (50, 60))
    mask = np.ones(frame.shape, bool)
    mask[25, 5:] = False
    mask[rng.random(frame.shape) < 0.05] = False
    finite = 0
    for trial in range(8):
        gf = GeodesicField(mask, frame, rng.uniform([0.31, -0.77], [3.31, 1.73], size=(int(rng.integers(1, 6)), 2)))
        for _ in range(60):
            p = rng.uniform([0.2, -0.9], [3.45, 1.85])
            got, want = gf.distance(p), _reference_geodesic_distance(gf, p)
            assert got == want or (np.isinf(got) and np.isinf(want)), (trial, p)
            finite += np.isfinite(got)
    assert finite > 100


def test_segment_image_equals_the_masked_lookup():
    """Geom-id images with none (-1), other negative values and every geom: the table's segment ids as the masked
    lookup gave them (int32, -1 where no geom)."""
    from sdovon_mj.sim.model import segment_image

    rng = np.random.default_rng(4753)
    lut = rng.integers(-1, 100_500, size=300).astype(np.int64)
    ids = rng.integers(-3, 300, size=(48, 64)).astype(np.int32)
    want = np.full(ids.shape, -1, dtype=np.int32)
    ok = ids >= 0
    want[ok] = lut[ids[ok]]
    got = segment_image(ids, lut)
    assert got.dtype == np.int32 and np.array_equal(got, want)


def test_clip_depth_range_equals_nan_to_num_then_clip():
    """Depth images (float32 and float64) with NaN, +-inf, -0.0 and values either side of the range: the bits of
    ``np.clip(np.nan_to_num(d, nan=hi, posinf=hi), lo, hi).astype(np.float32)``, the form it replaces."""
    from sdovon_mj.sim.render import clip_depth_range

    rng = np.random.default_rng(4754)
    for dtype in (np.float32, np.float64):
        d = rng.uniform(-1.0, 12.0, size=(60, 80)).astype(dtype)
        for value, count in ((np.nan, 300), (np.inf, 300), (-np.inf, 300), (-0.0, 30)):
            d.flat[rng.integers(0, d.size, count)] = value
        for lo, hi in ((0.1, 5.0), (0.0, 10.0), (0.5, 4.9)):
            want = np.clip(np.nan_to_num(d, nan=hi, posinf=hi), lo, hi).astype(np.float32)
            got = clip_depth_range(d, lo, hi)
            assert got.dtype == np.float32 and np.array_equal(got.view(np.uint32), want.view(np.uint32))
    clean = rng.uniform(0.0, 6.0, size=(8, 8)).astype(np.float32)  # no NaN: no fill
    assert np.array_equal(clip_depth_range(clean, 0.1, 5.0), np.clip(clean, 0.1, 5.0))


def test_distance_field_on_the_mask_window_equals_scipy_on_the_whole_grid():
    """Masks filling a window of a larger grid, sources on and off the mask and off the grid: `distance_field`
    (searching only the window that holds the mask's cells) gives scipy's Dijkstra on the whole grid's graph."""
    from scipy.sparse.csgraph import dijkstra

    from sdovon_mj.gridgraph import cell_graph, distance_field

    rng = np.random.default_rng(4755)
    for trial in range(30):
        h, w = int(rng.integers(5, 90)), int(rng.integers(5, 90))
        mask = np.zeros((h, w), bool)
        a, b = sorted(rng.integers(0, h, 2))
        c, d = sorted(rng.integers(0, w, 2))
        mask[a:b + 1, c:d + 1] = rng.random((b - a + 1, d - c + 1)) > 0.2
        src = np.stack([rng.integers(-2, h + 2, 6), rng.integers(-2, w + 2, 6)], 1)
        on = src[(src[:, 0] >= 0) & (src[:, 0] < h) & (src[:, 1] >= 0) & (src[:, 1] < w)]
        on = on[mask[on[:, 0], on[:, 1]]]
        want = np.full((h, w), np.inf)
        if len(on):
            g, index = cell_graph(mask)
            want[mask] = dijkstra(g, directed=True, indices=np.unique(index[on[:, 0], on[:, 1]]), min_only=True) * 0.05
        assert np.array_equal(distance_field(mask, src, 0.05), want), trial


def test_learned_scores_with_the_kernel_cache_equal_fresh_ones():
    """The bundled model's pair scores asked in a sequence of overlapping column lists (as an agent asks them while it
    sees more receptacles): each answer equals a fresh model's (no cached kernel column), bit for bit."""
    from sdovon_mj.semantics.learned import LearnedModel, column_kernel, default_model

    warm = default_model()
    text = warm.to_json()
    rooms = ["kitchen", "living_room", "bedroom", "bathroom", "garage", "dining room"]
    recs = ["counter", "sofa", "bed", "bottom_cabinet", "shelf", "sink", "table", "fridge", "dresser", "desk"]
    rng = np.random.default_rng(4754)
    for trial in range(6):
        rr = list(rng.choice(rooms, size=int(rng.integers(1, 5)), replace=False))
        cc = list(rng.choice(recs, size=int(rng.integers(1, 8)), replace=False))
        obj = str(rng.choice(["mug", "pillow", "toothbrush", "hammer"]))
        got = warm.score_pairs(obj, rr, cc)
        fresh = LearnedModel.from_json(text).score_pairs(obj, rr, cc)
        assert np.array_equal(got, fresh), trial
    head = warm.heads["pair"]
    cols = list(head._kc)[:40]
    from sdovon_mj.embeddings import embed_labels
    want = column_kernel(head.column_vectors(), embed_labels(cols), head.temperature)
    assert np.array_equal(head._kernel(cols, embed_labels(cols)), want)


@pytest.mark.parametrize("form", ["compiled", "python"])
def test_fused_voxel_union_equals_np_insert(form, monkeypatch):
    """Voxel maps grown by random sorted key sets (fresh keys before, between and after the old ones, repeats of old
    ones, signed zeros in the sums, heights known and not): keys, sums, counts and heights as np.insert built them,
    byte for byte, in the compiled merge (`native.sdv_union`) and the Python form."""
    from sdovon_mj import native
    from sdovon_mj.perceive.fusion import _Fused

    if form == "python":
        monkeypatch.setattr(native, "library", lambda: None)
    elif native.library() is None:
        pytest.skip(f"no compiled kernels here: {native.status()}")
    rng = np.random.default_rng(4755)
    for trial in range(20):
        f, ref = _Fused(voxel=0.05), {"keys": np.zeros(0, np.int64), "sums": np.zeros((0, 3)), "counts": np.zeros(0),
                                      "heights": np.zeros(0)}
        for _ in range(6):
            k = np.unique(rng.integers(-50, 50, size=int(rng.integers(0, 30))))
            s, c = rng.normal(size=(len(k), 3)), rng.integers(1, 5, size=len(k)).astype(float)
            s[rng.random(s.shape) < 0.1] = 0.0
            s[rng.random(s.shape) < 0.1] = -0.0
            h = None if rng.random() < 0.3 else rng.uniform(0, 2, size=len(k))
            f._union(k, s, c, h)
            old = ref["keys"]  # the code before: np.insert of each array, then the sums added
            pos = np.searchsorted(old, k)
            hit = pos < len(old)
            hit[hit] = old[pos[hit]] == k[hit]
            fresh = np.nonzero(~hit)[0]
            at = pos[fresh]
            new_at = np.empty(len(k), dtype=np.int64)
            new_at[fresh] = at + np.arange(len(fresh))
            new_at[hit] = pos[hit] + np.searchsorted(at, pos[hit], side="right")
            if len(fresh):
                ref = {"keys": np.insert(old, at, k[fresh]), "sums": np.insert(ref["sums"], at, 0.0, axis=0),
                       "counts": np.insert(ref["counts"], at, 0.0), "heights": np.insert(ref["heights"], at, np.nan)}
            ref["sums"][new_at] += s
            ref["counts"][new_at] += c
            if h is not None:
                ref["heights"][new_at] = np.fmax(ref["heights"][new_at], h)
            for name, want in ref.items():
                got = getattr(f, name)
                assert got.dtype == want.dtype and got.tobytes() == want.tobytes(), (trial, name)


def test_backproject_detections_equals_the_whole_image_back_projection():
    """Detections anywhere in a view (edges, empty masks, masks over invalid depth): the same instances, points and
    view heights bit for bit, as back-projecting the whole image under each mask."""
    from sdovon_mj.config import PerceiveConfig
    from sdovon_mj.perceive.backproject import backproject_detections, make_instance, noisy_depth, voxel_downsample_heights
    from sdovon_mj.records import Detection, Observation
    from sdovon_mj.sim.camera import valid_depth

    def reference(obs, dets, cfg, seed=0):
        depth = noisy_depth(obs, cfg.depth_noise_sigma, seed)
        K, T = np.asarray(obs.K, dtype=np.float64), np.asarray(obs.T_cam, dtype=np.float64)
        valid = valid_depth(depth, cfg.depth_min, cfg.depth_max)
        out = []
        for det in dets:
            pts = _reference_backproject(depth, K, T, mask=det.mask, depth_min=cfg.depth_min, depth_max=cfg.depth_max,
                                         valid=valid)
            pts, vh = voxel_downsample_heights(pts, cfg.voxel_size, float(T[2, 3]))
            if len(pts) < max(cfg.min_points, 1):
                continue
            out.append(make_instance(pts, det.label, [det.score], [obs.view_id], det.gt_id, view_height=vh))
        return out

    rng = np.random.default_rng(4756)
    cfg = PerceiveConfig()
    K = intrinsics(80, 60, 79.0)
    made = 0
    for trial in range(12):
        depth = rng.uniform(0.05, 7.0, size=(60, 80)).astype(np.float32)
        depth[rng.random(depth.shape) < 0.1] = 0.0
        T = pose_cv(np.append(rng.uniform(-2, 2, 2), 0.88), float(rng.uniform(0, 360)), float(rng.uniform(-40, 10)))
        obs = Observation(view_id=trial, rgb=np.zeros((60, 80, 3), np.uint8), depth=depth, K=K, T_cam=T)
        dets = []
        for n in range(int(rng.integers(1, 6))):
            m = np.zeros((60, 80), bool)
            if n % 4:
                r, c = rng.integers(-5, 60, 2)
                m[max(r, 0):r + int(rng.integers(1, 30)), max(c, 0):c + int(rng.integers(1, 40))] = True
            dets.append(Detection(mask=m, label=f"thing{n}", score=0.9, view_id=trial))
        got, want = backproject_detections(obs, dets, cfg, seed=trial), reference(obs, dets, cfg, seed=trial)
        assert len(got) == len(want), trial
        for a, b in zip(got, want):
            assert a.label == b.label and np.array_equal(a.points, b.points) and np.array_equal(a.center, b.center)
            assert np.array_equal(a.view_height, b.view_height, equal_nan=True)
        made += len(got)
    assert made > 10


def test_axis_by_axis_box_helpers_equal_numpys_reductions():
    """geometry.axis_bounds, boxes_apart and in_box give numpy's 3-wide reductions' values, points on box faces and
    coincident boxes included."""
    rng = np.random.default_rng(4750)
    for n in (1, 2, 7, 500):
        p = np.round(rng.normal(size=(n, 3)) * 10.0, 1)
        lo, hi = axis_bounds(p)
        assert np.array_equal(lo, p.min(axis=0)) and np.array_equal(hi, p.max(axis=0))
        boxes_lo = np.round(rng.normal(size=(40, 3)) * 10.0, 1)
        boxes_hi = boxes_lo + np.round(rng.uniform(0.0, 5.0, (40, 3)), 1)
        boxes_lo[0], boxes_hi[0] = lo, hi
        expect = np.any(boxes_lo > hi, axis=1) | np.any(boxes_hi < lo, axis=1)
        assert np.array_equal(boxes_apart(boxes_lo, boxes_hi, lo, hi), expect)
        for b_lo, b_hi in zip(boxes_lo[:5], boxes_hi[:5]):
            assert np.array_equal(in_box(p, b_lo, b_hi), np.all((p >= b_lo) & (p <= b_hi), axis=1))


@pytest.mark.parametrize("form", ["compiled", "python"])
def test_voxel_stats_equals_the_unique_and_bincount_reference(form, monkeypatch):
    """perceive.backproject.voxel_stats, compiled (native sdv_voxel_stats) and by one stable numpy sort: the keys,
    sums, counts and view-height maxima of the np.unique + bincount form it replaced (kept here verbatim), byte for
    byte, NaN heights, signed zeros, points on voxel faces and empty input included."""
    from sdovon_mj import native
    from sdovon_mj.perceive.backproject import voxel_keys, voxel_stats

    if form == "python":
        monkeypatch.setattr(native, "library", lambda: None)
    elif native.library() is None:
        pytest.skip(f"no compiled kernels here: {native.status()}")

    def reference(points, voxel, values=None):
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        keys = voxel_keys(p, voxel)
        uniq, inv, counts = np.unique(keys, return_inverse=True, return_counts=True)
        inv = inv.reshape(-1)
        sums = np.zeros((len(uniq), 3))
        for d in range(3):
            sums[:, d] = np.bincount(inv, weights=p[:, d], minlength=len(uniq))
        vmax = None
        if values is not None:
            v = np.asarray(values, dtype=np.float64).reshape(-1)
            vmax = np.full(len(uniq), np.nan)
            if len(v):
                order = np.argsort(inv, kind="stable")
                starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
                vmax = np.fmax.reduceat(v[order], starts)
        return uniq, sums, counts.astype(np.float64), vmax

    rng = np.random.default_rng(4751)
    for n in (0, 1, 2, 5, 300, 4000):
        p = (rng.uniform(-0.3, 0.3, (n, 3)) + rng.uniform(-20, 20, 3)).astype(rng.choice([np.float32, np.float64]))
        if n > 10:
            p[: n // 4] = np.round(p[: n // 4] / 0.02) * 0.02  # on voxel faces
            p[n // 4 : n // 4 + 3] = -0.0
        heights = rng.uniform(0.0, 2.0, n)
        heights[rng.random(n) < 0.3] = np.nan
        for values in (None, heights):
            for got, want in zip(voxel_stats(p, 0.02, values), reference(p, 0.02, values)):
                assert (got is None) == (want is None)
                if got is not None:
                    assert got.dtype == want.dtype and got.shape == want.shape and got.tobytes() == want.tobytes()


@pytest.mark.parametrize("form", ["compiled", "python"])
def test_walking_windows_equal_the_one_dijkstra_per_window_reference(form, monkeypatch):
    """semantics.regions' walking windows, by the compiled grid search or scipy's Dijkstra WALK_BATCH centres per
    call, labels read from (cell, instance) pairs: the cells, weights and label sets of one scipy call and one np.isin
    per window (the form it replaced, kept here verbatim), on a walled floor with a doorway, more centres than one
    batch, some on walls."""
    from scipy.sparse.csgraph import dijkstra

    from sdovon_mj import native

    if form == "python":
        monkeypatch.setattr(native, "library", lambda: None)

    from sdovon_mj.gridgraph import graph_of
    from sdovon_mj.records import Instance, NavMap
    from sdovon_mj.semantics import regions

    def reference(navmap, space, centres, r, pflat, idx, labels):
        h, w = space.shape
        res = float(navmap.resolution)
        g, index = graph_of(space)
        nodes_rc = np.argwhere(space)
        out = []
        for ci, cj in navmap.frame.to_cell(centres):
            if not (0 <= ci < h and 0 <= cj < w) or not space[ci, cj]:
                continue
            dist = dijkstra(g, directed=True, indices=int(index[ci, cj]), limit=r / res + 1e-9) * res
            near = np.flatnonzero(np.isfinite(dist) & (dist <= r))
            rr, cc = nodes_rc[near, 0], nodes_rc[near, 1]
            hit = np.isin(pflat, rr * w + cc)
            labs = tuple(sorted(set(labels[idx[hit]]) - {""}))
            out.append((rr, cc, 1.0 - (dist[near] / r) ** 2, labs))
        return out

    rng = np.random.default_rng(4752)
    res = 0.05
    free = np.ones((70, 150), dtype=bool)
    free[:2], free[-2:], free[:, :2], free[:, -2:] = False, False, False, False
    free[:, 74:77] = False
    free[25:45, 74:77] = True  # the doorway
    insts = []
    for k, label in enumerate(["bed", "sofa", "toilet", "sink", "table", "chair", "lamp"]):
        lo = rng.uniform([0.2, 0.2], [6.5, 2.8])
        pts = np.column_stack([rng.uniform(lo, lo + rng.uniform(0.3, 1.0, 2), (300, 2)), rng.uniform(0, 1, 300)])
        insts.append(Instance(id=k, label=label, points=(pts - pts.mean(axis=0)).astype(np.float32),
                              center=pts.mean(axis=0)))
    navmap = NavMap(floor=0, height=0.0, origin=np.zeros(2), resolution=res, navigable=free, free=free)
    pts, idx = regions._points_xy(insts)
    pc = navmap.frame.to_cell(pts)
    pflat = pc[:, 0] * free.shape[1] + pc[:, 1]
    labels = np.array([i.label for i in insts] + [""], dtype=object)
    space = free.copy()
    space[pc[:, 0], pc[:, 1]] = True
    centres = regions.window_centres(navmap, 0.3)
    assert len(centres) > 2 * regions.WALK_BATCH
    got = regions._walking_windows(navmap, space, centres, 1.2, pflat, idx, labels)
    want = reference(navmap, space, centres, 1.2, pflat, idx, labels)
    assert len(got) == len(want) and len(got) < len(centres)  # centres on the wall have no window
    for (a_r, a_c, a_w, a_l), (b_r, b_c, b_w, b_l) in zip(got, want):
        assert np.array_equal(a_r, b_r) and np.array_equal(a_c, b_c) and a_w.tobytes() == b_w.tobytes() and a_l == b_l
    assert any(w[3] for w in got)


def test_plan_cells_equals_the_undirected_search_reference():
    """nav.astar.plan_cells searches the symmetric cell graph directed: the same cell paths as the undirected
    search it replaced (scipy then also scans the transpose), on random masks, starts, goals and tolerances."""
    from sdovon_mj.nav import astar

    rng = np.random.default_rng(4756)
    calls = []
    real = astar.dijkstra

    def undirected(g, directed=True, **kw):  # the code before: directed=False
        calls.append(directed)
        return real(g, directed=False, **kw)

    for trial in range(60):
        h, w = (int(x) for x in rng.integers(6, 70, 2))
        mask = rng.random((h, w)) > rng.uniform(0.0, 0.4)
        start = (int(rng.integers(0, h)), int(rng.integers(0, w)))
        goal = (int(rng.integers(0, h)), int(rng.integers(0, w)))
        tol = float(rng.choice([0.0, 1.5, 4.0]))
        got = astar.plan_cells(mask, start, goal, tol)
        astar.dijkstra = undirected
        try:
            want = astar.plan_cells(mask, start, goal, tol)
        finally:
            astar.dijkstra = real
        assert got == want, trial
    assert calls and all(calls)  # the new form asks for the directed search


def _reference_plan_cells(mask, start, goal, tolerance_cells=0.0):
    """`nav.astar.plan_cells` before it searched the mask's window (verbatim but the name): the whole grid's graph."""
    import math

    from scipy.sparse.csgraph import dijkstra

    from sdovon_mj.gridgraph import graph_of

    m = np.asarray(mask, dtype=bool)
    h, w = m.shape
    if not (0 <= start[0] < h and 0 <= start[1] < w) or not m[start[0], start[1]]:
        return None
    g, index = graph_of(mask)
    s = int(index[start[0], start[1]])
    r = int(math.ceil(tolerance_cells))
    r0, r1 = max(0, goal[0] - r), min(h, goal[0] + r + 1)
    c0, c1 = max(0, goal[1] - r), min(w, goal[1] + r + 1)
    if r0 >= r1 or c0 >= c1:
        return None
    rr, cc = np.mgrid[r0:r1, c0:c1]
    near = ((rr - goal[0]) ** 2 + (cc - goal[1]) ** 2 <= tolerance_cells ** 2 + 1e-9) & m[r0:r1, c0:c1]
    if not near.any():
        return None
    cand = np.stack([rr[near], cc[near]], axis=1)
    dist, pred = dijkstra(g, directed=True, indices=s, return_predecessors=True)
    dc = dist[index[cand[:, 0], cand[:, 1]]]
    if not np.isfinite(dc).any():
        return None
    off = (cand[:, 0] - goal[0]) ** 2 + (cand[:, 1] - goal[1]) ** 2
    k = int(np.lexsort((off, dc))[0])
    node = int(index[cand[k, 0], cand[k, 1]])
    nodes = [node]
    while node != s:
        node = int(pred[node])
        if node < 0:
            return None
        nodes.append(node)
    cells = np.argwhere(m)
    return [(int(cells[n][0]), int(cells[n][1])) for n in nodes[::-1]]


def test_plan_cells_on_the_mask_window_equals_the_whole_grid_reference():
    """nav.astar.plan_cells searches the graph of the window holding the mask's cells: the same cell paths as the
    whole grid's graph, on masks filling part of a larger grid, with starts and goals on and off them."""
    from sdovon_mj.nav import astar

    rng = np.random.default_rng(4758)
    found = 0
    for trial in range(60):
        h, w = (int(x) for x in rng.integers(8, 80, 2))
        mask = np.zeros((h, w), bool)
        a, b = sorted(int(x) for x in rng.integers(0, h, 2))
        c, d = sorted(int(x) for x in rng.integers(0, w, 2))
        mask[a:b + 1, c:d + 1] = rng.random((b - a + 1, d - c + 1)) > rng.uniform(0.0, 0.35)
        on = np.argwhere(mask)
        start = tuple(int(x) for x in on[rng.integers(len(on))]) if len(on) and trial % 5 else \
            (int(rng.integers(0, h)), int(rng.integers(0, w)))
        goal = tuple(int(x) for x in on[rng.integers(len(on))]) if len(on) and trial % 4 else \
            (int(rng.integers(0, h)), int(rng.integers(0, w)))
        tol = float(rng.choice([0.0, 1.5, 4.0]))
        got, want = astar.plan_cells(mask, start, goal, tol), _reference_plan_cells(mask, start, goal, tol)
        assert got == want, trial
        found += got is not None
    assert found > 10


def test_category_image_compiled_equals_the_numpy_form(monkeypatch):
    """ObservationBuilder.category_image in one compiled pass (native sdv_category): the numpy form's image for
    segment ids of instances, placed objects, unlabelled ids between them, ids past the table and -1."""
    from sdovon_mj import native
    from sdovon_mj.knowledge import Knowledge
    from sdovon_mj.sim.model import OBJECT_ID_BASE
    from sdovon_mj.suite.observation import ObservationBuilder, Vocabulary

    if native.library() is None:
        pytest.skip(f"no compiled kernels here: {native.status()}")
    vocab = Vocabulary(goal_categories=("cup", "book"), labels=("cup", "book", "table", "sofa"))
    labels = {0: "table", 3: "sofa", 7: "lamp", OBJECT_ID_BASE + 0: "cup", OBJECT_ID_BASE + 4: "book"}
    builder = ObservationBuilder(Knowledge(), vocab, labels)
    rng = np.random.default_rng(4757)
    pool = np.array([-1, 0, 1, 3, 5, 7, 8, 40, OBJECT_ID_BASE - 1, OBJECT_ID_BASE, OBJECT_ID_BASE + 2,
                     OBJECT_ID_BASE + 4, OBJECT_ID_BASE + 5, OBJECT_ID_BASE + 999], dtype=np.int32)
    seg = pool[rng.integers(0, len(pool), (48, 64))]
    got = builder.category_image(seg)
    with monkeypatch.context() as m:
        m.setattr(native, "library", lambda: None)
        want = builder.category_image(seg)
    assert got.dtype == want.dtype == np.int16 and np.array_equal(got, want)
    assert set(np.unique(got).tolist()) == {-1, 0, 1, 2, 3}
