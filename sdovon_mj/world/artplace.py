"""Articulated furniture in the default apartments (``world.articulated``): placement proxies and the written pieces.

With the switch on, the room programs (``world/programs.py``) draw some pieces as articulated ones: kitchens get a
base cabinet with hinged doors (a microwave on its top) and an articulated fridge, bedrooms an articulated dresser
and wardrobe, living/dining rooms and offices articulated dressers, bathrooms often a base cabinet. During layout an articulated piece is a
:func:`proxy` (a furniture `Model` with the piece's bounding box and no visible parts) that the room placement
treats like any other piece; it adds no triangles to the apartment mesh. Its instance id, pose and seed are kept
as an :class:`~sdovon_mj.world.model.ArticulatedInstance` in ``Apartment.articulated``.

:func:`write_articulated` writes, beside the scene file, ``<name>.articulated/<kind>_<id>/<kind>_<id>.urdf`` (+
``meshes/``) built by ``world.articulated.BUILDERS`` from the piece's own seed, and the sidecar
``<name>.articulated.json`` (format ``sdovon-articulated/1``) listing each piece: instance id, label, room, floor,
URDF path (relative to the sidecar), world pose (position of the URDF root frame, m, Z up; yaw in degrees about
+Z), its movable joints and its interior surfaces (local frame) with the joint that closes each.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from . import shapes
from .articulated import BUILDERS, draw_size
from .files import dumps_json, num
from .furniture import Model
from .model import ArticulatedInstance

FORMAT = "sdovon-articulated/1"
LABELS = {"cabinet": "cabinet", "dresser": "dresser", "wardrobe": "wardrobe", "fridge": "fridge",
          "microwave": "microwave"}


def proxy(kind: str, rng: np.random.Generator, lift: float = 0.0) -> Model:
    """Return a layout proxy of an articulated piece of `kind`: its bounding box as a `Model` (one draw from `rng`).

    `lift` (m) raises the piece above the floor (a microwave on a cabinet top). The piece's own generator is seeded
    by one integer drawn from `rng`, so the written URDF and the proxy agree.
    """
    if kind not in BUILDERS:
        raise ValueError(f"unknown articulated kind {kind!r} (known: {', '.join(sorted(BUILDERS))})")
    seed = int(rng.integers(0, 2**31 - 1))
    w, d, h = draw_size(np.random.default_rng(seed), kind)
    m = Model(LABELS[kind], "receptacle", [], w, d, h + lift)
    m.add(shapes.box((-w / 2, 0.0, lift), (w / 2, d, lift + h)), (0, 0, 0))  # bounds only: never meshed
    m.articulated = (kind, seed, float(lift))  # type: ignore[attr-defined]
    return m


def is_proxy(m: Model) -> bool:
    """Whether a model is an articulated proxy (see `proxy`)."""
    return getattr(m, "articulated", None) is not None


def write_articulated(pieces: tuple[ArticulatedInstance, ...] | list[ArticulatedInstance], out_dir: str | os.PathLike[str],
                      name: str, labels: dict[int, str]) -> list[Path]:
    """Write each piece's URDF + meshes and the ``<name>.articulated.json`` sidecar into `out_dir`; return the files.

    `labels` maps instance id -> label (the apartment's instance labels). Nothing is written for no pieces.
    """
    from ..store import atomic_write_text

    if not pieces:
        return []
    out = Path(out_dir)
    folder = out / f"{name}.articulated"
    entries, files = [], []
    for p in pieces:
        stem = f"{p.kind}_{p.id}"
        model = BUILDERS[p.kind](np.random.default_rng(p.seed), folder / stem, name=stem)
        files.append(model.urdf)
        files += sorted((folder / stem / "meshes").glob("*.obj"))
        entries.append({
            "id": int(p.id), "kind": p.kind, "label": labels.get(p.id, LABELS[p.kind]), "room": int(p.room),
            "floor": int(p.floor), "urdf": model.urdf.relative_to(out).as_posix(),
            "position": [num(v) for v in p.position], "yaw": int(p.yaw),
            "size": [num(model.width), num(model.depth), num(model.height)],
            "joints": list(model.joints),
            "interiors": [{"height": num(i.height), "polygon": [[num(a), num(b)] for a, b in i.polygon],
                           "joint": i.joint, "link": i.link} for i in model.interiors],
        })
    sidecar = out / f"{name}.articulated.json"
    atomic_write_text(sidecar, dumps_json({"format": FORMAT, "name": name, "pieces": entries}))
    return [sidecar, *files]


def remove_articulated(out_dir: str | os.PathLike[str], name: str) -> None:
    """Remove ``<name>.articulated.json`` and ``<name>.articulated/`` from `out_dir` if present."""
    import shutil

    out = Path(out_dir)
    (out / f"{name}.articulated.json").unlink(missing_ok=True)
    if (out / f"{name}.articulated").is_dir():
        shutil.rmtree(out / f"{name}.articulated")


__all__ = ["ArticulatedInstance", "FORMAT", "is_proxy", "proxy", "remove_articulated", "write_articulated"]
