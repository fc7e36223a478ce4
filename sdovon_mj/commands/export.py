"""`sdovon-mj export RUN_DIR --format habitat|mjcf|<plugin> --out DIR [--standalone]` and
`sdovon-mj export BUNDLE_DIR --standalone` (make an exported MJCF bundle, or every bundle of a dataset, self-contained)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .. import plugins
from ..errors import InputError
from ..export import export_run, make_exporter
from ..runview import RunLayout


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the export subcommand's arguments."""
    parser.add_argument("run_dir", metavar="RUN_DIR",
                        help="run folder written by `sdovon-mj generate` (with --standalone alone: an MJCF bundle "
                             "or dataset folder to make self-contained)")
    parser.add_argument("--format", help=f"exporter plugin ({', '.join(plugins.available('exporter'))})")
    parser.add_argument("--out", help="output folder")
    parser.add_argument("--name", default="sdovon", help="dataset name (default: sdovon)")
    parser.add_argument("--split", default="val", help="split name (default: val)")
    parser.add_argument("--merge", action="store_true",
                        help="add this dataset next to other datasets already in --out (never mixes into one)")
    parser.add_argument("--standalone", action="store_true",
                        help="mjcf: self-contained bundles (each with its own assets/) instead of one shared asset "
                             "folder; given an exported bundle (or dataset) folder instead of a run: make it self-contained")


def _bundle_dirs(folder: Path) -> list[Path]:
    """Return the MJCF bundle folders of a bundle folder or an exported MJCF dataset folder."""
    if (folder / "bundle.json").is_file():
        return [folder]
    index = folder / "index.json"
    if index.is_file():
        try:
            rows = json.loads(index.read_text(encoding="utf-8"))["bundles"]
            return [folder / str(r["path"]) for r in rows]
        except (json.JSONDecodeError, KeyError, TypeError) as e:
            raise InputError(index, f"not an MJCF dataset index ({e})") from None
    raise InputError(folder, "not a run folder, an MJCF bundle (bundle.json) or an MJCF dataset (index.json)")


def run(args: argparse.Namespace) -> int:
    """Run the export subcommand."""
    folder = Path(args.run_dir)
    if args.standalone and not (folder / RunLayout.SCENES).is_dir():  # a bundle or dataset already exported
        if args.format not in (None, "mjcf") or args.out:
            raise InputError(folder, "making a bundle self-contained takes no --format other than mjcf and no --out")
        exporter = make_exporter("mjcf")
        for bdir in _bundle_dirs(folder):
            copied = exporter.make_standalone(bdir)
            print(f"{bdir}: {'self-contained, ' + str(len(copied)) + ' asset files copied' if copied else 'already self-contained'}")
        return 0
    if not args.format or not args.out:
        print("sdovon-mj export: --format and --out are required to export a run folder", file=sys.stderr)
        return 2
    extra = {"standalone": True} if args.standalone else {}
    report = export_run(args.run_dir, args.format, args.out, args.name, args.split, args.merge, extra)
    print(report.summary())
    if not report.variants:
        print("sdovon-mj export: no variant had valid goals; nothing but the index was written", file=sys.stderr)
    return 0
