"""Navigation metrics with habitat-lab's definitions: success, SPL, Soft SPL, distance to goal.

Definitions (habitat-lab ``tasks/nav/nav.py``; docs/background.md, "Navigation metrics"):

- distance to goal ``d(t)``: geodesic from the agent base position to the nearest goal view point
  (``distance_to: VIEW_POINTS``); ``inf`` when no view point is reachable.
- success: STOP was called **and** ``d(T) < success_distance`` (strict).
- SPL: ``S * l / max(l, p)`` with ``l = d(0)`` (distance to goal at reset, not the episode's stored
  geodesic distance) and ``p`` the summed Euclidean length of the actual displacements.
- Soft SPL: ``max(0, 1 - d(T) / l) * l / max(l, p)``; needs no STOP.
- Dataset numbers are plain means over episodes; their 95 % intervals come from a cluster bootstrap
  (`cluster_bootstrap`: scenes, then variants within them, then episodes), since episodes come in clusters.

Degenerate ``l`` (habitat-lab divides by it): ``l = 0`` gives SPL = success and Soft SPL = 1 when
``d(T) = 0`` else 0; ``l = inf`` (unreachable goal) gives 0 for both.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Callable, Iterable, Sequence

import numpy as np

DistanceFn = Callable[[np.ndarray, np.ndarray], float]


def euclidean_distance_to_points(position: np.ndarray, points: np.ndarray) -> float:
    """Return the Euclidean distance from a position (3,) to the nearest of points (N, 3)."""
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    if pts.size == 0:
        return math.inf
    return float(np.min(np.linalg.norm(pts - np.asarray(position, dtype=float)[None, :], axis=1)))


def distance_to_goal(position: np.ndarray, view_points: np.ndarray, geodesic: DistanceFn | None = None) -> float:
    """Return the distance from the agent base to the nearest view point (geodesic if given, else Euclidean)."""
    vps = np.atleast_2d(np.asarray(view_points, dtype=float))
    if vps.size == 0:
        return math.inf
    if geodesic is None:
        return euclidean_distance_to_points(position, vps)
    return float(geodesic(np.asarray(position, dtype=float), vps))


def path_length(positions: Sequence[np.ndarray] | np.ndarray) -> float:
    """Return the summed Euclidean length of the displacements between consecutive positions."""
    p = np.asarray(positions, dtype=float)
    if len(p) < 2:
        return 0.0
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))


def success(stop_called: bool, final_distance: float, success_distance: float = 0.1) -> float:
    """Return 1.0 when STOP was called strictly within success_distance of a view point, else 0.0."""
    return 1.0 if (bool(stop_called) and float(final_distance) < float(success_distance)) else 0.0


def spl(success: float, shortest: float, path_length: float) -> float:
    """Return Success weighted by Path Length: S * l / max(l, p)."""
    s, l, p = float(success), float(shortest), float(path_length)
    if not math.isfinite(l):
        return 0.0
    if l <= 0.0:
        return s
    return s * l / max(l, p)


def soft_spl(final_distance: float, shortest: float, path_length: float) -> float:
    """Return Soft SPL: max(0, 1 - d_T / l) * l / max(l, p)."""
    d, l, p = float(final_distance), float(shortest), float(path_length)
    if not math.isfinite(l):
        return 0.0
    if l <= 0.0:
        return 1.0 if d <= 0.0 else 0.0
    soft = max(0.0, 1.0 - d / l)
    return soft * l / max(l, p)


@dataclass
class EpisodeMetrics:
    """Per-episode navigation metrics (habitat-lab definitions)."""

    success: float
    spl: float
    soft_spl: float
    distance_to_goal: float  # d(T), metres
    shortest: float  # l = d(0), metres
    path_length: float  # p, metres
    steps: int = 0
    stop_called: bool = False

    def to_dict(self) -> dict[str, float]:
        """Return the metrics as a plain dict."""
        return asdict(self)


def episode_metrics(positions: Sequence[np.ndarray] | np.ndarray, view_points: np.ndarray, stop_called: bool,
                    success_distance: float = 0.1, geodesic: DistanceFn | None = None) -> EpisodeMetrics:
    """Return the metrics of one trajectory of agent base positions (first = start) against goal view points.

    Parameters
    ----------
    positions : sequence of ndarray or ndarray (T + 1, 3)
        The agent's base positions, the start first (metres).
    view_points : ndarray (V, 3)
        Every goal view point (metres).
    stop_called : bool
        Whether the agent called STOP.
    success_distance : float
        Metres to the nearest view point within which STOP succeeds (strict).
    geodesic : callable, optional
        (position, view points) -> distance in metres; default the Euclidean distance.
    """
    pos = np.atleast_2d(np.asarray(positions, dtype=float))
    l = distance_to_goal(pos[0], view_points, geodesic)
    d_t = distance_to_goal(pos[-1], view_points, geodesic)
    p = path_length(pos)
    s = success(stop_called, d_t, success_distance)
    return EpisodeMetrics(success=s, spl=spl(s, l, p), soft_spl=soft_spl(d_t, l, p), distance_to_goal=d_t,
                          shortest=l, path_length=p, steps=len(pos) - 1, stop_called=bool(stop_called))


def aggregate(metrics: Iterable[EpisodeMetrics]) -> dict[str, float]:
    """Return dataset-level means (SR, SPL, Soft SPL, DTG) and the episode count."""
    ms = list(metrics)
    if not ms:
        return {"episodes": 0, "success": 0.0, "spl": 0.0, "soft_spl": 0.0, "distance_to_goal": 0.0}
    dtg = [m.distance_to_goal for m in ms if math.isfinite(m.distance_to_goal)]
    return {
        "episodes": len(ms),
        "success": float(np.mean([m.success for m in ms])),
        "spl": float(np.mean([m.spl for m in ms])),
        "soft_spl": float(np.mean([m.soft_spl for m in ms])),
        "distance_to_goal": float(np.mean(dtg)) if dtg else math.inf,
    }


def cluster_bootstrap(values: np.ndarray, scenes: Sequence[str], variants: Sequence[str], resamples: int = 1000,
                      seed: int = 0) -> np.ndarray:
    """Return bootstrap means (resamples, K) of per-episode values (N,) or (N, K), resampling the clusters they come in.

    Each resample draws scenes with replacement, then, for every draw of a scene, its variants with replacement,
    then, for every draw of a variant, its episodes with replacement; the resample's mean is the weighted mean of
    the values by how often each episode was drawn (non-finite values left out of their column). Episodes of one
    apartment or one arrangement are not independent: resampling them alone gives intervals too narrow. The
    percentile interval of the returned means is the 95 % interval (`percentile_interval`).

    Parameters
    ----------
    values : ndarray
        (N,) or (N, K) per-episode values.
    scenes, variants : sequence of str
        Each episode's scene and variant (a variant belongs to one scene).
    resamples : int
        Bootstrap resamples.
    seed : int
        Seed of the resampling.
    """
    x = np.asarray(values, float)
    flat = x.ndim == 1
    x = x.reshape(len(x), -1)
    ok = np.isfinite(x)
    xf = np.where(ok, x, 0.0)
    tree: dict[str, dict[str, list[int]]] = {}
    for i, (sc, va) in enumerate(zip(scenes, variants)):
        tree.setdefault(str(sc), {}).setdefault(f"{sc}/{va}", []).append(i)
    groups = [[np.array(ix) for ix in vs.values()] for _sc, vs in sorted(tree.items())]
    rng = np.random.default_rng(seed)
    w = np.zeros((int(resamples), len(x)))
    n_s = len(groups)
    for r in range(int(resamples)):
        for si, c in enumerate(rng.multinomial(n_s, np.full(n_s, 1.0 / n_s))):
            if c == 0:
                continue
            vs = groups[si]
            # c independent draws of the scene's variants = one multinomial of c * |variants| draws
            for vi, cv in enumerate(rng.multinomial(c * len(vs), np.full(len(vs), 1.0 / len(vs)))):
                if cv:
                    eps = vs[vi]
                    w[r, eps] += rng.multinomial(cv * len(eps), np.full(len(eps), 1.0 / len(eps)))
    with np.errstate(invalid="ignore", divide="ignore"):
        means = (w @ xf) / (w @ ok.astype(float))
    return means[:, 0] if flat else means


def percentile_interval(means: np.ndarray, level: float = 0.95) -> tuple[float, float]:
    """Return the percentile interval of bootstrap means (NaN resamples left out)."""
    m = np.asarray(means, float)
    m = m[np.isfinite(m)]
    if not len(m):
        return (math.nan, math.nan)
    lo, hi = np.percentile(m, [50.0 * (1.0 - level), 100.0 - 50.0 * (1.0 - level)])
    return float(lo), float(hi)
