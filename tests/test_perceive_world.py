"""Perceive + receptacle planes on default-world apartments 0-2 (gt detector, observe-stage views, default cameras). Slow.

Ground truth: every receptacle instance and every support surface of the world's sidecar; same-height faces
of one instance closer than JOIN_GAP form one region (seat cushions), parts a sink or hob keeps apart stay
apart. Each region also gets the fraction of its area the observations showed (gt segmentation + depth).
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.config import ObserveConfig, PerceiveConfig, ReceptacleConfig
from sdovon_mj.records import Floor, Room, SceneAsset, SemanticInstance, SupportSurface
from sdovon_mj.store import atomic_write_text

world = pytest.importorskip("sdovon_mj.world")


def scene_from_apartment(seed: int, root: Path) -> SceneAsset:
    """Write an apartment as a visual-only MJCF (one mesh geom per instance) + mesh sidecar; return its SceneAsset."""
    import trimesh

    from sdovon_mj.sim.model import save_scene_mesh

    apt = world.generate_apartment(seed)
    name = f"apartment_{seed:04d}"
    d = root / "scenes" / name
    (d / "meshes").mkdir(parents=True, exist_ok=True)
    m = apt.mesh
    geoms, assets, instances = [], [], []
    for inst in apt.instances:
        sel = np.nonzero(m.face_instance == inst.id)[0]
        if len(sel) == 0:
            continue
        tm = trimesh.Trimesh(m.vertices, m.faces[sel], process=False)
        tm.remove_unreferenced_vertices()
        atomic_write_text(d / "meshes" / f"inst_{inst.id}.obj", tm.export(file_type="obj"))
        rgba = np.asarray(m.face_color[sel[0]], float) / 255.0
        group = 1 if inst.label == "ceiling" else 0
        assets.append(f'    <mesh name="inst_{inst.id}" file="inst_{inst.id}.obj" inertia="shell"/>')
        geoms.append(f'    <geom name="inst_{inst.id}" type="mesh" mesh="inst_{inst.id}" group="{group}" contype="0" '
                     f'conaffinity="0" rgba="{rgba[0]:.3f} {rgba[1]:.3f} {rgba[2]:.3f} 1"/>')
        lo, hi = tm.vertices.min(axis=0), tm.vertices.max(axis=0)
        instances.append(SemanticInstance(id=inst.id, label=inst.label, geoms=[f"inst_{inst.id}"], room=inst.room,
                                          floor=inst.floor, kind=inst.kind, bounds=np.stack([lo, hi])))
    xml = (f'<mujoco model="{name}">\n  <compiler meshdir="meshes"/>\n  <asset>\n' + "\n".join(assets) + "\n  </asset>\n"
           "  <worldbody>\n    <light pos=\"0 0 6\" dir=\"0 0 -1\" directional=\"true\"/>\n" + "\n".join(geoms) +
           "\n  </worldbody>\n</mujoco>\n")
    atomic_write_text(d / "scene.xml", xml)
    save_scene_mesh(d / "mesh.npz", m.vertices, m.faces, m.face_instance)
    surfaces = [SupportSurface(instance_id=i.id, height=float(s.height), polygon=np.asarray(s.polygon, float))
                for i in apt.instances for s in i.support_surfaces]
    lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
    return SceneAsset(name=name, mjcf=f"scenes/{name}/scene.xml", mesh=f"scenes/{name}/mesh.npz",
                      source=f"default world seed {seed}",
                      floors=[Floor(index=f.index, height=float(f.height)) for f in apt.floors],
                      instances=instances, bounds=np.stack([lo, hi]),
                      rooms=[Room(id=r.id, type=r.type, floor=r.floor, polygon=np.asarray(r.polygon, float)) for r in apt.rooms],
                      support_surfaces=surfaces)


@functools.lru_cache(maxsize=None)
def world_observations(seed: int, root: str) -> tuple[SceneAsset, list]:
    """Observe-stage views (default viewpoints and cameras, 320x240) of one default-world apartment (cached per process)."""
    from sdovon_mj.observe import load_shards, observe_scene

    r = Path(root) / f"w{seed}"
    scene = scene_from_apartment(seed, r)
    cfg = ObserveConfig(width=320, height=240)
    s = observe_scene(scene, r, "observe", cfg, seed=seed)
    return scene, list(load_shards([r / p for p in s["shards"]]))


@functools.lru_cache(maxsize=None)
def world_result(seed: int, root: str, sigma: float) -> tuple[SceneAsset, list, list]:
    """Perceive + targeted views + planes through the perceive stage's own function (perceive.surfaces.perceive_and_find_planes)."""
    from sdovon_mj.config import RunConfig
    from sdovon_mj.records import NavMap, load_json
    from sdovon_mj.perceive.surfaces import perceive_and_find_planes

    scene, obs = world_observations(seed, root)
    r = Path(root) / f"w{seed}"
    navmaps = [load_json(p, NavMap) for p in sorted((r / "observe").glob("navmap_*.json"))]
    cfg = RunConfig(observe=ObserveConfig(width=320, height=240), perceive=PerceiveConfig(depth_noise_sigma=sigma),
                    receptacles=ReceptacleConfig())
    instances, planes, _views = perceive_and_find_planes(obs, scene, r, navmaps, cfg, seed)
    return scene, instances, planes


def instance_scores(scene: SceneAsset, fused: list, labels) -> tuple[float, float]:
    """Precision / recall of fused receptacle instances vs the scene's receptacles at 3D box IoU >= 0.5."""
    from sdovon_mj.perceive.correction import box_iou_3d
    from sdovon_mj.receptacles import receptacle_instances

    pred = receptacle_instances(fused, labels)
    truth = [i for i in scene.instances if i.kind == "receptacle"]
    used, tp = set(), 0
    for t in truth:
        best = max(((box_iou_3d(p.bounds, t.bounds), k) for k, p in enumerate(pred) if k not in used), default=(0.0, -1))
        if best[0] >= 0.5:
            tp += 1
            used.add(best[1])
    return tp / max(len(pred), 1), tp / max(len(truth), 1)


JOIN_GAP = 0.15  # m: same-height true faces of one instance closer than this form one support region


def true_regions(scene: SceneAsset) -> list[tuple[int, float, np.ndarray]]:
    """Return (instance, height, CCW polygon) per true support region: same-height faces of one instance closer
    than JOIN_GAP united into their convex hull (seat cushions); parts a sink or hob keeps apart stay apart."""
    from shapely.ops import unary_union

    from sdovon_mj.geometry import shapely_polygon

    groups: dict[tuple[int, float], list] = {}
    for s in scene.support_surfaces:
        groups.setdefault((s.instance_id, round(float(s.height), 3)), []).append(shapely_polygon(s.polygon))
    out = []
    for (iid, h), polys in sorted(groups.items()):
        clusters: list[list] = []
        for poly in polys:
            near = [c for c in clusters if any(poly.distance(q) < JOIN_GAP for q in c)]
            merged = [poly] + [q for c in near for q in c]
            clusters = [c for c in clusters if not any(c is n for n in near)] + [merged]
        for c in clusters:
            u = unary_union(c).convex_hull
            out.append((iid, h, np.asarray(u.exterior.coords)[:-1][::1]))
    return out


def surface_scores(scene: SceneAsset, planes: list, tol: float) -> list[tuple[int, str, float, float, float]]:
    """Per true support region: (instance, label, height, height error, best polygon IoU of a plane within tol)."""
    from sdovon_mj.geometry import polygon_iou
    from sdovon_mj.geometry import ensure_ccw

    out = []
    for iid, h, truth in true_regions(scene):
        truth = ensure_ccw(truth)
        cands = [(polygon_iou(p.polygon, truth), abs(p.height - h)) for p in planes
                 if p.instance_id >= 0 and abs(p.height - h) <= tol]
        iou, err = max(cands, default=(0.0, float("inf")))
        out.append((iid, scene.instance(iid).label, h, float(err), float(iou)))
    return out


def observed_fraction(obs: list, iid: int, height: float, polygon: np.ndarray, cell: float = 0.02) -> float:
    """Return the fraction of a true region's cells that some observation's depth pixel of that instance lands on
    (ground-truth segmentation, noise-free depth, within 1 cm of the surface): what the views showed of it."""
    from sdovon_mj.geometry import points_in_polygon
    from sdovon_mj.sim.camera import backproject

    lo, hi = polygon.min(axis=0), polygon.max(axis=0)
    xs, ys = np.arange(lo[0] + cell / 2, hi[0], cell), np.arange(lo[1] + cell / 2, hi[1], cell)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    inside = points_in_polygon(polygon, np.stack([gx.ravel(), gy.ravel()], 1)).reshape(gx.shape)
    seen = np.zeros_like(inside)
    for o in obs:
        m = o.segmentation == iid
        if not m.any():
            continue
        p = backproject(o.depth, o.K, o.T_cam, mask=m)
        p = p[np.abs(p[:, 2] - height) < 0.01]
        i = np.floor((p[:, 0] - lo[0]) / cell).astype(int)
        j = np.floor((p[:, 1] - lo[1]) / cell).astype(int)
        ok = (i >= 0) & (i < len(xs)) & (j >= 0) & (j < len(ys))
        seen[i[ok], j[ok]] = True
    return float((seen & inside).sum() / max(inside.sum(), 1))


def region_report(seed: int, root: str, sigma: float, tol: float) -> dict:
    """Score one apartment: instance P/R, and per true support region (height error, IoU, observed fraction)."""
    scene, fused, planes = world_result(seed, root, sigma)
    _scene, obs = world_observations(seed, root)
    p, r = instance_scores(scene, fused, ReceptacleConfig().labels)
    from sdovon_mj.geometry import ensure_ccw

    rows = []
    for (iid, label, h, err, iou), (_i, _h, poly) in zip(surface_scores(scene, planes, tol), true_regions(scene)):
        rows.append((iid, label, h, err, iou, observed_fraction(obs, iid, h, ensure_ccw(poly))))
    return {"precision": p, "recall": r, "regions": rows}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])  # seed 2 has two storeys
@pytest.mark.parametrize("sigma,tol", [(0.0, 0.02), (0.005, 0.03)])
def test_default_world_receptacles_and_planes(tmp_path_factory, seed: int, sigma: float, tol: float) -> None:
    root = str(tmp_path_factory.getbasetemp() / "perceive_world")
    rep = region_report(seed, root, sigma, tol)
    assert rep["precision"] >= 0.9 and rep["recall"] >= 0.9, rep
    rows = rep["regions"]
    for row in rows:  # (instance, label, true height, height error, IoU, fraction the coverage views showed)
        print(seed, sigma, *(f"{x:.3f}" if isinstance(x, float) else x for x in row))
    # Every true support region (every bookshelf level included) is found: a plane of its instance within tol.
    assert all(err <= tol for _i, _l, _h, err, _u, _f in rows), [x for x in rows if x[3] > tol]
    # Every region matches at polygon IoU >= 0.8 (targeted views show what the coverage views missed: the last
    # column), up to 10% of them: the world's true bed and sofa faces stop 3.5 cm short of rounded edges and
    # leave out the pillow strip, while a convex hull of the seen mattress runs past the pillows.
    bad = [x for x in rows if x[4] < 0.8]
    assert len(bad) <= 0.1 * len(rows), bad
