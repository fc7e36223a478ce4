"""The markdown tables of an evaluation: overall (with the episodes' difficulty, the first visits and the paper's
rows for context), per category, paired differences, how episodes ended, inside articulated receptacles, and a
lifelong evaluation's tables per day and by goal history."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from .outcomes import OUTCOME_HELP, OUTCOMES
from .statistics import INTERVALS, lifelong, paired_difference, summarize


PAPER = {  # SD-OVON tables 4 and 5 (ground-truth detector), for the closing comparison
    "random-astar": {"success": 0.7503, "spl": 0.3494, "soft_spl": 0.3931, "distance_to_goal": 1.5437},
    "random-astar no-FN": {"success": 0.3041, "spl": 0.1471, "soft_spl": 0.3748, "distance_to_goal": 2.1105},
    "semantic-astar": {"success": 0.8081, "spl": 0.4270, "soft_spl": 0.4700, "distance_to_goal": 1.0989},
    "semantic-astar no-FN": {"success": 0.3752, "spl": 0.2111, "soft_spl": 0.4742, "distance_to_goal": 1.5230},
}


def _cell(s: dict, k: str) -> str:
    ci = s.get(f"{k}_ci")
    return f"{s[k]:.3f} [{ci[0]:.3f}, {ci[1]:.3f}]" if ci else f"{s[k]:.3f}"


def _share(x: Any) -> str:
    return "-" if x is None else f"{100.0 * float(x):.1f} %"


def ran_as(s: dict[str, Any]) -> str:
    """Return how an agent ran, for the tables: sealed (file system sealed or not) or in-process, on which split
    (an open split, from public seeds, or a secret one: `loop.dataset_split`), and the renderer that drew its
    observations (cpu or gpu; ``auto`` that fell back to the CPU says so)."""
    mode = s.get("mode", "")
    split = s.get("split", "open split")
    if mode == "sealed":
        mode += "" if "NOT" not in s.get("seal", "") else ", file system not sealed"
    render = s.get("render", "")
    if render and render != "-":
        mode = f"{mode or '-'}, {render}" + (" (auto: no GPU)" if s.get("render_fallback") else "")
    return f"{mode}, {split}" if mode else "-"


def overall_table(rows: dict[str, dict[str, Any]], paper: bool = True) -> str:
    """Return the overall markdown table: each agent's knowledge, how it ran, metrics with 95 % intervals, and below
    it the episodes' difficulty, the first visits' budget and use, and the file-system seal of each sealed row.

    With ``paper``, the paper's GT-detector rows follow under their own heading: its scenes (HM3D/MP3D scans),
    objects and detector differ from ours, so its numbers are context, not a comparison.
    """
    lines = ["| Agent | Knowledge | Ran | Episodes | Success Rate [95% CI] | SPL [95% CI] | Soft SPL [95% CI] | Dist2Goal (m) |",
             "|---|---|---|---|---|---|---|---|"]
    for name, s in rows.items():
        lines.append(f"| {name} | {s.get('knowledge', '')} | {ran_as(s)} | {s['episodes']} | {_cell(s, 'success')} | "
                     f"{_cell(s, 'spl')} | {_cell(s, 'soft_spl')} | {s['distance_to_goal']:.3f} |")
    lines += ["", INTERVALS + "."]
    diff = difficulty_table(rows)
    if diff:
        lines += ["", diff]
    visits = first_visit_table(rows)
    if visits:
        lines += ["", visits]
    seals = sorted({s.get("seal", "") for s in rows.values() if s.get("mode") == "sealed"} - {""})
    if seals:
        lines += ["", "Sealed rows: " + "; ".join(seals) + "."]
    setups = [f"{n} {s['setup_seconds']:.1f} s" for n, s in rows.items() if s.get("setup_seconds") is not None]
    if setups:
        lines += ["", "Agent set-up (its process's start to its answer to setup, the longest of a row's processes): "
                  + "; ".join(setups) + "."]
    failed = [f"{n}: " + ", ".join(f"{k} {v}" for k, v in s["failures"].items()) for n, s in rows.items()
              if s.get("failures")]
    if failed:
        lines += ["", "Agent failures (episodes, by cause; each counted as a failed episode): " + "; ".join(failed) + "."]
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


def difficulty_table(rows: dict[str, dict[str, Any]]) -> str:
    """Return the difficulty of each distinct set of episodes the rows ran ('' when none is recorded)."""
    groups: dict[str, list[str]] = {}
    for name, s in rows.items():
        d = s.get("difficulty")
        if d:
            groups.setdefault(json.dumps(d, sort_keys=True), []).append(name)
    if not groups:
        return ""
    lines = ["| Episodes of | Episodes | Start-to-goal geodesic quartiles (m) | Goal in view at the start pose | "
             "Goal visible from the start point |", "|---|---|---|---|---|"]
    for text, names in groups.items():
        d = json.loads(text)
        q = " / ".join("-" if v is None else f"{float(v):.2f}" for v in d["geodesic_quartiles"])
        lines.append(f"| {', '.join(names) if len(groups) > 1 else 'every row'} | {d['episodes']} | {q} | "
                     f"{_share(d['in_view'])} | {_share(d['visible_from_start'])} |")
    lines += ["", "Difficulty: the evaluator's own measure at each reset (the episodes' visibility definition; "
                  "\"visible from the start point\": at one of 12 headings turning in place)."]
    return "\n".join(lines)


def first_visit_table(rows: dict[str, dict[str, Any]]) -> str:
    """Return the first visits of the rows with a scene prior: budget, mean steps and metres per scene ('' if none)."""
    shown = {n: s["first_visit"] for n, s in rows.items() if s.get("first_visit")}
    if not shown:
        return ""
    lines = ["| First visit of | Scenes | Floors per scene | Budget (steps per floor) | Steps per scene | Metres per scene "
             "| Seconds per scene |", "|---|---|---|---|---|---|---|"]
    for name, v in shown.items():
        lines.append(f"| {name} | {v['scenes']} | {v.get('floors', 1):g} | {v['budget']} | {v['steps']:.0f} | "
                     f"{v['metres']:.1f} | {v['seconds']:.1f} |")
    lines += ["", "First visit: the exploration phase an agent with a scene prior gets before a scene's episodes "
                  "(the evaluator's seeded start on each floor with episodes, no goal, no reward, placed objects "
                  "hidden)."]
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


def tables_markdown(per_agent: dict[str, list[dict]], pairs: list[tuple[str, str]] | None = None, paper: bool = True,
                    categories: bool = True) -> tuple[str, dict[str, dict[str, Any]]]:
    """Return the markdown of every table over rows' results (overall with difficulty and first visits, per category,
    paired differences, how episodes ended, inside articulated receptacles) and the rows' summaries."""
    rows = {label: summarize(res) for label, res in per_agent.items() if res}
    md = "## Overall\n\n" + overall_table(rows, paper) + "\n"
    if categories:
        md += "\n## Per category (top-5, >= 2 successes)\n\n" + category_table(per_agent) + "\n"
    labels = list(rows)
    paired = paired_table(per_agent, pairs if pairs is not None else
                          [(x, y) for i, x in enumerate(labels) for y in labels[i + 1:]])
    if paired:
        md += f"\n## Paired differences (same episodes; {INTERVALS})\n\n" + paired + "\n"
    ended, inside = outcome_table(rows), inside_table(rows)
    if ended:
        md += "\n## How episodes ended\n\n" + ended + "\n"
    if inside:
        md += "\n## Inside articulated receptacles (goal behind a closed door or drawer)\n\n" + inside + "\n"
    days = lifelong_tables(per_agent)
    if days:
        md += "\n" + days
    return md, rows


def lifelong_tables(per_agent: dict[str, list[dict]], bootstrap: int = 1000) -> str:
    """Return the markdown of a lifelong evaluation's tables ('' when no result has a day): SR and SPL per day, then
    by goal history (unmoved, moved, new since the day before), each cell with its 95 % interval (scenes, then days,
    then episodes), with the share of stale stops (`statistics.lifelong`)."""
    got = {n: lifelong(res, bootstrap) for n, res in per_agent.items() if any(r.get("day") is not None for r in res)}
    if not got:
        return ""

    def table(part: str, head: str) -> list[str]:
        lines = [f"| Agent | {head} | Episodes | SR [95% CI] | SPL [95% CI] | Stale stops | Not run |",
                 "|---|---|---|---|---|---|---|"]
        for name, f in got.items():
            for key, g in f[part].items():
                if g["episodes"]:
                    lines.append(f"| {name} | {key} | {g['episodes']} | {_cell(g, 'success')} | {_cell(g, 'spl')} | "
                                 f"{_share(g['stale_stop'])} | {g['not_run']} |")
        return lines

    stale = ["| Agent | Stale stops | Share of episodes | Share of failed STOPs |", "|---|---|---|---|"]
    for name, f in got.items():
        st = f["stale_stops"]
        stale.append(f"| {name} | {st['count']} | {_share(st['share'])} | "
                     f"{'-' if st['of_failed_stops'] != st['of_failed_stops'] else _share(st['of_failed_stops'])} |")
    return "\n".join(["## Lifelong: per day", "", *table("days", "Day"), "",
                      "## Lifelong: by goal history (since the day before)", "", *table("history", "History"), "",
                      "## Lifelong: stale stops (a failed STOP where the goal category rested on an earlier day, "
                      "and rests no more)", "", *stale, "", f"{INTERVALS.replace('variants', 'days')}.", ""])
