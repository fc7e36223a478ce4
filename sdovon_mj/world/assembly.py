"""Joining a home's pieces into numbered instances and one labelled, coloured triangle mesh.

A :class:`Piece` is an instance before numbering: its label, room, storey, kind, coloured mesh parts and support
surfaces (or, for an articulated piece, its placement and no parts). `assemble` numbers the pieces in order
(instance id = position) and joins their parts into one :class:`~sdovon_mj.world.model.WorldMesh`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import shapes
from .model import MATERIALS, InstanceSpec, SurfaceSpec, WorldMesh

MeshPart = tuple[shapes.Mesh, tuple[int, ...], str]  # a mesh (world metres, Z up), its RGB(A) colour and material


@dataclass(frozen=True)
class Piece:
    """An instance before numbering: its labels and coloured mesh parts (ids are given at assembly)."""

    label: str
    room: int
    floor: int
    kind: str
    parts: tuple[MeshPart, ...]
    supports: tuple[SurfaceSpec, ...] = ()
    art: tuple | None = None  # an articulated piece: (kind, seed, (x, y, z), yaw); no mesh parts


class MeshBuilder:
    """Accumulates coloured, labelled parts into one mesh."""

    def __init__(self) -> None:
        self.v: list[np.ndarray] = []
        self.f: list[np.ndarray] = []
        self.inst: list[np.ndarray] = []
        self.col: list[np.ndarray] = []
        self.mat: list[np.ndarray] = []
        self.n = 0

    def add(self, mesh: shapes.Mesh, instance: int, rgba: tuple[int, ...], material: str) -> None:
        """Append a part."""
        v, f = mesh
        m = len(f)
        self.v.append(np.asarray(v, dtype=np.float64))
        self.f.append(np.asarray(f, dtype=np.int64) + self.n)
        self.n += len(v)
        self.inst.append(np.full(m, instance, dtype=np.int32))
        c = tuple(rgba) + ((255,) if len(rgba) == 3 else ())
        self.col.append(np.tile(np.array(c, dtype=np.uint8), (m, 1)))
        self.mat.append(np.full(m, MATERIALS.index(material), dtype=np.uint8))

    def build(self) -> WorldMesh:
        """Return the accumulated mesh."""
        return WorldMesh(np.concatenate(self.v), np.concatenate(self.f), np.concatenate(self.inst),
                         np.concatenate(self.col), np.concatenate(self.mat))


def assemble(pieces: list[Piece]) -> tuple[tuple[InstanceSpec, ...], WorldMesh]:
    """Number the pieces in order (instance id = position) and join their parts into one mesh."""
    mb = MeshBuilder()
    instances = []
    for k, p in enumerate(pieces):
        instances.append(InstanceSpec(k, p.label, p.room, p.floor, p.kind, p.supports))
        for mesh, rgba, material in p.parts:
            mb.add(mesh, k, rgba, material)
    return tuple(instances), mb.build()

