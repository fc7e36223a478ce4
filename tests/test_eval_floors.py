"""A multi-storey home under the sealed evaluation: an agent with a scene prior gets a first visit of every floor with
episodes, each started on its floor, and plans each episode on the memory of the episode's own floor.

Before this, the one first visit ran on the floor of the scene's first episode, and an episode upstairs planned on
the ground floor's map (in the 3k-size houses the A* agents stood still through most of their episodes).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from sdovon_mj.config import AgentConfig, NavConfig
from sdovon_mj.suite import load_bundle
from sdovon_mj.suite.bundle import find_bundles
from sdovon_mj.suite.evaluation.loop import evaluate
from sdovon_mj.suite.evaluation.runner import agent_spec
from test_generate import TINY_SET, TINY_YAML, cli

pytestmark = pytest.mark.slow

TWO_STOREYS = TINY_YAML.replace("floors: 1", "floors: 2").replace("name: sdovon-tiny", "name: sdovon-two-storeys")
assert "floors: 2" in TWO_STOREYS


@pytest.fixture(scope="module")
def two_storey_dataset(tmp_path_factory) -> Path:
    """A default-world apartment of two storeys, generated and exported as MJCF bundles."""
    root = tmp_path_factory.mktemp("storeys")
    cfg = root / "two.yaml"
    cfg.write_text(TWO_STOREYS, encoding="utf-8")
    proc = cli("generate", "--out", str(root / "run"), "--config", str(cfg), *TINY_SET, "--set", "exporters=[mjcf]",
               "--quiet", timeout=1500)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return root / "run" / "export" / "mjcf"


def test_every_floor_gets_its_first_visit_and_its_episodes_plan_on_it(two_storey_dataset, tmp_path):
    b = load_bundle(find_bundles(two_storey_dataset)[0])
    heights = {nm.floor: nm.height for nm in b.navmaps}
    floors = sorted({ep.floor for ep in b.episodes})
    assert len(floors) == 2 and heights[floors[1]] - heights[floors[0]] > 2.0, (floors, heights)
    # two episodes per floor, the upper floor's first: the first visit of the scene starts there
    picked = [ep for f in reversed(floors) for ep in [e for e in b.episodes if e.floor == f][:2]]
    small = dataclasses.replace(b, episodes=picked)
    nav = NavConfig(max_steps=60)
    spec = agent_spec("semantic-astar", nav, agent=AgentConfig(), explore_steps=120, explore_size=(64, 48))
    out = tmp_path / "eval"
    results = evaluate([small], spec, nav=nav, out=out, progress=False,
                       body=AgentConfig(sensor_width=64, sensor_height=48))
    assert len(results) == 4

    visit = json.loads(next((out / "exploration").rglob("*.json")).read_text())
    assert [v["floor"] for v in visit["floors"]] == [floors[1], floors[0]]  # the first episode's floor first
    for v in visit["floors"]:
        assert v["start"][2] == pytest.approx(heights[v["floor"]], abs=1e-3)  # started on its own floor
        assert v["info"]["floor_z"] == pytest.approx(heights[v["floor"]], abs=0.01)  # and the agent mapped it there
    assert visit["steps"] == sum(v["steps"] for v in visit["floors"]) and visit["budget"] == 120
    for r, ep in zip(results, picked):
        assert r["episode_id"] == ep.episode_id
        assert r["first_visit"]["floors"] == 2
        assert r["info"]["memory_floor_z"] == pytest.approx(heights[ep.floor], abs=0.01), r["info"]
