"""The input check: whether a scene or object input can be used, asked once before any work (`check_inputs`) and
by the stages that read the inputs later (a resumed run whose inputs changed), with the same answers.

Bad input gets an `InputError` naming the file and what is wrong; `check_inputs` names every bad one at once.
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import InputError, InputsError
from .plugins import converter

OBJECT_SUFFIXES = (".obj", ".glb", ".gltf", ".ply", ".stl")
# An object library also takes URDF objects (assets_convert.urdf); the meshes a URDF references are its links'
# parts, not objects of their own (the converter drops them from the library).
OBJECT_LIBRARY_SUFFIXES = OBJECT_SUFFIXES + (".urdf",)
SCENE_CONFIG_SUFFIXES = (".json",)  # Habitat *.scene_instance.json / *.scene_dataset_config.json scenes

# What a readable file of each known format starts with (after leading white space for text formats).
_MAGIC = {".glb": (b"glTF",), ".gltf": (b"{",), ".ply": (b"ply",), ".stl": None, ".obj": None, ".json": (b"{",)}


def shown(path: str | Path) -> str:
    """Return a path as printable text (bytes of a non-UTF-8 name as \\x escapes)."""
    return os.fsencode(str(path)).decode("utf-8", "backslashreplace")


def input_problem(path: Path, known: tuple[str, ...]) -> str:
    """Return why one input file cannot be used ('' when it exists, is readable and looks like its format)."""
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:
        return "the file name is not UTF-8 (run folders record input names in UTF-8 JSON): rename the file"
    if not path.exists():
        return "file not found"
    if path.is_dir():
        return "is a folder, not a file"
    if path.suffix.lower() not in known:
        return f"unknown format '{path.suffix or path.name}' (known: {', '.join(known)})"
    try:
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError as e:
        return f"cannot be read ({e.strerror or e})"
    if not head:
        return "is empty (0 bytes)"
    magic = _MAGIC.get(path.suffix.lower())
    if magic and not head.lstrip().startswith(magic):
        return f"is not a {path.suffix.lower()[1:].upper()} file (it does not start with {magic[0]!r})"
    return ""


def library_files(folder: Path) -> list[Path]:
    """Return the object files of an object library folder (every file of a known object format, sorted)."""
    return [q for q in sorted(Path(folder).rglob("*")) if q.suffix.lower() in OBJECT_LIBRARY_SUFFIXES and q.is_file()]


# why an object library folder with no object file cannot be used
NO_LIBRARY_FILES = f"holds no {'/'.join(x[1:].upper() for x in OBJECT_LIBRARY_SUFFIXES)} files"


def scene_problem(path: Path) -> str:
    """Return why one scene input cannot be used ('' when usable): a file as `input_problem` judges it; a folder
    (a converted scene) is the converter's to judge (``check_scene``)."""
    return "" if path.is_dir() else input_problem(path, OBJECT_SUFFIXES + SCENE_CONFIG_SUFFIXES)


def object_files(p: Path) -> list[Path]:
    """Return the object files of one object input (a file: itself; a folder: `library_files`); raise InputError
    naming the input when it cannot be used."""
    if p.is_dir():
        found = library_files(p)
        if not found:
            raise InputError(p, NO_LIBRARY_FILES)
        return found
    why = input_problem(p, OBJECT_LIBRARY_SUFFIXES)
    if why:
        raise InputError(p, why)
    return [p]


def check_inputs(scenes: list[str] | None = None, objects: list[str] | None = None) -> None:
    """Check every scene and object input before any work; raise InputsError naming each bad one and why.

    A scene must be a readable file of a known format whose first bytes fit it, and every file it references must
    exist and parse (the converter plugin's ``check_scene``: a Habitat scene's dataset config, templates and render
    assets, an HM3D scene's semantic files, a converted scene's record); an object is such a file or a folder holding
    at least one. Mesh contents are read by the converter later (a corrupt mesh fails its scene's task).
    """
    problems: list[tuple[str, str]] = []
    check = getattr(converter(), "check_scene", None) if scenes else None
    for s in scenes or []:
        # a converted scene's folder: the converter checks it (none: it cannot be read)
        why = scene_problem(Path(s)) if check is not None else input_problem(Path(s), OBJECT_SUFFIXES + SCENE_CONFIG_SUFFIXES)
        if why:
            problems.append((f"scene {shown(s)}", why))
        elif check is not None:  # what the file references exists and parses (a dataset's templates, companions)
            try:
                check(s)
            except InputError as e:
                where = "" if e.path == shown(s) else f" ({e.path})"
                problems.append((f"scene {shown(s)}{where}", e.cause))
    for o in objects or []:
        p = Path(o)
        if p.is_dir():
            found = library_files(p)
            if not found:
                problems.append((f"objects folder {shown(o)}", NO_LIBRARY_FILES))
            problems += [(f"object {shown(q)}", w) for q in found for w in [input_problem(q, OBJECT_LIBRARY_SUFFIXES)] if w]
        else:
            why = input_problem(p, OBJECT_LIBRARY_SUFFIXES)
            if why:
                problems.append((f"object {shown(o)}", why))
    if problems:
        raise InputsError(problems)


__all__ = ["OBJECT_LIBRARY_SUFFIXES", "OBJECT_SUFFIXES", "SCENE_CONFIG_SUFFIXES", "check_inputs", "input_problem",
           "library_files", "object_files", "scene_problem", "shown"]
