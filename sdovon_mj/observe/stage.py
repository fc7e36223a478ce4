"""The observe stage for one scene: floors -> navmaps -> coverage viewpoints -> rendered shards.

Outputs under ``<out_root>/<out_rel_dir>/`` (paths in the summary are relative to out_root):
``floors.json`` (Floor list), ``navmap_<i>.json`` (NavMap) + ``navmap_<i>.png``,
``coverage_<i>.png`` (M_P over the navmap with the viewpoints), ``viewpoints.json`` (CoverageCamera
list, all floors), ``obs_<k>.npz`` shards (Observation records with K and T_cam) and
``summary.json``..
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from .. import hints
from ..config import AgentConfig, ObserveConfig
from ..errors import InputError, StageError
from ..records import CoverageCamera, NavMap, SceneAsset, dumps, save_json
from ..runview import RunLayout
from ..sim.model import load_scene_mesh
from ..store import atomic_write_text
from .coverage import coverage_viewpoints
from .floors import NoFloorFound, find_floors
from .io import save_shards
from .navmap import NoNavigableArea, navigable_map, navmap_image, save_png
from .render_views import load_model, render_observations, view_angles


def load_mesh(scene: SceneAsset, store_root: str | Path) -> tuple[Path, np.ndarray, np.ndarray, np.ndarray]:
    """Load a scene's mesh sidecar: path, vertices, faces, face_instance (InputError when missing)."""
    if not scene.mesh:
        raise InputError(Path(store_root) / scene.mjcf, "scene has no mesh sidecar (SceneAsset.mesh is empty)")
    path = Path(store_root) / scene.mesh
    if not path.exists():
        raise InputError(path, "scene mesh sidecar not found")
    try:
        v, f, fi = load_scene_mesh(path)
    except (OSError, KeyError, ValueError) as e:
        raise InputError(path, f"not a scene mesh sidecar ({e})") from None
    return path, v, f, fi


def scene_floors_and_maps(vertices: np.ndarray, faces: np.ndarray, cfg: ObserveConfig,
                          source: str | Path = "<mesh>", agent: AgentConfig = AgentConfig()
                          ) -> tuple[list, list[NavMap], dict[int, str]]:
    """Return floors, navmaps of floors with navigable area, and why other floors were skipped.

    Parameters
    ----------
    vertices : (N, 3) float
        Scene mesh vertices, world metres, Z up.
    faces : (M, 3) int
        Triangle vertex indices.
    cfg : ObserveConfig
        Floor detection and navigable-map settings.
    source : str or Path
        The mesh's source (named in errors).
    agent : AgentConfig
        The agent's body (radius, height) and camera (height, HFOV), metres and degrees.
    """
    try:
        floors = find_floors(vertices, faces, cfg, agent)
    except NoFloorFound as e:
        raise InputError(source, f"{e}; {hints.no_floor(e.largest_m2, cfg.min_floor_area, e.above_m)}") from None
    except StageError as e:
        raise InputError(source, str(e)) from None
    maps: list[NavMap] = []
    skipped: dict[int, str] = {}
    figures = []
    for fl in floors:
        try:
            maps.append(navigable_map(vertices, faces, fl, cfg, agent))
        except NoNavigableArea as e:
            skipped[fl.index] = str(e)
            figures.append(e.figures)
        except StageError as e:
            skipped[fl.index] = str(e)
    if not maps:
        hint = hints.no_navigable_area(figures, cfg.min_component_area, agent.radius)
        raise InputError(source, "no floor has navigable area: " + "; ".join(skipped.values()) + (f"; {hint}" if hint else ""))
    return floors, maps, skipped


def observe_scene(scene: SceneAsset, store_root: str | Path, out_rel_dir: str | Path, cfg: ObserveConfig,
                  seed: int = 0, out_root: str | Path | None = None, render: bool = True,
                  agent: AgentConfig = AgentConfig()) -> dict[str, Any]:
    """Run the observe stage on one scene and write its outputs; return a JSON-able summary.

    Parameters
    ----------
    scene
        The converted scene (its mesh sidecar is sliced for floors and navigable maps).
    store_root
        Run folder the scene's paths are relative to.
    out_rel_dir
        Output folder relative to ``out_root``.
    cfg
        Observe settings.
    seed
        Scene seed (combined with ``cfg.seed`` and the floor for coverage sampling).
    out_root
        Folder the outputs are written under (default ``store_root``).
    render
        Render the RGB-D(+seg) observation shards.
    agent
        The agent's body (navigable map erosion and obstacle band) and camera (height, hfov).
    """
    t0 = time.perf_counter()
    store_root = Path(store_root)
    root = Path(out_root) if out_root is not None else store_root
    rel = Path(out_rel_dir)
    out = root / rel
    out.mkdir(parents=True, exist_ok=True)
    mesh_path, v, f, _fi = load_mesh(scene, store_root)
    floors, maps, skipped = scene_floors_and_maps(v, f, cfg, mesh_path, agent)
    outputs: list[str] = []

    def _p(name: str) -> str:
        outputs.append((rel / name).as_posix())
        return outputs[-1]

    save_json(floors, root / _p("floors.json"))
    viewpoints: list[CoverageCamera] = []
    per_floor = []
    log = []
    for nm in maps:
        vps, mp, stats = coverage_viewpoints(nm, cfg, seed=[int(seed), int(cfg.seed), int(nm.floor)], agent=agent)
        save_json(nm, root / _p(RunLayout.navmap_file(nm.floor)))
        save_png(navmap_image(nm), root / _p(RunLayout.navmap_file(nm.floor, ".png")))
        pts = np.array([vp.position for vp in vps]) if vps else None
        save_png(navmap_image(nm, coverage=mp, points=pts), root / _p(f"coverage_{nm.floor}.png"))
        res2 = nm.resolution ** 2
        per_floor.append({"floor": nm.floor, "height": nm.height, "navigable_m2": round(float(nm.navigable.sum()) * res2, 4),
                          "free_m2": round(float(nm.free.sum()) * res2, 4), "viewpoints": len(vps),
                          "first_viewpoint": len(viewpoints), "coverage": stats.to_dict()})
        log.append(f"floor {nm.floor} ({per_floor[-1]['navigable_m2']:g} m^2 navigable): "
                   + stats.describe(cfg.coverage_threshold))
        viewpoints.extend(vps)
    save_json(viewpoints, root / _p("viewpoints.json"))
    shards: list[str] = []
    frames = 0
    if render and viewpoints:
        model = load_model(scene, store_root)
        paths = save_shards(render_observations(model, viewpoints, cfg, agent=agent), out, cfg.frames_per_shard)
        shards = [(rel / p.name).as_posix() for p in paths]
        outputs.extend(shards)
        frames = len(viewpoints) * len(view_angles(cfg))
    notes = []
    known = sorted(round(fl.height, 2) for fl in scene.floors)
    found = [round(fl.height, 2) for fl in floors]
    if known and (len(known) != len(found) or any(abs(a - b) > cfg.floor_cluster_tol for a, b in zip(known, found))):
        notes.append(f"floors found at {found} differ from the scene's own floors {known}")
    summary = {
        "scene": scene.name,
        "floors": [{"index": fl.index, "height": fl.height, "area": fl.area} for fl in floors],
        "skipped_floors": {str(k): v for k, v in sorted(skipped.items())},
        "maps": per_floor,
        "viewpoints": len(viewpoints),
        "frames": frames,
        "views_per_viewpoint": len(view_angles(cfg)),
        "shards": shards,
        "outputs": sorted(outputs + [(rel / "summary.json").as_posix()]),
        "notes": notes,
    }
    atomic_write_text(out / "summary.json", dumps(summary))
    summary["seconds"] = round(time.perf_counter() - t0, 3)  # not written: outputs stay byte-identical
    summary["log"] = log  # one line per floor: the coverage reached (the pipeline prints them; not written)
    return summary
