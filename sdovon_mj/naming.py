"""Names made from file names: the one rule for a safe name and for a scene's name from its input file.

The core names a run's scenes (`stages.name_scenes`) and the converter names the folder it writes
(`assets_convert.scene.convert_scene`), finds a scene's sidecars (``<stem>.semantics.json``,
``<stem>.articulated.json``) and names objects (`assets_convert.naming`): all of them use these functions, so a
scene file gives one name and one folder whatever reads it (``van-gogh-room.mesh.ply`` -> ``van-gogh-room_mesh``).
"""

from __future__ import annotations

import hashlib
import re
import unicodedata
from pathlib import Path

# Latin letters that Unicode does not decompose into an ASCII letter and a mark
_LATIN = str.maketrans({"ß": "ss", "æ": "ae", "Æ": "AE", "ø": "o", "Ø": "O", "œ": "oe", "Œ": "OE", "ł": "l", "Ł": "L",
                        "đ": "d", "Đ": "D", "þ": "th", "Þ": "Th", "ð": "d", "Ð": "D", "ı": "i"})

# Suffixes that name a scene file's format or dataset layout, not the scene: Habitat configs (whole file names),
# then, after the extension, HM3D's ``.basis`` (``<id>.basis.glb``) and ScanNet's mesh suffixes
# (``<scene>_vh_clean_2.ply``, the decimated mesh; ``<scene>_vh_clean.ply``, the full one).
CONFIG_SUFFIXES = (".scene_instance.json", ".scene_dataset_config.json", ".stage_config.json")
STEM_SUFFIXES = (".basis", "_vh_clean_2", "_vh_clean")


def sanitize(name: str, fallback: str = "object") -> str:
    """Return a name safe for MJCF and file names ([A-Za-z0-9_-]): accented Latin letters lose their marks
    (``Café`` -> ``Cafe``, ``groß`` -> ``gross``), other characters (dots, spaces) become ``_``; `fallback` when
    none is left."""
    s = unicodedata.normalize("NFKD", str(name).translate(_LATIN)).encode("ascii", "ignore").decode("ascii")
    s = re.sub(r"[^A-Za-z0-9_\-]+", "_", s).strip("_")
    return s or fallback


def scene_stem(path: str | Path) -> str:
    """Return the text of a scene file's name without its format's suffixes, as the file system spells it.

    Habitat configs lose their config suffix (``apt_0.scene_instance.json`` -> ``apt_0``); other files lose their
    extension, then HM3D's ``.basis`` and ScanNet's ``_vh_clean_2`` / ``_vh_clean`` (``scene0470_00_vh_clean_2.ply``
    -> ``scene0470_00``). Other dots stay (``van-gogh-room.mesh.ply`` -> ``van-gogh-room.mesh``): sidecars beside
    the file are found under this stem.
    """
    n = Path(path).name
    for suffix in CONFIG_SUFFIXES:
        if n.lower().endswith(suffix) and len(n) > len(suffix):
            return n[: -len(suffix)]
    stem = Path(n).stem
    for suffix in STEM_SUFFIXES:
        if stem.lower().endswith(suffix) and len(stem) > len(suffix):
            return stem[: -len(suffix)]
    return stem


def scene_name(path: str | Path) -> str:
    """Return a scene's name from its input: `sanitize` of `scene_stem` (a folder, a converted scene: its name).

    A stem with no ASCII letter or digit (``客厅.ply``) becomes ``scene_<8 hex digits>``, the digits from the stem's
    text (NFC), so two such files stay apart and each keeps its name from run to run.
    """
    p = Path(path)
    text = unicodedata.normalize("NFC", p.name if p.is_dir() else scene_stem(p))
    name = sanitize(text, fallback="")
    if name:
        return name
    return f"scene_{hashlib.sha1(text.encode('utf-8')).hexdigest()[:8]}" if text.strip() else "scene"


def name_scenes(paths: list[str]) -> dict[str, str]:
    """Return scene name -> input for a list of scene inputs: `scene_name` of each, a second scene of one name
    ``_2``, ``_3``, ... in input order (two ``room.ply`` in two folders: ``room``, ``room_2``; a name already taken
    by an earlier input is skipped)."""
    out: dict[str, str] = {}
    for path in paths:
        name = scene_name(path)
        base, k = name, 1
        while name in out:
            k += 1
            name = f"{base}_{k}"
        out[name] = path
    return out


__all__ = ["CONFIG_SUFFIXES", "STEM_SUFFIXES", "name_scenes", "sanitize", "scene_name", "scene_stem"]
