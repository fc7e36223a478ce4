"""`sdovon-mj view RUN_DIR [--eval EVAL_DIR] [--port P] [--export DIR]`: look at a run in the browser.

Serves a local page (127.0.0.1) showing, per scene and variant, the scene in 3D with its placed objects coloured by
category and labelled, the region map on the floor, receptacle planes, the episodes' starts, goals and view points,
and the trajectories of evaluated agents (`--eval`: folders written by `sdovon-mj eval --out`). `--export DIR` writes
the same page as static files instead (open DIR/index.html from disk, or publish the folder).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import InputError, InputsError


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare view's options."""
    p.add_argument("run_dir", help="a run folder written by `sdovon-mj generate` (or demo)")
    p.add_argument("--eval", dest="eval_dirs", action="append", default=[], metavar="EVAL_DIR",
                   help="an output folder of `sdovon-mj eval --out` whose trajectories to show (repeatable)")
    p.add_argument("--port", type=int, default=8000, help="local port to serve on (default 8000; 0: any free port)")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1: this machine only)")
    p.add_argument("--export", default=None, metavar="DIR", help="write the page as static files into DIR and exit")
    p.add_argument("--scene-faces", type=int, default=None,
                   help="triangle budget of a scene's mesh on the page (default 400000; larger scenes are decimated)")


def run(args: argparse.Namespace) -> int:
    """Serve the viewer (until Ctrl-C) or export it."""
    from ..viewer import data
    from ..viewer.site import Site, export_site, make_server

    if not 0 <= args.port <= 65535:
        raise InputsError([("--port", f"{args.port} is not a port number (0-65535)")])
    if args.scene_faces is not None and args.scene_faces < 1000:
        raise InputsError([("--scene-faces", f"{args.scene_faces} is below 1000 triangles")])
    try:  # every input is read and checked here, before any page is built: a bad one is a usage error (exit 2)
        site = Site(args.run_dir, args.eval_dirs, scene_faces=args.scene_faces or data.SCENE_FACES)
    except InputError as e:
        raise InputsError([(e.path, e.cause)]) from None
    if site.evals is not None:
        for line in site.evals.skipped[:20]:
            data.warn(f"skipped {line}")
        for agent, (unmatched, total) in site.unmatched_results().items():
            data.warn(f"{unmatched} of {total} results of agent '{agent}' name no episode of this run")
    if args.export:
        out = Path(args.export)
        paths = export_site(site, out)
        print(f"viewer: {len(paths)} files in {out.resolve()}; open {(out / 'index.html').resolve().as_uri()}")
        return 0
    try:
        server = make_server(site, args.host, args.port)
    except OSError as e:
        raise InputsError([(f"{args.host}:{args.port}", f"cannot serve there ({e.strerror or e})")]) from None
    host, port = server.server_address[:2]
    print(f"viewer: http://{host}:{port}/ (run {site.view.root}; Ctrl-C to stop)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        print("viewer: stopped", file=sys.stderr)
    finally:
        server.server_close()
    return 0
