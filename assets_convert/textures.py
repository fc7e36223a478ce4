"""Textures: any image trimesh/Pillow can read -> PNG (MuJoCo loads only PNG/KTX), downscaled."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np


def to_png_bytes(image: Any, max_size: int = 1024) -> bytes:
    """Return PNG bytes of a PIL image (or image file), RGB or RGBA, longest edge <= max_size."""
    from PIL import Image

    img = Image.open(image) if isinstance(image, (str, Path)) else image
    img.load()
    mode = "RGBA" if img.mode in ("RGBA", "LA", "PA") or (img.mode == "P" and "transparency" in img.info) else "RGB"
    img = img.convert(mode)
    if mode == "RGBA" and np.asarray(img)[..., 3].min() == 255:
        img = img.convert("RGB")
    if max_size and max(img.size) > max_size:
        s = max_size / max(img.size)
        img = img.resize((max(1, round(img.size[0] * s)), max(1, round(img.size[1] * s))), Image.Resampling.LANCZOS)
    buf = io.BytesIO()
    img.save(buf, format="PNG", compress_level=6)
    return buf.getvalue()


def mean_color(image: Any) -> np.ndarray:
    """Return the mean RGB (0-255) of an image (PIL image or file)."""
    from PIL import Image

    img = Image.open(image) if isinstance(image, (str, Path)) else image
    return np.asarray(img.convert("RGB"), dtype=np.float64).reshape(-1, 3).mean(axis=0)


def surface_mean_color(image: Any, vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray,
                       samples: int = 20000, seed: int = 0) -> np.ndarray:
    """Return the area-weighted mean RGB (0-255) of a texture as it lies on a mesh surface.

    Parameters
    ----------
    image : PIL.Image.Image or str or Path
        The texture image or its file.
    vertices : (N, 3) float
        Mesh vertices, metres.
    faces : (M, 3) int
        Triangle vertex indices.
    uv : (N, 2) float
        Texture coordinates per vertex (wrapped into [0, 1)).
    samples : int
        Number of surface points sampled (area-weighted).
    seed : int
        Seed of the sampling.
    """
    from PIL import Image

    img = Image.open(image) if isinstance(image, (str, Path)) else image
    arr = np.asarray(img.convert("RGB"), dtype=np.float64)
    h, w = arr.shape[:2]
    tri = vertices[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    if area.sum() <= 0:
        return mean_color(img)
    rng = np.random.default_rng(seed)
    fi = rng.choice(len(faces), size=samples, p=area / area.sum())
    r = rng.random((samples, 2))
    flip = r.sum(axis=1) > 1
    r[flip] = 1 - r[flip]
    t = uv[faces[fi]]
    p = t[:, 0] + r[:, :1] * (t[:, 1] - t[:, 0]) + r[:, 1:] * (t[:, 2] - t[:, 0])
    p = p % 1.0
    col = np.clip((p[:, 0] * w).astype(int), 0, w - 1)
    row = np.clip(((1.0 - p[:, 1]) * h).astype(int), 0, h - 1)
    return arr[row, col].mean(axis=0)
