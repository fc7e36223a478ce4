"""Audit of a run's objects inside articulated receptacles, against what the episodes promise.

For a run folder whose episodes stage is done (`world.articulated` or articulated scenes), over every variant:

- how many resting objects lie inside articulated receptacles (on a plane whose `part` is set), and how many the
  parts displaced or tunnelled when the variant's state was set;
- the parts' states drawn (open / closed / ajar);
- every resting object inside a fully closed piece: whether it is a valid goal and whether its goal names the part
  to open (`Goal.open_part`); a goal that does not is seen with the part closed (through a gap between door and
  carcass), which an independent render from its first view point must confirm (``seen_closed``), else it is
  counted ``unexplained``;
- for every goal naming a part, an independent render check from its first view point: the object's pixel fraction
  in a segmentation render of everything (no culling, no ray shortcut) at the episodes' visibility size, with the
  part open (must reach ``eta_gt``) and in the variant's state (must stay below).

`bench/bench_articulated.py` prints it; the tests assert on it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco

from ..records import NavMap, ReceptaclePlane, load_json
from ..runview import RunLayout, RunView
from ..sim.articulation import part_instance, part_joints
from .generate import build_goals
from .inside import part_opened, seen_fraction
from .viewpoints import load_variant_model


@dataclass
class PartCheck:
    """One goal naming a part: its pixel fractions with the part open and in the variant's state."""

    variant: str
    object_id: str
    category: str
    part: str
    open_fraction: float
    closed_fraction: float


@dataclass
class InsideAudit:
    """What `audit_inside` counted over a run's variants (see the module docstring)."""

    eta_gt: float = 0.0
    placed: int = 0
    resting: int = 0
    inside: int = 0
    displaced: int = 0
    tunnelled: int = 0
    states: dict[str, int] = field(default_factory=lambda: {"open": 0, "closed": 0, "ajar": 0})
    hidden_goals: int = 0
    named: int = 0
    seen_closed: int = 0
    unexplained: list[str] = field(default_factory=list)
    hidden_not_goal: int = 0
    checks: list[PartCheck] = field(default_factory=list)

    @property
    def inside_share(self) -> float:
        """Return the share of resting objects that rest inside articulated receptacles."""
        return self.inside / max(1, self.resting)

    @property
    def open_seen(self) -> int:
        """Return how many goals naming a part are seen (>= eta_gt) with it open."""
        return sum(c.open_fraction >= self.eta_gt for c in self.checks)

    @property
    def closed_hidden(self) -> int:
        """Return how many goals naming a part are hidden (< eta_gt) in the variant's state."""
        return sum(c.closed_fraction < self.eta_gt for c in self.checks)

    def summary(self) -> dict:
        """Return the counts as a JSON-able dict."""
        return {"inside_share": self.inside_share, "placed": self.placed, "resting": self.resting,
                "inside": self.inside, "displaced": self.displaced, "tunnelled": self.tunnelled,
                "states": dict(self.states), "hidden_goals": self.hidden_goals, "named": self.named,
                "seen_closed": self.seen_closed, "unexplained": list(self.unexplained),
                "hidden_not_goal": self.hidden_not_goal, "render_checks": len(self.checks),
                "open_seen": self.open_seen, "closed_hidden": self.closed_hidden}


def audit_inside(run_dir: str | Path) -> InsideAudit:
    """Return the audit of a run folder's objects inside articulated receptacles (episodes stage done).

    The goals are rebuilt with the run's own config (`build_goals`), so every valid goal is checked, not only those
    the sampled episodes name.
    """
    view = RunView(run_dir)
    run = view.root
    cfg = view.config()
    vis = (cfg.episodes.vis_width, cfg.episodes.vis_height)  # the view points' own visibility definition
    a = InsideAudit(eta_gt=cfg.agent.eta_gt)
    scenes: dict[str, tuple[dict[int, ReceptaclePlane], list[NavMap]]] = {}  # read once per scene
    for v in view.all_variants():
        if v.scene not in scenes:
            planes_path = view.path(RunLayout.planes(v.scene, "semantics"))
            scenes[v.scene] = ({p.id: p for p in load_json(planes_path, ReceptaclePlane)}, view.navmaps(v.scene))
        planes, navmaps = scenes[v.scene]
        a.placed += len(v.placements)
        for p in v.placements:
            a.resting += p.status == "resting"
            a.displaced += p.status == "displaced"
            a.tunnelled += p.status == "tunnelled"
            a.inside += p.status == "resting" and planes[p.plane_id].part is not None
        model, data = load_variant_model(v, run)
        closed_parts = set()
        for j in part_joints(model):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
            q, (lo, hi) = (v.articulation or {})[name], model.jnt_range[j]
            kind = "closed" if q <= lo + 1e-9 else "open" if q >= hi - 1e-9 else "ajar"
            a.states[kind] += 1
            if kind == "closed":
                closed_parts.add(name)
        goals, _floors, _rep = build_goals(v, navmaps, run, cfg.episodes, cfg.agent)
        by_obj = {g.object_id: g for g in goals}
        for p in v.resting:  # inside a piece whose every part is closed (a two-door cabinet with one door open shows it)
            piece = [n for n in (v.articulation or {}) if p.part and part_instance(n) == part_instance(p.part)]
            if p.part and all(n in closed_parts for n in piece):
                g = by_obj.get(p.object_id)
                if g is None:
                    a.hidden_not_goal += 1
                    continue
                a.hidden_goals += 1
                if g.open_part == p.part:
                    a.named += 1
                elif g.open_part is None and seen_fraction(model, data, g, g.view_points[0], cfg.agent, vis) >= a.eta_gt:
                    a.seen_closed += 1  # visible through a gap with every part closed: no part to open
                else:
                    a.unexplained.append(f"{v.name}/{p.object_id}")
        for g in goals:
            if g.open_part is None:
                continue
            closed = seen_fraction(model, data, g, g.view_points[0], cfg.agent, vis)
            with part_opened(model, data, g.open_part, g.object_id):
                opened = seen_fraction(model, data, g, g.view_points[0], cfg.agent, vis)
            a.checks.append(PartCheck(v.name, g.object_id, g.category, g.open_part, opened, closed))
    return a


__all__ = ["InsideAudit", "PartCheck", "audit_inside"]
