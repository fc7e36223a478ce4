"""`sdovon-mj export RUN_DIR --format habitat|mjcf|<plugin> --out DIR`."""

from __future__ import annotations

import argparse
import sys

from .. import plugins
from ..export import export_run


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the export subcommand's arguments."""
    parser.add_argument("run_dir", metavar="RUN_DIR", help="run folder written by `sdovon-mj generate`")
    parser.add_argument("--format", required=True, help=f"exporter plugin ({', '.join(plugins.available('exporter'))})")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--name", default="sdovon", help="dataset name (default: sdovon)")
    parser.add_argument("--split", default="val", help="split name (default: val)")
    parser.add_argument("--merge", action="store_true",
                        help="add this dataset next to other datasets already in --out (never mixes into one)")


def run(args: argparse.Namespace) -> int:
    """Run the export subcommand."""
    report = export_run(args.run_dir, args.format, args.out, args.name, args.split, args.merge)
    print(report.summary())
    if not report.variants:
        print("sdovon-mj export: no variant had valid goals; nothing but the index was written", file=sys.stderr)
    return 0
