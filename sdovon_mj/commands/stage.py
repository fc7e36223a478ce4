"""`sdovon-mj <stage> RUN_DIR`: one declared stage (and the stages it needs), exactly as `generate` runs it.

The per-stage commands (objects, convert, observe, perceive, semantics, place, episodes) are derived from
the stage declarations of `sdovon_mj.stages`: each runs the same tasks as ``generate``, limited to the named
stage and what it needs, so a run made stage by stage holds the same bytes as one made by ``generate``.
Finished stages are skipped (same fingerprint); a changed config redoes what it changes.

    sdovon-mj observe RUN_DIR [--scenes FILE...] [--objects PATH...] [--scene NAME...] [--config F] [--set K=V]

RUN_DIR is created when it does not exist (with ``--scenes/--objects``, or the default world without);
an existing run keeps its inputs and its ``config.yaml`` (``--config/--set`` change it, like ``generate``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..config import load_config
from ..seeds import SALT_HELP, use_secret_salt
from ..errors import InputError


class StageCommand:
    """The command of one declared stage (``add_arguments`` / ``run``, like every command module)."""

    def __init__(self, stage: str) -> None:
        from ..stages import COMMAND_STAGES, STAGES

        if stage not in COMMAND_STAGES:
            raise KeyError(stage)
        self.stage = STAGES[stage]

    def add_arguments(self, p: argparse.ArgumentParser) -> None:
        """Declare the stage command's options."""
        s = self.stage
        p.description = (f"Run the '{s.name}' stage ({s.scope} scope: {s.outputs}) and the stages it needs "
                         f"({', '.join(s.needs) or 'none'}), exactly as `sdovon-mj generate` does.")
        p.add_argument("run_dir", metavar="RUN_DIR", help="run folder (created if missing; an existing run is resumed)")
        p.add_argument("--scenes", nargs="*", default=None,
                       help="scenes for a new run, as `generate --scenes` takes them (default: the embedded world)")
        p.add_argument("--objects", nargs="*", default=None, help="object files or folders for a new run")
        if s.scope in ("scene", "variant"):
            p.add_argument("--scene", action="append", default=None, metavar="NAME",
                           help="only the scenes of this name (a shell pattern such as 'apt_*'; repeatable)")
        p.add_argument("--config", default=None, help="YAML config file (default: the run's config.yaml)")
        p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                       help="override a config key (repeatable)")
        p.add_argument("--jobs", type=int, default=1, help="parallel tasks")
        p.add_argument("--quiet", action="store_true", help="no progress output")
        p.add_argument("--secret-salt-file", default=None, metavar="FILE", help=SALT_HELP)

    def run(self, args: argparse.Namespace) -> int:
        """Run the stage on the run folder; print what ran and what was skipped."""
        from ..pipeline import generate
        from ..runview import RunLayout

        root = Path(args.run_dir)
        existing = root / RunLayout.CONFIG
        if root.exists() and not root.is_dir():
            raise InputError(root, "not a folder")
        base = args.config or (existing if existing.exists() else None)
        cfg = load_config(base, args.overrides)
        use_secret_salt(getattr(args, "secret_salt_file", None))
        scenes, objects = args.scenes, args.objects
        if scenes is None and objects is None and not (root / RunLayout.INPUTS).exists() \
                and (root / "convert_report.json").is_file():
            scenes = [str(root)]  # the folder `sdovon-mj convert --kind scene` wrote: its scene is the input
        if (root / RunLayout.INPUTS).exists() and scenes is None and objects is None:
            import json

            inputs = json.loads((root / RunLayout.INPUTS).read_text(encoding="utf-8"))
            scenes, objects = inputs["scenes"], inputs["objects"]
        from ..stages import expand_scene_inputs

        summary = generate(root, cfg, scenes=expand_scene_inputs(scenes, cfg), objects=objects, jobs=args.jobs,
                           until=[self.stage.name],
                           only_scenes=getattr(args, "scene", None), progress=False if args.quiet else None)
        ran = sorted(summary.seconds)
        skipped = sorted({k for r in summary.results for k in r.skipped})
        print(f"{self.stage.name}: {len(summary.results)} task(s); ran: {', '.join(ran) or 'nothing'}; "
              f"already done: {len(skipped)} stage run(s) -> {root.resolve()}")
        for f in summary.failures:
            print(f"not run: {f.spec.label} (caused by {f.caused_by})" if f.caused_by else f"failed: {f.spec.label}: {f.error}",
                  file=sys.stderr)
        return 1 if summary.failures else 0


def command(stage: str) -> StageCommand:
    """Return the command object of a declared stage."""
    return StageCommand(stage)
