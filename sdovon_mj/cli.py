"""`sdovon-mj` command line: one subcommand per stage, plus demo, generate, export, eval, show, view.

Each subcommand lives in its own module exposing ``add_arguments(parser)`` and ``run(args) -> int``;
the per-stage commands come from the stage declarations (``sdovon_mj.commands.stage``); this file only
lists them. Exit codes: 0 success, 1 failure (one-line cause on stderr), 2 usage
error (bad arguments, a config value out of range, missing or unreadable inputs: `errors.UsageError`, found
before any work) or a subcommand that is not built yet.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from typing import Sequence

from . import __version__

# name -> (module, one-line help). Order is the order of `--help`.
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("sdovon_mj.commands.demo", "the default world end to end, small and quick"),
    "world": ("sdovon_mj.commands.world", "write default-world apartments and objects as input files"),
    "convert": ("sdovon_mj.commands.convert", "convert objects and scenes (OBJ, GLB/glTF, PLY, STL) to MJCF"),
    "observe": ("sdovon_mj.commands.stage:observe", "floors, navigable maps, coverage viewpoints, RGB-D renders"),
    "perceive": ("sdovon_mj.commands.stage:perceive", "detect, back-project and fuse instances; receptacle planes"),
    "semantics": ("sdovon_mj.commands.stage:semantics", "region map and object-region-receptacle relevance"),
    "semantics-eval": ("sdovon_mj.commands.semantics_eval", "score a semantics backend on human judgements (ORR/OR mAP); also `semantics eval`"),
    "place": ("sdovon_mj.commands.stage:place", "place objects semantically and settle them with physics"),
    "episodes": ("sdovon_mj.commands.stage:episodes", "ObjectNav episodes for scene variants"),
    "generate": ("sdovon_mj.commands.generate", "the whole pipeline over scenes and objects (resumable)"),
    "export": ("sdovon_mj.commands.export", "export a run to habitat, mjcf or a plugin format"),
    "eval": ("sdovon_mj.commands.eval", "evaluate agents on an MJCF dataset (SR, SPL, Soft SPL, DTG)"),
    "show": ("sdovon_mj.commands.show", "pictures of a run: maps, receptacles, placements, episodes"),
    "view": ("sdovon_mj.commands.view", "look at a run in the browser: scenes, objects, regions, episodes, trajectories"),
    "verify": ("sdovon_mj.commands.verify", "check a run folder's stage outputs and exports against their done-markers"),
}


class _Parser(argparse.ArgumentParser):
    """ArgumentParser that exits with code 2 and a one-line message on usage errors."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def _load(name: str):
    """Import a subcommand's module (``module:stage`` for a declared stage's command), or None when not built yet."""
    module, _, stage = COMMANDS[name][0].partition(":")
    if stage:
        return importlib.import_module(module).command(stage)
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as e:
        if e.name and (module == e.name or module.startswith(e.name + ".")):
            return None
        raise


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """Build the parser; subcommand modules are imported only for the one being run."""
    parser = _Parser(prog="sdovon-mj", description="MuJoCo-native SD-OVON: dynamic scenes and ObjectNav benchmarks.")
    parser.add_argument("--version", action="version", version=f"sdovon-mj {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, (_module, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        if name == only:
            mod = _load(name)
            if mod is not None:
                mod.add_arguments(p)
            else:
                p.add_argument("rest", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:2] == ["semantics", "eval"]:  # `semantics eval` is semantics-eval (a run folder named eval: ./eval)
        argv = ["semantics-eval"] + argv[2:]
    only = next((a for a in argv if a in COMMANDS), None)
    parser = build_parser(only)
    args = parser.parse_args(argv)
    if not args.command:
        parser.print_help()
        return 2
    mod = _load(args.command)
    if mod is None:
        print(f"sdovon-mj {args.command}: not built yet", file=sys.stderr)
        return 2
    from .errors import SdovonError, UsageError

    try:
        return int(mod.run(args) or 0)
    except UsageError as e:  # a bad config value or input named before any work: a usage error
        print(f"sdovon-mj {args.command}: error: {e}", file=sys.stderr)
        return 2
    except SdovonError as e:
        print(f"sdovon-mj {args.command}: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as e:  # Ctrl-C, or SIGTERM during generate (`interrupt.Interrupted`)
        why = f": {e}" if str(e) else ""
        print(f"sdovon-mj {args.command}: interrupted{why}", file=sys.stderr)
        return int(getattr(e, "exit_code", 130))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
