"""Writers for generated homes: the way a user's scene files arrive, one module per layout.

* ``clean`` (`glb`): ``<name>.glb`` (glTF binary, **+Y up** as glTF requires, metres), one node per
  instance named ``instance_<id>`` whose mesh has one primitive per colour, each with its own
  material (wood, floor planks and tiles carry a small procedural PNG texture).
* ``scan`` (`scannet`): ``<name>_vh_clean.ply`` (one fused mesh, **+Z up**, metres, vertex colours, noise and
  holes), ``<name>_vh_clean.segs.json`` and ``<name>.aggregation.json`` (ScanNet style labels).
* both: ``<name>.semantics.json``: rooms, instances and support surfaces in the world Z-up frame (and, with
  ``world.articulated``, the URDF pieces: ``world/artplace.py``).
* ``hm3d`` (`hm3d`), ``mp3d`` (`mp3d`), ``habitat`` (`habitat`): only what a dataset of that layout holds.

Every writer is byte-deterministic: fixed float formatting, sorted JSON keys, no timestamps.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from ...store import user_cache_dir
from ..home import generate_apartment
from ..artplace import remove_articulated, write_articulated
from ..files import dumps_json, write_bytes
from ..model import Apartment
from ..presets import preset
from .glb import glb_bytes
from .habitat import write_habitat
from .hm3d import semantic_colour, write_hm3d
from .mp3d import MP3D_REGION_CODES, write_mp3d
from .scannet import ply_bytes, write_scannet

MODES = ("clean", "scan", "hm3d", "mp3d", "habitat")


def default_name(seed: int, preset_name: str = "apartment") -> str:
    """Return the default file stem of a home: ``apartment_<seed:04d>``, ``house_<seed:04d>``."""
    return f"{preset(preset_name).stem}_{int(seed):04d}"


def write_apartment(apartment: Apartment, out_dir: str | os.PathLike[str], mode: str = "clean", name: str | None = None,
                    noise_sigma: float = 0.003, max_faces: int = 300_000) -> Path:
    """Write an apartment in `mode` "clean" (GLB), "scan" (PLY + ScanNet labels), "hm3d", "mp3d" or "habitat"; return the main file.

    "clean" and "scan" also write the ``<name>.semantics.json`` sidecar; "hm3d" (`write_hm3d`), "mp3d" (`write_mp3d`)
    and "habitat" (`write_habitat`) write only what a dataset of that layout holds, so their readers get no help.

    Parameters
    ----------
    apartment : Apartment
        The generated apartment.
    out_dir : str or os.PathLike
        Output folder.
    mode : str
        "clean" (GLB, +Y up), "scan" (PLY, +Z up, ScanNet labels), "hm3d", "mp3d" or "habitat".
    name : str, optional
        File stem (default: `default_name`, ``apartment_<seed:04d>`` or ``house_<seed:04d>``).
    noise_sigma : float
        Scan mode: surface noise std along the normals, metres.
    max_faces : int
        Scan mode: about the most faces of the re-meshed scan.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    out = Path(out_dir)
    name = name or default_name(apartment.seed, apartment.preset)
    if mode == "hm3d":
        return write_hm3d(apartment, out, name)
    if mode == "habitat":
        return write_habitat(apartment, out, name)
    if mode == "mp3d":
        return write_mp3d(apartment, out, name)
    if mode == "clean":
        mesh_path = out / f"{name}.glb"
        write_bytes(mesh_path, glb_bytes(apartment, name))
        up = "+Y"
    else:
        mesh_path = write_scannet(apartment, out, name, noise_sigma, max_faces)
        up = "+Z"
    sidecar = apartment.semantics(name, mode, mesh_path.name, up)
    write_bytes(out / f"{name}.semantics.json", dumps_json(sidecar).encode())
    remove_articulated(out, name)  # an earlier write's pieces must not outlive a switch to rigid furniture
    if apartment.articulated:  # world.articulated: URDF pieces + <name>.articulated.json (world/artplace.py)
        write_articulated(apartment.articulated, out, name, {i.id: i.label for i in apartment.instances})
    return mesh_path


def default_apartment_path(seed: int = 0, out_dir: str | os.PathLike[str] | None = None, mode: str = "clean",
                           floors: int | None = None) -> Path:
    """Return the mesh path of default apartment `seed`, generating it into out_dir (or the cache) if missing."""
    if out_dir is not None:
        base = Path(out_dir)
    else:  # the shared cache; with SDOVON_CACHE=off, a per-user temporary folder
        base = user_cache_dir("world") or Path(tempfile.gettempdir()) / f"sdovon-mj-world-{os.getuid()}"
    name = default_name(seed) + ("" if floors is None else f"_f{floors}")
    path = base / (f"{name}.glb" if mode == "clean" else f"{name}_vh_clean.ply")
    if not path.exists() or not (base / f"{name}.semantics.json").exists():
        write_apartment(generate_apartment(seed, floors), base, mode, name)
    return path


__all__ = ["MODES", "MP3D_REGION_CODES", "default_apartment_path", "default_name", "dumps_json", "glb_bytes",
           "ply_bytes", "semantic_colour", "write_apartment", "write_habitat", "write_hm3d", "write_mp3d",
           "write_scannet"]
