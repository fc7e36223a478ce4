"""Rendering throughput of the observe stage: RGB, depth, segmentation and all three, at 640x480.

Scenes: a default-world apartment (when sdovon_mj.world and assets_convert.convert_scene are
available; otherwise the synthetic two-storey apartment of tests/support/scenes.py) and the
shared furnished living room (its glTF room plus the furniture listed in placements.json, textured,
through convert_scene when available; otherwise composed from placements.json, untextured). Frames
are rendered from coverage viewpoints with the stage's yaw / pitch sweep, through the same SceneRenderer the stage uses (one update_scene per frame; RGB is one
pass, depth + segmentation one flat id-colour pass). Runs unchanged with MUJOCO_GL=egl on CPU
(Mesa llvmpipe) or on a GPU.

    python bench/bench_render.py [--frames 48] [--width 640 --height 480] [--out DIR]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))  # tests/support: the fixture scenes (not installed with the package)

from sdovon_mj.config import ObserveConfig  # noqa: E402
from sdovon_mj.observe import coverage_viewpoints, scene_floors_and_maps, view_angles  # noqa: E402
from sdovon_mj.observe.render_views import load_model, make_renderer  # noqa: E402
from sdovon_mj.observe.stage import load_mesh  # noqa: E402
from support.scenes import apartment_boxes, living_room_parts, write_box_scene, write_mesh_scene  # noqa: E402
from sdovon_mj.sim.camera import pose_cv  # noqa: E402

SHARED = Path(os.environ.get("SDOVON_SHARED_ASSETS", REPO.parent / "shared" / "assets"))


def _convert():
    """Return assets_convert.convert_scene, or None while it has not landed."""
    try:
        from assets_convert import convert_scene  # type: ignore[attr-defined]
    except ImportError:
        return None
    return convert_scene


def apartment_scene(work: Path):
    """Return (label, SceneAsset, store root) of a default-world apartment (or the synthetic one)."""
    conv = _convert()
    try:
        from sdovon_mj.world import generate_apartment, write_apartment  # type: ignore[attr-defined]
    except ImportError:
        generate_apartment = None
    if conv is not None and generate_apartment is not None:
        src = write_apartment(generate_apartment(0), work / "apt_src")
        return "default apartment (seed 0)", conv(src, work / "apt"), work / "apt"
    return "synthetic 2-storey apartment", write_box_scene(apartment_boxes(2), work / "apt"), work / "apt"


def living_room_scene(work: Path):
    """Return (label, SceneAsset, store root) of the shared furnished living room."""
    conv = _convert()
    room = SHARED / "scenes" / "furnished_living_room" / "living_room.gltf"
    if not room.exists():
        return None
    if conv is not None:
        try:
            return "furnished living room (convert_scene, textured)", conv(room, work / "lr"), work / "lr"
        except Exception as e:  # noqa: BLE001 - the fallback still measures the same geometry
            print(f"  convert_scene failed ({e}); composing the room from placements.json instead")
    return "furnished living room (untextured)", write_mesh_scene(living_room_parts(SHARED), work / "lr", "living_room"), work / "lr"


def bench(label: str, scene, root: Path, cfg: ObserveConfig, frames: int) -> None:
    """Print fps for rgb, depth, seg and all three on one scene."""
    _p, v, f, _fi = load_mesh(scene, root)
    _floors, maps, _sk = scene_floors_and_maps(v, f, cfg)
    vps, _mp, _st = coverage_viewpoints(maps[0], cfg, seed=0)
    poses = [pose_cv(vp.position, yaw, pitch) for vp in vps for yaw, pitch in view_angles(cfg)]
    poses = (poses * (frames // max(len(poses), 1) + 1))[:frames]
    model = load_model(scene, root)
    r = make_renderer(model, cfg)
    print(f"{label}: {len(f)} triangles, {model.ngeom} geoms, {len(poses)} frames at {cfg.width}x{cfg.height}")
    try:
        r.render(poses[0], rgb=True, depth=True, segmentation=True)  # warm-up (shader/texture upload)
        for name, kw in [("rgb", dict(rgb=True, depth=False, segmentation=False)),
                         ("depth", dict(rgb=False, depth=True, segmentation=False)),
                         ("seg", dict(rgb=False, depth=False, segmentation=True)),
                         ("rgb+depth+seg", dict(rgb=True, depth=True, segmentation=True))]:
            best, cpu = 0.0, 0.0
            for _rep in range(2):
                t0, c0 = time.perf_counter(), time.process_time()
                for T in poses:
                    r.render(T, **kw)
                fps = len(poses) / (time.perf_counter() - t0)
                if fps > best:
                    best, cpu = fps, (time.process_time() - c0) / len(poses)
            print(f"  {name:14s} {best:7.1f} frames/s   ({cpu * 1000:.1f} ms CPU per frame, all threads)")
    finally:
        r.close()


def main() -> int:
    """Run the benchmark and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=48, help="frames per measurement")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--out", default=None, help="work folder (default: a temporary one)")
    a = ap.parse_args()
    cfg = dataclasses.replace(ObserveConfig(), width=a.width, height=a.height)
    import mujoco

    print(f"MUJOCO_GL={os.environ.get('MUJOCO_GL')} mujoco {mujoco.__version__}, {os.cpu_count()} CPUs visible, "
          f"LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', '(default)')}, load average {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(a.out) if a.out else Path(tmp)
        for make in (apartment_scene, living_room_scene):
            got = make(work)
            if got is None:
                print("shared assets not found: skipping the living room")
                continue
            bench(*got, cfg, a.frames)
    return 0


if __name__ == "__main__":
    sys.exit(main())
