"""A small cluttered room as a scene file (GLB, Y up as glTF has it, one node per instance named by its label), for
tests of small floors: the coverage sampler's stall rules, the navigable-area refusal and its hint, receptacle
labels that match none of the defaults.

The room is `size` x `size` m inside 0.1 m walls, 2.4 m high, no ceiling (the renders need no light from
outside then). The clutter: a table (0.75 m top on four thin legs) in one corner, a sofa along one wall, a crate
and a chair; what is left of the floor is one small navigable component.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def small_room_boxes(size: float = 2.0, labels: dict[str, str] | None = None) -> list[tuple[str, tuple, tuple]]:
    """Return the room's boxes: (label, min corner, max corner), Z up, metres; `labels` renames the furniture
    (``table``, ``sofa``, ``crate``, ``chair``)."""
    name = {"table": "table", "sofa": "sofa", "crate": "crate", "chair": "chair", **(labels or {})}
    s, t, h = float(size), 0.1, 2.4
    out = [("floor", (-t, -t, -0.1), (s + t, s + t, 0.0)),
           ("wall", (-t, -t, 0.0), (s + t, 0.0, h)), ("wall", (-t, s, 0.0), (s + t, s + t, h)),
           ("wall", (-t, 0.0, 0.0), (0.0, s, h)), ("wall", (s, 0.0, 0.0), (s + t, s, h))]
    tx, ty, tw, td = s - 0.8, s - 0.6, 0.8, 0.6  # the table in the +X +Y corner
    out.append((name["table"], (tx, ty, 0.71), (tx + tw, ty + td, 0.75)))
    for lx, ly in ((tx, ty), (tx + tw - 0.04, ty), (tx, ty + td - 0.04), (tx + tw - 0.04, ty + td - 0.04)):
        out.append((name["table"], (lx, ly, 0.0), (lx + 0.04, ly + 0.04, 0.71)))
    out.append((name["sofa"], (0.0, 0.0, 0.0), (0.8, s - 0.2, 0.45)))  # along the -X wall
    out.append((name["crate"], (s - 0.45, 0.0, 0.0), (s, 0.4, 0.4)))
    out.append((name["chair"], (s - 1.2, s - 0.45, 0.0), (s - 0.8, s - 0.05, 0.9)))
    return out


def write_small_room(path: str | Path, size: float = 2.0, labels: dict[str, str] | None = None) -> Path:
    """Write the small cluttered room as a GLB at `path` (one node per box, named ``<label>_<k>``); return the path."""
    import trimesh

    scene = trimesh.Scene()
    to_y_up = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]], dtype=float)  # Z up -> glTF Y up
    for k, (label, lo, hi) in enumerate(small_room_boxes(size, labels)):
        lo_, hi_ = np.asarray(lo, float), np.asarray(hi, float)
        m = trimesh.creation.box(extents=hi_ - lo_)
        m.apply_translation((lo_ + hi_) / 2)
        m.apply_transform(to_y_up)
        scene.add_geometry(m, node_name=f"{label}_{k}", geom_name=f"{label}_{k}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(scene.export(file_type="glb"))
    return path
