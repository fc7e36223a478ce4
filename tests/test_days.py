"""Days in a home (issue 49): a scene's chain of days by the habit model, its episodes, exports and statistics.

One small default-world chain (one apartment, three cheap categories, three days) is generated once for the module
and every test reads it; the resume test reruns its chain (killed with SIGKILL, then resumed on two workers).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from sdovon_mj.config import ConfigError, RunConfig, day_rates, load_config, to_dict
from sdovon_mj.records import MOVED, NEW, UNMOVED
from sdovon_mj.runview import RunView
from sdovon_mj.stats import day_statistics, poisson_binomial_interval

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
from run_digests import run_digests  # noqa: E402

DAYS = 3
# The smallest default-world run of tests/test_stage_contract.py, with a third category and two objects per plane so
# that the chain has a few dozen object-days.
SMALL_DAYS = {
    "world": {"scene_seeds": [0], "floors": 1, "object_variants": 1, "object_categories": ["apple", "book", "mug"]},
    "observe": {"width": 160, "height": 120, "yaw_steps": 4, "pitch_angles": [-30.0]},
    "place": {"k_v": 1, "m": 2, "days": DAYS},
    "episodes": {"k_e": 1},
    "exporters": ["habitat", "mjcf"],
}


def _generate(run: Path, cfg_file: Path, jobs: int, *more: str, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "sdovon_mj.cli", "generate", "--out", str(run), "--config",
                             str(cfg_file), "--jobs", str(jobs), "--quiet", *more], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


@pytest.fixture(scope="module")
def chain(tmp_path_factory) -> tuple[Path, Path]:
    """(run folder, config file) of the small chain, generated on one worker."""
    folder = tmp_path_factory.mktemp("days")
    cfg_file = folder / "days.yaml"
    cfg_file.write_text(yaml.safe_dump(SMALL_DAYS))
    proc = _generate(folder / "run", cfg_file, 1)
    _, err = proc.communicate()
    assert proc.returncode == 0, err[-3000:]
    return folder / "run", cfg_file


def _chain(run: Path):
    view = RunView(run)
    days = view.days("apt_0000")
    return view, days, [view.day_change(d) for d in days]


def test_days_are_quiet_in_the_config_and_checked():
    assert "days" not in to_dict(RunConfig())["place"]  # runs without days keep their config bytes and fingerprints
    assert to_dict(load_config(None, ["place.days=2"]))["place"]["days"] == 2
    with pytest.raises(ConfigError, match="day_rates"):
        load_config(None, ["place.day_rates=['mug: 0.9 0.5']"])
    with pytest.raises(ConfigError, match="day_rates"):
        load_config(None, ["place.day_rates=['mug 0.1 0.1']"])
    assert day_rates(RunConfig().place)["book"][0] < day_rates(RunConfig().place)["mug"][0]  # books stay longer


def test_poisson_binomial_interval_is_the_binomial_one_for_equal_rates():
    from scipy.stats import binom

    for n, p in ((58, 0.17), (200, 0.05), (30, 0.5)):
        assert poisson_binomial_interval([p] * n) == tuple(int(x) for x in binom.interval(0.999, n, p))


def test_identities_persist_and_each_day_says_what_changed(chain):
    run, _ = chain
    view, days, changes = _chain(run)
    assert [d.day for d in days] == list(range(DAYS)) and [c.day for c in changes] == list(range(DAYS))
    assert sorted(changes[0].arrived) == sorted(p.object_id for p in days[0].placements)
    ever: dict[str, tuple[str, str]] = {}  # object id -> (asset, category) the first time it was seen
    for prev, day, ch in zip(days, days[1:], changes[1:]):
        before = {p.object_id: p for p in prev.resting}
        moved = {m.object_id for m in ch.moved}
        drawn = set(ch.stayed) | moved | set(ch.left)
        assert drawn == set(before) and len(ch.stayed) + len(moved) + len(ch.left) == len(before)  # a partition
        assert ch.previous == len(before)
        now = {p.object_id: p for p in day.resting}
        assert set(now) == (drawn - set(ch.left) | set(ch.arrived)) - set(ch.dropped)
        assert not set(ch.arrived) & set(ever) and not set(ch.arrived) & set(before)  # ids are never reused
        for oid, p in now.items():
            if oid in before:
                assert (p.asset, p.category) == (before[oid].asset, before[oid].category)
            if oid in ch.stayed and oid not in ch.resettled:
                assert np.array_equal(p.settled_pos, before[oid].settled_pos)
                assert np.array_equal(p.settled_quat, before[oid].settled_quat)
                assert p.plane_id == before[oid].plane_id
            if oid in moved:
                m = next(m for m in ch.moved if m.object_id == oid)
                assert p.plane_id == m.to_plane != m.from_plane == before[oid].plane_id
        for d in (prev, day):
            for p in d.placements:
                ever.setdefault(p.object_id, (p.asset, p.category))
                assert ever[p.object_id] == (p.asset, p.category)
    assert sum(len(c.moved) for c in changes[1:]) > 0 and sum(len(c.stayed) for c in changes[1:]) > 0


def test_every_day_passes_the_variant_checks(chain):
    from sdovon_mj.place import check_variant
    from sdovon_mj.place.check import PENETRATION_TOL

    run, _ = chain
    view, days, changes = _chain(run)
    planes = view.planes("apt_0000")
    for day, ch in zip(days, changes):
        check = check_variant(day, planes, run)
        resting = {p.object_id for p in day.resting}
        assert resting and all(o.ok for o in check.objects if o.object_id in resting), \
            [(o.object_id, o.reason) for o in check.objects if o.object_id in resting and not o.ok]
        assert check.max_penetration <= PENETRATION_TOL
        not_resting = {p.object_id for p in day.placements if p.status != "resting"}
        assert not_resting <= set(ch.dropped)  # nothing falls out of the record silently


def test_observed_changes_lie_within_the_intervals_of_the_configured_rates(chain):
    run, cfg_file = chain
    view, days, changes = _chain(run)
    cfg = load_config(cfg_file).place
    table = day_rates(cfg)
    rates: dict[str, list[float]] = {"moved": [], "left": [], "arrived": []}
    seen = {"moved": 0, "left": 0, "arrived": 0}
    for prev, ch in zip(days, changes[1:]):
        for p in prev.resting:  # the configured rates of each object-day, from the config and the category
            move, leave = table.get(p.category, (cfg.day_move, cfg.day_leave))
            rates["moved"].append(move)
            rates["left"].append(leave)
            rates["arrived"].append(cfg.day_arrive)
        seen["moved"] += len(ch.moved)
        seen["left"] += len(ch.left)
        seen["arrived"] += len(ch.arrived)
    for k, rs in rates.items():
        lo, hi = poisson_binomial_interval(rs, 0.999)
        assert lo <= seen[k] <= hi, (k, seen[k], lo, hi)
    stats = day_statistics(run)
    assert {k: v["observed"] for k, v in stats["rates"].items()} == seen
    assert all(v["within"] for v in stats["rates"].values())


def test_moves_follow_the_placement_prior(chain):
    run, _ = chain
    view, days, changes = _chain(run)
    planes = view.planes("apt_0000")
    rel = view.relevance("apt_0000")
    index = {p.id: k for k, p in enumerate(planes)}
    to, everywhere = [], []
    for ch in changes[1:]:
        for m in ch.moved:
            if m.to_plane < 0:
                continue
            w = rel.plane_relevance(m.category, planes)
            to.append(w[index[m.to_plane]])
            everywhere.append(w.mean())
    assert to and np.mean(to) > np.mean(everywhere)
    prior = day_statistics(run)["prior"]
    assert prior["mean_relevance_moved_to"] == pytest.approx(np.mean(to), abs=1e-4)


def test_episodes_of_a_day_label_their_goals_by_history(chain):
    run, _ = chain
    view, days, changes = _chain(run)
    labels = set()
    for day, ch in zip(days, changes):
        eps = view.episodes(day)
        assert eps and all(e.day == day.day and e.variant == day.name for e in eps)
        moved = {m.object_id for m in ch.moved}
        for e in eps:
            for g in e.goals:
                want = NEW if day.day == 0 or g.object_id in ch.arrived else MOVED if g.object_id in moved else UNMOVED
                assert g.history == want
                labels.add(g.history)
    assert {UNMOVED, NEW} <= labels
    for v in view.variants("apt_0000"):  # independent variants stay as they were
        assert v.day is None and all(e.day is None for e in view.episodes(v))


def test_habitat_export_carries_the_days(chain, tmp_path):
    import gzip

    run, _ = chain
    view, days, changes = _chain(run)
    root = run / "export" / "habitat"
    content = root / "data" / "datasets" / "objectnav" / "sdovon" / "val" / "content"
    for day, ch in zip(days, changes):
        assert (root / "data" / "scene_datasets" / "sdovon" / "scenes" / f"{day.name}.scene_instance.json").is_file()
        doc = json.loads(gzip.decompress((content / f"{day.name}.json.gz").read_bytes()))
        assert doc["episodes"] and all(e["info"]["day"] == day.day for e in doc["episodes"])
        hist = {k: v for e in doc["episodes"] for k, v in e["info"]["goal_history"].items()}
        assert set(hist.values()) <= {UNMOVED, MOVED, NEW} and (day.day > 0 or set(hist.values()) == {NEW})
    for v in view.variants("apt_0000"):
        doc = json.loads(gzip.decompress((content / f"{v.name}.json.gz").read_bytes()))
        assert all("day" not in e["info"] for e in doc["episodes"])
    import habitat_lab_env

    py = habitat_lab_env.cached_python()
    if py is None:  # `./run.sh test` builds it first; under CI=true a skip fails the run (tests/conftest.py)
        pytest.skip(f"habitat-lab venv not built at {habitat_lab_env.venv_dir()}: run `python tests/habitat_lab_env.py`")
    from test_export_habitat_lab import CLIENT

    client = CLIENT[:CLIENT.index("import numpy as np")] + HABITAT_DAYS
    (tmp_path / "client.py").write_text(client)
    r = subprocess.run([str(py), str(tmp_path / "client.py"), str(tmp_path / "res.json")], cwd=root,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads((tmp_path / "res.json").read_text())
    n = sum(len(view.episodes(v)) for v in view.dataset_variants("apt_0000"))
    assert len(res["episodes"]) == n and not res["missing"]
    by_day: dict[int, set[str]] = {}
    for scene, day in res["episodes"]:
        if day is not None:
            by_day.setdefault(day, set()).add(Path(scene).name)
    assert by_day == {d.day: {f"{d.name}.scene_instance.json"} for d in days}  # a scene instance per day


# habitat-lab (stubbed simulator, as in tests/test_export_habitat_lab.py) loads the dataset; each episode's scene
# instance and day as it reads them.
HABITAT_DAYS = r'''
import habitat
from omegaconf import OmegaConf
from habitat.config.default_structured_configs import DatasetConfig
from habitat.datasets.object_nav.object_nav_dataset import ObjectNavDatasetV1

dp = "data/datasets/objectnav/sdovon/{split}/{split}.json.gz"
cfg = OmegaConf.structured(DatasetConfig(type="ObjectNav-v1", split="val", data_path=dp, scenes_dir="data/scene_datasets"))
ds = ObjectNavDatasetV1(cfg)
out = {"episodes": [[ep.scene_id, (ep.info or {}).get("day")] for ep in ds.episodes],
       "missing": [ep.scene_id for ep in ds.episodes if not os.path.isfile(ep.scene_id) or not ep.goals]}
json.dump(out, open(sys.argv[1], "w"))
'''


def test_mjcf_bundles_carry_the_day_and_load_from_any_folder(chain, tmp_path):
    import mujoco

    from sdovon_mj.suite.bundle import load_bundle

    run, _ = chain
    view, days, _changes = _chain(run)
    moved = tmp_path / "elsewhere" / "dataset"
    shutil.copytree(run / "export" / "mjcf" / "sdovon", moved)
    names = [d.name for d in days]
    index = json.loads((moved / "index.json").read_text())
    assert [r["day"] for r in index["bundles"] if "day" in r] == list(range(DAYS))
    cwd = os.getcwd()
    os.chdir(tmp_path)  # neither the run folder nor the original export is reachable by a relative path
    try:
        for k, d in enumerate(days):
            b = load_bundle(moved / d.name)
            assert b.day == k and b.sequence["days"] == names
            assert b.sequence["previous"] == (names[k - 1] if k else "") and b.sequence["next"] == (
                names[k + 1] if k + 1 < DAYS else "")
            assert all(e.day == k and all(g.history for g in e.goals) for e in b.episodes)
            model = mujoco.MjModel.from_xml_path(str(b.mjcf))
            assert all(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.object_id) >= 0 for p in d.resting)
        v = load_bundle(moved / view.variants("apt_0000")[0].name)
        assert v.day is None and v.sequence == {}
    finally:
        os.chdir(cwd)


def test_show_stats_prints_what_moved_per_day_and_where(chain, capsys):
    from sdovon_mj.cli import main

    run, _ = chain
    view, days, changes = _chain(run)
    assert main(["show", str(run), "--stats"]) == 0
    out = capsys.readouterr().out
    assert "Days: what changed overnight" in out and "Moves by receptacle" in out and "Moves by region" in out
    pairs: dict[str, int] = {}
    for ch in changes[1:]:
        for m in ch.moved:
            if m.to_plane >= 0:
                pairs[f"{m.from_region} -> {m.to_region}"] = pairs.get(f"{m.from_region} -> {m.to_region}", 0) + 1
    region_part = out.split("Moves by region")[1]
    for k, n in pairs.items():
        assert f"{n:>5}  {k}" in region_part
    from sdovon_mj.stats import dataset_statistics, summary_table

    moved = sum(len(c.moved) for c in changes[1:])
    assert any(line.split()[:2] == ["moved", "overnight"] and line.split()[-1] == str(moved)
               for line in summary_table(dataset_statistics(run)).splitlines())  # generate's closing table


@pytest.mark.slow
def test_a_chain_killed_with_sigkill_resumes_to_the_same_bytes_on_two_workers(chain, tmp_path):
    run, cfg_file = chain
    ref = run_digests(run)
    copy = tmp_path / "run"
    shutil.copytree(run, copy, symlinks=True)
    for p in copy.glob("scenes/*/days"):
        shutil.rmtree(p)
    # The exports are not rerun (their bytes follow from the records, as other tests show): the chain's records,
    # models and stage markers are what this test compares, with every other file of scenes/.
    no_export = ("--set", "exporters=[]")
    proc = _generate(copy, cfg_file, 2, *no_export, start_new_session=True)
    first = copy / "scenes" / "apt_0000" / "days" / "apt_0000_d001" / "day" / ".done.json"
    t0 = time.monotonic()
    while not first.exists() and proc.poll() is None and time.monotonic() - t0 < 600:
        time.sleep(0.05)
    assert proc.poll() is None, "the chain finished before it could be killed"
    os.killpg(proc.pid, signal.SIGKILL)  # the generate process and its workers, mid-chain
    proc.communicate()
    last = copy / "scenes" / "apt_0000" / "days" / f"apt_0000_d{DAYS - 1:03d}" / "day_episodes" / ".done.json"
    assert not last.exists()
    again = _generate(copy, cfg_file, 2, *no_export)
    _, err = again.communicate()
    assert again.returncode == 0, err[-3000:]
    scenes = lambda d: {k: v for k, v in d.items() if k.startswith("scenes/")}  # noqa: E731
    ref, got = scenes(ref), scenes(run_digests(copy))
    differ = sorted(k for k in ref.keys() | got.keys() if ref.get(k) != got.get(k))
    assert not differ, differ[:20]
    assert sum("/days/" in k for k in ref) >= 6 * DAYS


def test_days_keys_leave_the_variants_and_earlier_days_alone(tmp_path):
    from sdovon_mj import stages
    from sdovon_mj.store import Store

    store = Store(tmp_path)
    store.write_json("inputs.json", {"scenes": [], "objects": []})

    def fp(stage: str, cfg: RunConfig, day: int = -1) -> str:
        return stages.stage_fingerprint(stages.STAGES[stage], stages.StageContext(store, cfg, "apt_0000", 0, day=day))

    off, three, five = RunConfig(), load_config(None, ["place.days=3"]), load_config(None, ["place.days=5"])
    rates = load_config(None, ["place.days=3", "place.day_move=0.5"])
    assert fp("place", off) == fp("place", three) == fp("place", rates)  # days on: the variants stay done
    assert fp("day", three, 1) == fp("day", five, 1) != fp("day", rates, 1)  # a longer chain keeps its days
    assert fp("place", off) != fp("place", load_config(None, ["place.m=5"]))  # what it reads still counts
