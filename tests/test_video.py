"""Episode videos (suite/video.py): an episode stepped in the dm_control suite, written as H.264 MP4 by the ffmpeg
inside the imageio-ffmpeg wheel and read back with it: one frame per step plus the first, each showing that step's
RGB view beside the top-down map with the agent where it stood; and `sdovon-mj eval --video N` recording the first N
episodes in the evaluator (steps + 1 frames each, named and listed in the results, re-recorded when deleted)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sdovon_mj import suite
from sdovon_mj.suite.video import AGENT, GOAL, EpisodeVideo, MapPanel, read_video, write_episode_video
from support.bundles import fixture_bundle

# Turns change every view; forward moves change the map (and the view where the way is free).
ACTIONS = [suite.TURN_LEFT, suite.MOVE_FORWARD, suite.MOVE_FORWARD, suite.TURN_RIGHT, suite.MOVE_FORWARD,
           suite.TURN_RIGHT, suite.MOVE_FORWARD, suite.MOVE_FORWARD, suite.TURN_LEFT, suite.LOOK_DOWN, suite.STOP]


@pytest.fixture(scope="module")
def stepped(tmp_path_factory):
    """One episode of the fixture apartment stepped with the suite: views, positions, yaws, its navmap and episode."""
    root = fixture_bundle(tmp_path_factory.mktemp("fx"), variants=1, seed=3)
    env = suite.load("objectnav", task_kwargs={"bundle": root / "fixture_apartment_v000", "width": 96, "height": 72})
    task = env.task
    ts = env.reset()
    frames, positions, yaws = [ts.observation["rgb"].copy()], [task.state.position.copy()], [task.state.yaw]
    for a in ACTIONS:
        ts = env.step(a)
        frames.append(ts.observation["rgb"].copy())
        positions.append(task.state.position.copy())
        yaws.append(task.state.yaw)
        if ts.last():
            break
    out = dict(frames=frames, positions=positions, yaws=yaws, navmap=task.navmap, episode=task.episode, steps=task.steps)
    task.close()
    return out


def _nearest(x: np.ndarray, candidates: list[np.ndarray]) -> list[float]:
    return [float(np.abs(x.astype(float) - c.astype(float)).mean()) for c in candidates]


def test_video_has_a_frame_per_step_showing_the_view_and_the_map(stepped, tmp_path):
    s = stepped
    path = write_episode_video(tmp_path / "videos" / "ep.mp4", s["frames"], s["positions"], s["yaws"], s["navmap"],
                               s["episode"], label="test")
    decoded, meta = read_video(path)
    assert meta["codec"] == "h264"
    assert len(decoded) == s["steps"] + 1 == len(s["frames"])
    h, w = s["frames"][0].shape[:2]
    panel = MapPanel(s["navmap"], s["episode"], h)
    assert decoded[0].shape[0] >= h and decoded[0].shape[1] >= w + panel.width
    below = h // 3  # under the caption
    views = [f[below:] for f in s["frames"]]
    maps = [panel.draw(s["positions"][:k + 1], s["yaws"][k]) for k in range(len(s["frames"]))]
    for k, frame in enumerate(decoded):
        # the left part is step k's view: nearer to it than to any other step's view that differs from it
        d = _nearest(frame[below:h, :w], views)
        assert all(d[k] < d[j] for j in range(len(views)) if not np.array_equal(views[j], views[k])), (k, d)
        # the right part is the map with the path up to step k
        m = frame[:h, w:w + panel.width]
        d = _nearest(m, maps)
        assert all(d[k] < d[j] for j in range(len(maps)) if not np.array_equal(maps[j], maps[k])), (k, d)
        # ... where the agent's red disc (radius r, heading line 2r) stands at its position, the goal's green disc at it
        red = (m[..., 0] > 150) & (m[..., 1] < 100) & (m[..., 2] < 100)
        assert red.any(), k
        ys, xs = np.nonzero(red)
        ex, ey = panel.px(s["positions"][k])
        r = max(4, int(round(panel.scale * 3.0)))
        assert np.hypot(xs.mean() - ex, ys.mean() - ey) <= 2 * r, (k, xs.mean(), ys.mean(), ex, ey)
    gx, gy = panel.px(s["episode"].goals[0].position)
    near = decoded[0][max(gy - 2, 0):gy + 3, w + max(gx - 2, 0):w + gx + 3].reshape(-1, 3).astype(int)
    assert np.any(np.abs(near - np.array(GOAL)).sum(axis=1) < 90), near
    assert AGENT != GOAL
    # the agent moved: its first and last positions are different map pixels
    assert panel.px(s["positions"][0]) != panel.px(s["positions"][-1])


def test_recorder_streams_and_leaves_no_partial_file(stepped, tmp_path):
    s = stepped
    path = tmp_path / "stream.mp4"
    with EpisodeVideo(path, s["navmap"], s["episode"], fps=4) as video:
        for rgb, p, y in zip(s["frames"][:3], s["positions"][:3], s["yaws"][:3]):
            video.add(rgb, p, y)
            assert not path.exists()  # written under a temporary name until closed
    assert len(read_video(path)[0]) == 3
    broken = tmp_path / "broken.mp4"
    with pytest.raises(ValueError, match="frame"):
        with EpisodeVideo(broken, s["navmap"], s["episode"]) as video:
            video.add(s["frames"][0], s["positions"][0], s["yaws"][0])
            video.add(s["frames"][0][:, :-8], s["positions"][0], s["yaws"][0])  # another size
    assert list(tmp_path.iterdir()) == [path]
    with pytest.raises(ValueError, match="one position and yaw per frame"):
        write_episode_video(tmp_path / "x.mp4", s["frames"], s["positions"][:-1], s["yaws"], s["navmap"], s["episode"])


def test_eval_writes_a_video_per_episode_asked_for(tmp_path):
    """`sdovon-mj eval --video 2` (the oracle, sealed, small images) writes 2 MP4s, named by agent and episode and
    listed in the results; each has the episode's steps + 1 frames, the first showing the start view. A rerun plays
    no episode again (issue 46: a begun episode is never replayed), so a deleted video is not recorded again and the
    others are kept as they are."""
    from sdovon_mj.cli import main

    root = fixture_bundle(tmp_path / "fx", variants=1, seed=3)
    out = tmp_path / "ev"
    args = ["eval", str(root), "--agent", "oracle", "--episodes", "3", "--video", "2", "--width", "64", "--height", "48",
            "--pictures", "0", "--out", str(out)]
    assert main(args) == 0
    results = [json.loads(p.read_text()) for p in sorted((out / "episodes" / "oracle").glob("*.json"))]
    assert len(results) == 3
    shot = [r for r in results if r.get("video")]
    assert sorted(p.relative_to(out).as_posix() for p in (out / "videos").rglob("*.mp4")) == sorted(r["video"] for r in shot)
    assert len(shot) == 2 and all(r["video"] == f"videos/oracle/{r['episode_id']}.mp4" for r in shot)
    assert json.loads((out / "summary.json").read_text())["oracle"]["videos"] == [r["video"] for r in shot]
    env = suite.load("objectnav", task_kwargs={"bundle": root / "fixture_apartment_v000", "width": 64, "height": 48})
    ids = [e.episode_id for e in env.task.bundle.episodes]
    for r in shot:
        frames, meta = read_video(out / r["video"])
        assert meta["codec"] == "h264" and len(frames) == r["steps"] + 1 > 1
        env.task.set_next_episode(ids.index(r["episode_id"]))
        start = env.reset().observation["rgb"][16:]  # under the caption
        first, last = frames[0][16:48, :64], frames[-1][16:48, :64]
        assert _nearest(start, [first, last])[0] < _nearest(start, [first, last])[1]
    env.task.close()
    gone = out / shot[0]["video"]
    kept = out / shot[1]["video"]
    before = kept.stat().st_mtime_ns
    gone.unlink()
    assert main(args) == 0
    assert not gone.is_file() and kept.stat().st_mtime_ns == before
