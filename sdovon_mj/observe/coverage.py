"""Gaussian coverage sampling of observation points (paper section 3.1), and a uniform baseline.

The probability layer M_P lives on the navmap grid and starts at 0. Candidates are drawn one at a
time over navigable cells with probability proportional to (1 - M_P). A candidate closer than
``min_obstacle_distance`` to a non-free cell is rejected (invalid). Each valid point p overlays the
Gaussian g(q) = exp(-|q - p|^2 / (2 r_max^2)) (peak 1, so g >= 0.5 marks the paper's *strong*
observation region, out to 1.18 r_max), set to 0 inside the invalid radius r_min. "Overlaid" is
read as accumulation: ``coverage_combine = "add"`` sums the Gaussians and clips M_P to 1 (two
weak observations of a cell make a strong one); ``"max"`` keeps the best single observation.
Sampling stops when the fraction of navigable cells with M_P >= eps_p_obs reaches
``coverage_threshold`` or after ``max_iterations`` candidate draws. Coverage ignores occlusion, as
in the paper.

On a small or cluttered floor the goal can be out of reach: the footprint is zero inside r_min,
so cells that lie within r_min of every spot the draw favours (the uncovered ones) are never
covered, and the draw keeps landing on them. Two rules stop the weighted sampler there (`_stalled`):
it stops when ``coverage_patience`` view points in a row add together less than
``coverage_min_gain`` of the goal, and it never accepts more than ``max_viewpoints_per_disc`` view
points per disc of radius r_max that the navigable area would fill (`viewpoint_bound`). The stats
say why sampling stopped (``CoverageStats.stopped``).

``uniform_viewpoints`` draws candidates uniformly over navigable cells with the same rejection,
the same M_P bookkeeping and the same goal: the baseline the coverage sampler must beat. The two
stall rules do not apply to it (its draws land on covered cells by design; ``max_iterations``
bounds it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..config import AgentConfig, ObserveConfig
from ..errors import StageError
from ..records import CoverageCamera, NavMap
from .navmap import clearance


# Why sampling stopped (`CoverageStats.stopped`).
STOP_GOAL = "goal"  # coverage reached coverage_threshold
STOP_NO_GAIN = "no_gain"  # coverage_patience view points in a row added less than coverage_min_gain of the goal
STOP_BOUND = "viewpoint_bound"  # max_viewpoints_per_disc view points per r_max disc of navigable area
STOP_DRAWS = "max_iterations"  # max_iterations candidate draws
STOP_EMPTY = "no_weight"  # every navigable cell fully observed (M_P = 1) without reaching the goal


@dataclass
class CoverageStats:
    """What a sampling run did: draws, accepted/rejected points, final coverage, why it stopped."""

    iterations: int = 0
    accepted: int = 0
    rejected_obstacle: int = 0
    coverage: float = 0.0
    reached: bool = False
    history: list[float] = field(default_factory=list)  # coverage after each accepted point
    stopped: str = ""  # STOP_* (why sampling stopped)
    bound: int = 0  # the most view points the floor's area allows (0: no bound)

    def to_dict(self) -> dict:
        """Return the stats as plain JSON-able data (why it stopped only when the goal was not reached, so the
        records of floors that reach it keep their bytes)."""
        out = {"iterations": self.iterations, "accepted": self.accepted, "rejected_obstacle": self.rejected_obstacle,
               "coverage": round(self.coverage, 6), "reached": self.reached,
               "history": [round(h, 6) for h in self.history]}
        if not self.reached:
            out.update(stopped=self.stopped, viewpoint_bound=self.bound)
        return out

    def describe(self, goal: float) -> str:
        """Return one line: the coverage reached against the goal, the view points, and why sampling stopped."""
        why = {STOP_GOAL: "goal reached",
               STOP_NO_GAIN: "stopped: the last view points added almost nothing (observe.coverage_min_gain)",
               STOP_BOUND: f"stopped at the floor's bound of {self.bound} view points (observe.max_viewpoints_per_disc)",
               STOP_DRAWS: f"stopped after {self.iterations} candidate draws (observe.max_iterations)",
               STOP_EMPTY: "stopped: every navigable cell is fully observed"}.get(self.stopped, self.stopped)
        return f"coverage {self.coverage:.3f} of goal {goal:g} with {self.accepted} view points ({why})"


def viewpoint_bound(navmap: NavMap, cfg: ObserveConfig) -> int:
    """Return the most view points the weighted sampler accepts on a floor (0: no bound).

    ``max_viewpoints_per_disc`` view points per disc of radius r_max (where a view point's Gaussian is >= 0.61)
    that the navigable area would fill, rounded up to whole discs: the bound grows with the floor's area.
    """
    if cfg.max_viewpoints_per_disc <= 0:
        return 0
    area = float(np.count_nonzero(navmap.navigable)) * navmap.resolution ** 2
    discs = max(1, math.ceil(area / (math.pi * cfg.r_max ** 2)))
    return max(1, math.ceil(cfg.max_viewpoints_per_disc * discs))


def gaussian_footprint(navmap: NavMap, xy: np.ndarray, cfg: ObserveConfig) -> tuple[tuple[slice, slice], np.ndarray]:
    """Return the grid window and the Gaussian g (r_min hole zeroed) of a viewpoint at world XY."""
    res = navmap.resolution
    h, w = navmap.navigable.shape
    reach = 4.0 * cfg.r_max  # g < 3.4e-4 beyond 4 sigma
    c = (np.asarray(xy, dtype=np.float64) - navmap.origin) / res - 0.5  # fractional (col, row)
    r0, r1 = max(0, int(np.floor(c[1] - reach / res))), min(h, int(np.ceil(c[1] + reach / res)) + 1)
    c0, c1 = max(0, int(np.floor(c[0] - reach / res))), min(w, int(np.ceil(c[0] + reach / res)) + 1)
    rows = (np.arange(r0, r1) - c[1]) * res
    cols = (np.arange(c0, c1) - c[0]) * res
    d2 = rows[:, None] ** 2 + cols[None, :] ** 2
    g = np.exp(-d2 / (2.0 * cfg.r_max ** 2))
    g[d2 < cfg.r_min ** 2] = 0.0
    return (slice(r0, r1), slice(c0, c1)), g


def overlay(mp: np.ndarray, navmap: NavMap, xy: np.ndarray, cfg: ObserveConfig) -> None:
    """Overlay a viewpoint's Gaussian on M_P in place (add-and-clip or max)."""
    win, g = gaussian_footprint(navmap, xy, cfg)
    if cfg.coverage_combine == "add":
        mp[win] = np.minimum(mp[win] + g, 1.0)
    elif cfg.coverage_combine == "max":
        mp[win] = np.maximum(mp[win], g)
    else:
        raise StageError(f"observe.coverage_combine must be 'add' or 'max', got {cfg.coverage_combine!r}")


def coverage_fraction(mp: np.ndarray, navmap: NavMap, cfg: ObserveConfig) -> float:
    """Return the fraction of navigable cells with M_P >= eps_p_obs."""
    nav = navmap.navigable
    n = int(nav.sum())
    return float((mp[nav] >= cfg.eps_p_obs).sum()) / n if n else 0.0


def _sample(navmap: NavMap, cfg: ObserveConfig, seed: int | tuple[int, ...] | list[int],
            weighted: bool, agent: AgentConfig) -> tuple[list[CoverageCamera], np.ndarray, CoverageStats]:
    """Sequential candidate sampling with rejection and M_P bookkeeping."""
    nav = np.asarray(navmap.navigable, dtype=bool)
    cells = np.argwhere(nav)
    if not len(cells):
        raise StageError(f"floor {navmap.floor}: the navigable map is empty; nothing to sample")
    rng = np.random.default_rng(seed)
    clear = clearance(np.asarray(navmap.free, dtype=bool), navmap.resolution)
    ok = clear[cells[:, 0], cells[:, 1]] >= cfg.min_obstacle_distance
    mp = np.zeros(nav.shape, dtype=np.float64)
    stats = CoverageStats()
    points: list[CoverageCamera] = []
    z = float(navmap.height) + float(agent.camera_height)
    stats.bound = viewpoint_bound(navmap, cfg) if weighted else 0
    min_gain = cfg.coverage_min_gain * cfg.coverage_threshold  # as a fraction of the navigable cells
    stats.stopped = STOP_DRAWS
    while stats.iterations < cfg.max_iterations:
        if weighted:
            wgt = 1.0 - mp[cells[:, 0], cells[:, 1]]
            total = wgt.sum()
            if total <= 0:
                stats.stopped = STOP_EMPTY
                break
            k = int(rng.choice(len(cells), p=wgt / total))
        else:
            k = int(rng.integers(len(cells)))
        stats.iterations += 1
        if not ok[k]:
            stats.rejected_obstacle += 1
            continue
        xy = navmap.frame.to_world(cells[k])[0]
        overlay(mp, navmap, xy, cfg)
        points.append(CoverageCamera(floor=int(navmap.floor), position=np.array([xy[0], xy[1], z], dtype=np.float64)))
        stats.accepted += 1
        stats.coverage = coverage_fraction(mp, navmap, cfg)
        stats.history.append(stats.coverage)
        if stats.coverage >= cfg.coverage_threshold:
            stats.reached, stats.stopped = True, STOP_GOAL
            break
        if weighted and _stalled(stats.history, cfg.coverage_patience, min_gain):
            stats.stopped = STOP_NO_GAIN
            break
        if stats.bound and stats.accepted >= stats.bound:
            stats.stopped = STOP_BOUND
            break
    return points, mp, stats


def _stalled(history: list[float], patience: int, min_gain: float) -> bool:
    """Return whether the last `patience` accepted view points added together less than `min_gain` coverage."""
    h = [0.0] + list(history)
    if patience <= 0 or len(h) <= patience:
        return False
    return h[-1] - h[-1 - patience] < min_gain


def coverage_viewpoints(navmap: NavMap, cfg: ObserveConfig, seed: int | tuple[int, ...] | list[int] = 0,
                        agent: AgentConfig = AgentConfig()) -> tuple[list[CoverageCamera], np.ndarray, CoverageStats]:
    """Return viewpoints sampled by the paper's Gaussian coverage filter, the final M_P, and stats."""
    return _sample(navmap, cfg, seed, weighted=True, agent=agent)


def uniform_viewpoints(navmap: NavMap, cfg: ObserveConfig, seed: int | tuple[int, ...] | list[int] = 0,
                       agent: AgentConfig = AgentConfig()) -> tuple[list[CoverageCamera], np.ndarray, CoverageStats]:
    """Return viewpoints drawn uniformly over navigable cells until the same coverage (baseline)."""
    return _sample(navmap, cfg, seed, weighted=False, agent=agent)
