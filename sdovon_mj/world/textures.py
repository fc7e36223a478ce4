"""Small procedural textures (wood grain, floor planks, tiles) and a deterministic PNG encoder.

Textures are light grey-scale patterns meant to be tinted by a material's base colour, so one
image serves every wood colour. Pixels depend only on fixed seeds: the bytes never change.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

# texture name -> metres per texture repeat (UV scale)
TEXTURE_SCALE: dict[str, float] = {"wood": 0.5, "floor_wood": 1.0, "floor_tile": 0.6}


def png_bytes(img: np.ndarray) -> bytes:
    """Encode an (H, W, 3|4) uint8 image as a PNG (no filters, zlib level 9, no metadata)."""
    img = np.ascontiguousarray(img, dtype=np.uint8)
    h, w, c = img.shape
    colour_type = {3: 2, 4: 6}[c]
    raw = b"".join(b"\x00" + img[y].tobytes() for y in range(h))

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def _to_rgb(v: np.ndarray) -> np.ndarray:
    """Map a [0, 1] grey image to uint8 RGB."""
    g = np.clip(np.round(v * 255.0), 0, 255).astype(np.uint8)
    return np.repeat(g[:, :, None], 3, axis=2)


def wood(size: int = 64) -> np.ndarray:
    """Return a wood-grain texture (grain along the image x axis)."""
    rng = np.random.default_rng(101)
    y, x = np.mgrid[0:size, 0:size] / size
    warp = 0.06 * np.sin(2 * np.pi * x) + 0.03 * np.sin(2 * np.pi * (2 * x + 0.3))
    grain = 0.5 + 0.5 * np.sin(2 * np.pi * 7.0 * (y + warp))
    v = 0.86 + 0.08 * grain ** 3 + rng.normal(0.0, 0.015, (size, size))
    return _to_rgb(v)


def planks(size: int = 128) -> np.ndarray:
    """Return floor planks: four boards per repeat with seams and staggered joints."""
    rng = np.random.default_rng(202)
    y, x = np.mgrid[0:size, 0:size] / size
    board = np.floor(y * 4).astype(int)
    shade = np.array([0.0, -0.05, 0.03, -0.02])[board]
    grain = 0.5 + 0.5 * np.sin(2 * np.pi * (24.0 * y + 0.8 * np.sin(2 * np.pi * x) + board * 0.37))
    v = 0.88 + shade + 0.05 * grain + rng.normal(0.0, 0.012, (size, size))
    seam = (np.mod(y * 4, 1.0) < 1.5 / size * 4)
    joint = np.abs(np.mod(x + board * 0.37, 1.0) - 0.5) < 0.8 / size
    v[seam | joint] = 0.55
    return _to_rgb(v)


def tiles(size: int = 64) -> np.ndarray:
    """Return square tiles (two by two per repeat) with grout lines."""
    rng = np.random.default_rng(303)
    y, x = np.mgrid[0:size, 0:size] / size
    v = 0.95 + rng.normal(0.0, 0.01, (size, size))
    grout = (np.mod(x * 2, 1.0) < 2.0 / size) | (np.mod(y * 2, 1.0) < 2.0 / size)
    v[grout] = 0.72
    return _to_rgb(v)


def texture_png(name: str) -> bytes:
    """Return the PNG bytes of a named texture (wood, floor_wood, floor_tile)."""
    img = {"wood": wood, "floor_wood": planks, "floor_tile": tiles}[name]()
    return png_bytes(img)


def triplanar_uv(tri: np.ndarray, scale: float) -> np.ndarray:
    """Return per-corner UVs (M, 3, 2) for Z-up triangles (M, 3, 3) by projecting on the dominant axis."""
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    axis = np.argmax(np.abs(n), axis=1)
    uv = np.empty(tri.shape[:2] + (2,), dtype=np.float64)
    pairs = {0: (1, 2), 1: (0, 2), 2: (0, 1)}
    for a, (i, j) in pairs.items():
        m = axis == a
        uv[m, :, 0] = tri[m][:, :, i]
        uv[m, :, 1] = tri[m][:, :, j]
    return uv / scale
