"""The statistics of an evaluation's results: SR, SPL, Soft SPL and DTG with cluster-bootstrap intervals (scenes, then
variants, then episodes), paired differences of two rows over the same episodes, the episodes' difficulty, the
first visits' use, the evaluation's speed, and a lifelong evaluation's figures per day and by goal history."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ... import metrics
from .outcomes import OUTCOMES


INTERVALS = "95 % intervals: cluster bootstrap (scenes, then variants within them, then episodes)"


def summarize(results: list[dict], bootstrap: int = 1000, seed: int = 0) -> dict[str, Any]:
    """Return SR, SPL, Soft SPL and mean DTG over result dicts, with 95 % cluster-bootstrap intervals, the episodes'
    difficulty and, for agents with a first visit, its budget and use.

    The intervals resample scenes, then variants within them, then episodes (`metrics.cluster_bootstrap`,
    ``bootstrap`` resamples, percentile method; results without ``scene``/``variant`` count as clusters of one);
    ``<m>_ci`` holds (low, high) for each metric. Non-finite distances to goal are left out of the DTG mean.
    ``difficulty`` (`difficulty`) and ``first_visit`` (`first_visit`) describe the episodes and the exploration;
    ``mode`` and ``seal`` how the agent ran. When some episodes are "inside" ones (a goal hidden in a closed
    articulated part, ``Goal.open_part``), ``inside`` holds the same summary over those episodes alone (without it
    when there are none), ``must_open`` over the episodes whose every goal is hidden.
    """
    out = _summary(results, bootstrap, seed)
    for key in ("inside", "must_open"):
        sub = [r for r in results if r.get(key)]
        if sub:
            out[key] = _summary(sub, bootstrap, seed)
    return out


def _clusters(results: list[dict]) -> tuple[list[str], list[str]]:
    """Return each result's scene and variant (an episode of its own where they are not recorded)."""
    sc = [str(r.get("scene", r.get("episode_id", i))) for i, r in enumerate(results)]
    va = [str(r.get("variant", r.get("episode_id", i))) for i, r in enumerate(results)]
    return sc, va


def _summary(results: list[dict], bootstrap: int, seed: int) -> dict[str, Any]:
    """Return the metric means and cluster-bootstrap intervals of `summarize` over result dicts."""
    ms = [metrics.EpisodeMetrics(r["success"], r["spl"], r["soft_spl"], _num(r["distance_to_goal"]), _num(r["shortest"]),
                           r["path_length"]) for r in results]
    out: dict[str, Any] = dict(metrics.aggregate(ms))
    keys = ("success", "spl", "soft_spl", "distance_to_goal")
    if results and bootstrap > 0:
        x = np.array([[_num(r[k]) for k in keys] for r in results], float)
        means = metrics.cluster_bootstrap(x, *_clusters(results), resamples=bootstrap, seed=seed)
        for j, k in enumerate(keys):
            lo, hi = metrics.percentile_interval(means[:, j])
            out[f"{k}_ci"] = (round(lo, 4), round(hi, 4))
    if results:
        out["knowledge"] = results[0].get("knowledge", "")
        out["mode"] = results[0].get("mode", "")
        out["seal"] = results[0].get("seal", "")
        out["split"] = results[0].get("split", "open split")
        setups = [float(r["setup_seconds"]) for r in results if isinstance(r.get("setup_seconds"), (int, float))
                  and math.isfinite(r["setup_seconds"])]
        if setups:
            out["setup_seconds"] = round(max(setups), 2)
        failed = [r["failure"]["cause"] for r in results if r.get("failure")]
        if failed:
            out["failures"] = {c: failed.count(c) for c in sorted(set(failed))}
        out["render"] = "+".join(sorted({str(r.get("render", "-")) for r in results}))  # results of older runs: -
        if any(r.get("render_fallback") for r in results):
            out["render_fallback"] = next(r["render_fallback"] for r in results if r.get("render_fallback"))
        if all("outcome" in r for r in results):
            out["outcomes"] = {k: round(sum(r["outcome"] == k for r in results) / len(results), 4) for k in OUTCOMES}
        out["difficulty"] = difficulty(results)
        visit = first_visit(results)
        if visit:
            out["first_visit"] = visit
        secs = [r["seconds"] for r in results if isinstance(r.get("seconds"), (int, float))]
        if secs:
            out["episodes_per_minute"] = round(episodes_per_minute(results, float(sum(secs))), 2)
    return out


def _num(x: Any) -> float:
    """Return a JSON number as float (None, as written for non-finite values, is inf)."""
    return math.inf if x is None else float(x)


def difficulty(results: list[dict]) -> dict[str, Any]:
    """Return how hard the episodes are: quartiles of the start-to-goal geodesic (m), the share whose goal is in view
    at the start pose and the share visible from the start point turning in place (the episodes' own visibility
    definition, measured by the evaluator at each reset)."""
    geo = np.array([_num(r.get("start_geodesic", r.get("shortest"))) for r in results], float)
    geo = geo[np.isfinite(geo)]
    q = [round(float(v), 2) for v in np.percentile(geo, [25, 50, 75])] if len(geo) else [math.nan] * 3
    seen = [r for r in results if "goal_in_view" in r]
    return {"episodes": len(results), "geodesic_quartiles": q,
            "in_view": round(float(np.mean([r["goal_in_view"] for r in seen])), 4) if seen else None,
            "visible_from_start": round(float(np.mean([r["goal_visible_from_start"] for r in seen])), 4) if seen else None}


def first_visit(results: list[dict]) -> dict[str, Any] | None:
    """Return the first visits behind results (one per scene): their count, budget per floor, mean floors, steps,
    metres and seconds per scene."""
    visits = {str(r.get("scene")): r["first_visit"] for r in results if r.get("first_visit")}
    if not visits:
        return None
    v = list(visits.values())
    return {"scenes": len(v), "budget": int(max(x["budget"] for x in v)),
            "floors": round(float(np.mean([x.get("floors", 1) for x in v])), 2),
            "steps": round(float(np.mean([x["steps"] for x in v])), 1),
            "metres": round(float(np.mean([x["metres"] for x in v])), 1),
            "seconds": round(float(np.mean([x.get("seconds", math.nan) for x in v])), 1)}


def paired_difference(a: list[dict], b: list[dict], key: str = "success", bootstrap: int = 2000,
                      seed: int = 0) -> dict[str, Any]:
    """Return the mean per-episode difference a - b of a metric over the episodes both agents ran, with a 95 % interval.

    The agents ran the same episodes, so the comparison is paired: the cluster bootstrap (scenes, variants,
    episodes; `metrics.cluster_bootstrap`) resamples episode differences, each carrying both agents' results, which
    removes the episode-to-episode spread the two unpaired intervals of `summarize` both hold. Returns
    ``{"diff", "ci": (low, high), "episodes"}``; an interval that excludes 0 orders the two agents on these episodes.

    Parameters
    ----------
    a, b : list of dict
        Two rows' per-episode results (``episode_id``, ``scene``, ``variant`` and the metric).
    key : str
        The metric.
    bootstrap : int
        Resamples.
    seed : int
        Seed of the resampling.
    """
    bx = {r["episode_id"]: float(r[key]) for r in b}
    pairs = [(float(r[key]) - bx[r["episode_id"]], r) for r in a if r["episode_id"] in bx]
    if not pairs:
        return {"diff": float("nan"), "ci": (float("nan"), float("nan")), "episodes": 0}
    d = np.array([x for x, _r in pairs])
    means = metrics.cluster_bootstrap(d, *_clusters([r for _x, r in pairs]), resamples=bootstrap, seed=seed)
    lo, hi = metrics.percentile_interval(means)
    return {"diff": round(float(d.mean()), 4), "ci": (round(lo, 4), round(hi, 4)), "episodes": len(d)}


def episodes_per_minute(results: list[dict], seconds: float) -> float:
    """Return evaluation speed: episodes per wall minute."""
    return 60.0 * len(results) / seconds if seconds > 0 else float("nan")


def lifelong(results: list[dict], bootstrap: int = 1000, seed: int = 0) -> dict[str, Any]:
    """Return a lifelong evaluation's figures (results with ``day``; `lifelong.py`): SR and SPL per day and by the
    goal's history (unmoved since the day before, moved, new; `lifelong.goal_history`), each with its 95 % interval,
    and the stale stops (a failed STOP where the goal category rested on an earlier day and rests no more).

    The intervals resample scenes, then days within them, then episodes (`metrics.cluster_bootstrap`: a day's
    bundle is its variant). Returns ``{"days": {day: {...}}, "history": {history: {...}}, "stale_stops": {...}}``;
    each group holds ``episodes``, ``success``, ``spl``, ``success_ci``, ``spl_ci`` and ``stale_stop`` (its share
    of the group's episodes); ``stale_stops`` holds the count, the share of all episodes and the share of the
    failed STOPs. Episodes not run (a broken sequence) count as failures and are counted in ``not_run``.
    """
    from .lifelong import HISTORIES

    rs = [r for r in results if r.get("day") is not None]
    days = sorted({int(r["day"]) for r in rs})

    def group(sub: list[dict]) -> dict[str, Any]:
        out: dict[str, Any] = {"episodes": len(sub)}
        if not sub:
            return out
        x = np.array([[float(r["success"]), float(r["spl"]), float(bool(r.get("stale_stop")))] for r in sub], float)
        for j, k in enumerate(("success", "spl", "stale_stop")):
            out[k] = round(float(x[:, j].mean()), 4)
        if bootstrap > 0:
            means = metrics.cluster_bootstrap(x[:, :2], *_clusters(sub), resamples=bootstrap, seed=seed)
            for j, k in enumerate(("success", "spl")):
                lo, hi = metrics.percentile_interval(means[:, j])
                out[f"{k}_ci"] = (round(lo, 4), round(hi, 4))
        out["not_run"] = sum(1 for r in sub if r.get("not_run"))
        return out

    stale = sum(1 for r in rs if r.get("stale_stop"))
    failed_stops = sum(1 for r in rs if r.get("stop_called") and not r.get("success"))
    return {"days": {d: group([r for r in rs if int(r["day"]) == d]) for d in days},
            "history": {h: group([r for r in rs if r.get("goal_history") == h]) for h in HISTORIES},
            "stale_stops": {"count": stale, "share": round(stale / len(rs), 4) if rs else math.nan,
                            "of_failed_stops": round(stale / failed_stops, 4) if failed_stops else math.nan}}
