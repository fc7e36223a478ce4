"""The compiled agent kernels (sdovon_mj/native) compute exactly what their Python forms compute: the lattice planner's
action lists, the occupancy map's ray carving and fusion's overlap counts, compared on random inputs with the kernels on and off; where the
library cannot be built (a failing compiler) or is turned off, the Python forms run and say so.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from sdovon_mj import native
from sdovon_mj.config import AgentConfig, NavConfig
from sdovon_mj.grid import GridFrame
from sdovon_mj.nav.control import lattice_plan
from sdovon_mj.nav.frontier import FREE, OCCUPIED, OccupancyMap
from sdovon_mj.perceive.fusion import _Chunk, _Fused
from sdovon_mj.sim.camera import intrinsics, pose_cv

needs_cc = pytest.mark.skipif(shutil.which(os.environ.get("CC", "cc")) is None and shutil.which("gcc") is None,
                              reason="no C compiler: only the Python forms can run here")


@pytest.fixture
def python_only(monkeypatch):
    """Return a function that runs `fn(*a, **k)` with the compiled kernels off (their Python forms)."""
    def run(fn, *a, **k):
        with monkeypatch.context() as m:
            m.setattr(native, "library", lambda: None)
            return fn(*a, **k)
    return run


@needs_cc
def test_the_kernels_build_and_load_here():
    assert native.library() is not None, native.status()
    assert native.status().startswith("compiled (") and str(native.library_dir()) in native.status()


@needs_cc
def test_lattice_plan_compiled_equals_python(python_only):
    """Random room-like masks, starts anywhere on them (off cell centres), any heading, tolerances from 5 cm to 1 m,
    targets on and off the mask, search budgets that run out: the same action lists (or None) both ways."""
    assert native.library() is not None
    rng = np.random.default_rng(4747)
    frame = GridFrame(np.array([-2.37, 1.19]), 0.05, (140, 150))
    found = failed = 0
    for trial in range(60):
        nav = NavConfig() if trial % 3 else NavConfig(forward_step=0.2, turn_angle=15.0)
        mask = np.zeros(frame.shape, bool)
        for _ in range(int(rng.integers(1, 5))):
            r, c = rng.integers(5, 120, 2)
            mask[r:r + int(rng.integers(6, 50)), c:c + int(rng.integers(6, 50))] = True
        if trial % 4 == 0:
            mask[rng.random(frame.shape) < 0.03] = False  # specks: forward moves refused mid-room
        cells = np.argwhere(mask)
        a = cells[rng.integers(len(cells))]
        start = frame.to_world(a[None])[0] + rng.uniform(-0.024, 0.024, 2)
        goal = (frame.to_world(cells[rng.integers(len(cells))][None])[0] if trial % 5
                else rng.uniform(-2.0, 5.0, 2))  # sometimes anywhere: off the mask, outside the grid
        yaw = float(rng.uniform(-180, 360))
        tol = float(rng.choice([0.05, 0.2, 0.35, 1.0]))
        budget = int(rng.choice([50, 600, 5000]))
        weight = float(rng.choice([1.0, 1.2, 2.0]))
        got = lattice_plan(start, yaw, goal, tol, mask, frame, nav, max_nodes=budget, weight=weight)
        want = python_only(lattice_plan, start, yaw, goal, tol, mask, frame, nav, max_nodes=budget, weight=weight)
        assert got == want, trial
        found += got is not None and len(got) > 0
        failed += got is None
    assert found > 10 and failed > 3  # both outcomes compared, not only one


@needs_cc
def test_occupancy_carving_compiled_equals_python(python_only):
    """Frames of random depth (near, far, obstacles, rays leaving the map) integrated one after another: the same
    occupancy map, cell for cell, with the compiled ray carving and without."""
    assert native.library() is not None
    rng = np.random.default_rng(4748)
    frame = GridFrame(np.array([-3.03, -2.98]), 0.05, (118, 124))
    K = intrinsics(80, 60, 79.0)
    for trial in range(4):
        new, ref = (OccupancyMap(frame, floor_z=0.0, agent=AgentConfig()) for _ in range(2))
        for _ in range(5):
            depth = rng.uniform(0.2, 5.5, size=(60, 80)).astype(np.float32)
            depth[rng.random(depth.shape) < 0.2] = 5.0
            pos = np.append(rng.uniform(-2.0, 2.0, 2), 0.88)
            T = pose_cv(pos, float(rng.uniform(0, 360)), float(rng.choice([-30.0, 0.0, 10.0])))
            new.integrate(depth, K, T, 5.0)
            python_only(ref.integrate, depth, K, T, 5.0)
            assert np.array_equal(new.state, ref.state), trial
        assert (new.state == FREE).any() and (new.state == OCCUPIED).any()


@needs_cc
def test_segment_free_compiled_equals_python(python_only):
    """Segments of every length and direction on a speckled mask (ends on and off the grid, on cell borders, zero
    length, other sample steps): the same answer compiled and in numpy."""
    from sdovon_mj.grid import segment_free

    assert native.library() is not None
    rng = np.random.default_rng(4751)
    frame = GridFrame(np.array([-1.013, 0.52], dtype=np.float32), 0.05, (60, 70))
    mask = rng.random(frame.shape) > 0.03
    mask[20:25, :] = False
    free = 0
    for trial in range(3000):
        a = rng.uniform(-1.3, 2.8, 2)
        b = a + rng.normal(0, 0.6 if trial % 2 else 0.1, 2)
        if trial % 10 == 0:
            a = np.round(a / 0.05) * 0.05 + np.array([-1.013, 0.52])  # on cell borders
        if trial % 50 == 0:
            b = a.copy()
        step = None if trial % 7 else 0.013
        got = segment_free(mask, frame, a, b, step)
        assert got == python_only(segment_free, mask, frame, a, b, step), trial
        free += got
    assert 100 < free < 2900  # both answers compared


def _status_in(env_extra: dict, tmp_path) -> str:
    env = dict(os.environ, SDOVON_CACHE=str(tmp_path / "cache"), **env_extra)
    code = ("from sdovon_mj import native; from sdovon_mj.nav.control import lattice_plan; "
            "from sdovon_mj.config import NavConfig; from sdovon_mj.grid import GridFrame; import numpy as np; "
            "m = np.ones((40, 40), bool); f = GridFrame(np.zeros(2), 0.05, (40, 40)); "
            "p = lattice_plan(np.array([0.3, 0.3]), 0.0, np.array([1.5, 1.6]), 0.2, m, f, NavConfig()); "
            "print(len(p)); print(native.status())")
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    return run.stdout


@needs_cc
def test_fusion_overlap_compiled_equals_kd_tree(python_only, monkeypatch):
    """Fused instances of 1-8 chunks (raw and voxel-rounded points, centimetres to tens of metres across, far from
    the origin), query points anywhere near them and placed at the radius from a chunk point (exactly on an axis,
    and a few ulps either side along random directions): the compiled cell search gives scipy's KD-tree answer
    every time, and the points on the radius go through its fallback to the KD-tree."""
    assert native.library() is not None
    rng = np.random.default_rng(4748)
    asked, fallbacks = [], 0
    tree = _Chunk.tree
    monkeypatch.setattr(_Chunk, "tree", property(lambda c: asked.append(1) or tree.fget(c)))
    for _ in range(150):
        f = _Fused(voxel=0.02)
        scale, off = rng.choice([0.05, 0.4, 3.0, 30.0]), rng.uniform(-60.0, 60.0, 3)
        for _ in range(rng.integers(1, 9)):
            pts = off + rng.uniform(0.0, scale, (rng.integers(1, 1500), 3))
            f.chunks.append(_Chunk(np.round(pts / 0.01) * 0.01 if rng.random() < 0.4 else pts))
        r = float(rng.choice([0.01, 0.025, 0.1]))
        every = np.concatenate([c.data for c in f.chunks])
        near = every[rng.integers(0, len(every), 60)]
        unit = rng.normal(size=(30, 3))
        unit /= np.linalg.norm(unit, axis=1)[:, None]
        q = np.concatenate([off + rng.uniform(-0.2, scale + 0.2, (rng.integers(1, 700), 3)),
                            near[:30] + np.array([r, 0.0, 0.0]),
                            near[30:] + unit * (r * rng.choice([1.0, 1 - 1e-15, 1 + 1e-15, 1 - 1e-11], 30))[:, None]])
        q = rng.permutation(q).astype(rng.choice([np.float32, np.float64]))
        before = len(asked)
        got = f.overlap(q, r)
        fallbacks += len(asked) - before
        assert got == python_only(f.overlap, q, r)
    assert fallbacks  # points on the radius were asked of the KD-tree by the compiled path


def test_a_failing_build_falls_back_to_python_and_says_why(tmp_path):
    """CC names a compiler that fails: the planner still plans (its Python form) and `status` names the failure."""
    bad = tmp_path / "badcc"
    bad.write_text("#!/bin/sh\necho 'badcc: no compiling today' >&2\nexit 1\n", encoding="utf-8")
    bad.chmod(0o755)
    out = _status_in({"CC": str(bad)}, tmp_path)
    n, status = out.splitlines()
    assert int(n) > 0
    assert status.startswith("python: ") and "badcc failed" in status and "no compiling today" in status, status
    assert not list((tmp_path / "cache").rglob("*.so"))  # nothing half-built left to load


def test_native_off_runs_python(tmp_path):
    out = _status_in({"SDOVON_NATIVE": "off"}, tmp_path)
    assert out.splitlines()[1] == "python: turned off (SDOVON_NATIVE=off)"


@needs_cc
def test_grid_dijkstra_equals_scipys(python_only):
    """Random masks (open floors, walls with gaps, scattered obstacles, corner-only contacts), one to many sources,
    sources off the mask: `distance_field` and limited `grid_distances` give scipy's Dijkstra's values on the cell
    graph, byte for byte (each cell the least fl(d + cost) over its neighbours, whatever the queues' tie order)."""
    from scipy import ndimage
    from scipy.sparse.csgraph import dijkstra

    from sdovon_mj.gridgraph import distance_field, graph_of, grid_distances

    assert native.library() is not None
    rng = np.random.default_rng(4753)
    for trial in range(60):
        h, w = (int(x) for x in rng.integers(5, 90, 2))
        mask = rng.random((h, w)) > rng.uniform(0.0, 0.45)
        if trial % 3 == 0:
            mask = ndimage.binary_opening(mask)
        if trial % 4 == 1:
            mask[:, w // 2] = False
            mask[rng.integers(0, h, 2), w // 2] = True
        n = int(rng.integers(1, 12))
        src = np.column_stack([rng.integers(-2, h + 2, n), rng.integers(-2, w + 2, n)])
        res = float(rng.choice([0.05, 0.1, 0.037]))
        got = distance_field(mask, src, res)
        want = python_only(distance_field, mask, src, res)
        assert got.tobytes() == want.tobytes(), trial
        on = [(r, c) for r, c in src if 0 <= r < h and 0 <= c < w and mask[r, c]]
        if on:
            g, index = graph_of(mask)
            limit = float(rng.uniform(2.0, 30.0))
            d = dijkstra(g, directed=True, indices=int(index[on[0]]), limit=limit)
            full = np.full(h * w, np.inf)
            full[np.flatnonzero(mask)] = d
            assert grid_distances(mask, np.array([on[0][0] * w + on[0][1]]), limit).reshape(-1).tobytes() == full.tobytes()


@needs_cc
def test_geodesic_field_compiled_equals_scipys(python_only):
    """GeodesicField's virtual-source search (each target's cell starts at its offset to the cell centre; several
    targets in a cell, targets off the mask and off the grid): the same field, byte for byte, both ways."""
    from sdovon_mj.gridgraph import GeodesicField

    assert native.library() is not None
    rng = np.random.default_rng(4754)
    frame = GridFrame(np.array([-1.23, 0.71]), 0.05, (60, 80))
    for trial in range(25):
        mask = rng.random((60, 80)) > rng.uniform(0.0, 0.4)
        targets = rng.uniform([-1.5, 0.5], [3.0, 3.9], (int(rng.integers(1, 9)), 2))
        if trial % 2:
            targets = np.concatenate([targets, targets[:1] + 0.004])  # a second target in the first one's cell
        got = GeodesicField(mask, frame, targets).field
        want = python_only(GeodesicField, mask, frame, targets).field
        assert got.tobytes() == want.tobytes(), trial


def test_codes_seen_equal_bincount():
    """sdv_codes_seen (the id codes an image shows, read every third byte) marks exactly the codes np.bincount counts,
    on images of few and of all 256 codes, of one pixel and many."""
    from sdovon_mj import native

    lib = native.library()
    assert lib is not None, native.status()
    rng = np.random.default_rng(4759)
    for trial in range(40):
        h, w = int(rng.integers(1, 60)), int(rng.integers(1, 80))
        img = rng.integers(0, int(rng.integers(1, 257)), size=(h, w, 3)).astype(np.uint8)
        seen = np.full(256, 7, dtype=np.uint8)
        lib.sdv_codes_seen(img.ctypes.data, h * w, 3, seen.ctypes.data)
        assert np.array_equal(seen.astype(bool), np.bincount(img[..., 0].ravel(), minlength=256) > 0), trial
        assert set(np.unique(seen).tolist()) <= {0, 1}


def test_code_lookup_equals_numpy_take_of_the_red_channel():
    """sdv_code_lookup (a table entry per pixel of an id-colour image, its red channel the code, rows read bottom-up
    when flipped) equals numpy's take of the table by the flipped view's red channel, on images of one pixel and many,
    tables of -1 and large labels."""
    from sdovon_mj import native
    from sdovon_mj.sim.render import _lookup_codes

    lib = native.library()
    assert lib is not None, native.status()
    rng = np.random.default_rng(4761)
    for trial in range(30):
        h, w = int(rng.integers(1, 50)), int(rng.integers(1, 70))
        buf = rng.integers(0, 256, size=(h, w, 3)).astype(np.uint8)
        table = rng.integers(-1, 2**31 - 1, size=256).astype(np.int32)
        for view in (buf, buf[::-1]):  # as GL read it (flipped by `_pass`) and as it is
            want = table.take(view[..., 0])
            got = _lookup_codes(view, view[..., 0], table)
            assert got.dtype == np.int32 and got.flags.c_contiguous and np.array_equal(got, want), trial


def test_frustum_out_compiled_equals_its_python_form():
    """sdv_frustum_out decides for every geom exactly what `render.frustum_out` decides (the same double operations in
    the same order), on random cameras and geoms many of which sit near the view's planes."""
    from sdovon_mj import native
    from sdovon_mj.sim.render import frustum_out

    lib = native.library()
    assert lib is not None, native.status()
    rng = np.random.default_rng(4762)
    for trial in range(40):
        fwd = rng.normal(size=3)
        fwd /= np.linalg.norm(fwd)
        up = np.cross(np.cross(fwd, [0.0, 0.0, 1.0]), fwd)
        up /= np.linalg.norm(up)
        axes = np.concatenate([rng.uniform(-5, 5, 3), np.cross(fwd, up), up, fwd])  # as occlusion.camera_of
        near, far = float(rng.uniform(0.01, 0.1)), float(rng.uniform(5, 50))
        planes = [near, far]
        for half in (rng.uniform(0.01, 0.1), rng.uniform(0.01, 0.1)):
            s_hi, s_lo = 1.05 * half / near, -1.05 * half / near
            planes += [s_hi, math.hypot(1.0, s_hi), s_lo, math.hypot(1.0, s_lo)]
        n = 500
        xpos = axes[:3] + rng.uniform(-12, 12, size=(n, 3))
        rb = np.where(rng.random(n) < 0.05, 0.0, rng.uniform(0.0, 2.0, n))
        want = frustum_out(xpos, rb, axes, planes)
        out = np.empty(n, dtype=np.uint8)
        p = np.asarray(planes, dtype=np.float64)
        lib.sdv_frustum_out(xpos.ctypes.data, rb.ctypes.data, n, axes.ctypes.data, p.ctypes.data, out.ctypes.data)
        assert np.array_equal(out.astype(bool), want), trial
        assert 0 < want.sum() < n, trial  # both kinds of geom in every trial
