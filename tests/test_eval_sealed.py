"""The sealed evaluation (issue 30): adversarial agents written only against the protocol (tests/adversaries.py,
never imported here: the evaluator builds them in their own process) learn nothing a robot could not know.

- an agent that steers by any reward gets none: its episodes are the blind random walk's, step for step;
- an agent that declares no prior gets no first visit and no call before its episodes, and nothing it is handed
  holds an environment;
- an agent that walks everything reachable (attributes, closures, containers, gc referents, its module's globals,
  then its process's whole heap) finds no generator object and no id -> label table (in-process, the same walker
  finds them: the walk can fail);
- an agent that scans the disk cannot open the dataset's files nor the evaluator's /proc entries when Landlock
  seals its process (unsealed, it reads them; where Landlock is unavailable the tables say the file system was not
  sealed);
- a declared oracle gets the parts it declared and `KnowledgeError` for the others.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.config import AgentConfig, NavConfig
from sdovon_mj.suite import landlock
from sdovon_mj.suite.evaluation.loop import evaluate
from sdovon_mj.suite.evaluation.statistics import summarize
from sdovon_mj.suite.evaluation.tables import outcome_table, overall_table
from sdovon_mj.suite.protocol import AgentSpec
from support.bundles import fixture_bundle

HERE = str(Path(__file__).resolve().parent)
SMALL = AgentConfig(sensor_width=32, sensor_height=24)
NAV = NavConfig(max_steps=80)


def spec(name: str, **kw) -> AgentSpec:
    """Name an adversary of tests/adversaries.py (built in the agent's process only)."""
    return AgentSpec(f"adversaries:{name}", kw, paths=(HERE,))


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """The fixture apartment (one variant) in a folder of this test module."""
    return fixture_bundle(tmp_path_factory.mktemp("sealed"), variants=1, seed=5)


def _run(dataset, agent, episodes=3, **kw):
    return evaluate(dataset, agent, nav=NAV, episodes=episodes, progress=False, body=SMALL, **kw)


def test_an_agent_steering_by_the_reward_gets_none(dataset):
    """The dm_control environment keeps its dense reward (generator knowledge, for training): a reward-steering walker
    on it sees non-zero rewards. Through the evaluation it sees none, no extra observation key, and every episode
    is the blind walker's, trajectory for trajectory (so its SR is a blind agent's)."""
    from sdovon_mj.suite import make_environment

    env = make_environment(dataset / "fixture_apartment_v000", nav=NAV, agent=SMALL)
    env.task.render_frames = False
    ts, rewards = env.reset(), []
    for _ in range(20):
        ts = env.step(1)  # MOVE_FORWARD: where it moves, the geodesic to the goal changes
        rewards.append(ts.reward)
    env.task.close()
    assert any(r for r in rewards), "the environment's reward should carry the geodesic signal"

    steer = _run(dataset, spec("RewardSteerer"), episodes=4)
    blind = _run(dataset, spec("Blind"), episodes=4)
    for s, b in zip(steer, blind):
        assert s["info"]["rewards_seen"] == 0 and s["info"]["extra_keys"] == []
        assert s["trajectory"] == b["trajectory"] and s["success"] == b["success"]
    assert "adversaries" not in sys.modules  # the evaluator never imported the agents' code


def test_an_agent_without_prior_gets_no_environment_before_its_episodes(dataset, tmp_path):
    """prior="none": no first visit (no exploration record), no call before its first episode, and nothing it is
    handed (sensors, the phase's view) names an environment, a bundle or a task; every action it was asked for
    belongs to an episode."""
    res = _run(dataset, spec("NoPriorPeeker"), episodes=3, out=tmp_path)
    assert not (tmp_path / "exploration").exists()
    for r in res:
        info = r["info"]
        assert info["explored"] is False and info["calls_before_episodes"] == 0 and info["handles"] == []
        assert r["first_visit"] is None
    assert res[-1]["info"]["acts"] == sum(r["steps"] for r in res)  # one act per episode step, nothing else


def test_a_walker_finds_no_generator_object_sealed_and_finds_them_in_process(dataset):
    """Sealed: nothing of the evaluator's process is in the agent's (no Bundle, task, physics, navmap, geodesic field,
    episode, goal, relevance, region map; no id -> label table). In-process the same walk finds them, whatever the
    process imported before (torch and transformers here, as earlier tests of a worker do: a depth-first walk spent
    its cap in their modules and missed them)."""
    pytest.importorskip("torch")
    transformers = pytest.importorskip("transformers")
    transformers.AutoModel  # noqa: B018 - loads the lazily imported model modules as a model's use does
    sealed = _run(dataset, spec("Walker"), episodes=1)[0]
    assert sealed["mode"] == "sealed" and sealed["info"]["walked"] > 1000
    assert sealed["info"]["found"] == [] and sealed["info"]["label_tables"] == 0, sealed["info"]
    inproc = _run(dataset, spec("Walker"), episodes=1, mode="in-process")[0]
    assert {"Bundle", "ObjectNavTask", "Episode", "Goal", "NavMap"} <= set(inproc["info"]["found"])
    assert inproc["info"]["label_tables"] > 0
    assert "in-process" in overall_table({"walker": summarize([inproc], bootstrap=0)})


def test_a_disk_scanning_agent_cannot_read_the_dataset(dataset):
    """Sealed by Landlock: opening the dataset's files (the agent was told where they are) and the evaluator's
    /proc/<pid>/cmdline, environ and mem raises PermissionError, a walk of the file system finds no readable
    episode file, and it can leave no note in /dev/shm or the embedding cache (nothing it writes outlives it). Unsealed (the control) it reads them, and the table says the file system was not sealed."""
    variant = dataset / "fixture_apartment_v000"
    files = tuple(str(variant / f) for f in ("episodes.json", "oracle/navmap.json", "oracle/object_labels.json"))
    r = _run(dataset, spec("DiskScanner", paths=files), episodes=1)[0]
    if landlock.abi_version() > 0:
        assert r["sealed"] and "sealed (Landlock ABI" in r["seal"]
        assert all(v == "denied" for v in r["info"]["tried"].values()), r["info"]["tried"]
        assert r["info"]["episode_files_readable"] == []
        # nothing it writes outlives it: no note in /dev/shm nor in the shared embedding cache
        assert r["info"]["notes"]["shm"] == "denied" and r["info"]["notes"]["embedding_cache"] != "written"
    else:
        assert not r["sealed"] and "NOT sealed" in overall_table({"scanner": summarize([r], bootstrap=0)})
    open_ = _run(dataset, spec("DiskScanner", paths=files, walk_dirs=0), episodes=1, seal=False)[0]
    assert not open_["sealed"] and all(open_["info"]["tried"][f] == "read" for f in files)
    assert open_["info"]["notes"]["shm"] == "written"
    assert "file system not sealed" in overall_table({"scanner": summarize([open_], bootstrap=0)})


def test_a_declared_oracle_gets_its_parts_and_no_other(dataset):
    """The oracle agent (navmap + view points declared) succeeds sealed; an agent reading an undeclared part gets
    KnowledgeError (recorded as the episode's failure, with the agent's traceback)."""
    from sdovon_mj.suite.evaluation.runner import agent_spec

    res = _run(dataset, agent_spec("oracle", NavConfig(), agent=SMALL), episodes=2)
    assert all(r["success"] == 1.0 and r["oracle"] and "ORACLE: navmap, view_points" in r["knowledge"] for r in res)
    half = _run(dataset, spec("HalfOracle"), episodes=1)[0]  # its error is the episode's recorded failure
    assert half["failure"]["cause"] == "crash" and re.search("KnowledgeError.*relevance", half["failure"]["message"])


def test_landlock_seals_a_process_to_its_allow_list(tmp_path):
    """`landlock.restrict` in a child process: the allowed tree is readable, a sibling is not (or, without Landlock,
    the seal says it is unavailable)."""
    import subprocess

    (tmp_path / "ok").mkdir()
    (tmp_path / "ok" / "a.txt").write_text("a")
    (tmp_path / "secret").mkdir()
    (tmp_path / "secret" / "b.txt").write_text("b")
    code = ("import json, sys; from sdovon_mj.suite.landlock import restrict; "
            f"s = restrict(list(sys.path) + ['/usr', '/lib', '/lib64', '/etc', {str(tmp_path / 'ok')!r}], []); "
            "out = {'sealed': s.sealed}\n"
            f"for p in ({str(tmp_path / 'ok' / 'a.txt')!r}, {str(tmp_path / 'secret' / 'b.txt')!r}):\n"
            "    try: open(p).read(); out[p] = 'read'\n"
            "    except PermissionError: out[p] = 'denied'\n"
            "print(json.dumps(out))")
    got = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    assert got[str(tmp_path / "ok" / "a.txt")] == "read"
    if landlock.abi_version() > 0:
        assert got["sealed"] and got[str(tmp_path / "secret" / "b.txt")] == "denied"
    else:
        assert not got["sealed"]


def test_observations_carry_categories_of_the_dataset_vocabulary_and_no_ids(dataset):
    """The agent's observation: the category image maps every pixel to the index of its label in the dataset's
    vocabulary (-1 where nothing is labelled), never a segmentation id; the pose follows the declared sensor; the
    goal is an index into the dataset's goal categories; there is no reward and no other key."""
    from sdovon_mj.knowledge import Knowledge
    from sdovon_mj.suite import load_bundle, make_environment
    from sdovon_mj.suite.observation import ObservationBuilder, Vocabulary, dataset_vocabulary

    b = load_bundle(dataset / "fixture_apartment_v000")
    vocab = dataset_vocabulary(dataset, [b])
    assert vocab == Vocabulary.of_bundles([b]) and set(b.categories()) <= set(vocab.goal_categories)
    env = make_environment(b, nav=NAV, agent=AgentConfig(sensor_width=64, sensor_height=48), semantic=True)
    try:
        ts = env.reset()
        for _ in range(3):
            ts = env.step(2)  # turn: more of the room in view
        seg = ts.observation["semantic"]
        labels = b.detector_labels()
        for know, keys in ((Knowledge(detector="gt"), {"category"}), (Knowledge(detector="owl", pose="absolute"), set())):
            o = ObservationBuilder(know, vocab, labels)(ts.observation)
            assert set(o) == {"rgb", "depth", "gps", "compass", "pitch", "position", "heading", "objectgoal",
                              "objectgoal_text"} | keys
            assert vocab.goal_categories[int(o["objectgoal"][0])] == o["objectgoal_text"] == env.task.episode.object_category
            if know.pose == "absolute":
                assert np.allclose(o["position"], ts.observation["position"])
            else:
                assert np.allclose(o["position"][:2], ts.observation["gps"]) and o["position"][2] == 0.0
        cat = ObservationBuilder(Knowledge(), vocab, labels)(ts.observation)["category"]
        want = np.array([vocab.labels.index(labels[i]) if i in labels else -1 for i in seg.ravel()]).reshape(seg.shape)
        assert cat.dtype == np.int16 and np.array_equal(cat, want) and (cat >= 0).any()
        assert set(np.unique(cat).tolist()) <= set(range(-1, len(vocab.labels)))
    finally:
        env.task.close()


def test_a_first_visit_shows_the_home_without_the_placed_objects(dataset):
    """The exploration phase renders no placed object (segmentation ids of obj_<n>) while the scene's instances
    stay; the next reset is an episode again, with its objects, its goal and the scene as compiled."""
    from sdovon_mj.sim.model import OBJECT_ID_BASE
    from sdovon_mj.suite import load_bundle, make_environment
    from sdovon_mj.suite.evaluation.exploration import exploration_start

    b = load_bundle(dataset / "fixture_apartment_v000")
    env = make_environment(b, nav=NAV, agent=AgentConfig(sensor_width=64, sensor_height=48), semantic=True)
    try:
        env.task.set_exploration(*exploration_start(b, 0))
        seen_explore, seen_episode = set(), set()
        ts = env.reset()
        assert ts.observation["objectgoal_text"] == "" and env.task.exploring and not env.task.episode.goals
        for _ in range(12):
            seen_explore |= set(np.unique(env.step(2).observation["semantic"]).tolist())
        assert seen_explore and not any(i >= OBJECT_ID_BASE for i in seen_explore)
        goal = b.episodes[0].goals[0]
        for i in range(len(b.episodes)):  # an episode whose start sees a goal object when turning around
            env.task.set_next_episode(i)
            ts = env.reset()
            assert not env.task.exploring and ts.observation["objectgoal_text"] == b.episodes[i].object_category
            for _ in range(12):
                seen_episode |= set(np.unique(env.step(2).observation["semantic"]).tolist())
            if any(i >= OBJECT_ID_BASE for i in seen_episode):
                break
        assert any(i >= OBJECT_ID_BASE for i in seen_episode), goal.object_id
    finally:
        env.task.close()


def test_a_rerun_resumes_from_the_episodes_written_and_only_the_same_run(dataset, tmp_path, monkeypatch):
    """With an output folder, a rerun reads finished episodes back instead of starting the agent; an episode whose
    file is gone runs again (with the same result); another configuration of the agent is another run."""
    import sdovon_mj.suite.evaluation.loop as evaluation_loop

    keys = ("episode_id", "trajectory", "success", "run_key")
    first = _run(dataset, spec("Blind"), episodes=3, out=tmp_path)
    real = evaluation_loop.open_session

    def no_agent(*a, **k):
        raise AssertionError("a finished run started its agent again")

    monkeypatch.setattr(evaluation_loop, "open_session", no_agent)
    again = _run(dataset, spec("Blind"), episodes=3, out=tmp_path)
    assert [[r[k] for k in keys] for r in again] == [[r[k] for k in keys] for r in first]
    (tmp_path / "episodes" / "Blind" / f"{first[1]['episode_id']}.json").unlink()
    started = []
    monkeypatch.setattr(evaluation_loop, "open_session", lambda *a, **k: started.append(1) or real(*a, **k))
    third = _run(dataset, spec("Blind"), episodes=3, out=tmp_path)
    assert started == [1] and [[r[k] for k in keys] for r in third] == [[r[k] for k in keys] for r in first]
    other = _run(dataset, spec("Blind", steps=5), episodes=3, out=tmp_path)
    assert len(started) == 2 and other[0]["run_key"] != first[0]["run_key"]


def test_a_pth_hook_of_the_agents_interpreter_runs_sealed(dataset, tmp_path):
    """The agent's own interpreter (a virtual environment made here, reaching the shared packages through a .pth
    file) holds a .pth hook that reads the dataset at interpreter start-up, before any agent code: sealed, the read
    is refused (the seal applies before the interpreter starts); unsealed (the control) it reads the file."""
    import site
    import subprocess

    from sdovon_mj.suite.protocol import SealedSession

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    lib = next((venv / "lib").glob("python*/site-packages"))
    shared = [p for p in site.getsitepackages() if Path(p).is_dir()]
    (lib / "aaa_shared.pth").write_text("import site; " + "; ".join(f"site.addsitedir({p!r})" for p in shared) + "\n")
    target = str(dataset / "fixture_apartment_v000" / "episodes.json")
    probe = (f"try:\n    open({target!r}, 'rb').read(64); builtins.sdovon_pth_probe = 'read'\n"
             "except PermissionError:\n    builtins.sdovon_pth_probe = 'denied'\n")
    (lib / "zzz_probe.pth").write_text(f"import builtins; exec({probe!r})\n")
    python = str(venv / "bin" / "python")
    for seal in (True, False):
        session = SealedSession(spec("PthProbe"), 32, 24, seal=seal, protect=(dataset,), python=python, timeout=60)
        try:
            name, sealed = session.name, session.seal.sealed
        finally:
            session.close()
        if seal and landlock.abi_version() > 0:
            assert sealed and name == "pth-denied"
        elif not seal:
            assert not sealed and name == "pth-read"


@pytest.mark.parametrize("name", ["Silent", "HalfReply"])
def test_a_silent_agent_and_half_a_reply_end_in_recorded_timeouts(dataset, name):
    """An agent that never answers, and one that sends a length header and part of the bytes it announces (a poll
    sees data; a blocking read would wait forever), end in the episode's recorded failure, cause "timeout", after
    their reply limit; the evaluation goes on with a new agent process for the next episode (which times out too)."""
    limit = 2.0
    res = _run(dataset, spec(name), episodes=2, timeout=limit)
    assert [r["outcome"] for r in res] == ["agent failure"] * 2
    assert all(r["failure"]["cause"] == "timeout" and r["seconds"] >= limit and r["success"] == 0 for r in res)
    assert "agent failure" in outcome_table({name: summarize(res, bootstrap=0)})


def test_a_crash_is_recorded_and_never_replayed(dataset, tmp_path, monkeypatch):
    """Crasher (a first visit declared) crashes in its second episode: that episode is recorded as an agent failure
    (cause crash, the agent's traceback) and the evaluation goes on in a new process, which gets no second first
    visit. A resumed run replays nothing: with every record there it starts no agent (the failed episode stays
    failed); with a finished episode's record removed it runs that one alone, again without a first visit, and the
    scene's first-visit record keeps the one visit's steps."""
    import sdovon_mj.suite.evaluation.loop as E

    res = _run(dataset, spec("Crasher"), episodes=3, out=tmp_path)
    assert [r["outcome"] == "agent failure" for r in res] == [False, True, False]
    assert res[1]["failure"]["cause"] == "crash" and "deliberate crash" in res[1]["failure"]["message"]
    assert res[0]["info"]["visits"] == 1 and res[2]["info"]["visits"] == 0
    record = tmp_path / "exploration" / "Crasher" / f"{res[0]['scene']}.json"
    visit = json.loads(record.read_text())
    assert 0 < visit["steps"] <= 6 and all(r["first_visit"]["steps"] == visit["steps"] for r in res)

    real, started = E.open_session, []
    monkeypatch.setattr(E, "open_session", lambda *a, **k: started.append(1) or real(*a, **k))
    again = _run(dataset, spec("Crasher"), episodes=3, out=tmp_path)
    assert started == [] and [r["outcome"] for r in again] == [r["outcome"] for r in res]
    (tmp_path / "episodes" / "Crasher" / f"{res[2]['episode_id']}.json").unlink()
    third = _run(dataset, spec("Crasher"), episodes=3, out=tmp_path)
    assert started == [1] and third[2]["info"]["visits"] == 0 and third[1]["failure"]["cause"] == "crash"
    assert json.loads(record.read_text())["steps"] == visit["steps"]


def test_a_forged_table_row_is_rejected(dataset):
    """An agent declaring a detector with a line break and a table row in it is refused before its first episode
    (a protocol error): nothing it declares reaches a table."""
    from sdovon_mj.suite.protocol import AgentError

    with pytest.raises(AgentError, match="plain word") as err:
        _run(dataset, spec("Forger"), episodes=1)
    assert err.value.cause == "protocol error"


def test_agent_read_inside_the_dataset_is_refused(dataset):
    """`--agent-read` (``read``) naming a folder inside the dataset is refused before the agent starts; a folder
    that contains the dataset still runs, labelled not sealed."""
    from sdovon_mj.errors import InputError

    with pytest.raises(InputError, match="may not read"):
        _run(dataset, spec("Blind"), episodes=1, read=(str(dataset / "fixture_apartment_v000"),))
    r = _run(dataset, spec("Blind"), episodes=1, read=(str(dataset.parent),))[0]
    assert not r["sealed"] and "NOT sealed" in r["seal"]


def test_an_agent_that_reads_no_colour_gets_none_and_the_same_depth(dataset):
    """An agent that declares `Knowledge(rgb=False)` gets a blank colour image on every frame (the evaluator renders
    none for it, sealed) and, step for step, the depth images the same agent gets when it reads colour; its tables
    say so."""
    seeing = _run(dataset, spec("Looker"), episodes=2)
    blind = _run(dataset, spec("Looker", colour=False), episodes=2)
    for s, b in zip(seeing, blind):
        assert s["trajectory"] == b["trajectory"]
        fs, fb = s["info"]["frames"], b["info"]["frames"]
        assert len(fs) == len(fb) > 5
        assert all(a[0] > 0 for a in fs) and all(c[0] == 0 for c in fb)  # colour in one, blank in the other
        assert [a[1] for a in fs] == [c[1] for c in fb]  # the same depth
    assert "no colour image" in blind[0]["knowledge"] and "no colour image" not in seeing[0]["knowledge"]


@pytest.mark.skipif(shutil.which(os.environ.get("CC", "cc")) is None and shutil.which("gcc") is None,
                    reason="no C compiler: the agent kernels run as Python everywhere")
def test_a_sealed_agent_loads_the_compiled_kernels_the_evaluator_built(dataset):
    """The sealed agent may not write the shared cache; the evaluator builds the kernels first and lets it read them,
    so the built-in agents run at their compiled speed there too."""
    from sdovon_mj import native

    r = _run(dataset, spec("KernelProbe"), episodes=1)[0]
    assert r["sealed"]
    assert r["info"]["kernels"] == native.status() and r["info"]["kernels"].startswith("compiled ("), r["info"]


def test_the_colour_declaration_crosses_the_protocol_as_a_boolean():
    """`Knowledge.rgb` goes through the protocol's JSON and back; anything but true or false is a protocol error."""
    from sdovon_mj.knowledge import Knowledge
    from sdovon_mj.suite.protocol import AgentError, knowledge_from_json, knowledge_to_json

    k = Knowledge(detector="gt", rgb=False)
    assert knowledge_from_json(knowledge_to_json(k)) == k
    assert knowledge_from_json({}).rgb is True  # an agent that says nothing reads colour, as before
    for bad in ("no", 0, None):
        with pytest.raises(AgentError, match="rgb must be true or false"):
            knowledge_from_json({"rgb": bad})
