"""`sdovon-mj show RUN_DIR`: top-down pictures of a run from its records alone; ``--stats``: its scenes' statistics."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..records import NavMap, ReceptaclePlane, RegionMap, load_json
from ..runview import RunLayout, RunView


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare show's options."""
    p.add_argument("run_dir", help="a run folder written by `sdovon-mj generate`")
    p.add_argument("--out", default=None, help="picture folder (default: RUN_DIR/pictures)")
    p.add_argument("--stats", action="store_true",
                   help="print the scenes' size, clutter and episode lengths with their medians instead of pictures; "
                        "with chains of days (place.days), what moved per day and where")


def run(args: argparse.Namespace) -> int:
    """Render one picture per scene floor and per variant (or print the scene statistics)."""
    if args.stats:
        from ..stats import dataset_statistics, day_statistics, days_table, homes_table

        view = RunView(args.run_dir)  # refuses a folder that is not a run
        print(homes_table(dataset_statistics(view.root)))
        days = day_statistics(view.root)
        if days:
            print()
            print(days_table(days))
        return 0
    written = show_run(Path(args.run_dir), Path(args.out) if args.out else None)
    for p in written:
        print(p)
    return 0


def _extent(nm: NavMap) -> list[float]:
    """Return matplotlib's imshow extent of a navmap grid (world metres)."""
    h, w = nm.navigable.shape
    x0, y0 = float(nm.origin[0]), float(nm.origin[1])
    return [x0, x0 + w * nm.resolution, y0, y0 + h * nm.resolution]


def _base(ax, nm: NavMap, regions: RegionMap | None) -> None:
    """Draw the free/navigable grid and, when given, the region map under it."""
    img = np.full(nm.navigable.shape + (3,), 0.15)
    img[nm.free] = (0.55, 0.55, 0.55)
    img[nm.navigable] = (0.85, 0.85, 0.85)
    if regions is not None and regions.label_map.shape == nm.navigable.shape:
        import matplotlib

        cmap = matplotlib.colormaps["tab10"]
        for i, _lab in enumerate(regions.labels):
            sel = (regions.label_map == i) & nm.free
            img[sel] = 0.55 * img[sel] + 0.45 * np.array(cmap(i % 10)[:3])
    ax.imshow(img, origin="lower", extent=_extent(nm), interpolation="nearest")


def show_run(run_dir: Path, out: Path | None = None) -> list[Path]:
    """Write top-down pictures (maps, receptacles, regions, placements, episodes) of a run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    view = RunView(run_dir)  # refuses a folder that is not a run
    out = out or view.path(RunLayout.PICTURES)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for scene in view.scene_names():
        navmaps = {m.floor: m for m in view.navmaps(scene)}
        regions = {r.floor: r for r in view.region_maps(scene)}
        planes_path = view.path(RunLayout.planes(scene, "perceive"))  # as perceive found them
        planes: list[ReceptaclePlane] = load_json(planes_path, ReceptaclePlane) if planes_path.exists() else []
        variants = view.variants(scene)
        for floor, nm in sorted(navmaps.items()):
            targets = [(None, [])] + [(v, view.episodes(v)) for v in variants]
            for v, eps in targets:
                fig, ax = plt.subplots(figsize=(8, 8), dpi=100)
                _base(ax, nm, regions.get(floor))
                if floor in regions:
                    from matplotlib.patches import Patch

                    cmap = matplotlib.colormaps["tab10"]
                    present = sorted(set(int(i) for i in np.unique(regions[floor].label_map) if i >= 0))
                    ax.legend(handles=[Patch(color=cmap(i % 10), label=regions[floor].labels[i]) for i in present],
                              loc="upper right", fontsize=7)
                for pl in planes:
                    if pl.floor != floor:
                        continue
                    poly = np.vstack([pl.polygon, pl.polygon[:1]])
                    ax.plot(poly[:, 0], poly[:, 1], "-", color="tab:brown", lw=1)
                    if v is None:
                        c = pl.polygon.mean(axis=0)
                        ax.text(c[0], c[1], f"{pl.label}\n{pl.height:.2f}", fontsize=5, ha="center")
                title = f"{scene} floor {floor}"
                if v is not None:
                    title = f"{v.name} floor {floor}: {len(v.resting)} objects, {len(eps)} episodes"
                    for p in v.placements:
                        if p.settled_pos is None or abs(float(p.settled_pos[2]) - nm.height) > 3.0:
                            continue
                        color = {"resting": "tab:green", "resting_elsewhere": "tab:orange"}.get(p.status, "tab:red")
                        ax.plot(p.settled_pos[0], p.settled_pos[1], "o", ms=3, color=color)
                        ax.text(p.settled_pos[0], p.settled_pos[1], p.category, fontsize=5)
                    for e in eps:
                        if e.floor != floor:
                            continue
                        ax.plot(e.start_position[0], e.start_position[1], "^", ms=4, color="tab:blue")
                        for g in e.goals:
                            for vp in g.view_points[:5]:
                                ax.plot(vp.position[0], vp.position[1], ".", ms=2, color="tab:purple")
                ax.set_title(title, fontsize=9)
                ax.set_xlabel("x (m)")
                ax.set_ylabel("y (m)")
                name = f"{scene}_floor{floor}.png" if v is None else f"{v.name}_floor{floor}.png"
                path = out / name
                fig.savefig(path, bbox_inches="tight")
                plt.close(fig)
                written.append(path)
    return written
