"""Names from files and nodes: object names and categories guessed from paths, labels from scene node names.

One home for the naming rules every converter shares (objects, URDF objects, scenes, dataset readers), so none
of them imports another's module for them.
"""

from __future__ import annotations

import json
import os
import re
import unicodedata
from pathlib import Path
from typing import TYPE_CHECKING

from sdovon_mj.naming import sanitize  # the one safe-name rule, shared with the core (scene names)

if TYPE_CHECKING:
    from .metadata import AssetMeta

# Bulk densities (kg/m^3) of the solid hull volume: hollow things (boxes, bins, furniture) are light.
DENSITIES: dict[str, float] = {
    "apple": 800, "ball": 150, "banana": 900, "bin": 150, "book": 700, "bottle": 800, "bowl": 700,
    "bread": 250, "cabinet": 350, "can": 900, "chair": 250, "cup": 700, "cushion": 60, "donut": 400,
    "food_box": 250, "fruit": 900, "keyboard": 600, "lamp": 300, "laptop": 1200, "mug": 700,
    "pillow": 60, "plant": 400, "plate": 1500, "power_drill": 900, "remote": 900, "shelf": 300,
    "shoe": 400, "sofa": 120, "stool": 350, "table": 350, "tea_set": 700, "teddy_bear": 80,
    "toy": 300, "toy_block": 80, "vase": 900,
}
GENERIC_STEMS = {"textured", "model", "mesh", "object", "untitled", "scene", "visual", "model_normalized",
                 "mobility"}  # PartNet-Mobility: <id>/mobility.urdf


def density_for(category: str, default: float = 500.0) -> float:
    """Return the bulk density (kg/m^3) of a category (default when unknown)."""
    key = re.sub(r"[\s\-]+", "_", category.strip().lower())
    if key in DENSITIES:
        return float(DENSITIES[key])
    last = key.split("_")[-1]
    return float(DENSITIES.get(last, default))


# Folders that hold a model's files rather than name it (YCB <name>/google_16k/textured.obj, Google Scanned Objects
# <name>/meshes/model.obj): a generic file stem takes its name from the first folder above them
GENERIC_DIRS = {"meshes", "mesh", "models", "model", "obj", "objs", "geometry", "visual", "visuals", "textured",
                "google_16k", "google_64k", "google_512k", "poisson", "tsdf", "normalized", "glb", "gltf"}


def default_name(path: Path) -> str:
    """Return an object name from a file path (the folder name for generic stems like textured.obj).

    The folder is the first one up that is not a container like ``meshes/`` or ``google_16k/`` (`GENERIC_DIRS`), so
    ``Panda/meshes/model.obj`` is ``Panda`` and ``002_master_chef_can/google_16k/textured.obj`` is
    ``002_master_chef_can``; two inputs that still end with one name are told apart by `convert_tree`.
    """
    return sanitize(_name_text(Path(path)))


def _name_text(path: Path) -> str:
    """Return the text `default_name` makes a name of, as the file system spells it (not yet `sanitize`d)."""
    stem = path.stem
    if stem.lower() in GENERIC_STEMS:
        for anc in list(path.parents)[:3]:
            if anc.name and anc.name.lower() not in GENERIC_DIRS:
                return anc.name
        return path.parent.name
    if stem.lower().endswith("_1k"):
        return re.sub(r"_1k$", "", stem)
    return stem


def category_label(text: str) -> str:
    """Return a category guessed from a file or folder name as goal text is written: lower case, words joined by one
    underscore, letters of every script kept (``Coffee Mug`` and ``coffee-mug`` -> ``coffee_mug``, ``PowerDrill`` ->
    ``power_drill``, ``Tasse groß`` -> ``tasse_groß``; empty when the text has no letter or digit).

    A word boundary inside a name written in camel case counts where two lower-case letters meet an upper-case one
    followed by a lower-case one (``PowerDrill``; not ``iPad`` or ``USBStick``). Case variants of one category in a
    library (``Mug.obj``, ``mug_2.glb``) so become one category.
    """
    s = unicodedata.normalize("NFC", str(text))
    s = re.sub(r"(?<=[a-z]{2})(?=[A-Z][a-z])", "_", s)
    return re.sub(r"[\W_]+", "_", s.lower()).strip("_")


def object_name(path: str | Path, name: str | None = None) -> str:
    """Return the name a conversion of `path` gives its object (its folder under objects/): `name` when given,
    else `default_name` (a URDF's file stem, or its folder's name for a generic stem such as PartNet-Mobility's
    ``<id>/mobility.urdf``)."""
    path = Path(path)
    if name:
        return sanitize(name)
    return default_name(path)


def meta_json_category(path: str | Path) -> str | None:
    """Return the category a ``meta.json`` beside an object file names: its ``category``, else PartNet-Mobility's
    ``model_cat`` in snake case (``StorageFurniture`` -> ``storage_furniture``); None when there is none."""
    meta = Path(path).parent / "meta.json"
    if not meta.is_file():
        return None
    try:
        doc = json.loads(meta.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError, UnicodeDecodeError):
        return None
    if not isinstance(doc, dict):
        return None
    if doc.get("category"):
        return str(doc["category"])
    if isinstance(doc.get("model_cat"), str) and doc["model_cat"].strip():
        return re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", doc["model_cat"].strip()).replace(" ", "_").lower()
    return None


def default_category(path: Path, root: str | Path | None = None) -> str:
    """Return a category guess for an object file: the category ``meta.json`` beside it names
    (`meta_json_category`), else its grandparent folder's name (``<category>/<name>/<file>``; YCB
    ``<name>/google_16k/textured.obj`` and GSO ``<name>/meshes/model.obj`` give the object's name), a leading numeric
    id such as YCB's '002_' dropped.

    ``root``: the library folder the file was found in (default: the file's own folder, as for one file converted
    alone). The grandparent counts only when it lies inside that folder; otherwise (a flat library ``lib/mug.obj``,
    one folder per object ``lib/mug/model.obj``, a single file) the guess is the object's own name (`default_name`'s
    text) without a numeric id before it or an instance number after it (``chair_01`` -> ``chair``): the library
    folder (or a folder above it) names no category. A guessed name is written as `category_label` writes it
    (``Coffee Mug`` -> ``coffee_mug``); a category ``meta.json`` names is kept as written.
    """
    path = Path(path)
    cat = meta_json_category(path)
    if cat:
        return cat
    folder = path.parent.parent
    root = path.parent if root is None else root
    inside = os.path.abspath(folder).startswith(os.path.abspath(root).rstrip(os.sep) + os.sep)
    name = (folder.name or path.parent.name) if inside else _name_text(path)
    name = re.sub(r"^\d+[\W_]+(?=[^\W\d_])", "", name) or name
    if not inside:
        name = re.sub(r"(?<=[^\W\d_])[\W_]*\d+[\W_]*$", "", name) or name  # chair_01, mug (2)
    return category_label(name) or "object"


def library_category(path: str | Path, library: str | Path | None = None, meta: AssetMeta | None = None) -> str | None:
    """Return the category converting an object file gives it when none is named: ``assets.yaml`` metadata (`meta`,
    `metadata.meta_for`'s answer when the caller has it), else `default_category` with the library folder it was found
    in; None for a part of a multi-part object (its group's category applies)."""
    from .metadata import meta_for

    meta = meta if meta is not None else meta_for(Path(path))
    if meta.multipart is not None:
        return None
    return meta.category or default_category(Path(path), library)


LABEL_RULES = 2  # version of `label_from_node` (part of the cache key of scenes labelled by node names)
PRIMITIVES = frozenset({"box", "cube", "cuboid", "cylinder", "sphere", "capsule", "plane", "mesh", "geom", "ellipsoid",
                        "cone", "torus", "prism", "primitive", "shape", "quad"})


def label_from_node(node: str) -> str:
    """Return a category label from a node or file name, normalised as artists name parts.

    'frl_apartment_chair_05' -> 'frl apartment chair'; 'Cube.001' -> 'cube'; 'mug_Cylinder.002' -> 'mug'; a fixture
    name with a number followed by a part name and a primitive type, 'stove1 burner box' or
    'kitchen_cabinet_2_door_cylinder', -> 'stove', 'kitchen cabinet': the name ends at its first numbered word when
    more words follow it (they name a part of that numbered fixture), and a trailing capitalised primitive name
    (Box, Cylinder, Mesh, ... as modelling tools name new primitives) goes when a word is left ('cracker box' stays).
    """
    s = re.sub(r"\.\d+$", "", node)
    s = re.sub(r"[_\-\s]*[0-9a-f]{6}$", "", s) if re.search(r"_[0-9a-f]{6}$", s) else s
    s = re.sub(r"(\d)\.\d+(?=[_\-\s]|$)", r"\1", s)  # Blender duplicates inside: 'Shelf_03.002_Cube' -> 'Shelf_03_Cube'
    raw = re.sub(r"[_\-]+", " ", s).split()
    words = [w.lower() for w in raw]
    for k, w in enumerate(words[:-1]):
        m = re.fullmatch(r"([a-z][a-z ]*?)?\d+", w)
        if m and (m.group(1) or k > 0):
            words, raw = words[:k] + ([m.group(1)] if m.group(1) else []), raw[:k] + ([m.group(1)] if m.group(1) else [])
            break
    # a trailing primitive name written as a modelling tool names a new primitive ('mug_Cylinder') is no category
    while len(words) > 1 and words[-1] in PRIMITIVES and raw[-1][:1].isupper():
        words.pop()
        raw.pop()
    s = re.sub(r"\s*\d+$", "", " ".join(words)).strip()
    return s or "object"
