"""`sdovon-mj export RUN_DIR --format habitat|mjcf|<plugin> --out DIR`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sdovon_mj import plugins
from sdovon_mj.errors import SdovonError

from .base import ExportOptions, Exporter, RunView, run_export


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the export subcommand's arguments."""
    parser.add_argument("run_dir", metavar="RUN_DIR", help="run folder written by `sdovon-mj generate`")
    parser.add_argument("--format", required=True, help=f"exporter plugin ({', '.join(plugins.available('exporter'))})")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--name", default="sdovon", help="dataset name (default: sdovon)")
    parser.add_argument("--split", default="val", help="split name (default: val)")
    parser.add_argument("--merge", action="store_true",
                        help="add this dataset next to other datasets already in --out (never mixes into one)")


def make_exporter(fmt: str) -> Exporter:
    """Return an exporter instance for a plugin name."""
    obj = plugins.load("exporter", fmt)
    exp = obj() if isinstance(obj, type) else obj
    if not hasattr(exp, "export"):
        raise plugins.PluginError(f"exporter plugin '{fmt}' has no export() method")
    if not getattr(exp, "name", ""):
        exp.name = fmt
    return exp


def export_run(run_dir: str | Path, fmt: str, out: str | Path, name: str = "sdovon", split: str = "val", merge: bool = False):
    """Export a run folder with a named exporter plugin and return its ExportReport."""
    exp = make_exporter(fmt)
    return run_export(exp, RunView(run_dir), Path(out), ExportOptions(name=name, split=split, merge=merge))


def run(args: argparse.Namespace) -> int:
    """Run the export subcommand."""
    report = export_run(args.run_dir, args.format, args.out, args.name, args.split, args.merge)
    print(report.summary())
    if not report.variants:
        print("sdovon-mj export: no variant had valid goals; nothing but the index was written", file=sys.stderr)
    return 0


__all__ = ["add_arguments", "run", "export_run", "make_exporter", "SdovonError"]
