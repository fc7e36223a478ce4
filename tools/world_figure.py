"""Draw a default-world home of a run for the docs: a render (ceilings hidden) beside its ground floor's region map.

    python tools/world_figure.py RUN_DIR [--scene house_0000] [--out docs/images/house.png]

A maintainer script (the README's and docs/world.md's picture): reads the run's converted scene (MJCF), its
navigable map and its region map (the semantics stage's), renders the scene with MuJoCo from above a corner, and
writes one small PNG.
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")


def main() -> None:
    """Render and draw the figure."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--scene", default=None, help="scene folder name (default: the first)")
    ap.add_argument("--out", default="docs/images/house.png")
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import mujoco

    from sdovon_mj.records import NavMap, RegionMap, SceneAsset, load_json
    from sdovon_mj.sim import GROUP_OBJECT_VISUAL, GROUP_SCENE
    from sdovon_mj.sim.camera import pose_cv
    from sdovon_mj.sim.render import SceneRenderer

    run = Path(args.run_dir)
    scene_dir = run / "scenes" / (args.scene or sorted(p.name for p in (run / "scenes").iterdir() if p.is_dir())[0])
    asset = load_json(scene_dir / "scene.json", SceneAsset)
    model = mujoco.MjModel.from_xml_path(str(scene_dir / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lo, hi = np.array(model.stat.center) - model.stat.extent, np.array(model.stat.center) + model.stat.extent
    nm = load_json(scene_dir / "observe" / "navmap_0.json", NavMap)
    h, w = nm.navigable.shape
    x0, y0 = nm.origin
    x1, y1 = x0 + w * nm.resolution, y0 + h * nm.resolution
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, 1.0])
    span = max(x1 - x0, y1 - y0)
    yaw, pitch = -135.0, -52.0  # from above the house's north-east corner
    back = span * 1.05
    pos = centre - back * np.array([math.cos(math.radians(pitch)) * math.cos(math.radians(yaw)),
                                    math.cos(math.radians(pitch)) * math.sin(math.radians(yaw)), math.sin(math.radians(pitch))])
    del lo, hi
    with SceneRenderer(model, data, width=720, height=540, hfov=60.0, zfar=200.0, shadows=True,
                       groups=(GROUP_SCENE, GROUP_OBJECT_VISUAL)) as r:
        rgb = r.render(pose_cv(pos, yaw, pitch), depth=False).rgb
    regions = load_json(scene_dir / "semantics" / "regions_0.json", RegionMap)
    fig, (a, b) = plt.subplots(1, 2, figsize=(11.0, 4.4), dpi=80, gridspec_kw={"width_ratios": [1.33, 1.0]})
    a.imshow(rgb)
    a.set_axis_off()
    a.set_title(f"{asset.name}: {len(asset.floors)} storeys, {len(asset.rooms)} rooms, {len(asset.instances)} labelled instances",
                fontsize=9)
    img = np.full(nm.navigable.shape + (3,), 0.15)
    img[nm.free] = (0.55, 0.55, 0.55)
    img[nm.navigable] = (0.85, 0.85, 0.85)
    cmap = matplotlib.colormaps["tab10"]
    present = []
    if regions.label_map.shape == nm.navigable.shape:
        for i, lab in enumerate(regions.labels):
            sel = (regions.label_map == i) & nm.free
            if sel.any():
                img[sel] = 0.45 * img[sel] + 0.55 * np.array(cmap(i % 10)[:3])
                present.append((i, lab))
    b.imshow(img, origin="lower", extent=[x0, x1, y0, y1], interpolation="nearest")
    from matplotlib.patches import Patch

    b.legend(handles=[Patch(color=cmap(i % 10), label=lab) for i, lab in present], loc="upper left",
             bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False)
    b.set_title("ground floor: navigable map and inferred regions", fontsize=9)
    b.set_xlabel("m", fontsize=8)
    b.tick_params(labelsize=7)
    fig.tight_layout()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, metadata={"Software": None})
    print(out, out.stat().st_size, "bytes")


if __name__ == "__main__":
    main()
