"""One rule for a scene's name from its file (`sdovon_mj.naming.scene_name`), end to end through a run.

Awkward names as users' files have them: dots in the stem (``van-gogh-room.mesh.ply`` once made two scene folders and
a FileNotFoundError), spaces, accented and non-Latin letters, ScanNet's ``_vh_clean_2`` and HM3D's ``.basis``, and two
files of one stem in two folders. The run's convert stage must write exactly one folder per scene, under the name the
run lists, and the names must be the same on a second run.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from sdovon_mj.config import RunConfig
from sdovon_mj.naming import scene_name, scene_stem
from sdovon_mj.pipeline import generate
from sdovon_mj.stages import name_scenes


def write_room(path: Path, width: float = 2.0) -> Path:
    """Write a `width` x 2 x 1 m box (a tiny room's shell) in the file's format."""
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=(width, 2.0, 1.0)).export(str(path))
    return path


def test_the_rule_on_names_seen_in_the_wild() -> None:
    assert scene_stem("x/van-gogh-room.mesh.ply") == "van-gogh-room.mesh"  # sidecars are found under this stem
    assert scene_name("x/van-gogh-room.mesh.ply") == "van-gogh-room_mesh"
    assert scene_name("scans/scene0470_00_vh_clean_2.ply") == "scene0470_00"
    assert scene_name("scans/scene0470_00_vh_clean.ply") == "scene0470_00"
    assert scene_name("hm3d/00800-TEEsavR23oF/TEEsavR23oF.basis.glb") == "TEEsavR23oF"
    assert scene_name("stages/Baked_sc1_staging_00.glb") == "Baked_sc1_staging_00"
    assert scene_name("d/scenes/apt_0.scene_instance.json") == "apt_0"
    assert scene_name("d/rc.scene_dataset_config.json") == "rc"
    assert scene_name("my room (2).obj") == "my_room_2"
    assert scene_name("Café Zimmer.ply") == "Cafe_Zimmer"
    a, b = scene_name("客厅.obj"), scene_name("卧室.obj")  # no ASCII left: a stable digest of the text
    assert a.startswith("scene_") and b.startswith("scene_") and a != b and scene_name("客厅.obj") == a


def test_awkward_names_give_one_folder_per_scene_through_a_run(tmp_path: Path) -> None:
    src = tmp_path / "in"
    files = [write_room(src / n, 3.0 if n == "b/room.ply" else 2.0)
             for n in ("van-gogh-room.mesh.ply", "my room (2).obj", "Café Zimmer.ply", "客厅.obj", "a/room.ply",
                       "b/room.ply", "scene0470_00_vh_clean_2.ply")]
    names = list(name_scenes([str(f.resolve()) for f in files]))
    assert names == ["van-gogh-room_mesh", "my_room_2", "Cafe_Zimmer", scene_name("客厅.obj"), "room", "room_2",
                     "scene0470_00"]
    assert list(name_scenes([str(f.resolve()) for f in files])) == names  # stable
    summary = generate(tmp_path / "run", RunConfig(), scenes=[str(f) for f in files], until=["convert"],
                       progress=False)
    assert sorted(summary.scenes) == sorted(names)
    folders = sorted(p.name for p in (tmp_path / "run" / "scenes").iterdir() if p.is_dir())
    assert folders == sorted(names)  # one folder per scene, named as the run names it
    for n in names:
        assert (tmp_path / "run" / "scenes" / n / "scene.xml").is_file(), n
    # the two room.ply files are two scenes, each its own file's geometry (a/room.ply 2 m wide, b/room.ply 3 m)
    for n, width in (("room", 2.0), ("room_2", 3.0)):
        v = np.load(tmp_path / "run" / "scenes" / n / "scene_mesh.npz")["vertices"]
        assert abs(float(np.ptp(v[:, 0])) - width) < 1e-6, n


def test_sdovon_mj_convert_names_scenes_as_a_run_does(tmp_path: Path) -> None:
    """`sdovon-mj convert --kind scene` (`convert_tree`) gives two files of one stem two folders, named as a run
    names them."""
    from assets_convert import convert_tree

    files = [write_room(tmp_path / "in" / d / "room.mesh.ply", w) for d, w in (("a", 2.0), ("b", 3.0))]
    convert_tree([str(f) for f in files], tmp_path / "out", kind="scene", jobs=1, progress=False, cache_dir="off")
    assert sorted(p.name for p in (tmp_path / "out" / "scenes").iterdir()) == ["room_mesh", "room_mesh_2"]
    for n, width in (("room_mesh", 2.0), ("room_mesh_2", 3.0)):
        v = np.load(tmp_path / "out" / "scenes" / n / "scene_mesh.npz")["vertices"]
        assert abs(float(np.ptp(v[:, 0])) - width) < 1e-6, n
