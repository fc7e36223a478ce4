"""Articulated receptacles in default-world apartments at their configured part probabilities (issue 17).

Two apartments x 5 variants with `world.articulated` and the default open / closed / ajar probabilities, run to
their episodes, then audited (`sdovon_mj.episodes.audit.audit_inside`):

- at least 20 % of the resting objects lie inside articulated receptacles (the goal the issue sets; the bench,
  `bench/bench_articulated.py`, runs apartments 2 and 4, these are others); objects a moving part pushed away
  (displaced, tunnelled) are classified and leave the variant (`place.inside`), so they are not counted resting;
- every valid goal resting inside a fully closed piece names the part to open, or is seen with the part closed
  (through a gap between door and carcass) by an independent render from its first view point;
- every goal naming a part is seen from its first view point with the part open and hidden in the variant's state,
  by a render of everything at the episodes' visibility size (the suite's "goal seen" check renders so).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from sdovon_mj.episodes.audit import audit_inside

CONFIG = """\
name: sdovon-articulated-share
seed: 0
world:
  scene_seeds: [1, 3]
  floors: 1
  object_variants: 1
  articulated: true
observe:
  width: 320
  height: 240
place:
  k_v: 5
episodes:
  k_e: 2
"""


@pytest.mark.slow
def test_default_world_puts_a_fifth_inside_and_hidden_goals_name_their_part(tmp_path: Path) -> None:
    cfg = tmp_path / "art.yaml"
    cfg.write_text(CONFIG, encoding="utf-8")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "episodes", str(tmp_path / "run"), "--config", str(cfg),
                           "--jobs", "2"],  # its two scenes side by side (same bytes on any number of workers)
                          cwd=Path(__file__).resolve().parents[1], env=env, capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    a = audit_inside(tmp_path / "run")
    s = a.summary()
    print(s)
    assert a.inside_share >= 0.20, s
    # every valid goal inside a fully closed piece names its part, or a render confirms it is seen through a gap
    assert a.hidden_goals > 0 and a.named > 0 and a.named + a.seen_closed == a.hidden_goals and not a.unexplained, s
    assert a.checks, s
    bad = [c for c in a.checks if not c.open_fraction >= a.eta_gt > c.closed_fraction]
    assert not bad, bad
