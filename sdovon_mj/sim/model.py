"""Naming contract between converted scenes, placed objects and segmentation.

- Scene instance k: geoms named ``inst_<k>`` or ``inst_<k>_<j>`` (one per material).
- Placed object ``obj_<n>`` (Placement.object_id): a body named ``obj_<n>`` whose geoms are named
  ``obj_<n>/...``; its segmentation id is ``OBJECT_ID_BASE + n``.
- Scene mesh sidecar (SceneAsset.mesh): an npz with ``vertices`` (N, 3) float32 metres Z-up,
  ``faces`` (M, 3) int32 and ``face_instance`` (M,) int32 (-1 = no instance).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

import mujoco

OBJECT_ID_BASE = 1_000_000
_INST = re.compile(r"^inst_(\d+)(?:_\d+)?$")
_OBJ = re.compile(r"^obj_(\d+)(?:/.*)?$")


def instance_geom_name(instance_id: int, part: int | None = None) -> str:
    """Return the geom name of a scene instance (part = material index, optional)."""
    return f"inst_{instance_id}" if part is None else f"inst_{instance_id}_{part}"


def object_segment_id(object_id: str) -> int:
    """Return the segmentation id of a placed object named like 'obj_007'."""
    m = _OBJ.match(object_id)
    if not m:
        raise ValueError(f"object id {object_id!r} is not of the form obj_<n>")
    return OBJECT_ID_BASE + int(m.group(1))


def geom_segment_ids(model: mujoco.MjModel) -> np.ndarray:
    """Return geom id -> segmentation id (scene instance id, OBJECT_ID_BASE + n, or -1)."""
    out = np.full(model.ngeom, -1, dtype=np.int64)
    for g in range(model.ngeom):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
        m = _INST.match(name)
        if m:
            out[g] = int(m.group(1))
            continue
        body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g])) or ""
        m = _OBJ.match(name) or _OBJ.match(body)
        if m:
            out[g] = OBJECT_ID_BASE + int(m.group(1))
    return out


def label_table(lut: np.ndarray) -> np.ndarray:
    """Return the int32 table `lut` (per geom id) with -1 appended: indexed by a geom id, or by -1 for no geom."""
    ext = np.empty(len(lut) + 1, dtype=np.int32)
    ext[:-1] = lut
    ext[-1] = -1
    return ext


def segment_image(geom_ids: np.ndarray, lut: np.ndarray) -> np.ndarray:
    """Map a geom-id image (-1 = none) to a segmentation-id image with lookup table `lut`."""
    return label_table(lut).take(np.maximum(geom_ids, -1))  # every negative id reads the appended -1


def load_scene_mesh(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Load a scene mesh sidecar: vertices (N,3), faces (M,3), face_instance (M,)."""
    with np.load(Path(path), allow_pickle=False) as z:
        return np.asarray(z["vertices"], dtype=np.float64), np.asarray(z["faces"], dtype=np.int64), np.asarray(z["face_instance"], dtype=np.int64)


def save_scene_mesh(path: str | Path, vertices: np.ndarray, faces: np.ndarray, face_instance: np.ndarray) -> None:
    """Write a scene mesh sidecar atomically and deterministically."""
    import io

    from ..records import _savez_deterministic
    from ..store import atomic_write_bytes

    buf = io.BytesIO()
    _savez_deterministic(buf, {"vertices": np.asarray(vertices, np.float32), "faces": np.asarray(faces, np.int32),
                               "face_instance": np.asarray(face_instance, np.int32)})
    atomic_write_bytes(Path(path), buf.getvalue())


def pose_settled(model: mujoco.MjModel, data: mujoco.MjData, qpos: np.ndarray | None, source: str | Path) -> None:
    """Set a variant's settled qpos on `data` and run forward kinematics (InputError naming `source` on a size mismatch)."""
    from ..errors import InputError

    if qpos is not None:
        q = np.asarray(qpos, dtype=float).ravel()
        if q.size != model.nq:
            raise InputError(source, f"qpos has {q.size} values, model has nq={model.nq}")
        data.qpos[:] = q
    mujoco.mj_forward(model, data)
