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
import sys
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.config import AgentConfig, NavConfig
from sdovon_mj.suite import landlock
from sdovon_mj.suite.evaluation.loop import evaluate
from sdovon_mj.suite.evaluation.statistics import summarize
from sdovon_mj.suite.evaluation.tables import overall_table
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
    episode, goal, relevance, region map; no id -> label table). In-process the same walk finds them."""
    sealed = _run(dataset, spec("Walker"), episodes=1)[0]
    assert sealed["mode"] == "sealed" and sealed["info"]["walked"] > 1000
    assert sealed["info"]["found"] == [] and sealed["info"]["label_tables"] == 0, sealed["info"]
    inproc = _run(dataset, spec("Walker"), episodes=1, mode="in-process")[0]
    assert {"Bundle", "ObjectNavTask", "Episode", "Goal", "NavMap"} <= set(inproc["info"]["found"])
    assert inproc["info"]["label_tables"] > 0
    assert "in-process" in overall_table({"walker": summarize([inproc], bootstrap=0)})


def test_a_disk_scanning_agent_cannot_read_the_dataset(dataset):
    """Sealed by Landlock: opening the dataset's files (the agent was told where they are) and the evaluator's
    /proc/<pid>/cmdline, environ and mem raises PermissionError, and a walk of the file system finds no readable
    episode file. Unsealed (the control) it reads them, and the table says the file system was not sealed."""
    variant = dataset / "fixture_apartment_v000"
    files = tuple(str(variant / f) for f in ("episodes.json", "oracle/navmap.json", "oracle/object_labels.json"))
    r = _run(dataset, spec("DiskScanner", paths=files), episodes=1)[0]
    if landlock.abi_version() > 0:
        assert r["sealed"] and "sealed (Landlock ABI" in r["seal"]
        assert all(v == "denied" for v in r["info"]["tried"].values()), r["info"]["tried"]
        assert r["info"]["episode_files_readable"] == []
    else:
        assert not r["sealed"] and "NOT sealed" in overall_table({"scanner": summarize([r], bootstrap=0)})
    open_ = _run(dataset, spec("DiskScanner", paths=files, walk_dirs=0), episodes=1, seal=False)[0]
    assert not open_["sealed"] and all(open_["info"]["tried"][f] == "read" for f in files)
    assert "file system not sealed" in overall_table({"scanner": summarize([open_], bootstrap=0)})


def test_a_declared_oracle_gets_its_parts_and_no_other(dataset):
    """The oracle agent (navmap + view points declared) succeeds sealed; an agent reading an undeclared part gets
    KnowledgeError (the session reports the agent's error)."""
    from sdovon_mj.suite.evaluation.runner import agent_spec
    from sdovon_mj.suite.protocol import AgentError

    res = _run(dataset, agent_spec("oracle", NavConfig(), agent=SMALL), episodes=2)
    assert all(r["success"] == 1.0 and r["oracle"] and "ORACLE: navmap, view_points" in r["knowledge"] for r in res)
    with pytest.raises(AgentError, match="KnowledgeError.*relevance"):
        _run(dataset, spec("HalfOracle"), episodes=1)


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
