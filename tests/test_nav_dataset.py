"""The honest baselines on a pipeline-made default-world dataset (slow).

    SDOVON_EVAL_DATASET=/tmp/nav300/export/mjcf [SDOVON_EVAL_EPISODES=N] [SDOVON_EVAL_WIDTH=320] \
        pytest -m slow tests/test_nav_dataset.py -s

Without SDOVON_EVAL_DATASET a small default-world dataset is generated with the pipeline (one
apartment, two variants) into SDOVON_CACHE (reused by later runs). No margin here is taken from an
observed run: the test asserts orderings only. On any dataset, final navigation must help both A* agents
(without FN an agent stops where it detected the goal, which is within the success distance of a view point
only by chance). On a dataset of at least 300 episodes, Semantic A* must beat Random A*, and Random A* the
no-prior Semantic Frontier agent, in SR and in SPL (the issue's must-show; the table with 95 % bootstrap
intervals is printed). A small dataset is too small for the ranking to be decided, so it is printed only.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

from sdovon_mj.config import AgentConfig
from sdovon_mj.nav.agents import RandomAStar, SemanticAStar, SemanticFrontierAgent
from sdovon_mj.suite.evaluate import evaluate, overall_table, summarize
from sdovon_mj.suite import find_bundles, load_bundle

pytestmark = pytest.mark.slow

LARGE = 300
PRESET = Path(__file__).resolve().parents[1] / "sdovon_mj" / "presets" / "demo.yaml"


def _small_dataset() -> Path:
    """Generate (once, cached) a small default-world dataset with the pipeline; return its MJCF export."""
    from sdovon_mj.config import load_config
    from sdovon_mj.pipeline import generate

    root = Path(os.environ.get("SDOVON_CACHE", Path(tempfile.gettempdir()) / "sdovon_mj_cache")) / "nav_dataset_small"
    out = root / "export" / "mjcf"
    if not (out.exists() and any(out.rglob("episodes.json"))):
        cfg = load_config(PRESET, ["world.scene_seeds=[1]", "place.k_v=2", "episodes.k_e=2", "exporters=[mjcf]"])
        summary = generate(root, cfg, progress=False)
        assert not summary.failures, [f.error for f in summary.failures]
    return out


def _dataset() -> tuple[Path, int | None]:
    given = os.environ.get("SDOVON_EVAL_DATASET")
    if given:
        return Path(given), int(os.environ.get("SDOVON_EVAL_EPISODES", "0")) or None
    return _small_dataset(), None


def test_honest_baselines_rank_and_fn_helps_on_default_world():
    """FN helps both A* agents; with >= 300 episodes Semantic A* > Random A* > no-prior in SR and SPL."""
    root, limit = _dataset()
    total = sum(len(load_bundle(p).episodes) for p in find_bundles(root))
    n = total if limit is None else min(limit, total)
    w = int(os.environ.get("SDOVON_EVAL_WIDTH", "320"))
    body = AgentConfig(sensor_width=w, sensor_height=w * 3 // 4)
    out = {}
    for cls in (SemanticAStar, RandomAStar, SemanticFrontierAgent):
        for fn in ((True, False) if cls is not SemanticFrontierAgent else (True,)):
            res = evaluate(root, cls(seed=0, final_nav=fn, agent=body), episodes=n, progress=False)
            assert len(res) == n
            out[f"{cls.name}{'' if fn else ' no-FN'}"] = summarize(res)
    print(overall_table(out, paper=False))
    for name in ("random-astar", "semantic-astar"):
        assert out[name]["success"] > out[f"{name} no-FN"]["success"], out
    if n >= LARGE:
        sem, rnd, nop = out["semantic-astar"], out["random-astar"], out["semantic-frontier"]
        for k in ("success", "spl"):
            assert sem[k] > rnd[k] > nop[k], (k, out)
