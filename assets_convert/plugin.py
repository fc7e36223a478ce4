"""The converter plugin: what the pipeline core asks of a mesh converter (entry-point group ``sdovon_mj.converters``).

The core never imports ``assets_convert`` modules; it loads this class through ``sdovon_mj.plugins`` (kind
``converter``, name ``mesh``) and calls the four members below. A third-party converter (another CoACD
setting, a different scene reader) ships a class with the same members under its own entry point and is
chosen with ``convert.converter``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from sdovon_mj.config import ConvertConfig
from sdovon_mj.records import ObjectAsset, SceneAsset, save_json


class MeshConverter:
    """OBJ / GLB / glTF / PLY / STL objects and scenes -> MJCF (CoACD hulls for objects, visual-only scenes)."""

    name = "mesh"

    @property
    def version(self) -> str:
        """Return the converter's output version (a new one invalidates converted scenes and objects)."""
        from .cache import CONVERTER_VERSION

        return CONVERTER_VERSION

    def convert_scene(self, path: str | Path, out_root: str | Path, name: str, cfg: ConvertConfig) -> SceneAsset:
        """Convert one scene file into ``<out_root>/scenes/<name>/`` and return its SceneAsset."""
        from .scene import convert_scene

        return convert_scene(Path(path), out_root, name=name, units=cfg.units, up=cfg.up,
                             texture_max_size=cfg.texture_max_size)

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
        from .object import load_converted
        from .tree import convert_tree

        assets: list[ObjectAsset] = []
        failures: dict[str, str] = {}
        with tempfile.TemporaryDirectory(prefix="sdovon-objects-") as scratch:
            report = convert_tree([p for p, _c in items], scratch, jobs=cfg.jobs, timeout=cfg.timeout_s,
                                  progress=False, config=cfg, categories={str(p): c for p, c in items if c})
            rows = {r["file"]: r for r in report["items"]}
            for path, _category in items:
                row = rows[display_path(path)]
                if row["status"] != "ok":
                    failures[str(path)] = str(row["error"])
                    continue
                asset = load_converted(scratch, row["name"])
                link_tree(Path(scratch) / "objects" / asset.name, Path(out_root) / "objects" / asset.name)
                save_json(asset, Path(out_root) / "objects" / asset.name / "object.json")
                assets.append(asset)
        assets.sort(key=lambda a: a.name)
        return assets, failures

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Declare the `sdovon-mj convert` options."""
        from .cli import add_arguments

        add_arguments(parser)

    def run(self, args: argparse.Namespace) -> int:
        """Run `sdovon-mj convert`; return the exit code."""
        from .cli import run

        return run(args)


__all__ = ["MeshConverter"]
