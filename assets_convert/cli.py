"""`sdovon-mj convert`: objects and scenes (OBJ, GLB/glTF, PLY, STL) to MJCF."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from sdovon_mj.config import ConvertConfig


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the convert subcommand's arguments."""
    parser.add_argument("inputs", nargs="+", help="mesh files or folders (searched recursively)")
    parser.add_argument("--out", required=True, help="output folder (objects/<name>/, scenes/<name>/, convert_report.json)")
    parser.add_argument("--kind", choices=("object", "scene"), default="object", help="what the inputs are")
    parser.add_argument("--units", default="auto", help="auto, m, cm, mm, in or metres per file unit")
    parser.add_argument("--up", default="auto", help="auto (glTF +Y, else +Z), +X, -X, +Y, -Y, +Z, -Z")
    parser.add_argument("--category", default=None, help="object category (single file), sets the density")
    parser.add_argument("--target-size", type=float, default=0.0, help="rescale objects to this largest extent (m)")
    parser.add_argument("--threshold", type=float, default=None, help="CoACD concavity threshold (default 0.05)")
    parser.add_argument("--jobs", type=int, default=0, help="worker processes (0: number of cores)")
    parser.add_argument("--timeout", type=float, default=None, help="per-input timeout in seconds (default 300)")
    parser.add_argument("--cache", default=None, help="cache folder ('off' disables; default $SDOVON_CACHE/convert)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Convert the inputs; print a summary; exit 1 when any input failed."""
    from .tree import convert_tree, known_suffixes

    cfg = ConvertConfig()
    cfg = replace(cfg, units=str(args.units), up=str(args.up), target_size=float(args.target_size))
    if args.threshold is not None:
        cfg = replace(cfg, coacd_threshold=float(args.threshold))
    categories = None
    if args.category and len(args.inputs) == 1 and Path(args.inputs[0]).is_file():
        categories = {str(Path(args.inputs[0])): args.category}
    report = convert_tree(args.inputs, args.out, kind=args.kind, jobs=args.jobs, timeout=args.timeout,
                          progress=not args.no_progress, config=cfg, cache_dir=args.cache, categories=categories)
    for row in report["items"]:
        if row["status"] != "ok":
            print(f"sdovon-mj convert: {row['file']}: {row['error']}", file=sys.stderr)
    for row in report.get("skipped", []):
        print(f"sdovon-mj convert: skipped {row['file']}: {row['reason']}", file=sys.stderr)
    unused = [f"sdovon-mj convert: {row['file']}: not used: {u}" for row in report["items"] for u in row.get("unused", [])]
    for line in unused:
        print(line, file=sys.stderr)
    if unused:
        print(f"sdovon-mj convert: {len(unused)} thing(s) the inputs held were not used (named above; listed under "
              "`unused` in the report)", file=sys.stderr)
    print(f"converted {report['ok']}/{report['count']} {args.kind}s in {report['seconds']:.1f} s"
          + (f", skipped {len(report['skipped'])} file(s) of other formats" if report.get("skipped") else "")
          + f"; report: {Path(args.out) / 'convert_report.json'}")
    if report["count"] == 0:
        print(f"sdovon-mj convert: nothing to convert in {', '.join(map(str, args.inputs))} (no "
              f"{', '.join(known_suffixes(args.kind))} files)", file=sys.stderr)
        return 1
    return 0 if report["failed"] == 0 else 1
