"""The A* baselines on a pipeline-made default-world dataset (issue 10's must-show; slow).

    SDOVON_EVAL_DATASET=/tmp/nav200/export/mjcf [SDOVON_EVAL_EPISODES=N] [SDOVON_EVAL_WIDTH=320] \
        pytest -m slow tests/test_nav_dataset.py -s

Without SDOVON_EVAL_DATASET a small default-world dataset is generated with the pipeline (one
apartment, two variants) into SDOVON_CACHE (reused by later runs). Margins: on a dataset of at least
200 episodes Semantic A* beats Random A* by >= 0.08 SR and >= 0.10 SPL, and FN adds >= 0.30 SR to
both agents; on the small generated dataset (too few episodes for the ranking to be stable) only
the FN margins are asserted, with a looser 0.2.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

from sdovon_mj.config import AgentConfig
from sdovon_mj.nav.agents import RandomAStar, SemanticAStar
from sdovon_mj.suite.evaluate import evaluate, summarize
from sdovon_mj.suite import find_bundles, load_bundle

pytestmark = pytest.mark.slow

LARGE = 200
SR_MARGIN, SPL_MARGIN, FN_MARGIN, FN_MARGIN_SMALL = 0.08, 0.10, 0.30, 0.2
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


def test_semantic_beats_random_and_fn_helps_on_default_world():
    """Semantic A* > Random A* on SR and SPL (>= 200 episodes) and FN raises both agents' SR."""
    root, limit = _dataset()
    total = sum(len(load_bundle(p).episodes) for p in find_bundles(root))
    n = total if limit is None else min(limit, total)
    w = int(os.environ.get("SDOVON_EVAL_WIDTH", "320"))
    body = AgentConfig(sensor_width=w, sensor_height=w * 3 // 4)
    out = {}
    for cls in (SemanticAStar, RandomAStar):
        for fn in (True, False):
            res = evaluate(root, cls(seed=0, final_nav=fn, agent=body), episodes=n, progress=False)
            assert len(res) == n
            out[(cls.name, fn)] = summarize(res)
    for (name, fn), s in out.items():
        print(f"{name:15s} FN={fn!s:5s} n={s['episodes']} SR={s['success']:.3f} SPL={s['spl']:.3f} "
              f"SoftSPL={s['soft_spl']:.3f} DTG={s['distance_to_goal']:.2f}")
    r, s = out[("random-astar", True)], out[("semantic-astar", True)]
    fn_margin = FN_MARGIN if n >= LARGE else FN_MARGIN_SMALL
    for name in ("random-astar", "semantic-astar"):
        assert out[(name, True)]["success"] >= out[(name, False)]["success"] + fn_margin, (name, out)
    if n >= LARGE:
        assert s["success"] >= r["success"] + SR_MARGIN, out
        assert s["spl"] >= r["spl"] + SPL_MARGIN, out
    assert s["success"] > 0.3, out  # the baselines find goals on real default-world data
