"""ScanNet v2 scans as they ship, written by the test in ScanNet's layout (binary little-endian PLY, Z up, metres).

A 4 x 4 m room (floor, one connected wall strip) with a table, a night stand, an unannotated box and a labelled
speck, as ``scene0470_00_vh_clean_2.ply`` with ``scene0470_00_vh_clean_2.labels.ply`` (NYU40 class per vertex),
optionally ``scene0470_00.txt`` (axisAlignment) and the segments + aggregation of the full release. The mesh is
written in the scan's own frame, the inverse of the alignment applied, so the converted room lies where the
alignment puts it only if the alignment is read.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from assets_convert.plugin import MeshConverter
from assets_convert.scene import check_scene, convert_scene
from sdovon_mj.config import RunConfig, load_config
from sdovon_mj.errors import InputError
from sdovon_mj.pipeline import generate
from sdovon_mj.records import ReceptaclePlane, load_json

SCENE = "scene0470_00"
# axisAlignment: a quarter turn about +Z and a shift; the file's mesh is its inverse applied to the room
ALIGN = np.array([[0.0, -1.0, 0.0, 1.0], [1.0, 0.0, 0.0, 2.0], [0.0, 0.0, 1.0, 0.5], [0.0, 0.0, 0.0, 1.0]])
SIZE = 4.0  # the room is SIZE x SIZE m, walls 1.2 m high
TABLE = ((1.5, 1.7, 0.0), (2.5, 2.3, 0.75))  # (lo, hi): 1.0 m along x, 0.6 m along y, top at 0.75 m


def grid(x0: float, x1: float, y0: float, y1: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Return a horizontal n x n grid of quads at z = 0 (vertices shared: one connected surface)."""
    xs, ys = np.linspace(x0, x1, n + 1), np.linspace(y0, y1, n + 1)
    v = np.array([[x, y, 0.0] for y in ys for x in xs])
    f = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            f += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    return v, np.array(f)


def wall_strip(size: float, height: float, per_side: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the four walls of a size x size room as one strip (corner vertices shared), facing in."""
    ring = []
    for a, b in (((0, 0), (size, 0)), ((size, 0), (size, size)), ((size, size), (0, size)), ((0, size), (0, 0))):
        for k in range(per_side):
            ring.append(np.array(a) + (np.array(b) - np.array(a)) * k / per_side)
    n = len(ring)
    v = np.array([[x, y, z] for z in (0.0, height) for x, y in ring])
    f = []
    for k in range(n):
        a, b = k, (k + 1) % n
        f += [[a, b + n, b], [a, a + n, b + n]]  # counter-clockwise seen from inside the room
    return v, np.array(f)


def box(lo: tuple[float, ...], hi: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Return a closed box between two corners."""
    m = trimesh.creation.box(bounds=np.array([lo, hi]))
    return np.asarray(m.vertices), np.asarray(m.faces)


def speck() -> tuple[np.ndarray, np.ndarray]:
    """Return one 5 cm triangle lying 1 mm above the floor (0.00125 m^2, under `scannet.SPECK_AREA`; as an instance
    of its own, in the segments' scene, a mesh of 3 vertices, which MuJoCo compiles only padded)."""
    return np.array([[3.7, 0.3, 0.001], [3.75, 0.3, 0.001], [3.7, 0.35, 0.001]]), np.array([[0, 1, 2]])


def room() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (vertices, faces, NYU40 label per vertex) of the room, in the aligned (room) frame."""
    pieces = [(*grid(0, SIZE, 0, SIZE, 16), 2), (*wall_strip(SIZE, 1.2, 8), 1), (*box(*TABLE), 7),
              (*box((0.2, 3.3, 0.0), (0.6, 3.7, 0.5)), 32),  # night stand
              (*box((3.5, 3.5, 0.0), (3.8, 3.8, 0.3)), 0),  # a box nobody annotated
              (*speck(), 5)]  # a 5 cm 'chair' triangle: label noise, not a chair
    vs, fs, ls, n = [], [], [], 0
    for v, f, lab in pieces:
        vs.append(v)
        fs.append(f + n)
        ls.append(np.full(len(v), lab))
        n += len(v)
    return np.concatenate(vs), np.concatenate(fs), np.concatenate(ls)


def ply(path: Path, v: np.ndarray, f: np.ndarray, labels: np.ndarray | None = None) -> None:
    """Write a binary little-endian PLY as ScanNet's: float xyz, uchar RGBA (and ushort label), int faces."""
    props = ["property float x", "property float y", "property float z", "property uchar red", "property uchar green",
             "property uchar blue", "property uchar alpha"] + (["property ushort label"] if labels is not None else [])
    head = ["ply", "format binary_little_endian 1.0", f"element vertex {len(v)}", *props, f"element face {len(f)}",
            "property list uchar int vertex_indices", "end_header"]
    dtype = [("p", "<f4", 3), ("c", "u1", 4)] + ([("l", "<u2")] if labels is not None else [])
    vd = np.zeros(len(v), dtype=dtype)
    vd["p"] = v
    vd["c"] = (np.abs(np.sin(v * 7.0)) * 200 + 40).astype(np.uint8)[:, [0, 1, 2, 2]]
    vd["c"][:, 3] = 255
    if labels is not None:
        vd["l"] = labels
    fd = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", 3)])
    fd["n"], fd["i"] = 3, f
    path.write_bytes(("\n".join(head) + "\n").encode("ascii") + vd.tobytes() + fd.tobytes())


def write_scan(folder: Path, labels: bool = True, align: bool = True, segments: bool = False) -> Path:
    """Write the room as a ScanNet scan folder; return its ``_vh_clean_2.ply``."""
    folder.mkdir(parents=True, exist_ok=True)
    v, f, lab = room()
    if align:  # the file holds the scan frame: aligned = ALIGN @ file, so file = ALIGN^-1 @ aligned
        inv = np.linalg.inv(ALIGN)
        v = v @ inv[:3, :3].T + inv[:3, 3]
        (folder / f"{SCENE}.txt").write_text("colorHeight = 968\naxisAlignment = " + " ".join(f"{x:g}" for x in
                                             ALIGN.ravel()) + "\nsceneType = Bedroom\n", encoding="utf-8")
    mesh = folder / f"{SCENE}_vh_clean_2.ply"
    ply(mesh, v, f)
    if labels:
        ply(folder / f"{SCENE}_vh_clean_2.labels.ply", v, f, lab)
    if segments:  # one segment per NYU40 class; the aggregation names them in its own words
        seg = lab.astype(int)
        (folder / f"{SCENE}_vh_clean_2.0.010000.segs.json").write_text(json.dumps({"segIndices": seg.tolist()}))
        words = {2: "floor", 1: "wall", 7: "coffee table", 32: "nightstand", 5: "chair"}
        groups = [{"objectId": k, "label": words[s], "segments": [s]} for k, s in enumerate(sorted(words))]
        (folder / f"{SCENE}.aggregation.json").write_text(json.dumps({"segGroups": groups}))
    return mesh


def labels_of(asset) -> list[str]:
    return sorted(i.label for i in asset.instances)


def test_labels_mesh_gives_named_instances_in_the_aligned_frame(tmp_path: Path) -> None:
    mesh = write_scan(tmp_path / SCENE)
    (tmp_path / SCENE / f"{SCENE}_vh_clean.ply").write_bytes(mesh.read_bytes())  # the full-resolution mesh
    # the folder as downloaded is one scene: the labels mesh and the full mesh are companions
    assert MeshConverter().scene_files(tmp_path / SCENE) == [mesh]
    asset = convert_scene(mesh, tmp_path / "out", cache_dir="off")
    assert asset.name == SCENE
    # one instance per connected component of a class; the speck (a 0.00125 m^2 'chair') joins the unannotated box
    assert labels_of(asset) == ["floor", "nightstand", "table", "unlabeled", "wall"]
    assert asset.unused == []
    table = next(i for i in asset.instances if i.label == "table")
    np.testing.assert_allclose(table.bounds, np.array(TABLE), atol=1e-5)  # the alignment was applied
    np.testing.assert_allclose(asset.bounds, [[0, 0, 0], [SIZE, SIZE, 1.2]], atol=1e-5)


def test_segments_and_aggregation_win_over_the_labels_mesh(tmp_path: Path) -> None:
    mesh = write_scan(tmp_path / SCENE, segments=True)
    asset = convert_scene(mesh, tmp_path / "out", cache_dir="off")
    assert labels_of(asset) == ["chair", "coffee table", "floor", "nightstand", "unlabeled", "wall"]
    assert len(asset.unused) == 1 and f"{SCENE}_vh_clean_2.labels.ply" in asset.unused[0]
    table = next(i for i in asset.instances if i.label == "coffee table")
    np.testing.assert_allclose(table.bounds, np.array(TABLE), atol=1e-5)


def test_a_scan_without_labels_names_the_files_it_looked_for(tmp_path: Path) -> None:
    mesh = write_scan(tmp_path / SCENE, labels=False, align=False)
    asset = convert_scene(mesh, tmp_path / "out", cache_dir="off")
    assert len(asset.instances) == 1
    (line,) = asset.unused
    assert f"{SCENE}_vh_clean_2.labels.ply" in line and "segs.json" in line and "aggregation.json" in line


def test_bad_scan_files_are_named_before_any_work(tmp_path: Path) -> None:
    mesh = write_scan(tmp_path / SCENE)
    check_scene(mesh)  # the good scan passes
    txt = tmp_path / SCENE / f"{SCENE}.txt"
    txt.write_text("axisAlignment = 1 0 0 0 0 1 0 0\n", encoding="utf-8")
    with pytest.raises(InputError, match=rf"{SCENE}\.txt: axisAlignment must be 16 numbers"):
        check_scene(mesh)
    txt.write_text("axisAlignment = 2 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"not a rotation and a translation"):
        check_scene(mesh)
    txt.unlink()
    v, f, _lab = room()
    ply(tmp_path / SCENE / f"{SCENE}_vh_clean_2.labels.ply", v, f)  # a labels mesh without its label property
    with pytest.raises(InputError, match=r"labels\.ply: not a ScanNet labels mesh"):
        check_scene(mesh)


@pytest.mark.slow
def test_a_labels_only_scan_has_a_table_receptacle_after_perceive(tmp_path: Path) -> None:
    """Convert, observe and perceive (the stage that finds receptacle planes) on the labels-only scan; the rest of a
    generate (objects, place, episodes) reads nothing of the scan that perceive did not."""
    mesh = write_scan(tmp_path / SCENE)
    cfg = load_config(None, ["observe.width=96", "observe.height=72", "observe.yaw_steps=4",
                             "observe.pitch_angles=[-35.0]", "observe.camera_heights=[]"])
    summary = generate(tmp_path / "run", cfg, scenes=[str(mesh)], until=["perceive"], progress=False)
    assert summary.scenes == [SCENE]
    planes = load_json(tmp_path / "run" / "scenes" / SCENE / "perceive" / "planes.json", ReceptaclePlane)
    tops = [p for p in planes if p.label == "table"]
    assert tops, [(p.label, p.height) for p in planes]
    assert abs(tops[0].height - TABLE[1][2]) < RunConfig().receptacles.eps_t
