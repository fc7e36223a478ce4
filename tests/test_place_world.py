"""Must-show of the place stage on default-world apartments: objects end resting on their intended
receptacle plane (independent ray + contact check), no interpenetration, figures per category.

Scenes: `generate_apartment(seed)` written as GLB and converted by `assets_convert.convert_scene`
(fallback without the converter: a visual MJCF written here, one mesh geom per instance), with its
ground-truth support surfaces as receptacle planes. Objects: the primitive Menagerie-style models of
`place.synthetic` (fast) and, in a slow test, the world's object library converted by assets_convert.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.config import PlaceConfig
from sdovon_mj.place import check_variant, format_report, per_category, planes_from_scene, run_variant, variant_seed
from sdovon_mj.place.synthetic import write_primitive_object
from sdovon_mj.records import Floor, Room, SceneAsset, SemanticInstance, SupportSurface
from sdovon_mj.store import atomic_write_text

world = pytest.importorskip("sdovon_mj.world")

CATEGORIES = (("box", "book"), ("mug", "mug"), ("ball", "ball"), ("can", "soda can"))


def scene_from_apartment(seed: int, root: Path) -> SceneAsset:
    """Return a default-world apartment as a SceneAsset: converted by assets_convert when available."""
    try:
        from assets_convert.scene import convert_scene
    except ImportError:
        return write_scene_locally(seed, root)
    glb = world.write_apartment(world.generate_apartment(seed), root / "inputs", mode="clean")
    return convert_scene(glb, root)


def write_scene_locally(seed: int, root: Path) -> SceneAsset:
    """Write an apartment's visual-only MJCF (one mesh per instance) and return its SceneAsset."""
    import trimesh

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
        instances.append(SemanticInstance(id=inst.id, label=inst.label, geoms=[f"inst_{inst.id}"], room=inst.room,
                                          floor=inst.floor, kind=inst.kind))
    xml = (f'<mujoco model="{name}">\n  <compiler meshdir="meshes"/>\n  <asset>\n' + "\n".join(assets) + "\n  </asset>\n"
           "  <worldbody>\n    <light pos=\"0 0 6\" dir=\"0 0 -1\" directional=\"true\"/>\n" + "\n".join(geoms) +
           "\n  </worldbody>\n</mujoco>\n")
    atomic_write_text(d / "scene.xml", xml)
    surfaces = [SupportSurface(instance_id=i.id, height=float(s.height), polygon=np.asarray(s.polygon, float))
                for i in apt.instances for s in i.support_surfaces]
    lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
    return SceneAsset(name=name, mjcf=f"scenes/{name}/scene.xml", source=f"default world seed {seed}",
                      floors=[Floor(index=f.index, height=float(f.height)) for f in apt.floors],
                      instances=instances, bounds=np.stack([lo, hi]),
                      rooms=[Room(id=r.id, type=r.type, floor=r.floor, polygon=np.asarray(r.polygon, float)) for r in apt.rooms],
                      support_surfaces=surfaces)


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    """Primitive household objects and an offline relevance table over the world's vocabulary."""
    root = tmp_path_factory.mktemp("world_store")
    rng = np.random.default_rng(0)
    lib = [write_primitive_object(root / "objects", root, kind, f"{cat.replace(' ', '_')}_{i}",
                                  scale=float(rng.uniform(0.85, 1.15)), category=cat)
           for kind, cat in CATEGORIES for i in range(2)]
    from sdovon_mj.semantics import get_backend, relevance

    rel = relevance([c for _, c in CATEGORIES], list(world.ROOM_TYPES), list(world.RECEPTACLE_LABELS), get_backend())
    return root, lib, rel


def _run(setup, seeds: list[int], per_scene: int, mode: str = "paper") -> tuple[list, list]:
    root, lib, rel = setup
    checks, variants = [], []
    cfg = PlaceConfig(spawn_mode=mode)
    for seed in seeds:
        scene = scene_from_apartment(seed, root)
        planes = planes_from_scene(scene)
        for k in range(per_scene):
            v, _ = run_variant(scene, planes, rel, lib, root, cfg, variant_seed(seed, k), k)
            assert len(v.placements) >= 10, v.notes
            variants.append(v)
            checks.append(check_variant(v, planes, root))
    return checks, variants


def _assert_must_show(checks: list, variants: list) -> None:
    report = format_report(checks)
    print(f"\n{len(variants)} variants of default-world apartments, {sum(len(v.placements) for v in variants)} placed objects")
    print(report)
    ok = sum(c.ok_count for c in checks)
    total = sum(len(c.objects) for c in checks)
    assert ok / total >= 0.95, report
    assert max(c.max_penetration for c in checks) <= 0.005, [c.penetrations for c in checks if c.penetrations]
    assert set(per_category(checks)) <= {c for _, c in CATEGORIES}


def test_world_variants_rest_on_intended_planes(setup):
    """Default run: 3 variants over 2 apartments (the slow test below does 24)."""
    checks, variants = _run(setup, [0, 1], 1)
    checks2, variants2 = _run(setup, [2], 1, mode="stable")
    _assert_must_show(checks + checks2, variants + variants2)


@pytest.mark.slow
def test_world_variants_rest_on_intended_planes_24(setup):
    """Must show: over 20 variants of default-world apartments with 10+ objects each."""
    checks, variants = _run(setup, [0, 1, 2, 3, 4, 5], 4)
    assert len(variants) >= 20
    _assert_must_show(checks, variants)


CONVERTED = ("book", "cereal_box", "can", "apple", "remote", "bowl")


@pytest.mark.slow
def test_world_variants_with_converted_world_objects(tmp_path):
    """Must show with the world's own object library converted by assets_convert (CoACD hulls), 20 variants."""
    convert = pytest.importorskip("assets_convert.object")
    if not hasattr(world, "write_object_library"):
        pytest.skip("the world's object library is not available")
    root = tmp_path
    paths = world.write_object_library(0, root / "inputs" / "objects", variants=1, categories=list(CONVERTED))
    lib = [convert.convert_object(p, root) for p in paths]  # cached in the user cache after the first run
    from sdovon_mj.semantics import get_backend, relevance

    cats = sorted({a.category for a in lib})
    rel = relevance(cats, list(world.ROOM_TYPES), list(world.RECEPTACLE_LABELS), get_backend())
    checks, variants = [], []
    for seed in range(5):
        scene = scene_from_apartment(seed, root)
        planes = planes_from_scene(scene)
        for k in range(4):
            v, _ = run_variant(scene, planes, rel, lib, root, PlaceConfig(), variant_seed(seed, k), k)
            assert len(v.placements) >= 10, v.notes
            variants.append(v)
            checks.append(check_variant(v, planes, root))
    report = format_report(checks)
    print(f"\n{len(variants)} variants, converted world objects: {', '.join(cats)}\n{report}")
    ok = sum(c.ok_count for c in checks)
    assert ok / sum(len(c.objects) for c in checks) >= 0.95, report
    assert max(c.max_penetration for c in checks) <= 0.005
