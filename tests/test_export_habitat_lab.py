"""habitat-lab as a real client of our Habitat export (its own venv; research/habitat_format.md section 4).

habitat-lab 0.3.3 runs in a venv of its own (tests/habitat_lab_env.py; `./run.sh test` builds or reuses it
before pytest, so CI runs this test on a clean clone). habitat-sim is not on PyPI, so `magnum`,
`habitat_sim` and `corrade` are stubbed by an import hook; dataset loading, config and the metric
Measures are habitat-lab's own code.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.export import ExportOptions, RunView, run_export
from exporters.habitat import HabitatExporter
from sdovon_mj import metrics as M
from support.run_folder import build_sample_run
from sdovon_mj.records import Episode, load_json

import habitat_lab_env

CLIENT = r'''
import importlib.abc, importlib.machinery, json, os, sys, types
from unittest.mock import MagicMock

class _Meta(type):
    def __getattr__(cls, name):
        return MagicMock(name=f"{cls.__name__}.{name}")

class _Stub(types.ModuleType):
    __path__ = []
    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        body = {"__init__": lambda self, *a, **k: None, "__getattr__": lambda self, n: MagicMock(name=n)}
        val = _Meta(name, (), body) if name[:1].isupper() else MagicMock(name=name)
        setattr(self, name, val)
        return val

class _Finder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, fullname, path, target=None):
        if fullname.split(".")[0] in ("magnum", "habitat_sim", "corrade"):
            return importlib.machinery.ModuleSpec(fullname, self, is_package=True)
        return None
    def create_module(self, spec):
        return _Stub(spec.name)
    def exec_module(self, module):
        pass

sys.meta_path.insert(0, _Finder())
import numpy as np
import habitat
from omegaconf import OmegaConf
from habitat.config.default_structured_configs import DatasetConfig
from habitat.datasets.object_nav.object_nav_dataset import ObjectNavDatasetV1
from habitat.core.embodied_task import Measurements
from habitat.tasks.nav.nav import DistanceToGoal, Success, SPL, SoftSPL

req = json.load(open(sys.argv[1]))
name = req["name"]
out = {"version": habitat.__version__}
dp = f"data/datasets/objectnav/{name}/{{split}}/{{split}}.json.gz"
cfg = OmegaConf.structured(DatasetConfig(type="ObjectNav-v1", split="val", data_path=dp, scenes_dir="data/scene_datasets"))
ds = ObjectNavDatasetV1(cfg)
out["n_direct"] = len(ds.episodes)
out["scenes_to_load"] = ObjectNavDatasetV1.get_scenes_to_load(cfg)
bad = []
for ep in ds.episodes:
    if ep.goals_key not in ds.goals_by_category or not ep.goals:
        bad.append(("goals", ep.goals_key))
    if not os.path.isfile(ep.scene_id):
        bad.append(("scene_id", ep.scene_id))
    if not os.path.isfile(ep.scene_dataset_config):
        bad.append(("scene_dataset_config", ep.scene_dataset_config))
    if not all(vp.agent_state.rotation is not None for g in ep.goals for vp in g.view_points):
        bad.append(("rotation", ep.goals_key))
out["bad"] = bad
out["goals_keys"] = sorted(ds.goals_by_category)
from habitat.config.default import get_config
c = get_config("benchmark/nav/objectnav/objectnav_hm3d.yaml",
               overrides=[f"habitat.dataset.data_path='{dp}'", "habitat.dataset.split=val",
                          "habitat.dataset.scenes_dir=data/scene_datasets"])
ds2 = habitat.datasets.make_dataset(c.habitat.dataset.type, config=c.habitat.dataset)
out["n_benchmark"] = len(ds2.episodes)
out["benchmark_success_distance"] = float(c.habitat.task.measurements.success.success_distance)

class Sim:
    pos = np.zeros(3)
    def get_agent_state(self):
        return types.SimpleNamespace(position=self.pos)
    def geodesic_distance(self, a, bs, episode=None):
        b = np.asarray(bs, dtype=float).reshape(-1, 3)
        return float(np.min(np.linalg.norm(b - np.asarray(a, dtype=float), axis=1)))

results = []
for tr in req["trajectories"]:
    ep = ds.episodes[tr["episode"]]
    sim = Sim()
    sim.pos = np.array(tr["positions"][0], dtype=float)
    task = types.SimpleNamespace(is_stop_called=False)
    task.add_perf_timing = lambda *a, **k: None
    dtg = DistanceToGoal(sim=sim, config=OmegaConf.create({"distance_to": "VIEW_POINTS"}))
    succ = Success(sim=sim, config=OmegaConf.create({"success_distance": req["success_distance"]}))
    spl = SPL(sim=sim, config=OmegaConf.create({}))
    soft = SoftSPL(sim=sim, config=OmegaConf.create({}))
    task.measurements = Measurements([dtg, succ, spl, soft])
    task.measurements.reset_measures(episode=ep, task=task)
    for i, p in enumerate(tr["positions"][1:]):
        sim.pos = np.array(p, dtype=float)
        if tr["stop"] and i == len(tr["positions"]) - 2:
            task.is_stop_called = True
        task.measurements.update_measures(episode=ep, action=None, task=task)
    m = task.measurements.get_metrics()
    results.append({k: float(m[k]) for k in ("distance_to_goal", "success", "spl", "soft_spl")})
out["metrics"] = results
json.dump(out, open(sys.argv[2], "w"))
'''


def _yup(p) -> list[float]:
    return [float(p[0]), float(p[2]), float(-p[1])]


def _trajectories(eps: list[Episode]) -> list[dict]:
    """Synthetic trajectories in the MuJoCo frame: straight+stop, no stop, detour, halfway, near misses."""
    out = []
    for k, e in enumerate(eps[:3]):
        vps = np.array([vp.position for g in e.goals for vp in g.view_points])
        s = np.asarray(e.start_position, float)
        tgt = vps[np.argmin(np.linalg.norm(vps - s, axis=1))]
        side = np.array([0.0, 0.0, 0.0]) + np.cross(tgt - s, [0, 0, 1]) * 0.6
        out += [
            {"episode": k, "positions": list(np.linspace(s, tgt, 9)), "stop": True},
            {"episode": k, "positions": list(np.linspace(s, tgt, 5)), "stop": False},
            {"episode": k, "positions": [s, s + side, tgt], "stop": True},
            {"episode": k, "positions": [s, (s + tgt) / 2], "stop": True},
            {"episode": k, "positions": [s, tgt + [0.09, 0, 0]], "stop": True},
            {"episode": k, "positions": [s, tgt + [0.0, 0.11, 0]], "stop": True},
        ]
    return out


def _check(py: Path, tmp: Path) -> None:
    run_dir = build_sample_run(tmp / "run", episodes=True, seed=0)
    out = tmp / "export"
    run_export(HabitatExporter(), RunView(run_dir), out, ExportOptions(name="sdovon", split="val"))
    eps = load_json(run_dir / "scenes/room/variants/room_v000/episodes.json", Episode)
    trajs = _trajectories(eps)
    req = {"name": "sdovon", "success_distance": 0.1,
           "trajectories": [{**t, "positions": [_yup(p) for p in t["positions"]]} for t in trajs]}
    (tmp / "req.json").write_text(json.dumps(req))
    (tmp / "client.py").write_text(CLIENT)
    r = subprocess.run([str(py), str(tmp / "client.py"), str(tmp / "req.json"), str(tmp / "res.json")], cwd=out,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads((tmp / "res.json").read_text())
    assert res["n_direct"] == len(eps) == res["n_benchmark"]
    assert res["bad"] == []
    assert res["scenes_to_load"] == ["room_v000"]  # content file stems
    assert res["goals_keys"] == ["room_v000.scene_instance.json_ball", "room_v000.scene_instance.json_mug"]
    assert res["benchmark_success_distance"] == 0.1
    for t, hm in zip(trajs, res["metrics"]):
        e = eps[t["episode"]]
        vps = np.array([vp.position for g in e.goals for vp in g.view_points])
        ours = M.episode_metrics(t["positions"], vps, t["stop"], success_distance=0.1)
        # habitat-lab rounds nothing, but our export writes 6 decimals: compare to 1e-5.
        assert hm["distance_to_goal"] == pytest.approx(ours.distance_to_goal, abs=1e-5)
        assert hm["success"] == ours.success
        assert hm["spl"] == pytest.approx(ours.spl, abs=1e-5)
        assert hm["soft_spl"] == pytest.approx(ours.soft_spl, abs=1e-5)
    kinds = {(m["success"], round(m["spl"], 3)) for m in res["metrics"]}
    assert (1.0, 1.0) in kinds and (0.0, 0.0) in kinds and any(0 < m["spl"] < 1 for m in res["metrics"])


def test_habitat_lab_loads_export_and_agrees_on_metrics(tmp_path):
    py = habitat_lab_env.cached_python()
    if py is None:  # `./run.sh test` builds it first; under CI=true a skip fails the run (tests/conftest.py)
        pytest.skip(f"habitat-lab venv not built at {habitat_lab_env.venv_dir()}: run `python tests/habitat_lab_env.py`")
    _check(py, tmp_path)
