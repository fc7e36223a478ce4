"""`sdovon-mj generate`: the whole pipeline over scenes and objects, resumable and reproducible."""

from __future__ import annotations

import argparse
import sys

from ..config import load_config


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare generate's options (the ARCHITECTURE.md command-line contract)."""
    p.add_argument("--out", required=True, help="run folder (created; an existing run is resumed)")
    p.add_argument("--scenes", nargs="*", default=None, help="scene files (GLB/glTF/OBJ/PLY); default: the embedded world")
    p.add_argument("--objects", nargs="*", default=None, help="object files or folders; default: the embedded library")
    p.add_argument("--config", default=None, help="YAML config file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config key, e.g. --set place.k_v=4 (repeatable)")
    p.add_argument("--executor", choices=("local", "ray"), default="local", help="local process pool or Ray")
    p.add_argument("--address", default=None, help="Ray cluster address (with --executor ray)")
    p.add_argument("--jobs", type=int, default=1, help="parallel tasks (local workers / Ray CPUs)")
    p.add_argument("--retries", type=int, default=1, help="retries of a failed task")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def run(args: argparse.Namespace) -> int:
    """Run the pipeline and print the summary table."""
    from ..pipeline import generate

    cfg = load_config(args.config, args.overrides)
    summary = generate(args.out, cfg, scenes=args.scenes, objects=args.objects, executor=args.executor,
                       jobs=args.jobs, address=args.address, retries=args.retries,
                       progress=False if args.quiet else None)
    print(summary.table())
    for f in summary.failures:
        print(f"failed: {f.spec.label}: {f.error}", file=sys.stderr)
    # Partial runs keep every finished output; the exit code still tells scripts that something failed.
    return 1 if summary.failures else 0
