"""The converter plugin: what the pipeline core asks of a mesh converter (entry-point group ``sdovon_mj.converters``).

The core never imports ``assets_convert`` modules; it loads this class through ``sdovon_mj.plugins`` (kind
``converter``, name ``mesh``) and calls the four members below. A third-party converter (another CoACD
setting, a different scene reader) ships a class with the same members under its own entry point and is
chosen with ``convert.converter``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path
from typing import Any

from sdovon_mj.config import ConvertConfig
from sdovon_mj.records import ObjectAsset, SceneAsset, save_json
from sdovon_mj.store import atomic_write_text, dumps


def provenance(path: str | Path, out_root: str | Path) -> str:
    """Return the source recorded for an input: relative to the run folder when inside it, else its full path.

    Inputs the run wrote itself (the default world) are then named the same wherever the run folder lives and
    whichever run first filled the conversion cache, so a run's bytes do not depend on either.
    """
    from .load import display_path

    p, root = Path(path).resolve(), Path(out_root).resolve()
    return p.relative_to(root).as_posix() if p.is_relative_to(root) else display_path(path)


def _urdf_linked(paths: list[Path]) -> set[str]:
    """Return (real paths of) the mesh files the URDFs among `paths` reference."""
    import os

    from .urdf import urdf_mesh_files

    return {os.path.realpath(m) for p in paths if Path(p).suffix.lower() == ".urdf" for m in urdf_mesh_files(p)}


class MeshConverter:
    """OBJ / GLB / glTF / PLY / STL objects and scenes -> MJCF (CoACD hulls for objects, visual-only scenes); URDF
    articulated objects -> MJCF bodies with hinge/slide joints (`assets_convert.urdf`)."""

    name = "mesh"

    @property
    def version(self) -> str:
        """Return the converter's output version (a new one invalidates converted scenes and objects)."""
        from .cache import CONVERTER_VERSION

        return CONVERTER_VERSION

    def convert_scene(self, path: str | Path, out_root: str | Path, name: str, cfg: ConvertConfig) -> SceneAsset:
        """Convert one scene file into ``<out_root>/scenes/<name>/`` and return its SceneAsset; a converted scene's
        folder (`scene_files`) is used as it is (its files linked in, nothing converted again)."""
        from .scene import convert_scene, link_converted

        if Path(path).is_dir():
            asset = link_converted(path, out_root, name)
            atomic_write_text(Path(out_root) / "scenes" / name / "asset.json", asset.to_json())
            return asset
        asset = convert_scene(Path(path), out_root, name=name, units=cfg.units, up=cfg.up,
                              texture_max_size=cfg.texture_max_size, add_floor=cfg.add_floor)
        asset.source = provenance(path, out_root)
        atomic_write_text(Path(out_root) / "scenes" / name / "asset.json", asset.to_json())
        return asset

    def convert_library(self, items: list[tuple[Path, str | None]], out_root: str | Path,
                        cfg: ConvertConfig) -> tuple[list[ObjectAsset], dict[str, str]]:
        """Convert object files into ``<out_root>/objects/<name>/`` (+ object.json); return (assets, failures).

        CoACD runs in `convert_tree`'s process pool (``cfg.jobs`` workers, ``cfg.timeout_s`` per object: a stuck
        decomposition is killed and reported, one bad object is reported and the library goes on) into a scratch
        folder, so its batch report and a killed worker's temp folder stay out of ``out_root``; each converted
        object is then hard-linked into ``out_root``. ``items`` are (file, category or None); failures map a
        file to its error. Assets are sorted by name.
        """
        from .cache import link_tree
        from .load import display_path
        from .objcache import load_converted
        from .tree import convert_tree

        assets: list[ObjectAsset] = []
        failures: dict[str, str] = {}
        with tempfile.TemporaryDirectory(prefix="sdovon-objects-") as scratch:
            report = convert_tree([p for p, _c in items], scratch, jobs=cfg.jobs, timeout=cfg.timeout_s,
                                  progress=None, config=cfg, categories={str(p): c for p, c in items if c})
            rows = {r["file"]: r for r in report["items"]}
            for r in report["items"]:  # a multi-part object (assets.yaml) answers for each of its part files
                rows.update({part: r for part in r.get("parts", [])})
            done: set[str] = set()
            linked = _urdf_linked([p for p, _c in items])
            for path, _category in items:
                if display_path(path) not in rows and os.path.realpath(path) in linked:
                    continue  # a mesh of a URDF's link: part of that articulated object
                row = rows[display_path(path)]
                if row["status"] != "ok":
                    failures[str(path)] = str(row["error"])
                    continue
                if row["name"] in done:
                    continue
                done.add(row["name"])
                asset = load_converted(scratch, row["name"])
                dst = Path(out_root) / "objects" / asset.name
                link_tree(Path(scratch) / "objects" / asset.name, dst)
                # the cached record names the input of the conversion that filled the cache: name this run's
                # (a multi-part object: its folder); rewriting replaces the hard link, the cache entry stays
                asset.source = provenance(Path(path).parent if row.get("parts") else path, out_root)
                stored = json.loads((dst / "asset.json").read_text(encoding="utf-8"))
                stored["source"] = asset.source
                atomic_write_text(dst / "asset.json", dumps(stored))
                save_json(asset, dst / "object.json")
                assets.append(asset)
        assets.sort(key=lambda a: a.name)
        return assets, failures

    def object_category(self, path: str | Path, library: str | Path | None = None) -> str | None:
        """Return the category converting an object file gives it when none is named (``assets.yaml`` metadata, else
        `object.default_category` with the library folder it was found in); None for a part of a multi-part object
        (its group's category applies)."""
        from .naming import library_category

        return library_category(path, library)

    def skipped_files(self, folder: str | Path, kind: str = "object") -> dict[str, str]:
        """Return {file: why} for the model files in a folder this converter does not read (other formats)."""
        from .load import display_path
        from .tree import skipped_reason, unsupported_models

        return {display_path(f): skipped_reason(f, kind) for f in unsupported_models(Path(folder), kind)}

    def scene_files(self, path: str | Path) -> list[Path]:
        """Return the scenes an input stands for, each a file or a converted scene's folder.

        A converted scene's folder (its ``asset.json``, or a run's ``scene.json``) is one scene; a ``sdovon-mj
        convert`` output or run folder, its ``scenes/<name>/`` folders; a Habitat ``*.scene_dataset_config.json``, its
        scene instances (with none, its stages: HM3D, MP3D); another folder, the scene files in it (mesh files, the
        members of the scene dataset configs in it; companions and dataset assets skipped); a file, itself.
        """
        from .scene import converted_scenes
        from .tree import find_inputs

        path = Path(path)
        if path.is_dir():
            return converted_scenes(path) or find_inputs(path, kind="scene")
        return find_inputs(path, kind="scene")

    def check_scene(self, path: str | Path) -> None:
        """Check one scene input before any work: every file it references exists and parses (InputError naming
        the file otherwise); see `scene.check_scene`."""
        from .scene import check_scene

        check_scene(path)

    def extra_inputs(self, path: str | Path) -> list[Path]:
        """Return the files besides `path` that its conversion reads and a stage fingerprint must cover.

        These are ``assets.yaml`` / ``<file>.yaml`` metadata and the companion files of a dataset layout (HM3D
        semantic mesh and txt; a Habitat scene's dataset config, templates and assets; a ScanNet scan's labels and
        alignment); [] for a plain file.
        """
        from . import habitat
        from .metadata import meta_for

        path = Path(path)
        if path.is_dir():  # a converted scene: its record (content hash of the conversion's inputs), MJCF, mesh
            from .scene import converted_files

            return converted_files(path)
        out = list(meta_for(path).sources)
        from .articulated_scene import input_files as articulated_inputs

        out += articulated_inputs(path)  # a scene's <stem>.articulated.json and its URDF pieces (world.articulated)
        from .scannet import scan_files

        out += scan_files(path).inputs()  # a ScanNet scan's segments + aggregation or labels mesh, its <scene>.txt
        if path.suffix.lower() == ".urdf":  # its meshes, their textures, a Habitat ao_config and render asset
            from .urdf import read_urdf

            out += [f for f in read_urdf(path).files() if f != path]
        if habitat.layout_of(path):
            out += [f for f in habitat.input_files(path) if f != path]
        return out

    def key_params(self, path: str | Path, extra: list[Path] | None = None) -> dict[str, Any]:
        """Return the conversion rules a stage fingerprint must hold for `path` beside its files' digests: the
        GPU-texture orientation rule for an input with KTX2 / Basis base-colour images (`load.gpu_texture_key`: a run
        converted before that rule holds them upside down and must convert again on resume); {} for every other
        input, so their fingerprints stay as they were. `extra`: `extra_inputs(path)` when the caller has it."""
        from .load import gpu_texture_key

        path = Path(path)
        if path.is_dir():
            return {}
        return gpu_texture_key([path] + (self.extra_inputs(path) if extra is None else [Path(f) for f in extra]))

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Declare the `sdovon-mj convert` options."""
        from .cli import add_arguments

        add_arguments(parser)

    def run(self, args: argparse.Namespace) -> int:
        """Run `sdovon-mj convert`; return the exit code."""
        from .cli import run

        return run(args)


__all__ = ["MeshConverter"]
