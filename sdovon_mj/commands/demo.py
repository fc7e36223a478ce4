"""`sdovon-mj demo`: the default world end to end, small and quick (the README's main command)."""

from __future__ import annotations

import argparse
import sys
from importlib.resources import files
from pathlib import Path

from ..config import load_config
from ..runview import RunLayout


def demo_config_path() -> Path:
    """Return the bundled demo config."""
    return Path(str(files("sdovon_mj") / "presets" / "demo.yaml"))


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare demo's options."""
    p.add_argument("--out", default="out/demo", help="run folder (default: out/demo; an existing run is resumed)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config key of the demo config (repeatable)")
    p.add_argument("--jobs", type=int, default=1, help="parallel tasks")
    p.add_argument("--episodes", type=int, default=20, help="episodes per agent in the closing evaluation (0: skip)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def run(args: argparse.Namespace) -> int:
    """Generate the demo dataset, export it (habitat + mjcf), evaluate the baselines, draw pictures."""
    from ..pipeline import generate
    from .show import show_run

    cfg = load_config(demo_config_path(), args.overrides)
    out = Path(args.out)
    summary = generate(out, cfg, jobs=args.jobs, progress=False if args.quiet else None)
    print(summary.table())
    if summary.failures:
        for f in summary.failures:
            print(f"failed: {f.spec.label}: {f.error}", file=sys.stderr)
        return 1
    pictures = show_run(out)
    print(f"pictures: {len(pictures)} in {out / RunLayout.PICTURES}")
    render = render_preview(out)
    if render:
        print(f"render: {render}")
    if args.episodes > 0:
        from . import eval as eval_command

        eval_command.run(argparse.Namespace(
            dataset=str(out / RunLayout.export_dir("mjcf")), agent=["random-astar", "semantic-astar"],
            episodes=args.episodes, no_fn=False, fn_ablation=False, fn_mode=None, width=160, height=120, seed=0,
            pictures=2, out=str(out / RunLayout.EVAL)))
    print(f"done: {out.resolve()}")
    return 0


def render_preview(run_dir: Path) -> Path | None:
    """Render one variant of the run from above with MuJoCo (offscreen) and save it as PNG."""
    import numpy as np
    from PIL import Image

    from ..records import SceneVariant, load_json
    from ..sim import GROUP_OBJECT_VISUAL, GROUP_SCENE
    from ..sim.render import SceneRenderer, top_down_camera

    variants = sorted(run_dir.glob(RunLayout.variant_record("*")))
    if not variants:
        return None
    import mujoco

    v = load_json(variants[0], SceneVariant)
    model = mujoco.MjModel.from_xml_path(str(run_dir / v.mjcf))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lo = model.stat.center - model.stat.extent / 2
    hi = model.stat.center + model.stat.extent / 2
    T, hfov = top_down_camera(np.stack([lo, hi]), margin=0.2)
    with SceneRenderer(model, data, width=800, height=800, hfov=hfov, groups=(GROUP_SCENE, GROUP_OBJECT_VISUAL)) as r:
        img = r.render(T, depth=False).rgb
    out = run_dir / RunLayout.PICTURES / f"{v.name}_render.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(out)
    return out
