"""Uniform sampling in convex polygons (paper appendix B) and polygon helpers."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chisquare
from shapely.geometry import Polygon, box

from sdovon_mj.geometry import (convex_hull_ccw, ensure_ccw, fan_triangles, points_in_convex_polygon,
                                           polygon_area, polygon_iou, sample_in_polygon, shrink_polygon)


def random_convex_polygon(rng: np.random.Generator) -> np.ndarray:
    """A random convex polygon: the hull of random points in a random ellipse-ish blob."""
    while True:
        n = int(rng.integers(3, 12))
        pts = rng.normal(size=(n, 2)) * rng.uniform(0.2, 2.0, size=2) + rng.uniform(-5, 5, size=2)
        poly = convex_hull_ccw(pts)
        if len(poly) >= 3 and polygon_area(poly) > 1e-2:
            return poly


def chi_square_p(poly: np.ndarray, samples: np.ndarray, cells: int = 8) -> float:
    """p-value of the sample counts over a grid of cells against area-proportional expectations."""
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    shp = Polygon(poly)
    xs = np.linspace(lo[0], hi[0], cells + 1)
    ys = np.linspace(lo[1], hi[1], cells + 1)
    ix = np.clip(np.searchsorted(xs, samples[:, 0], side="right") - 1, 0, cells - 1)
    iy = np.clip(np.searchsorted(ys, samples[:, 1], side="right") - 1, 0, cells - 1)
    counts = np.zeros((cells, cells))
    np.add.at(counts, (ix, iy), 1)
    expected = np.array([[shp.intersection(box(xs[i], ys[j], xs[i + 1], ys[j + 1])).area for j in range(cells)]
                         for i in range(cells)]) / shp.area * len(samples)
    keep = expected > 5
    # Pool the tiny boundary cells into one bin so every bin has a healthy expectation.
    obs = np.append(counts[keep], counts[~keep].sum())
    exp = np.append(expected[keep], expected[~keep].sum())
    if exp[-1] <= 0:
        obs, exp = obs[:-1], exp[:-1]
    return float(chisquare(obs, exp * obs.sum() / exp.sum()).pvalue)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1))
def test_samples_inside_and_uniform(seed: int) -> None:
    rng = np.random.default_rng(seed)
    poly = random_convex_polygon(rng)
    pts = sample_in_polygon(poly, 20000, rng)
    assert pts.shape == (20000, 2)
    assert points_in_convex_polygon(poly, pts, tol=1e-9).all()
    assert chi_square_p(poly, pts) > 1e-4


def test_chi_square_detects_nonuniform_sampling() -> None:
    """The uniformity check has teeth: choosing fan triangles with equal probability fails it."""
    rng = np.random.default_rng(0)
    poly = np.array([[0.0, 0.0], [4.0, 0.0], [4.2, 0.3], [0.3, 1.0]])  # very unequal fan triangles
    tri, areas = fan_triangles(poly)
    idx = rng.integers(0, len(tri), 20000)
    r = rng.random((20000, 2))
    flip = r.sum(axis=1) > 1
    r[flip] = 1 - r[flip]
    t = tri[idx]
    biased = t[:, 0] + r[:, :1] * (t[:, 1] - t[:, 0]) + r[:, 1:] * (t[:, 2] - t[:, 0])
    assert chi_square_p(poly, biased) < 1e-6
    assert chi_square_p(poly, sample_in_polygon(poly, 20000, rng)) > 1e-4


def test_sampling_is_seeded() -> None:
    poly = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    a = sample_in_polygon(poly, 50, np.random.default_rng(3))
    b = sample_in_polygon(poly, 50, np.random.default_rng(3))
    assert np.array_equal(a, b)
    with pytest.raises(ValueError):
        sample_in_polygon(np.array([[0.0, 0.0], [1.0, 1.0]]), 5, np.random.default_rng(0))


def test_polygon_helpers() -> None:
    sq = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    assert polygon_area(sq) == pytest.approx(2.0)
    assert polygon_area(sq[::-1]) == pytest.approx(-2.0)
    assert polygon_area(ensure_ccw(sq[::-1])) == pytest.approx(2.0)
    hull = convex_hull_ccw(np.vstack([sq, [[1.0, 0.5], [0.5, 0.5]]]))
    assert len(hull) == 4 and polygon_area(hull) == pytest.approx(2.0)
    assert polygon_iou(sq, sq) == pytest.approx(1.0)
    assert polygon_iou(sq, sq + [1.0, 0.0]) == pytest.approx(1.0 / 3.0)
    small = shrink_polygon(sq, 0.1)
    assert polygon_area(small) == pytest.approx(1.8 * 0.8)
    assert len(shrink_polygon(sq, 0.6)) == 0
    inside = points_in_convex_polygon(sq, np.array([[1.0, 0.5], [2.5, 0.5], [1.0, -0.01]]))
    assert inside.tolist() == [True, False, False]
