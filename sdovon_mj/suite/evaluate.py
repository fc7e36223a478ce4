"""The evaluation loop and `sdovon-mj eval DATASET --agent ...`: run agents over MJCF bundles, write
per-episode JSON, print tables.

Agents are plugins (`plugins.load("agent", name)`: built-ins random-astar, semantic-astar, oracle,
random; others from the ``sdovon_mj.agents`` entry points), built as
``factory(nav=NavConfig, agent=AgentConfig, seed=int)``.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import metrics as M
from .. import plugins
from ..config import AgentConfig, NavConfig
from ..errors import InputError
from ..geometry import quat_yaw
from ..progress import Progress
from ..store import atomic_write_bytes, atomic_write_text
from ..knowledge import knowledge_of
from ..perceive.gt_detector import GroundTruthDetector
from .boundary import AgentBundle, AgentEnv, scene_frame_point
from .bundle import Bundle, find_bundles, load_bundle
from .objectnav import make_environment

PAPER = {  # SD-OVON tables 4 and 5 (ground-truth detector), for the closing comparison
    "random-astar": {"success": 0.7503, "spl": 0.3494, "soft_spl": 0.3931, "distance_to_goal": 1.5437},
    "random-astar no-FN": {"success": 0.3041, "spl": 0.1471, "soft_spl": 0.3748, "distance_to_goal": 2.1105},
    "semantic-astar": {"success": 0.8081, "spl": 0.4270, "soft_spl": 0.4700, "distance_to_goal": 1.0989},
    "semantic-astar no-FN": {"success": 0.3752, "spl": 0.2111, "soft_spl": 0.4742, "distance_to_goal": 1.5230},
}


# Why an episode ended as it did (`episode_outcome`), in table order.
OUTCOMES = ("success", "step limit", "not found", "other instance", "missed stop")
OUTCOME_HELP = {
    "success": "STOP within the success distance of a goal's view point",
    "step limit": "the step limit ended the episode (no STOP)",
    "not found": "STOP without having detected the goal category (the agent's search was exhausted)",
    "other instance": "STOP at an object of the goal category that is no goal (nowhere within the view radius sees it)",
    "missed stop": "STOP near a detected goal object, not within the success distance of its view points",
}
# A detected object's reconstructed centre (the median of its depth points, `nav.goal.object_centre`) lies on the
# object's surface, so within its box up to the depth pixels at its rim; 0.3 m leaves room for those and for a
# partly occluded object while staying below the spacing of two receptacles (an object on another piece).
OTHER_INSTANCE_M = 0.3


def episode_outcome(result: dict, episode: Any, pose: str = "absolute") -> str:
    """Return why an episode ended as it did: one of `OUTCOMES` (evaluation only: it reads the episode's goals).

    ``result`` holds the suite's metrics (``success``, ``stop_called``) and the agent's ``info``: ``detected``
    (whether it saw the goal category) and ``goal`` (the reconstructed centre it drove to, XYZ in the agent's
    frame), as the built-in agents report them. ``pose`` is the agent's pose sensor (`Knowledge.pose`): with
    ``gps+compass`` the centre is in the episode's start frame and is taken back to the scene frame here.
    Agents that report neither end as "missed stop" when they STOP elsewhere.
    """
    if result.get("success"):
        return "success"
    if not result.get("stop_called"):
        return "step limit"
    info = result.get("info") or {}
    if info.get("detected") is False:
        return "not found"
    centre, goals = info.get("goal"), list(getattr(episode, "goals", []) or [])
    if centre is not None and goals:
        c = np.asarray(centre, float)[:3]
        if pose != "absolute":  # start frame (x forward, y left at the start pose) -> scene frame
            c = scene_frame_point(c, episode.start_position, quat_yaw(episode.start_rotation))
        d = []
        for g in goals:
            lo, hi = (np.asarray(g.bounds, float) if g.bounds is not None else np.stack([g.position, g.position]))
            d.append(float(np.linalg.norm(np.maximum(np.maximum(lo - c, c - hi), 0.0))))
        if min(d) > OTHER_INSTANCE_M:
            return "other instance"
    return "missed stop"


def make_agent(name: str, nav: NavConfig, seed: int = 0, final_nav: bool = True, agent: AgentConfig | None = None) -> Any:
    """Return the agent plugin `name` built with ``nav`` (``final_nav`` sets ``nav.final_nav``), ``agent`` and ``seed``."""
    factory = plugins.load("agent", name)
    return factory(nav=replace(nav, final_nav=bool(final_nav)), agent=agent or AgentConfig(), seed=seed)


def evaluate(dataset: str | Path | list[Path | Bundle], agent: Any, nav: NavConfig | None = None, episodes: int | None = None,
             out: Path | None = None, label: str | None = None, progress: bool = True) -> list[dict]:
    """Run an agent over a dataset's episodes; return (and optionally write) one result dict per episode.

    Parameters
    ----------
    dataset
        MJCF bundle dataset folder (variant folders with episodes.json), one variant folder, or a list of variant
        folders (a subset of a dataset, e.g. `select_bundles`) or loaded `Bundle`s.
    agent
        An agent following the protocol of `nav.agents` (prepare, reset, act, wants_frame); its
        ``agent_config`` (`AgentConfig`, default `AgentConfig()`) builds the environments.
    nav
        Actions, step limit and success radius of the environments (default ``agent.nav``).
    episodes
        Evaluate at most this many episodes (default: all).
    out
        Folder for ``episodes/<label>/<episode id>.json`` (None: write nothing).
    label
        Name of this run in results and folders (default ``agent.name``).
    progress
        Show a progress bar.
    """
    nav = nav or agent.nav
    body = getattr(agent, "agent_config", None) or AgentConfig()
    know = knowledge_of(agent)
    gt = know.detector == "gt"
    paths = find_bundles(dataset) if isinstance(dataset, (str, Path)) else list(dataset)
    bundles = [p if isinstance(p, Bundle) else load_bundle(p) for p in paths]
    total = sum(len(b.episodes) for b in bundles)
    limit = total if episodes is None else min(int(episodes), total)
    label = label or agent.name
    results: list[dict] = []
    with Progress(limit, f"eval {label}", enabled=progress) as bar:
        for b in bundles:
            if len(results) >= limit:
                break
            # the ground-truth detector is the suite's: it knows every label (scene instances and placed objects)
            detector = GroundTruthDetector(labels=b.detector_labels(), agent=body) if gt else None

            def make_env(_view: Any, b=b, **kw: Any) -> AgentEnv:
                return AgentEnv(make_environment(b, semantic=gt, **kw), know)

            agent.prepare(AgentBundle(b, know, detector), make_env)
            env = make_environment(b, nav=nav, agent=body, semantic=gt)
            aenv = AgentEnv(env, know)
            try:
                for i in range(len(b.episodes)):
                    if len(results) >= limit:
                        break
                    env.task.set_next_episode(i)
                    env.task.render_frames = True  # every episode's first observation is rendered
                    ts = aenv.reset()
                    agent.reset(aenv, ts)
                    while not ts.last():
                        a = agent.act(ts)
                        env.task.render_frames = bool(getattr(agent, "wants_frame", True))
                        ts = aenv.step(a)
                    m = env.task.metrics()
                    ep = env.task.episode
                    r = {"agent": label, "knowledge": know.describe(), "oracle": know.is_oracle,
                         "episode_id": ep.episode_id, "variant": b.name, "scene": ep.scene,
                         "category": ep.object_category, **m.to_dict(), "collisions": env.task.collisions,
                         "inside": any(g.open_part for g in ep.goals),
                         "must_open": bool(ep.goals) and all(g.open_part for g in ep.goals),
                         "part_moves": [list(t) for t in env.task.part_moves],
                         "info": agent.info, "trajectory": np.round(np.array(env.task.trajectory)[:, :2], 4).tolist()}
                    r["outcome"] = episode_outcome(r, ep, know.pose)
                    results.append(r)
                    if out is not None:
                        atomic_write_text(out / "episodes" / label.replace(" ", "_") / f"{ep.episode_id}.json",
                                          json.dumps(_finite(r), sort_keys=True) + "\n")
                    bar.update(1, ep.episode_id)
            finally:
                env.task.close()
    return results


def select_bundles(dataset: str | Path, per_scene: int) -> list[Bundle]:
    """Return the first `per_scene` variants of every scene of a dataset, loaded (scenes and variant folders sorted).

    A balanced subset for evaluating on many scenes at once (`evaluate` takes the list, and every run over it reuses
    the loaded bundles): the first N episodes of a dataset all come from its first scene.
    """
    by_scene: dict[str, list[Bundle]] = {}
    for p in find_bundles(dataset):
        b = load_bundle(p)
        kept = by_scene.setdefault(str(b.episodes[0].scene) if b.episodes else p.name, [])
        if len(kept) < per_scene:
            kept.append(b)
    return [b for scene in sorted(by_scene) for b in by_scene[scene]]


def _finite(x: Any) -> Any:
    """Return x with non-finite floats replaced by None (JSON has no inf/nan)."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_finite(v) for v in x]
    return x


def summarize(results: list[dict], bootstrap: int = 1000, seed: int = 0) -> dict[str, Any]:
    """Return SR, SPL, Soft SPL and mean DTG over result dicts, with 95 % bootstrap intervals.

    The intervals resample episodes with replacement (``bootstrap`` resamples, percentile method); ``<m>_ci``
    holds (low, high) for each metric. Non-finite distances to goal are left out of the DTG mean. When some
    episodes are "inside" ones (a goal hidden in a closed articulated part, ``Goal.open_part``), ``inside`` holds
    the same summary over those episodes alone (without it when there are none), ``must_open`` over the episodes
    whose every goal is hidden (no success without opening a part).
    """
    out = _summary(results, bootstrap, seed)
    for key in ("inside", "must_open"):
        sub = [r for r in results if r.get(key)]
        if sub:
            out[key] = _summary(sub, bootstrap, seed)
    return out


def _summary(results: list[dict], bootstrap: int, seed: int) -> dict[str, Any]:
    """Return the metric means and bootstrap intervals of `summarize` over result dicts."""
    ms = [M.EpisodeMetrics(r["success"], r["spl"], r["soft_spl"], r["distance_to_goal"], r["shortest"], r["path_length"])
          for r in results]
    out: dict[str, Any] = dict(M.aggregate(ms))
    if results and bootstrap > 0:
        rng = np.random.default_rng(seed)
        cols = {k: np.array([float(r[k]) if r[k] is not None else np.nan for r in results])
                for k in ("success", "spl", "soft_spl", "distance_to_goal")}
        idx = rng.integers(0, len(results), size=(int(bootstrap), len(results)))
        for k, v in cols.items():
            vv = np.where(np.isfinite(v), v, np.nan)
            means = np.nanmean(vv[idx], axis=1)
            lo, hi = np.nanpercentile(means, [2.5, 97.5])
            out[f"{k}_ci"] = (round(float(lo), 4), round(float(hi), 4))
    if results:
        out["knowledge"] = results[0].get("knowledge", "")
        if all("outcome" in r for r in results):
            out["outcomes"] = {k: round(sum(r["outcome"] == k for r in results) / len(results), 4) for k in OUTCOMES}
    return out


def paired_difference(a: list[dict], b: list[dict], key: str = "success", bootstrap: int = 2000,
                      seed: int = 0) -> dict[str, Any]:
    """Return the mean per-episode difference a - b of a metric over the episodes both agents ran, with a 95 % interval.

    The agents ran the same episodes, so the comparison is paired: the bootstrap resamples episodes (percentile
    method), each carrying both agents' results, which removes the episode-to-episode spread the two unpaired
    intervals of `summarize` both hold. Returns ``{"diff", "ci": (low, high), "episodes"}``; an interval that
    excludes 0 orders the two agents on these episodes.
    """
    bx = {r["episode_id"]: float(r[key]) for r in b}
    pairs = [(float(r[key]), bx[r["episode_id"]]) for r in a if r["episode_id"] in bx]
    if not pairs:
        return {"diff": float("nan"), "ci": (float("nan"), float("nan")), "episodes": 0}
    d = np.array([x - y for x, y in pairs])
    rng = np.random.default_rng(seed)
    means = d[rng.integers(0, len(d), size=(int(bootstrap), len(d)))].mean(axis=1)
    lo, hi = np.percentile(means, [2.5, 97.5])
    return {"diff": round(float(d.mean()), 4), "ci": (round(float(lo), 4), round(float(hi), 4)), "episodes": len(d)}


def paired_table(per_episode: dict[str, list[dict]], pairs: list[tuple[str, str]]) -> str:
    """Return the markdown table of paired differences (SR, SPL) for agent pairs present in ``per_episode``."""
    shown = [(x, y) for x, y in pairs if x in per_episode and y in per_episode]
    if not shown:
        return ""
    lines = ["| A - B | Episodes | SR difference [95% CI] | SPL difference [95% CI] |", "|---|---|---|---|"]
    for x, y in shown:
        sr, spl = (paired_difference(per_episode[x], per_episode[y], k) for k in ("success", "spl"))
        lines.append(f"| {x} - {y} | {sr['episodes']} | {sr['diff']:+.3f} [{sr['ci'][0]:+.3f}, {sr['ci'][1]:+.3f}] | "
                     f"{spl['diff']:+.3f} [{spl['ci'][0]:+.3f}, {spl['ci'][1]:+.3f}] |")
    return "\n".join(lines)


def episodes_per_minute(results: list[dict], seconds: float) -> float:
    """Return evaluation speed: episodes per wall minute."""
    return 60.0 * len(results) / seconds if seconds > 0 else float("nan")


def _cell(s: dict, k: str) -> str:
    ci = s.get(f"{k}_ci")
    return f"{s[k]:.3f} [{ci[0]:.3f}, {ci[1]:.3f}]" if ci else f"{s[k]:.3f}"


def inside_table(rows: dict[str, dict[str, Any]]) -> str:
    """Return the markdown table of "inside" episodes per agent ('' when none).

    Rows: a goal hidden in a closed part (``inside``) and every goal hidden (``must_open``: no success without OPEN).
    """
    shown = [(n, k, s[k]) for n, s in rows.items() for k in ("inside", "must_open") if s.get(k)]
    if not shown:
        return ""
    lines = ["| Agent | Episodes | Count | Success Rate [95% CI] | SPL [95% CI] | Soft SPL [95% CI] | Dist2Goal (m) |",
             "|---|---|---|---|---|---|---|"]
    for name, key, s in shown:
        what = "a goal hidden" if key == "inside" else "every goal hidden"
        lines.append(f"| {name} | {what} | {s['episodes']} | {_cell(s, 'success')} | {_cell(s, 'spl')} | "
                     f"{_cell(s, 'soft_spl')} | {s['distance_to_goal']:.3f} |")
    return "\n".join(lines)


def outcome_table(rows: dict[str, dict[str, Any]]) -> str:
    """Return the markdown table of why episodes ended (shares of `OUTCOMES` per agent; '' when none recorded)."""
    shown = {n: s["outcomes"] for n, s in rows.items() if s.get("outcomes")}
    if not shown:
        return ""
    lines = ["| Agent | Episodes | " + " | ".join(OUTCOMES) + " |", "|---" * (len(OUTCOMES) + 2) + "|"]
    for name, o in shown.items():
        lines.append(f"| {name} | {rows[name]['episodes']} | " + " | ".join(f"{o.get(k, 0.0):.3f}" for k in OUTCOMES) + " |")
    lines += ["", "; ".join(f"{k}: {OUTCOME_HELP[k]}" for k in OUTCOMES) + "."]
    return "\n".join(lines)


def overall_table(rows: dict[str, dict[str, Any]], paper: bool = True) -> str:
    """Return the overall markdown table: each agent's knowledge, metrics with 95 % bootstrap intervals.

    With ``paper``, the paper's GT-detector rows follow under their own heading: its scenes (HM3D/MP3D scans),
    objects and detector differ from ours, so its numbers are context, not a comparison.
    """
    lines = ["| Agent | Knowledge | Episodes | Success Rate [95% CI] | SPL [95% CI] | Soft SPL [95% CI] | Dist2Goal (m) |",
             "|---|---|---|---|---|---|---|"]
    for name, s in rows.items():
        lines.append(f"| {name} | {s.get('knowledge', '')} | {s['episodes']} | {_cell(s, 'success')} | {_cell(s, 'spl')} | "
                     f"{_cell(s, 'soft_spl')} | {s['distance_to_goal']:.3f} |")
    shown = [n for n in rows if paper and n in PAPER]
    if shown:
        lines += ["", "Paper (SD-OVON-3k, tables 4-5, GT detector): other scenes (HM3D/MP3D scans), other objects, the",
                  "paper's own agents and FN; context only, not comparable with the rows above.", "",
                  "| Baseline | Episodes | Success Rate | SPL | Soft SPL | Dist2Goal |", "|---|---|---|---|---|---|"]
        for name in shown:
            pp = PAPER[name]
            lines.append(f"| paper: {name} GT | 3k | {pp['success']:.4f} | {pp['spl']:.4f} | {pp['soft_spl']:.4f} | "
                         f"{pp['distance_to_goal']:.4f} |")
    return "\n".join(lines)


def category_table(per_agent: dict[str, list[dict]], k: int = 5, min_successes: int = 2) -> str:
    """Return the top-k categories by success rate (with at least `min_successes` successes) per agent."""
    tops = {}
    for name, res in per_agent.items():
        cats: dict[str, list[float]] = {}
        for r in res:
            cats.setdefault(r["category"], []).append(r["success"])
        ok = [(c, float(np.mean(v))) for c, v in cats.items() if sum(v) >= min_successes]
        tops[name] = sorted(ok, key=lambda t: (-t[1], t[0]))[:k]
    names = list(per_agent)
    lines = ["| Top-k / Cat. (SR) | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for i in range(k):
        cells = [f"{tops[n][i][0]} ({tops[n][i][1]:.4f})" if i < len(tops[n]) else "-" for n in names]
        lines.append(f"| Top-{i + 1} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def trajectory_picture(dataset: str | Path, result: dict, path: Path, scale: int = 4) -> None:
    """Draw an episode's trajectory, start and goal view points on the top-down navigable map (PNG)."""
    import cv2

    match = [p for p in find_bundles(dataset) if p.name == result["variant"]]
    b = load_bundle(match[0] if match else dataset)
    ep = next(e for e in b.episodes if e.episode_id == result["episode_id"])
    nm = b.navmap(ep.floor)
    img = np.full(nm.navigable.shape + (3,), 40, np.uint8)
    img[nm.free] = (150, 150, 150)
    img[nm.navigable] = (220, 220, 220)
    img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)

    def px(xy):
        rc = (np.asarray(xy, float)[:2] - nm.origin) / nm.resolution * scale
        return int(rc[0]), int(rc[1])

    for g in ep.goals:
        for vp in g.view_points:
            cv2.circle(img, px(vp.position), 1, (80, 200, 80), -1)
        cv2.circle(img, px(g.position), 4, (0, 140, 0), -1)
    traj = result["trajectory"]
    for a, c in zip(traj[:-1], traj[1:]):
        cv2.line(img, px(a), px(c), (40, 40, 230), 2)
    cv2.circle(img, px(traj[0]), 5, (230, 120, 20), -1)
    cv2.circle(img, px(traj[-1]), 4, (0, 0, 255) if not result["success"] else (0, 200, 0), 2)
    img = img[::-1].copy()  # north (+Y) up
    cv2.putText(img, f"{result['agent']} {result['category']} S={result['success']:.0f} SPL={result['spl']:.2f}",
                (5, 15), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1)
    ok, buf = cv2.imencode(".png", img)
    atomic_write_bytes(path, buf.tobytes())


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the eval options."""
    parser.add_argument("dataset", help="MJCF bundle dataset folder (variant folders with episodes.json)")
    parser.add_argument("--agent", action="append", default=None,
                        help="random-astar | semantic-astar | oracle | random | <plugin> (repeatable; default both A* agents)")
    parser.add_argument("--episodes", type=int, default=None, help="evaluate at most N episodes")
    parser.add_argument("--no-fn", action="store_true", help="A* agents without final point-goal navigation")
    parser.add_argument("--fn-ablation", action="store_true", help="run A* agents with and without FN (paper table 5)")
    parser.add_argument("--fn-mode", choices=("paper", "lattice"), default=None,
                        help="FN variant: paper (Navigate(p_g|eps_nav), default) or lattice (our inferred-view-point variant)")
    parser.add_argument("--width", type=int, default=None, help="camera width (default AgentConfig.sensor_width: 640)")
    parser.add_argument("--height", type=int, default=None, help="camera height (default AgentConfig.sensor_height: 480)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pictures", type=int, default=5, help="trajectory pictures per agent")
    parser.add_argument("--out", required=True, help="output folder")


def run(args: argparse.Namespace) -> int:
    """Evaluate the agents and print the tables."""
    out = Path(args.out)
    if not Path(args.dataset).is_dir():
        raise InputError(args.dataset, "dataset folder not found")
    nav = NavConfig() if args.fn_mode is None else replace(NavConfig(), fn_mode=args.fn_mode)
    upd = {k: v for k, v in (("sensor_width", args.width), ("sensor_height", args.height)) if v}
    body = replace(AgentConfig(), **upd)
    names = args.agent or ["random-astar", "semantic-astar"]
    runs: list[tuple[str, str, bool]] = []
    for n in names:
        astar = n in ("random-astar", "semantic-astar", "semantic-frontier")
        if astar and args.fn_ablation:
            runs += [(n, n, True), (n, f"{n} no-FN", False)]
        else:
            runs.append((n, f"{n} no-FN" if (astar and args.no_fn) else n, not args.no_fn))
    per_agent: dict[str, list[dict]] = {}
    speed: dict[str, float] = {}
    for name, label, fn in runs:
        agent = make_agent(name, nav, args.seed, final_nav=fn, agent=body)
        t0 = time.perf_counter()
        res = evaluate(args.dataset, agent, nav, args.episodes, out, label)
        speed[label] = episodes_per_minute(res, time.perf_counter() - t0)
        print(f"{label}: {len(res)} episodes, {speed[label]:.1f} episodes/min (incl. its scene exploration)")
        per_agent[label] = res
        for r in res[: max(0, args.pictures)]:
            trajectory_picture(args.dataset, r, out / "pictures" / label.replace(" ", "_") / f"{r['episode_id']}.png")
    rows = {label: {**summarize(res), "episodes_per_minute": round(speed[label], 2)} for label, res in per_agent.items()}
    md = "## Overall\n\n" + overall_table(rows) + "\n\n## Per category (top-5, >= 2 successes)\n\n" + category_table(per_agent) + "\n"
    labels = list(per_agent)
    paired = paired_table(per_agent, [(x, y) for i, x in enumerate(labels) for y in labels[i + 1:]])
    if paired:
        md += "\n## Paired differences (same episodes, 95 % paired bootstrap)\n\n" + paired + "\n"
    ended, inside = outcome_table(rows), inside_table(rows)
    if ended:
        md += "\n## How episodes ended\n\n" + ended + "\n"
    if inside:
        md += "\n## Inside articulated receptacles (goal behind a closed door or drawer)\n\n" + inside + "\n"
    atomic_write_text(out / "tables.md", md)
    atomic_write_text(out / "summary.json", json.dumps(_finite(rows), indent=1, sort_keys=True) + "\n")
    print(md)
    return 0
