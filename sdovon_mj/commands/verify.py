"""`sdovon-mj verify RUN_DIR`: check a run folder's finished stages and exports against their done-markers.

Every done-marker records the size and sha256 of each output of its stage; this command re-checks them all
(the stage outputs and the exporters' files under ``export/``) and names each output that is missing,
truncated or changed. Exit code 0 when everything is intact, 1 otherwise; a resume (``generate`` or a stage
command) recomputes exactly the stages listed as damaged.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import InputError


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare verify's arguments."""
    p.add_argument("run_dir", metavar="RUN_DIR", help="run folder written by `sdovon-mj generate`")
    p.add_argument("--quiet", action="store_true", help="print only the damaged stages")


def run(args: argparse.Namespace) -> int:
    """Verify the run folder; print one line per stage (damaged ones with each bad output)."""
    from ..runview import RunLayout
    from ..store import LOCK, Store, process_alive

    root = Path(args.run_dir)
    if not root.is_dir():
        raise InputError(root, "run folder not found")
    if not (root / RunLayout.CONFIG).is_file() or not (root / RunLayout.INPUTS).is_file():
        raise InputError(root, "not a run folder (no config.yaml / inputs.json inside)")
    store = Store(root)
    lock = root / LOCK
    if lock.exists():
        import json

        try:
            owner = json.loads(lock.read_text(encoding="utf-8"))
            live = process_alive(int(owner["pid"]), str(owner.get("started", "")))
            who = f"pid {owner['pid']} on host {owner['host']}"
        except (OSError, ValueError, KeyError, TypeError):
            live, who = False, "an unknown writer"
        print(f"note: {'being written now by' if live else 'a stale lock of'} {who} ({lock})", file=sys.stderr)
    report = store.verify()
    damaged = {k: v for k, v in report.items() if v}
    for key, problems in report.items():
        if problems:
            print(f"DAMAGED {key}")
            for line in problems:
                print(f"  {line}")
        elif not args.quiet:
            print(f"ok      {key}")
    exports = sorted(k for k in report if k.split("/")[0] == RunLayout.EXPORT)
    print(f"{len(report)} finished stage(s) checked ({len(exports)} export(s)): "
          + (f"{len(damaged)} damaged; rerun generate to recompute them" if damaged else "all outputs intact"))
    return 1 if damaged else 0
