"""Same bytes on any CPU and thread count: the exact ray caster, the embedding grid, the numerics profile and the
CoACD processor-time budget (docs/reproducibility.md). The whole-run check (1 and 2 threads, golden digests) is in
tests/test_stage_contract.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from sdovon_mj import embeddings as E
from sdovon_mj import numerics
from sdovon_mj.raycast import first_hits


def _grid_of_squares(n: int, z: float) -> tuple[np.ndarray, np.ndarray]:
    """A flat n x n grid of unit squares at height z, each split into two triangles along alternating diagonals."""
    xs = np.arange(n + 1, dtype=float)
    vx, vy = np.meshgrid(xs, xs)
    v = np.column_stack([vx.ravel(), vy.ravel(), np.full(vx.size, z)])
    f = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = i * (n + 1) + j, i * (n + 1) + j + 1, (i + 1) * (n + 1) + j + 1, (i + 1) * (n + 1) + j
            f += [[a, b, c], [a, c, d]] if (i + j) % 2 else [[a, b, d], [b, c, d]]
    return v, np.array(f)


def test_rays_through_shared_edges_and_vertices_always_hit():
    # rays exactly on every vertex, every edge midpoint and every diagonal point of a tiled floor: a watertight
    # cast hits each one (a ray engine whose edge tests are not antisymmetric lets some slip between triangles)
    v, f = _grid_of_squares(6, 0.25)
    t = np.linspace(0.0, 6.0, 49)
    x, y = np.meshgrid(t, t)
    pts = np.column_stack([x.ravel(), y.ravel()])
    pts = np.vstack([pts, np.column_stack([t, t]), np.column_stack([t, 6.0 - t])])
    origins = np.column_stack([pts, np.full(len(pts), 1.0)])
    tri, z = first_hits(v, f, origins, axis=2, sign=-1)
    assert (tri >= 0).all() and (z == 0.25).all()
    # shuffled triangles and rays give the same answers (the lowest index wins ties, whatever the order)
    perm = np.random.default_rng(0).permutation(len(f))
    tri2, z2 = first_hits(v, f[perm], origins[::-1], axis=2, sign=-1)
    assert np.array_equal(z2[::-1], z)


def test_first_hits_agree_with_a_ray_engine_away_from_edges():
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    mesh.apply_translation([0.3, -0.2, 0.1])
    rng = np.random.default_rng(1)
    for axis in (0, 1, 2):
        for sign in (1, -1):
            o = rng.uniform(-1.5, 1.5, (3000, 3))
            o[:, axis] = -3.0 * sign
            tri, h = first_hits(mesh.vertices, mesh.faces, o, axis, sign)
            d = np.zeros((len(o), 3))
            d[:, axis] = sign
            loc, ir, it = mesh.ray.intersects_location(o, d, multiple_hits=False)
            want = np.full(len(o), -1)
            want[ir] = it
            # on a triangle edge two answers are both right: compare the rays that pass no edge by more than 1e-9
            assert np.array_equal(tri >= 0, want >= 0)
            hit = tri >= 0
            assert np.allclose(h[hit][np.argsort(np.nonzero(hit)[0])], loc[np.argsort(ir), axis], atol=1e-9)
            # behind the origin is no hit: from inside the sphere the ray meets the far side only
    inside = np.array([[0.3, -0.2, 0.1]])
    tri, h = first_hits(mesh.vertices, mesh.faces, inside, 2, -1)
    assert tri[0] >= 0 and h[0] < 0.1 - 0.9


def test_edge_on_triangles_are_not_hit_and_bad_axes_are_refused():
    wall = (np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1.0]]), np.array([[0, 1, 2]]))  # vertical, in the plane y = 0
    tri, _z = first_hits(*wall, np.array([[0.5, 0.0, 2.0]]), axis=2, sign=-1)
    assert tri[0] == -1
    with pytest.raises(ValueError):
        first_hits(*wall, np.zeros((1, 3)), axis=3, sign=1)


def test_quantised_dot_products_are_exact_in_any_order():
    rng = np.random.default_rng(2)
    raw = rng.normal(size=(64, E.DIM))
    q = E.quantise(raw)
    assert np.array_equal(np.round(q / E.QUANTUM) * E.QUANTUM, q)
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-5)
    exact = [math.fsum(a * b) for a, b in zip(q[:-1], q[1:])]  # the correctly rounded sum of the products
    assert np.array_equal(np.einsum("ij,ij->i", q[:-1], q[1:]), exact)
    assert np.array_equal((q @ q.T)[np.arange(63), np.arange(1, 64)], exact)
    assert np.array_equal([float(np.dot(a[::-1], b[::-1])) for a, b in zip(q[:-1], q[1:])], exact)
    # unquantised vectors are not summed exactly: the same check finds order-dependent bits (the test can fail)
    u = raw / np.linalg.norm(raw, axis=1, keepdims=True)
    assert not np.array_equal([float(np.dot(a[::-1], b[::-1])) for a, b in zip(u[:-1], u[1:])],
                              [math.fsum(a * b) for a, b in zip(u[:-1], u[1:])])


def test_label_embeddings_are_on_the_grid_and_batch_free(tmp_path, monkeypatch):
    import torch

    monkeypatch.setenv("SDOVON_CACHE", str(tmp_path))
    labels = ["coffee mug", "kitchen counter", "a toothbrush", "bedside table", "living room"]
    batch = E._forward(labels)
    alone = np.stack([E._forward([lab])[0] for lab in labels])
    assert np.array_equal(batch, alone)
    assert np.array_equal(np.round(batch / E.QUANTUM) * E.QUANTUM, batch)
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        assert np.array_equal(E._forward(labels), batch)  # one intra-op thread inside, the caller's setting kept
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)
    # the disk cache keeps the bits; a vector off the grid there (another encoding) is not read
    folder = E.embedding_cache_dir()
    E._write_cached(folder, "x", batch[0])
    assert np.array_equal(E._read_cached(folder, "x"), batch[0])
    E._write_cached(folder, "y", batch[0] + 1e-9)
    assert E._read_cached(folder, "y") is None


def test_the_numerics_profile_by_cpu():
    name, env = numerics.profile({"sse4_2", "avx", "avx2", "fma", "avx512f"}, "x86_64")
    assert name == "x86-64-v3" and env["OPENBLAS_CORETYPE"] == "Haswell" and "X86_V4" in env["NPY_DISABLE_CPU_FEATURES"]
    name, env = numerics.profile({"sse4_2", "avx"}, "x86_64")
    assert name == "x86-64-v2" and "X86_V3" in env["NPY_DISABLE_CPU_FEATURES"]
    assert numerics.profile(set(), "aarch64") == ("aarch64", {})
    # in this test process the profile was set before numpy loaded (tests/conftest.py imports sdovon_mj first)
    assert numerics.active()
    d = numerics.describe()
    assert d["profile"] == numerics.profile()[0]


def test_the_profile_holds_in_a_fresh_process_and_numpy_follows_it():
    import json
    import os
    import subprocess
    import sys

    code = ("import sdovon_mj, json, numpy; from numpy._core._multiarray_umath import __cpu_features__ as f; "
            "print(json.dumps([sdovon_mj.numerics.describe(), sdovon_mj.numerics.active(), f.get('X86_V4', False)]))")
    env = {k: v for k, v in os.environ.items() if k not in numerics.V3_ENV and k != "SDOVON_NUMERICS"}
    desc, active, v4 = json.loads(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                                 check=True).stdout)
    assert active and not v4 and desc["env"] == numerics.profile()[1]
    late = "import numpy, sdovon_mj; print(sdovon_mj.numerics.active())"
    assert subprocess.run([sys.executable, "-c", late], env=env, capture_output=True, text=True,
                          check=True).stdout.strip() == "False"


def test_coacd_budget_counts_processor_time():
    from assets_convert import hulls
    from sdovon_mj.config import ConvertConfig
    from sdovon_mj.world.objects import generate_object

    cfg = ConvertConfig()
    bowl = generate_object("bowl", 0, 0)
    v, f, how = hulls.solid_for_coacd(bowl.vertices, bowl.faces, int(cfg.remesh_resolution), float(cfg.remesh_offset))
    assert how == "closed"
    kwargs = {**hulls._coacd_kwargs(cfg, "auto"), "preprocess_mode": "off"}
    # one processor-second is far below what this shell's search takes on any CPU: the kernel ends the child
    assert hulls._run_isolated(v, f, kwargs, 1.0) is None
    assert hulls._run_isolated(v, f, kwargs, 0.0) is None
