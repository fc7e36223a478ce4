"""The Gymnasium environments (suite/gym.py) on the fixture apartment, real MuJoCo rendering at small sizes:

- ``sdovon_mj/ObjectNav-v0`` passes Gymnasium's own `check_env` and its observations are the sealed evaluation's
  (`ObservationBuilder`, the dataset's vocabulary);
- an `AsyncVectorEnv` of two bundles (two variants of one dataset, each its own process) steps within its spaces;
- under evaluation (the default) the reward is 0.0 on every step, also on steps that bring the agent closer to the
  goal (where training mode's dense reward is positive), and neither ``info`` nor the observation holds generator data;
- importing the package does not import Gymnasium; a dataset of several variants is a clear error;
- the renderer: ``render="gpu"`` on this machine (no GPU) is a clear error, ``auto`` falls back to the CPU and
  ``reset``'s info records it, with why.
"""

from __future__ import annotations

import math
import subprocess
import sys
from functools import partial

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from sdovon_mj.errors import InputError, RendererError
from sdovon_mj.knowledge import Knowledge
from sdovon_mj.suite.gym import ENV_ID, ObjectNavEnv
from sdovon_mj.suite.observation import ObservationBuilder, dataset_vocabulary
from support.bundles import fixture_bundle

MAKE_ID = f"sdovon_mj.suite.gym:{ENV_ID}"  # Gymnasium imports the module before ':' (it registers the id)
SIZE = {"width": 32, "height": 24}
# What an agent observes under the default knowledge (ground-truth category image, GPS+compass)
KEYS = {"rgb", "depth", "category", "gps", "compass", "pitch", "position", "heading", "objectgoal"}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """The fixture apartment, two variants (one dataset: one vocabulary)."""
    return fixture_bundle(tmp_path_factory.mktemp("gym"), variants=2, seed=3)


def test_the_registered_env_passes_gymnasiums_checker(dataset):
    env = gymnasium.make(MAKE_ID, bundle=dataset / "fixture_apartment_v000", render_mode="rgb_array", **SIZE)
    check_env(env.unwrapped)  # spaces, seeding determinism, step/reset signatures, render, close
    u = env.unwrapped
    assert u.action_names == ("STOP", "MOVE_FORWARD", "TURN_LEFT", "TURN_RIGHT", "LOOK_UP", "LOOK_DOWN", "OPEN", "CLOSE")
    assert env.action_space == gymnasium.spaces.Discrete(8)
    assert set(env.observation_space.spaces) == KEYS
    obs, info = env.reset(seed=7)
    assert env.observation_space.contains(obs) and set(info) == {"render"}  # which renderer draws, nothing else
    assert env.render().shape == (24, 32, 3)
    # the same seed, the same episode; the observation is the one the sealed evaluation builds from the same state
    again, _ = env.reset(seed=7)
    assert all(np.array_equal(obs[k], again[k]) for k in KEYS)
    vocab = dataset_vocabulary(dataset)
    assert u.vocabulary == vocab
    task = u._env.task
    built = ObservationBuilder(Knowledge(), vocab, u._bundle.detector_labels())(task.get_observation(u._env.physics))
    assert all(np.array_equal(obs[k], built[k]) for k in KEYS)
    assert vocab.goal_categories[int(obs["objectgoal"][0])] == task.episode.object_category
    assert (obs["category"] >= 0).any()  # the walls and floor are labelled
    # sequential order visits every episode once per cycle; options pick one by index or id
    seq = ObjectNavEnv(dataset / "fixture_apartment_v000", episode_order="sequential", **SIZE)
    ids = []
    for k in range(seq.num_episodes):
        seq.reset(seed=0 if k == 0 else None)
        ids.append(seq._env.task.episode.episode_id)
    assert len(set(ids)) == seq.num_episodes
    seq.reset(options={"episode": ids[2]})
    assert seq._env.task.episode.episode_id == ids[2]
    seq.close()
    seq.close()
    env.close()


def test_an_async_vector_env_of_two_bundles_steps_within_its_spaces(dataset):
    fns = [partial(gymnasium.make, MAKE_ID, bundle=str(dataset / f"fixture_apartment_v00{k}"), **SIZE) for k in (0, 1)]
    venv = gymnasium.vector.AsyncVectorEnv(fns, context="spawn")  # fresh processes: no GL state inherited
    try:
        single = ObjectNavEnv(dataset / "fixture_apartment_v000", **SIZE)
        assert venv.single_observation_space == single.observation_space
        single.close()
        obs, info = venv.reset(seed=0)
        assert venv.observation_space.contains(obs)
        assert obs["rgb"].shape == (2, 24, 32, 3)
        assert not np.array_equal(obs["rgb"][0], obs["rgb"][1])  # two variants, two start poses
        for actions in ([1, 2], [1, 1], [3, 1], [4, 5]):
            obs, reward, terminated, truncated, info = venv.step(np.array(actions))
            assert venv.observation_space.contains(obs)
            assert reward.shape == (2,) and not reward.any()  # evaluation mode
            assert not terminated.any() and not truncated.any()
    finally:
        venv.close()


def _toward_goal(task) -> int:
    """An action that the generator knows brings the agent nearer: forward when the cell ahead is nearer the goal's
    view points (geodesic), else turn left."""
    yaw = math.radians(task.state.yaw)
    ahead = task.state.position + task.nav.forward_step * np.array([math.cos(yaw), math.sin(yaw), 0.0])
    return 1 if task.geodesic.distance(ahead) < task.distance - 1e-6 else 2


def test_under_evaluation_no_reward_and_no_generator_data(dataset):
    """The same episode, the same actions (chosen by the generator's geodesic so that forward moves get closer):
    training mode's dense reward is positive on those steps, evaluation mode's reward is 0.0 on every step and its
    info empty; both observe the same pixels and numbers, and nothing else."""
    bundle = dataset / "fixture_apartment_v001"
    train = ObjectNavEnv(bundle, training=True, **SIZE)
    ev = ObjectNavEnv(bundle, **SIZE)
    o_t, i_t = train.reset(seed=3)
    o_e, i_e = ev.reset(seed=3)
    assert set(i_e) == {"render"} and "distance_to_goal" in i_t
    closer = 0
    for _ in range(40):
        a = _toward_goal(train._env.task)
        o_t, r_t, term_t, trunc_t, i_t = train.step(a)
        o_e, r_e, term_e, trunc_e, i_e = ev.step(a)
        assert r_e == 0.0 and i_e == {}
        assert set(o_e) == KEYS and all(np.array_equal(o_e[k], o_t[k]) for k in KEYS)
        assert (term_e, trunc_e) == (term_t, trunc_t)
        if a == 1 and r_t > 0:
            closer += 1
            assert i_t["distance_to_goal"] < train._env.task.shortest
    assert closer >= 3, closer  # the walk got nearer, step by step
    assert ev.observation_space.contains(o_e)
    # what would be generator data is in no observation: no raw segment ids, no goal or start pose, no map
    assert not set(o_e) & {"semantic", "goal", "goals", "navmap", "objectgoal_text", "view_points"}
    with pytest.raises(RuntimeError, match="reset"):
        ObjectNavEnv(bundle, **SIZE).step(1)
    # STOP ends the episode (terminated); training's info carries the metrics then
    _o, _r, term, trunc, info = train.step(0)
    assert term and not trunc and {"success", "spl", "is_success"} <= set(info)
    with pytest.raises(RuntimeError, match="reset"):
        train.step(1)
    train.close()
    ev.close()


def test_render_and_options(dataset):
    bundle = dataset / "fixture_apartment_v000"
    with pytest.raises(ValueError, match="training"):
        ObjectNavEnv(bundle, render_map=True, render_mode="rgb_array", **SIZE)
    env = ObjectNavEnv(bundle, training=True, render_map=True, render_mode="rgb_array", goal_text=True, **SIZE)
    obs, _ = env.reset(seed=1)
    assert obs["objectgoal_text"] == env._env.task.episode.object_category
    assert env.observation_space.contains(obs)
    frame = env.render()
    assert frame.shape[0] >= 24 and frame.shape[1] > 32  # the view beside the map
    env.close()
    with pytest.raises(InputError, match="2 variant folders"):
        ObjectNavEnv(dataset, **SIZE)
    with pytest.raises(ValueError, match="first visit"):
        ObjectNavEnv(bundle, knowledge=Knowledge(prior="scene", explore_steps=10), **SIZE)


def test_render_choice_gpu_is_an_error_here_and_auto_falls_back_recorded(dataset):
    bundle = dataset / "fixture_apartment_v000"
    with pytest.raises(RendererError, match="render='gpu' but this machine offers no GPU EGL device"):
        ObjectNavEnv(bundle, render="gpu", **SIZE)
    with pytest.raises(ValueError, match="render 'vulkan'"):
        ObjectNavEnv(bundle, render="vulkan", **SIZE)
    for render in ("auto", "cpu"):
        env = ObjectNavEnv(bundle, render=render, **SIZE)
        _obs, info = env.reset(seed=0)
        rec = info["render"]
        assert rec["requested"] == render and rec["render"] == "cpu" and rec["renderer"].startswith("llvmpipe")
        assert ("fallback" in rec) == (render == "auto"), rec  # auto says why it draws on the CPU; cpu was asked for
        env.close()


def test_importing_the_package_does_not_import_gymnasium():
    code = ("import sys, sdovon_mj, sdovon_mj.suite, sdovon_mj.suite.evaluation.runner, sdovon_mj.commands.eval, sdovon_mj.cli; "
            "assert 'gymnasium' not in sys.modules, 'imported'; import gymnasium; "
            f"assert {ENV_ID!r} not in gymnasium.registry; import sdovon_mj.suite.gym; "
            f"assert {ENV_ID!r} in gymnasium.registry")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_the_training_example_runs_and_prints_its_returns(dataset):
    """examples/train_gym.py (REINFORCE in torch) for 40 steps of 15-step episodes: 3 episodes (the last cut short),
    each return a geodesic gain no larger than its steps times the 0.25 m forward step."""
    from pathlib import Path

    example = Path(__file__).resolve().parents[1] / "examples" / "train_gym.py"
    proc = subprocess.run([sys.executable, str(example), "--bundle", str(dataset / "fixture_apartment_v000"), "--steps",
                           "40", "--max-steps", "15", "--width", "16", "--height", "12"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("episode ")]
    assert [ln.split(":")[0] for ln in lines] == ["episode 1", "episode 2", "episode 3"], proc.stdout
    for ln, steps in zip(lines, (15, 15, 10)):
        n, ret = ln.split(": ")[1].split(" steps, return ")
        assert int(n) == steps and abs(float(ret.split(" m")[0])) <= steps * 0.25 + 1e-6, ln
    assert proc.stdout.splitlines()[-1].startswith("40 steps, 3 episodes; mean return")


def test_an_env_for_an_agent_that_reads_no_colour_renders_none(dataset):
    """`Knowledge(rgb=False)`: the observation's colour image is blank (within its space) and the depth and category
    images are those of the colour-reading environment, step for step."""
    both = [ObjectNavEnv(dataset / "fixture_apartment_v000", knowledge=Knowledge(rgb=rgb), **SIZE) for rgb in (True, False)]
    try:
        obs = [e.reset(seed=3)[0] for e in both]
        for action in (1, 2, 1, 3, 1):
            for k in ("depth", "category"):
                assert np.array_equal(obs[0][k], obs[1][k])
            assert obs[0]["rgb"].any() and not obs[1]["rgb"].any()
            assert both[1].observation_space.contains(obs[1])
            obs = [e.step(action)[0] for e in both]
    finally:
        for e in both:
            e.close()
