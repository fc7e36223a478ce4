"""The lifelong evaluation (issue 50): a chain dataset's days run in order in one agent process per scene, sealed,
with a "new day" message between days that says nothing of what changed; the memory baselines keep their memory
across the days; a sequence broken by a crash records its remaining episodes as not run and never replays one.

One small default-world chain (tests/test_days.py's: one apartment, three categories, three days), exported as MJCF
bundles, is generated once for the module and every test reads it.
"""

from __future__ import annotations

import json
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from sdovon_mj.config import AgentConfig, NavConfig
from sdovon_mj.suite.bundle import find_bundles, load_bundle
from sdovon_mj.suite.evaluation.lifelong import HISTORIES, NOT_RUN, stale_stop
from sdovon_mj.suite.evaluation.loop import evaluate
from sdovon_mj.suite.evaluation.runner import agent_spec
from sdovon_mj.suite.evaluation.statistics import lifelong
from sdovon_mj.suite.evaluation.tables import lifelong_tables
from sdovon_mj.suite.protocol import NEW_DAY, AgentSpec
from test_days import DAYS, SMALL_DAYS

HERE = str(Path(__file__).resolve().parent)
BODY = AgentConfig(sensor_width=160, sensor_height=120)
NAV = NavConfig(max_steps=200)


@pytest.fixture(scope="module")
def chain(tmp_path_factory) -> tuple[Path, list[Path]]:
    """(run folder, the chain's day bundles in reverse day order: the evaluator must put them in order)."""
    folder = tmp_path_factory.mktemp("lifelong")
    cfg_file = folder / "days.yaml"
    cfg_file.write_text(yaml.safe_dump({**SMALL_DAYS, "exporters": ["mjcf"]}))
    proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "generate", "--out", str(folder / "run"), "--config",
                           str(cfg_file), "--jobs", "1", "--quiet"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    days = [p for p in find_bundles(folder / "run" / "export" / "mjcf" / "sdovon") if load_bundle(p).day is not None]
    assert len(days) == DAYS
    return folder / "run", days[::-1]


def _counter(**kw) -> AgentSpec:
    return AgentSpec("lifelong_agents:DayCounter", kw, paths=(HERE,))


def _in_day_order(days: list[Path]) -> list[str]:
    bundles = sorted((load_bundle(p) for p in days), key=lambda b: b.day)
    return [e.episode_id for b in bundles for e in b.episodes]


@pytest.mark.parametrize("name", ["semantic-astar-memory", "semantic-frontier-memory"])
def test_the_memory_agents_run_sealed_in_the_days_order_and_remember_across_days(chain, tmp_path, name):
    """Semantic A* and the frontier agent with object memory run the chain sealed end to end: the days in order
    (given in reverse), each day's episodes in order, one agent process for the scene (one set-up), one "new day"
    heard before each later day; each episode starts with the sightings the one before ended with (its memory
    survives the nights), and some later day starts with sightings it made on an earlier one. The lifelong tables
    print every day and history."""
    _run, days = chain
    kw = {"explore_steps": 300} if "astar" in name else {}
    res = evaluate(days, agent_spec(name, NAV, agent=BODY, **kw), nav=NAV, body=BODY, out=tmp_path, progress=False)
    assert [r["episode_id"] for r in res] == _in_day_order(days)
    assert [r["day"] for r in res] == sorted(r["day"] for r in res) and {r["day"] for r in res} == set(range(DAYS))
    assert all(r["mode"] == "sealed" and r["goal_history"] in HISTORIES and isinstance(r["stale_stop"], bool)
               for r in res)
    assert len({r["setup_seconds"] for r in res}) == 1  # one process served the scene's whole sequence
    mem = [r["info"]["object_memory"] for r in res]
    assert [m["days"] for m in mem] == [r["day"] for r in res]
    assert mem[0]["at_start"] == 0 and all(b["at_start"] == a["at_end"] for a, b in zip(mem, mem[1:]))
    assert any(m["at_start"] > 0 for m, r in zip(mem, res) if r["day"] > 0)
    md = lifelong_tables({name: res}, bootstrap=50)
    for d in range(DAYS):
        assert f"| {name} | {d} | " in md
    assert "Lifelong: by goal history" in md and "stale stops" in md


def test_the_new_day_message_is_the_same_bytes_whatever_changed(chain, monkeypatch):
    """Between days the sealed agent gets `NEW_DAY`, the same bytes on each night although the nights changed
    different objects; the agent's `new_day` hears each (its count is the episode's day). The whole export is
    evaluated: the scene's independent variant runs as usual, in a process of its own that hears no new day."""
    from sdovon_mj.runview import RunView
    from sdovon_mj.suite import protocol

    run, days = chain
    view = RunView(run)
    changes = [view.day_change(d).to_dict() for d in view.days("apt_0000")]
    assert changes[1]["moved"] != changes[2]["moved"] or changes[1]["left"] != changes[2]["left"]
    sent: list[bytes] = []
    real = protocol.SealedSession._send_raw

    def spy(self, data, deadline=None):
        try:
            if pickle.loads(data)[0] == "new_day":
                sent.append(bytes(data))
        except Exception:  # the set-up's JSON handshake
            pass
        return real(self, data, deadline)

    monkeypatch.setattr(protocol.SealedSession, "_send_raw", spy)
    res = evaluate(run / "export" / "mjcf" / "sdovon", _counter(), nav=NAV, body=BODY, progress=False)
    assert sent == [NEW_DAY] * (DAYS - 1) and pickle.loads(NEW_DAY) == ("new_day",)
    on_days = [r for r in res if "day" in r]
    assert len(on_days) == len(_in_day_order(days)) and [r["info"]["days"] for r in on_days] == [r["day"] for r in on_days]
    variant = [r for r in res if "day" not in r]
    assert variant and [r["info"] for r in variant] == [{"days": 0, "episodes": k + 1} for k in range(len(variant))]


def test_a_broken_sequence_is_recorded_not_replayed(chain, tmp_path, monkeypatch):
    """The agent crashes in its fifth episode: that one is an agent failure, every later one of the scene is recorded
    as not run (cause `NOT_RUN`, naming the crashed episode) and no agent process is started for them. A rerun starts no
    agent; with the last records removed, a resumed run records those as not run again (the scene's sequence was
    begun: its memory is gone), and still begins none of them."""
    import sdovon_mj.suite.evaluation.loop as E

    _run, days = chain
    real, started = E.open_session, []
    monkeypatch.setattr(E, "open_session", lambda *a, **k: started.append(1) or real(*a, **k))
    res = evaluate(days, _counter(crash_at=4), nav=NAV, body=BODY, out=tmp_path, progress=False)
    assert started == [1]  # the crashed process is not replaced for the episodes left unrun
    started.clear()
    n = len(res)
    assert n > 5 and [r["outcome"] for r in res[4:]] == ["agent failure"] + ["not run"] * (n - 5)
    assert not any(r.get("failure") for r in res[:4])
    assert res[4]["failure"]["cause"] == "crash"
    assert all(r["failure"]["cause"] == NOT_RUN and res[4]["episode_id"] in r["failure"]["message"] and r["steps"] == 0
               and r["success"] == 0 for r in res[5:])
    assert all(r["info"]["episodes"] == k + 1 for k, r in enumerate(res[:4]))  # one process, episodes in turn

    again = evaluate(days, _counter(crash_at=4), nav=NAV, body=BODY, out=tmp_path, progress=False)
    assert started == [] and [r["outcome"] for r in again] == [r["outcome"] for r in res]
    for r in res[n - 2:]:
        (tmp_path / "episodes" / "DayCounter" / f"{r['episode_id']}.json").unlink()
    third = evaluate(days, _counter(crash_at=4), nav=NAV, body=BODY, out=tmp_path, progress=False)
    assert [r["outcome"] for r in third] == [r["outcome"] for r in res]
    assert all("resumed" in r["failure"]["message"] and r["steps"] == 0 for r in third[n - 2:])
    saved = json.loads((tmp_path / "episodes" / "DayCounter" / f"{res[-1]['episode_id']}.json").read_text())
    assert saved["outcome"] == "not run"


def test_stale_stops_and_the_lifelong_groups():
    """A failed STOP is stale where the goal category rested on an earlier day within the radius and rests there no
    more; a STOP beside today's object, a success or no STOP is not. The lifelong figures group by day and history."""
    mug_then = {"mug": np.array([[1.0, 1.0, 0.8]])}
    mug_now = {"mug": np.array([[4.0, 1.0, 0.8]])}
    r = {"stop_called": True, "success": 0.0, "trajectory": [[0.0, 0.0], [1.5, 1.2]]}
    assert stale_stop(r, "mug", [mug_then], mug_now, 1.0)
    assert not stale_stop(r, "mug", [mug_then], mug_then, 1.0)  # still there: a missed stop, not a stale one
    assert not stale_stop(r, "mug", [mug_then], mug_now, 0.3)  # too far from where it was
    assert not stale_stop({**r, "success": 1.0}, "mug", [mug_then], mug_now, 1.0)
    assert not stale_stop({**r, "stop_called": False}, "mug", [mug_then], mug_now, 1.0)
    assert not stale_stop(r, "book", [mug_then], {}, 1.0)
    rows = [{"scene": "s", "variant": f"s_d{d}", "day": d, "goal_history": h, "success": s, "spl": s / 2,
             "stop_called": True, "stale_stop": st}
            for d, h, s, st in ((0, "new", 1.0, False), (1, "unmoved", 1.0, False), (1, "moved", 0.0, True),
                                (2, "moved", 0.0, False))]
    f = lifelong(rows, bootstrap=0)
    assert {d: g["episodes"] for d, g in f["days"].items()} == {0: 1, 1: 2, 2: 1}
    assert f["history"]["moved"]["success"] == 0.0 and f["history"]["unmoved"]["spl"] == 0.5
    assert f["stale_stops"] == {"count": 1, "share": 0.25, "of_failed_stops": 0.5}
