"""`sdovon-mj generate`: the whole pipeline over scenes and objects, resumable and reproducible."""

from __future__ import annotations

import argparse
import os
import sys

from ..config import load_config
from ..gl import RENDER_ENV
from ..seeds import SALT_HELP, use_secret_salt


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare generate's options (the ARCHITECTURE.md command-line contract)."""
    p.add_argument("--out", required=True, help="run folder (created; an existing run is resumed)")
    p.add_argument("--scenes", nargs="*", default=None,
                   help="scenes: files (GLB/glTF/OBJ/PLY, Habitat scene instances), Habitat *.scene_dataset_config.json "
                        "(each scene of it), folders of scenes (HM3D, MP3D, datasets), `sdovon-mj convert` outputs or "
                        "one converted scene's folder; default: the embedded world (docs/inputs.md)")
    p.add_argument("--scene", action="append", default=None, metavar="NAME",
                   help="only the scenes of this name (a shell pattern such as '1023*'; repeatable)")
    p.add_argument("--objects", nargs="*", default=None, help="object files or folders; default: the embedded library")
    p.add_argument("--config", default=None, help="YAML config file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config key, e.g. --set place.k_v=4 (repeatable)")
    p.add_argument("--executor", choices=("local", "ray"), default="local", help="local process pool or Ray")
    p.add_argument("--address", default=None, help="Ray cluster address (with --executor ray)")
    p.add_argument("--jobs", type=int, default=1, help="parallel tasks (local workers / Ray CPUs)")
    p.add_argument("--retries", type=int, default=1,
                   help="retries of a failed task (not of a bad input: it fails the same way every time)")
    p.add_argument("--worker-memory", type=float, default=None, metavar="MIB",
                   help="a local worker holding more than this after a stage hands on its work to a fresh process "
                        "(default: sdovon_mj.executors.WORKER_MEMORY_MB; 0: never); outputs are the same bytes")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument("--secret-salt-file", default=None, metavar="FILE", help=SALT_HELP)
    p.add_argument("--any-renderer", action="store_true",
                   help="generate even where Mesa llvmpipe (the CPU renderer that defines a dataset's bytes) is not "
                        "what renders: other pixels, recorded in manifest.json `renderer` (SDOVON_RENDER=any)")
    p.add_argument("--allow-empty", action="store_true",
                   help="exit 0 even when a scene yields no receptacle or no episode (default: a warning and exit 1)")


def run(args: argparse.Namespace) -> int:
    """Run the pipeline and print the summary table."""
    from ..pipeline import generate

    from ..stages import expand_scene_inputs

    cfg = load_config(args.config, args.overrides)
    use_secret_salt(getattr(args, "secret_salt_file", None))
    if args.any_renderer:  # the explicit override; workers inherit it (gl)
        os.environ[RENDER_ENV] = "any"
    summary = generate(args.out, cfg, scenes=expand_scene_inputs(args.scenes, cfg), objects=args.objects,
                       only_scenes=args.scene, executor=args.executor,
                       jobs=args.jobs, address=args.address, retries=args.retries,
                       progress=False if args.quiet else None,
                       **({} if args.worker_memory is None else {"worker_memory_mb": args.worker_memory}))
    print(summary.table())
    for f in summary.failures:  # root causes; a follow-on failure names its cause instead of repeating it
        print(f"not run: {f.spec.label} (caused by {f.caused_by})" if f.caused_by else f"failed: {f.spec.label}: {f.error}",
              file=sys.stderr)
    for line in library_warnings(summary.run_root) + unused_input_warnings(summary.run_root):
        print(f"WARNING: {line}", file=sys.stderr)
    empty = empty_warnings(summary.run_root, {f.spec.label for f in summary.failures})
    for line in empty:
        print(f"WARNING: {line}", file=sys.stderr)
    if empty and not args.allow_empty:
        print("sdovon-mj generate: the run produced an empty result (above); pass --allow-empty to accept it",
              file=sys.stderr)
    # Partial runs keep every finished output; the exit code still tells scripts that something failed.
    return 1 if summary.failures or (empty and not args.allow_empty) else 0


def library_warnings(run_root: str) -> list[str]:
    """Return one line per input object the run's library left out (objects/failures.json: failed or skipped)."""
    import json
    from pathlib import Path

    from ..runview import RunLayout

    path = Path(run_root) / RunLayout.OBJECT_FAILURES
    if not path.is_file():
        return []
    failures = json.loads(path.read_text(encoding="utf-8"))
    return [f"object {f} left out of the library: {why}" for f, why in sorted(failures.items())]


def unused_input_warnings(run_root: str) -> list[str]:
    """Return one line per thing a scene input held that its conversion did not use (`SceneAsset.unused`), then one
    summary line counting them; nothing when every input was used."""
    from pathlib import Path

    from ..runview import RunLayout, RunView

    if not (Path(run_root) / RunLayout.SCENES).is_dir():  # the run stopped before any scene was converted
        return []
    view = RunView(run_root)
    lines = [f"scene {sc.name}: not used: {what}" for sc in view.scenes() for what in sc.unused]
    if lines:
        scenes = sum(1 for sc in view.scenes() if sc.unused)
        lines.append(f"{len(lines)} thing(s) the scene inputs held were not used, in {scenes} scene(s) (named above; "
                     "each scene's scene.json lists them under `unused`)")
    return lines


def empty_warnings(run_root: str, failed: set[str] | None = None) -> list[str]:
    """Return one line per scene of a finished run that yielded no episode, with what to set to get some
    (`sdovon_mj.hints`: no receptacle plane, no episode); a last line says so when the whole run has no episode.

    A scene whose tasks failed is left out (its failure is reported already).
    """
    from .. import hints
    from ..stats import dataset_statistics

    st = dataset_statistics(run_root)
    out = []
    for sc in st.get("scenes", []):
        name = sc.get("name", "")
        if any(name in f for f in failed or ()):
            continue
        if sc.get("episodes", 0) > 0:
            continue
        out.append(_empty_scene_warning(run_root, name, sc))
    total = sum(sc.get("episodes", 0) for sc in st.get("scenes", []))
    if st.get("scenes") and total == 0:
        out.append(hints.empty_run(len(st["scenes"]), sum("--set " in line for line in out)))
    return out


def _empty_scene_warning(run_root: str, name: str, sc: dict) -> str:
    """Return the warning of one scene without episodes (`empty_warnings`), from the scene's own figures: the labels
    of the instances perception fused (or the scene's own), the place stage's notes, the farthest start."""
    from pathlib import Path

    from .. import hints
    from ..receptacles.identify import is_receptacle
    from ..records import Instance, load_npz
    from ..runview import RunLayout, RunView

    view = RunView(run_root)
    cfg = view.config()
    if sc.get("receptacle_planes", 0) == 0:
        fused = view.path(RunLayout.instances(name))
        if fused.is_file():
            labels = [r.label for r in load_npz(fused) if isinstance(r, Instance)]
        else:  # perception did not run: the scene's own instances
            labels = [i.label for i in view.scene(name).instances]
        matched = sum(is_receptacle(lb, cfg.receptacles.labels) for lb in labels)
        return hints.no_receptacle_plane(name, labels, cfg.receptacles.labels, matched)
    variants = view.variants(name)
    placed = int(sc.get("placed_objects", 0))
    farthest = None
    if placed:
        from ..episodes import farthest_starts

        # one variant with resting objects tells (its goals' view points take a visibility render each; the
        # variants of one scene share its floor, and a floor too small for one is too small for all)
        one = next((v for v in variants if any(p.status == "resting" for p in v.placements)), None)
        farthest = farthest_starts(one, view.navmaps(name), run_root, cfg.episodes, cfg.agent) if one else None
    return hints.no_episodes(name, placed, int(sc.get("receptacle_planes", 0)), farthest,
                             cfg.episodes.min_start_distance, [n for v in variants for n in v.notes])
