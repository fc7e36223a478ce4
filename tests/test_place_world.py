"""Must-show of the place stage on default-world apartments: objects end resting on their intended
receptacle plane (independent ray + contact check), no interpenetration, figures per category.

Scenes: `generate_apartment(seed)` written as GLB and converted by `assets_convert.convert_scene`, with its
ground-truth support surfaces as receptacle planes. Objects: the primitive Menagerie-style models of
`support.placement` (tests/support, fast) and, in a slow test, the world's object library converted by assets_convert.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.config import PlaceConfig
from sdovon_mj.place import check_variant, format_report, per_category, planes_from_scene, run_variant
from sdovon_mj.seeds import variant_seed
from support.placement import write_primitive_object
from sdovon_mj.records import SceneAsset

world = pytest.importorskip("sdovon_mj.world")

CATEGORIES = (("box", "book"), ("mug", "mug"), ("ball", "ball"), ("can", "soda can"))


def scene_from_apartment(seed: int, root: Path) -> SceneAsset:
    """Return a default-world apartment as a SceneAsset, converted by assets_convert like the pipeline does."""
    from assets_convert.scene import convert_scene

    glb = world.write_apartment(world.generate_apartment(seed), root / "inputs", mode="clean")
    return convert_scene(glb, root)


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
