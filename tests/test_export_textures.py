"""Textured Habitat export: stage and object GLBs carry the base-colour textures MuJoCo renders.

The default apartment (wood and tiled floors, wooden furniture: PNG textures with UVs) is converted, its geoms are
written as the Habitat exporter writes a stage, and the GLB is read back with our own loader (trimesh's glTF reader
-> MJCF). Rendered from the same cameras, every textured surface must look like the MuJoCo original, closer than the
old colour-only export comes (an ordering, no tuned margin); the texture images in the GLB are MuJoCo's own texels.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh

import mujoco

from assets_convert import convert_scene
from exporters.habitat import frames
from exporters.habitat.glb import _RGB, geoms_mesh, geoms_scene, glb_bytes
from sdovon_mj.world import generate_apartment
from sdovon_mj.world.io import write_apartment


def _load(xml: Path) -> tuple[mujoco.MjModel, mujoco.MjData]:
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    return m, d


def _render(md: tuple[mujoco.MjModel, mujoco.MjData], cam: mujoco.MjvCamera, seg: bool = False) -> np.ndarray:
    r = mujoco.Renderer(md[0], 120, 160)
    try:
        if seg:
            r.enable_segmentation_rendering()
        r.update_scene(md[1], cam)
        return r.render().copy()
    finally:
        r.close()


@pytest.fixture(scope="module")
def scenes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    root = tmp_path_factory.mktemp("tex")
    apt = generate_apartment(0)
    src = convert_scene(write_apartment(apt, root / "in", "clean", "apt"), root / "conv", cache_dir="off")
    model, data = _load(root / "conv" / src.mjcf)
    geoms = [g for g in range(model.ngeom) if int(model.geom_group[g]) in (0, 1)]
    (root / "textured.glb").write_bytes(glb_bytes(geoms_scene(model, data, geoms, np.eye(4), frames.C)))
    (root / "colour.glb").write_bytes(glb_bytes(geoms_mesh(model, data, geoms, np.eye(4), frames.C)))
    back = {k: convert_scene(root / f"{k}.glb", root / f"re_{k}", up="+Y", cache_dir="off") for k in ("textured", "colour")}
    return {"root": root, "apt": apt, "src": src, "model": model, "data": data, "back": back}


def test_textured_glb_holds_mujocos_texels(scenes: dict) -> None:
    model = scenes["model"]
    glb = trimesh.load(str(scenes["root"] / "textured.glb"), force="scene", process=False)
    textured = [g for g in range(model.ngeom) if model.geom_matid[g] >= 0 and model.mat_texid[model.geom_matid[g], _RGB] >= 0]
    assert textured, "the default apartment has textured floors and furniture"
    for g in textured:
        geom = glb.geometry[mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)]
        img = np.asarray(geom.visual.material.baseColorTexture.convert("RGB"))
        tex = int(model.mat_texid[model.geom_matid[g], _RGB])
        h, w, c = int(model.tex_height[tex]), int(model.tex_width[tex]), int(model.tex_nchannel[tex])
        mj = model.tex_data[model.tex_adr[tex]:model.tex_adr[tex] + h * w * c].reshape(h, w, c)[..., :3]
        assert np.array_equal(img, mj)  # PNG in the GLB: lossless, same orientation
    # the same bytes for the same scene
    again = glb_bytes(geoms_scene(model, scenes["data"], list(range(model.ngeom)), np.eye(4), frames.C))
    assert again == glb_bytes(geoms_scene(model, scenes["data"], list(range(model.ngeom)), np.eye(4), frames.C))


def test_reimported_textured_export_renders_like_mujoco(scenes: dict) -> None:
    model = scenes["model"]
    orig = (model, scenes["data"])
    root = scenes["root"]
    tex = _load(root / "re_textured" / scenes["back"]["textured"].mjcf)
    col = _load(root / "re_colour" / scenes["back"]["colour"].mjcf)
    textured = {g for g in range(model.ngeom) if model.geom_matid[g] >= 0 and model.mat_texid[model.geom_matid[g], _RGB] >= 0}
    rows, seen = [], 0
    for room in scenes["apt"].rooms:
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        cam.lookat[:] = [*np.asarray(room.polygon).mean(axis=0), 0.3]
        cam.distance, cam.azimuth, cam.elevation = 2.0, 45.0, -50.0
        seg = _render(orig, cam, seg=True)[..., 0]
        a, b, c = _render(orig, cam), _render(tex, cam), _render(col, cam)
        rows.append(np.concatenate([a, b, c], axis=1))
        for g in np.unique(seg):
            mask = seg == g
            if g not in textured or mask.sum() < 100:
                continue
            ref = a[mask].astype(float).mean(axis=0)
            err_tex = np.abs(b[mask].astype(float).mean(axis=0) - ref).max()
            err_col = np.abs(c[mask].astype(float).mean(axis=0) - ref).max()
            assert err_tex < err_col, (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(g)), err_tex, err_col)
            seen += 1
    assert seen >= 2  # the floors at least
    picture = Path(os.environ.get("SDOVON_TEXTURE_PICTURE", root / "mujoco_vs_textured_vs_colour.png"))
    from PIL import Image

    Image.fromarray(np.concatenate(rows, axis=0)).save(picture)
