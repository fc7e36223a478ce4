"""Episode videos: the agent's RGB view beside the top-down map (navigable map, goals and their view points, the
path so far, the agent's heading), written as H.264 MP4 by the ffmpeg that ships inside the imageio-ffmpeg wheel.

The evaluation loop records an episode with `EpisodeVideo`, one frame after reset and one after every step
(steps + 1 frames), and closes it when the episode ends::

    video = EpisodeVideo(path, bundle.navmap(episode.floor), episode)
    video.add(rgb, task.state.position, task.state.yaw)      # after env.reset() and after every env.step()
    video.close()

(`write_episode_video` does the same for frames already in memory.) An agent that asks for no frame on some steps
(``wants_frame`` False) gets blank observations; the recorder wants the real view: render it for the video with
``task.render(env.physics)[0]`` without handing it to the agent. The map shows generator knowledge (navigable cells,
goals, view points): a video is the evaluator's record, never an agent's input.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..records import Episode, NavMap

FPS = 8  # habitat-style discrete steps: 8 steps a second reads as walking pace
BLOCK = 16  # frame sides are padded to a multiple of this (H.264 macroblocks; no resampling by the writer)
MARGIN_M = 0.5  # map crop: the free space's box plus this margin (m)
# BGR-free RGB colours of the map
WALL, FREE, NAVIGABLE = (40, 40, 40), (150, 150, 150), (222, 222, 222)
VIEW_POINT, GOAL, START, PATH, AGENT = (90, 200, 90), (0, 140, 0), (230, 120, 20), (40, 90, 230), (220, 30, 30)


class MapPanel:
    """The top-down map of one episode at a fixed pixel size: a static base (navigable map, view points, goals,
    start) and, per frame, the path so far and the agent's position and heading on top.

    Parameters
    ----------
    navmap
        The episode floor's navigable map (records.NavMap).
    episode
        The episode (its goals, their view points, the start pose).
    height
        Panel height in pixels (the RGB view's height); the width follows the cropped map's aspect.
    """

    def __init__(self, navmap: NavMap, episode: Episode, height: int) -> None:
        import cv2

        self.navmap, self.episode = navmap, episode
        free = np.asarray(navmap.free, bool) | np.asarray(navmap.navigable, bool)
        rows, cols = np.nonzero(free) if free.any() else (np.array([0, free.shape[0] - 1]), np.array([0, free.shape[1] - 1]))
        m = int(math.ceil(MARGIN_M / navmap.resolution))
        self.r0, self.r1 = max(int(rows.min()) - m, 0), min(int(rows.max()) + m + 1, free.shape[0])
        self.c0, self.c1 = max(int(cols.min()) - m, 0), min(int(cols.max()) + m + 1, free.shape[1])
        crop_h, crop_w = self.r1 - self.r0, self.c1 - self.c0
        self.scale = float(height) / crop_h  # pixels per cell
        self.height, self.width = int(height), max(int(round(crop_w * self.scale)), 1)
        img = np.empty((crop_h, crop_w, 3), np.uint8)
        img[:] = WALL
        img[np.asarray(navmap.free, bool)[self.r0:self.r1, self.c0:self.c1]] = FREE
        img[np.asarray(navmap.navigable, bool)[self.r0:self.r1, self.c0:self.c1]] = NAVIGABLE
        base = cv2.resize(img[::-1], (self.width, self.height), interpolation=cv2.INTER_NEAREST)  # north (+Y) up
        dot = max(1, int(round(self.scale * 0.4)))
        for g in episode.goals:
            for vp in g.view_points:
                cv2.circle(base, self.px(vp.position), dot, VIEW_POINT, -1)
        for g in episode.goals:
            cv2.circle(base, self.px(g.position), max(3, int(round(self.scale * 2))), GOAL, -1)
        cv2.circle(base, self.px(episode.start_position), max(3, int(round(self.scale * 1.6))), START, -1)
        self.base = np.ascontiguousarray(base)
        self.line = max(1, int(round(self.height / 240)))

    def px(self, xy: Any) -> tuple[int, int]:
        """Return the panel pixel (x, y) of a world point (its XY, m)."""
        p = np.asarray(xy, float)[:2]
        c = (p - np.asarray(self.navmap.origin, float)) / self.navmap.resolution  # (col, row) in cells
        x = (c[0] - self.c0) * self.scale
        y = self.height - (c[1] - self.r0) * self.scale
        return int(round(x)), int(round(y))

    def draw(self, path: Sequence[Any], yaw: float) -> np.ndarray:
        """Return the panel (height, width, 3) uint8 with the path so far (world points, the agent last) and the
        agent's heading `yaw` (deg, about +Z from +X)."""
        import cv2

        img = self.base.copy()
        pts = np.array([self.px(p) for p in path], np.int32)
        if len(pts) > 1:
            cv2.polylines(img, [pts.reshape(-1, 1, 2)], False, PATH, self.line + 1, cv2.LINE_AA)
        if len(pts):
            r = max(4, int(round(self.scale * 3.0)))
            tip = (int(round(pts[-1][0] + 2 * r * math.cos(math.radians(yaw)))),
                   int(round(pts[-1][1] - 2 * r * math.sin(math.radians(yaw)))))
            cv2.circle(img, tuple(int(v) for v in pts[-1]), r, AGENT, -1, cv2.LINE_AA)
            cv2.line(img, tuple(int(v) for v in pts[-1]), tip, AGENT, self.line + 1, cv2.LINE_AA)
        return img


def compose_frame(rgb: np.ndarray, panel: np.ndarray, caption: str = "") -> np.ndarray:
    """Return one video frame: `rgb` (H, W, 3) uint8 on the left, the map `panel` (H, Wm, 3) on the right, a
    caption over the view's top-left corner, padded with black to sides that are multiples of `BLOCK`."""
    import cv2

    rgb = np.asarray(rgb, np.uint8)
    if rgb.ndim != 3 or rgb.shape[2] != 3 or panel.shape[0] != rgb.shape[0]:
        raise ValueError(f"expected an (H, W, 3) view and an (H, Wm, 3) map panel, got {rgb.shape} and {panel.shape}")
    h, w = rgb.shape[0], rgb.shape[1] + panel.shape[1]
    H, W = -(-h // BLOCK) * BLOCK, -(-w // BLOCK) * BLOCK
    frame = np.zeros((H, W, 3), np.uint8)
    frame[:h, :rgb.shape[1]] = rgb
    frame[:h, rgb.shape[1]:w] = panel
    if caption:
        scale = max(0.35, rgb.shape[0] / 480.0 * 0.6)
        (tw, th), base = cv2.getTextSize(caption, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
        cv2.rectangle(frame, (0, 0), (min(tw + 8, rgb.shape[1]), th + base + 6), (0, 0, 0), -1)
        cv2.putText(frame, caption, (4, th + 3), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1, cv2.LINE_AA)
    return frame


class EpisodeVideo:
    """Record one episode as MP4, frame by frame (nothing kept in memory but the map's base image).

    The file appears at `path` only when `close` succeeds (written beside it under a temporary name, then renamed),
    so a killed evaluation leaves no half video. Use as a context manager or call `close`.

    Parameters
    ----------
    path
        The MP4 to write (parent folders are created).
    navmap
        The episode floor's navigable map (records.NavMap; the bundle's ``navmap(episode.floor)``).
    episode
        The episode: goals with view points, start pose, goal category (records.Episode).
    fps
        Frames per second of the video (one frame per step).
    label
        Text before the goal category in the caption (e.g. the agent's name).
    """

    def __init__(self, path: str | Path, navmap: NavMap, episode: Episode, fps: int = FPS, label: str = "") -> None:
        self.path = Path(path)
        self.navmap, self.episode, self.fps, self.label = navmap, episode, int(fps), label
        self.frames = 0
        self.positions: list[np.ndarray] = []
        self._panel: MapPanel | None = None
        self._writer: Any = None
        self._size: tuple[int, int] | None = None
        self._view_shape: tuple[int, ...] = ()
        self._tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp.mp4")

    def add(self, rgb: np.ndarray, position: Any, yaw: float) -> None:
        """Append a frame: the agent's view `rgb` (H, W, 3) uint8 at `position` (world XY(Z), m) heading `yaw`
        (deg, about +Z from +X, as ``ObjectNavTask.state.yaw``)."""
        import imageio_ffmpeg

        rgb = np.asarray(rgb)
        if rgb.ndim != 3 or rgb.shape[2] != 3:
            raise ValueError(f"expected an (H, W, 3) RGB frame, got shape {rgb.shape}")
        if self._panel is None:
            self._panel = MapPanel(self.navmap, self.episode, rgb.shape[0])
            self._view_shape = rgb.shape
        elif rgb.shape != self._view_shape:
            raise ValueError(f"frame {self.frames} is {rgb.shape[1]}x{rgb.shape[0]} px, the video's first "
                             f"{self._view_shape[1]}x{self._view_shape[0]}")
        self.positions.append(np.asarray(position, float)[:2].copy())
        caption = f"{self.label + ': ' if self.label else ''}find {self.episode.object_category}  step {self.frames}"
        frame = compose_frame(rgb.astype(np.uint8), self._panel.draw(self.positions, float(yaw)), caption)
        if self._writer is None:
            self._size = (frame.shape[1], frame.shape[0])
            self._tmp.parent.mkdir(parents=True, exist_ok=True)
            self._writer = imageio_ffmpeg.write_frames(str(self._tmp), self._size, fps=self.fps, codec="libx264",
                                                       pix_fmt_out="yuv420p", quality=7, macro_block_size=BLOCK,
                                                       ffmpeg_log_level="error",
                                                       output_params=["-preset", "veryfast", "-movflags", "+faststart"])
            self._writer.send(None)
        self._writer.send(np.ascontiguousarray(frame).tobytes())
        self.frames += 1

    def close(self) -> Path:
        """Finish the file and move it to `path`; return `path` (ValueError when no frame was added)."""
        if self._writer is None:
            raise ValueError(f"{self.path}: no frame was added")
        self._writer.close()
        self._writer = None
        os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Stop writing and remove the partial file."""
        if self._writer is not None:
            try:
                self._writer.close()
            finally:
                self._writer = None
        self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> "EpisodeVideo":
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def write_episode_video(path: str | Path, frames: Sequence[np.ndarray], positions: Sequence[Any], yaws: Sequence[float],
                        navmap: NavMap, episode: Episode, fps: int = FPS, label: str = "") -> Path:
    """Write an episode's video: frame k is view k beside the map with the path up to pose k; return `path`.

    Parameters
    ----------
    path
        The MP4 to write.
    frames
        The agent's RGB views, (H, W, 3) uint8 each: after reset and after every step (steps + 1).
    positions
        The agent's base position (world XY or XYZ, m) at each frame.
    yaws
        The agent's heading (deg, about +Z from +X) at each frame.
    navmap
        The episode floor's navigable map.
    episode
        The episode (goals, view points, start, goal category).
    fps
        Frames per second.
    label
        Text before the goal category in the caption (e.g. the agent's name).
    """
    if not (len(frames) == len(positions) == len(yaws)) or not len(frames):
        raise ValueError(f"need one position and yaw per frame, got {len(frames)} frames, {len(positions)} positions, "
                         f"{len(yaws)} yaws")
    with EpisodeVideo(path, navmap, episode, fps, label) as video:
        for rgb, p, y in zip(frames, positions, yaws):
            video.add(rgb, p, y)
    return Path(path)


def read_video(path: str | Path) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Read an MP4 back (the same bundled ffmpeg): its frames, (H, W, 3) uint8 each, and ffmpeg's metadata."""
    import imageio_ffmpeg

    gen = imageio_ffmpeg.read_frames(str(path))
    meta = next(gen)
    w, h = meta["size"]
    return [np.frombuffer(b, np.uint8).reshape(h, w, 3).copy() for b in gen], meta
