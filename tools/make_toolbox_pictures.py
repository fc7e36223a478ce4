"""Make the pictures of docs/toolbox.md: a screenshot of the viewer and a frame of an episode video (maintainer script).

    python tools/make_toolbox_pictures.py RUN_DIR MJCF_DATASET EVAL_DIR [--out docs]

The screenshot: `sdovon-mj view RUN_DIR --eval EVAL_DIR --export` opened from file:// in headless Chromium (Debian's
chromium + chromium-driver, as tests/test_viewer.py drives it) on an evaluated episode. The video: the first episode
of the dataset's first bundle, walked by a shortest-path follower (turn towards the neighbouring heading whose step
lowers the geodesic distance to the goals' view points most, step, STOP within the success distance), written by
suite.video.write_episode_video; its last frame is saved. Both as small palette PNGs.
"""

from __future__ import annotations

import argparse
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

REPO = Path(__file__).resolve().parents[1]


def _small_png(img: np.ndarray, path: Path, width: int) -> None:
    """Save an RGB image downscaled to `width` px as a 256-colour PNG."""
    im = Image.fromarray(img)
    if im.width > width:
        im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
    im.quantize(256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(path, optimize=True)
    print(f"wrote {path} ({path.stat().st_size} bytes)")


def screenshot(run: Path, eval_dir: Path, out: Path) -> None:
    """Export the viewer, open it from file:// in headless Chromium on an evaluated episode, save the screenshot."""
    sys.path.insert(0, str(REPO / "tests"))
    import test_viewer as tv
    from sdovon_mj.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        site = Path(tmp) / "site"
        assert main(["view", str(run), "--eval", str(eval_dir), "--export", str(site)]) == 0
        episode = sorted(p.stem for p in eval_dir.glob("episodes/*/*.json"))[-1]
        driver = tv._browser(Path(tmp) / "chromium")
        try:
            driver.set_window_size(1280, 760)
            driver.get(site.joinpath("index.html").as_uri() + f"#episode={episode}")
            tv._wait(driver, "document.body.dataset.state === 'ready'")
            time.sleep(0.5)
            img = np.asarray(Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB"))
        finally:
            driver.quit()
    _small_png(img, out / "viewer.png", 1000)


def video_frame(dataset: Path, out: Path, width: int = 320, height: int = 240) -> None:
    """Walk the dataset's first episode along the geodesic, write its video, save the last frame."""
    import math

    from sdovon_mj import suite
    from sdovon_mj.suite.video import read_video, write_episode_video

    env = suite.load("objectnav", task_kwargs={"bundle": suite.find_bundles(dataset)[0], "width": width, "height": height})
    task = env.task
    ts = env.reset()
    frames, pos, yaws = [ts.observation["rgb"]], [task.state.position.copy()], [task.state.yaw]
    while not ts.last():
        here = task.geodesic.distance(task.state.position)
        if here < task.nav.success_distance * 0.5:
            action = suite.STOP
        else:
            best = None
            for k in range(-6, 7):
                yaw = task.state.yaw + k * task.nav.turn_angle
                heading = np.array([math.cos(math.radians(yaw)), math.sin(math.radians(yaw)), 0.0])
                step = task.state.position + task.nav.forward_step * heading
                if task.can_stand(step):
                    key = (task.geodesic.distance(step), abs(k))
                    best = key + (k,) if best is None or key < best[:2] else best
            k = 0 if best is None else best[2]
            action = suite.MOVE_FORWARD if k == 0 else (suite.TURN_LEFT if k > 0 else suite.TURN_RIGHT)
        ts = env.step(action)
        frames.append(ts.observation["rgb"])
        pos.append(task.state.position.copy())
        yaws.append(task.state.yaw)
    with tempfile.TemporaryDirectory() as tmp:
        path = write_episode_video(Path(tmp) / "episode.mp4", frames, pos, yaws, task.navmap, task.episode,
                                   label="shortest path")
        decoded, _ = read_video(path)
        print(f"video: {len(decoded)} frames for {task.steps} steps, success {task.metrics().success}")
    task.close()
    _small_png(decoded[-1], out / "video_frame.png", 800)


def main() -> int:
    """Make both pictures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("dataset", type=Path, help="the run's MJCF export (sdovon-mj export RUN --format mjcf)")
    ap.add_argument("eval_dir", type=Path, help="an eval --out folder over that dataset")
    ap.add_argument("--out", type=Path, default=REPO / "docs")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    screenshot(args.run_dir, args.eval_dir, args.out)
    video_frame(args.dataset, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
