"""Hand-written MJCF and OBJ pieces shared by the fixture writers (metres, Z up)."""

from __future__ import annotations

from typing import Sequence

import numpy as np


def num(x: float) -> str:
    """Format a number for MJCF: six significant digits, so float noise such as 2.2999999999999998 reads 2.3."""
    return f"{float(x):.6g}"


def box_geom(name: str, pos: Sequence[float], size: Sequence[float], rgba: str = "0.8 0.8 0.8 1", group: int = 0) -> str:
    """Return one visual-only MJCF box geom (no contacts) as a line of XML.

    Parameters
    ----------
    name : str
        Geom name (``inst_<k>`` for scene instances).
    pos : (3,) float
        Box centre, world metres.
    size : (3,) float
        Half extents along x, y, z, metres (MJCF's box ``size``).
    rgba : str
        Colour as MJCF writes it, four numbers in [0, 1].
    group : int
        MuJoCo geom group (0 scene, 1 ceiling, 2 object visual; see ``sim``).
    """
    p = " ".join(num(v) for v in pos)
    s = " ".join(num(v) for v in size)
    return f'<geom name="{name}" type="box" pos="{p}" size="{s}" rgba="{rgba}" group="{group}" contype="0" conaffinity="0"/>'


def corner_box_geom(name: str, lo: Sequence[float], hi: Sequence[float], rgba: str = "0.8 0.8 0.8 1", group: int = 0) -> str:
    """Return `box_geom` of the axis-aligned box between corners `lo` and `hi`.

    Parameters
    ----------
    name : str
        Geom name.
    lo, hi : (3,) float
        Minimum and maximum corners, world metres.
    rgba : str
        Colour as MJCF writes it, four numbers in [0, 1].
    group : int
        MuJoCo geom group.
    """
    lo_, hi_ = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return box_geom(name, (lo_ + hi_) / 2, (hi_ - lo_) / 2, rgba, group)


def outer_walls(size: tuple[float, float], thickness: float = 0.1) -> list[tuple[float, float, float, float]]:
    """Return the four walls outside the rectangle (0, 0)-(size) as (xmin, ymin, xmax, ymax) footprints.

    The south and north walls run past the corners by `thickness`, so the four close the room.
    """
    t = thickness
    w, h = size
    return [(-t, -t, w + t, 0.0), (-t, h, w + t, h + t), (-t, 0.0, 0.0, h), (w, 0.0, w + t, h)]


def obj_text(vertices: np.ndarray, faces: np.ndarray) -> str:
    """Return a triangle mesh as Wavefront OBJ text (vertices to 6 decimals, 1-based faces)."""
    return ("".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in np.asarray(vertices, dtype=np.float64))
            + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in np.asarray(faces, dtype=np.int64)))
