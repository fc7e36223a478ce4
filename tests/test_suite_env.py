"""The dm_control ObjectNav suite: dm_env contract, specs, actions, collisions, registry, bad input."""

from __future__ import annotations

import json
import math
import shutil
import unittest

import numpy as np
import pytest
from dm_env import StepType, test_utils

from sdovon_mj import suite
from sdovon_mj.errors import InputError
from support.bundles import fixture_bundle


@pytest.fixture(scope="module")
def fixture_root(tmp_path_factory):
    """The fixture apartment dataset (2 variants) written once per module."""
    return fixture_bundle(tmp_path_factory.mktemp("fx"), variants=2, seed=3)


def _env(root, **kw):
    kw.setdefault("width", 64)
    kw.setdefault("height", 48)
    return suite.load("objectnav", task_kwargs={"bundle": root / "fixture_apartment_v000", **kw})


def test_dm_env_conformance(fixture_root):
    """dm_env's own EnvironmentTestMixin checks (specs vs observations, reset/step contract) pass."""

    class _T(test_utils.EnvironmentTestMixin, unittest.TestCase):
        def make_object_under_test(self):
            return _env(fixture_root, semantic=True)

        def make_action_sequence(self):
            rng = np.random.default_rng(0)
            for _ in range(60):
                yield int(rng.integers(0, 6))

    suite_ = unittest.defaultTestLoader.loadTestsFromTestCase(_T)
    result = unittest.TextTestRunner(verbosity=0).run(suite_)
    assert result.wasSuccessful(), [str(f[1]) for f in result.failures + result.errors]


def test_specs_match_observations_and_random_policy_1000_steps(fixture_root):
    """A random policy runs 1,000 steps across episode boundaries; every observation matches its spec."""
    env = _env(fixture_root, semantic=True, max_steps=120)
    spec = env.observation_spec()
    assert env.action_spec().num_values == len(suite.ACTION_NAMES)
    rng = np.random.default_rng(1)
    ts = env.reset()
    episodes, lasts = 0, 0
    for i in range(1000):
        if ts.last():
            lasts += 1
            assert ts.discount in (0.0, 1.0)
        ts = env.step(int(rng.integers(0, 6)) if i % 7 else 1)
        if ts.first():
            episodes += 1
        for k, s in spec.items():
            s.validate(ts.observation[k])
    assert episodes >= 2 and lasts >= 2
    d = ts.observation["depth"]
    assert d.min() >= 0.5 and d.max() <= 5.0


def test_stop_is_terminal_and_step_limit_truncates(fixture_root):
    """STOP ends the episode with discount 0; the step limit ends it with discount 1."""
    env = _env(fixture_root, max_steps=5)
    env.reset()
    ts = env.step(suite.STOP)
    assert ts.step_type == StepType.LAST and ts.discount == 0.0
    assert env.task.metrics().stop_called
    ts = env.reset()
    for _ in range(5):
        ts = env.step(suite.TURN_LEFT)
    assert ts.last() and ts.discount == 1.0
    m = env.task.metrics()
    assert m.success == 0.0 and m.steps == 5 and m.path_length == 0.0


def test_actions_move_turn_look_and_gps_compass(fixture_root):
    """MOVE_FORWARD moves 0.25 m along the heading; turns are 30 deg; gps/compass are in the start frame."""
    env = _env(fixture_root)
    for i in range(env.task.num_episodes):  # find an episode with free space ahead
        env.task.set_next_episode(i)
        ts = env.reset()
        p0 = np.array(ts.observation["position"], float)
        ts = env.step(suite.MOVE_FORWARD)
        if np.linalg.norm(ts.observation["position"] - p0) > 0.2:
            break
    assert np.linalg.norm(ts.observation["position"] - p0) == pytest.approx(0.25, abs=1e-5)
    assert ts.observation["gps"] == pytest.approx([0.25, 0.0], abs=1e-5)
    ts = env.step(suite.TURN_LEFT)
    assert float(ts.observation["compass"][0]) == pytest.approx(math.radians(30), abs=1e-5)
    ts = env.step(suite.LOOK_DOWN)
    assert float(ts.observation["pitch"][0]) == pytest.approx(math.radians(-30), abs=1e-5)
    assert env.task.metrics().path_length == pytest.approx(0.25, abs=1e-6)


def test_walls_block_the_agent(fixture_root):
    """Walking into a wall leaves the agent on navigable cells and counts collisions."""
    env = _env(fixture_root)
    env.reset()
    for _ in range(60):
        env.step(suite.MOVE_FORWARD)
        assert env.task.can_stand(env.task.state.position[:2])
    assert env.task.collisions > 0


def test_semantic_observation_sees_instances(fixture_root):
    """The semantic observation holds scene instance ids (walls/floor) and -1 elsewhere."""
    env = _env(fixture_root, semantic=True)
    ts = env.reset()
    ids = set(np.unique(ts.observation["semantic"]).tolist())
    assert 1 in ids or any(2 <= i <= 7 for i in ids)


def test_registry_and_load():
    """Tasks are registered with tags; unknown names fail clearly."""
    assert {"objectnav", "objectnav_semantic", "objectnav_small"} <= set(suite.ALL_TASKS)
    assert "objectnav" in suite.BENCHMARKING
    with pytest.raises(ValueError, match="unknown task"):
        suite.load("nope")


def test_bad_bundles_name_the_file(tmp_path, fixture_root):
    """A missing or corrupt episodes file raises InputError naming the path."""
    with pytest.raises(InputError, match="no episodes.json"):
        suite.find_bundles(tmp_path)
    bad = tmp_path / "v"
    shutil.copytree(fixture_root / "fixture_apartment_v000", bad)
    (bad / "episodes.json").write_text("{not json")
    with pytest.raises(InputError, match="episodes.json"):
        suite.load_bundle(bad)
    (bad / "episodes.json").write_text(json.dumps([]))
    (bad / "fixture_apartment_v000.xml").write_text("<mujoco><worldbody><geom type='nope'/></worldbody></mujoco>")
    with pytest.raises(InputError):
        suite.make_environment(bad)


def test_goal_table_round_trip_and_its_fallback(tmp_path, fixture_root):
    """Bundle v4 episodes (goals once, `suite.goals`) read back to the same records, goals shared by episodes
    written once; a goal the float64 arrays cannot hold exactly goes to goals.json; bad refs name the file."""
    from sdovon_mj.records import Goal, ViewPoint, load_json, records_equal
    from sdovon_mj.suite.goals import pack_episodes, unpack_episodes

    eps = load_json(fixture_root / "fixture_apartment_v000" / "episodes.json")
    text, data, name = pack_episodes(eps)
    assert name == "goals.npz" and "view_points" not in text
    (tmp_path / "episodes.json").write_text(text)
    (tmp_path / name).write_bytes(data)
    back = unpack_episodes(tmp_path / "episodes.json", tmp_path / name)
    assert records_equal(back, eps)
    shared = [(a, b) for a in back[0].goals for b in back[1].goals if a.object_id == b.object_id]
    assert shared and all(a is not b for a, b in shared)  # each episode its own Goal objects, as before
    n_refs = sum(len(e.goals) for e in eps)
    with np.load(tmp_path / name) as z:
        n_table = len(json.loads(bytes(z["__meta__"]).decode())["goals"])
    assert n_table == len({g.object_id for e in eps for g in e.goals}) < n_refs
    assert pack_episodes(eps) == (text, data, name)  # same episodes, same bytes
    # A float32 view point would come back float64 from the arrays: the exact JSON table is written instead.
    odd = [e for e in load_json(fixture_root / "fixture_apartment_v000" / "episodes.json")][:1]
    g = odd[0].goals[0]
    odd[0].goals[0] = Goal(g.object_id, g.category, g.position,
                           [ViewPoint(g.view_points[0].position.astype(np.float32), g.view_points[0].rotation)], g.bounds)
    text2, data2, name2 = pack_episodes(odd)
    assert name2 == "goals.json"
    (tmp_path / "episodes.json").write_text(text2)
    (tmp_path / name2).write_bytes(data2)
    assert records_equal(unpack_episodes(tmp_path / "episodes.json", tmp_path / name2), odd)
    rows = json.loads(text)
    rows[0]["goal_refs"] = [10_000]
    (tmp_path / "episodes.json").write_text(json.dumps(rows))
    with pytest.raises(InputError, match="episodes.json.*goal_refs"):
        unpack_episodes(tmp_path / "episodes.json", tmp_path / name)
    with pytest.raises(InputError, match="nope.npz.*not found"):
        unpack_episodes(tmp_path / "episodes.json", tmp_path / "nope.npz")


def test_frames_not_rendered_are_the_shared_read_only_blanks_a_sealed_agent_gets(fixture_root):
    """A step whose frame the agent did not ask for (render_frames off) holds blank images (black colour, depth at the
    near limit, -1 ids, -1 categories): the same read-only arrays step after step, equal to the blanks the sealed
    agent's side of the protocol reads (`FrameBuffer.read`), so an agent sees one kind of blank in-process and sealed;
    the next rendered step holds fresh writable images again."""
    from sdovon_mj.knowledge import Knowledge
    from sdovon_mj.suite.observation import ObservationBuilder, Vocabulary
    from sdovon_mj.suite.protocol import FrameBuffer

    env = _env(fixture_root, semantic=True)
    task = env.task
    h, w = task.agent.sensor_height, task.agent.sensor_width
    env.reset()
    task.render_frames = False
    a, b = env.step(2).observation, env.step(3).observation
    for k in ("rgb", "depth", "semantic"):
        assert a[k] is b[k] or np.shares_memory(a[k], b[k]), k  # one array, not a new one each step
        assert not a[k].flags.writeable, k
        with pytest.raises(ValueError):
            a[k][...] = 1
    assert not a["rgb"].any() and (a["depth"] == task.nav.depth_min).all() and (a["semantic"] == -1).all()
    builder = ObservationBuilder(Knowledge(detector="gt"), Vocabulary(("chair",), ("chair",)), {})
    o1, o2 = builder(a, rendered=False), builder(b, rendered=False)
    assert o1["category"] is o2["category"] and not o1["category"].flags.writeable
    assert (o1["category"] == -1).all() and o1["category"].shape == (h, w)
    fb = FrameBuffer(w, h)
    try:
        sealed = fb.read(fb.write(o1, False), task.nav.depth_min)
        for k in ("rgb", "depth", "category"):
            assert np.array_equal(sealed[k].reshape(np.shape(o1[k])), o1[k]) and not sealed[k].flags.writeable, k
    finally:
        fb.close()
    task.render_frames = True
    c = env.step(2).observation
    assert all(c[k].flags.writeable for k in ("rgb", "depth", "semantic"))
    env.task.close()
