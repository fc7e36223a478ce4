"""GPU-encoded textures: KTX2 (Basis Universal ETC1S / UASTC, or plain RGB(A)8) and raw ``.basis`` images -> RGBA.

HM3D ships its meshes as ``<id>.basis.glb`` whose base-colour textures are Basis Universal images (glTF extensions
``KHR_texture_basisu``, KTX2, or ``GOOGLE_texture_basis``, raw ``.basis``); Pillow, and so trimesh, cannot read
them and would drop them without a word. Here a glTF/GLB whose base-colour images are so encoded is rewritten in
memory with each such image decoded to PNG (`decoded_gltf`), and the mesh loader reads that instead; the converter
then writes PNG textures as for any model, so observation, perception and the exports all see the texture.

The Basis Universal transcoder is ``opengl-basisu`` (PyPI; MIT, with Binomial's Apache-2.0 basis_universal inside),
transcoding to RGBA8. A KTX2 file of plain 8-bit RGB/RGBA pixels (no Basis payload; no, zlib or Zstandard
supercompression) is read here directly. Anything else (another vkFormat, KTX1, DDS, ASTC textures) stays the
clear error of `load._check_colour_textures`: `header_problem` says what cannot be decoded.

Orientation: glTF puts the first image row at the top (texture coordinate v = 0), and `decode` hands back rows in
that order whatever the container says. A ``.basis`` file whose header has the Y-flipped flag (basisu ``-y_flip``;
ReplicaCAD's baked stage atlases) stores the image upside down; a KTX2 file says in its ``KTXorientation``
key/value how its rows and columns run (``rd``, x right and y down, is glTF's; ``ru`` is upside down; ``l`` mirrors
x). Both are turned back here, so perception and both exports see the image its author saw; a ``KTXorientation``
that is not an orientation is an error naming the file.
"""

from __future__ import annotations

import base64
import io
import json
import os
import struct
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from sdovon_mj.errors import InputError

KTX2_MAGIC = b"\xabKTX 20\xbb\r\n\x1a\n"
KTX1_MAGIC = b"\xabKTX 11\xbb\r\n\x1a\n"
BASIS_MAGIC = b"sB"  # the .basis file header's signature (uint16 0x4273, little endian)
BASIS_EXTENSIONS = ("KHR_texture_basisu", "GOOGLE_texture_basis")  # texture extensions naming a Basis image
# plain KTX2 pixel formats read here: vkFormat -> channels (R8G8B8 / R8G8B8A8, UNORM and SRGB)
PLAIN_FORMATS = {23: 3, 29: 3, 37: 4, 43: 4}
SUPERCOMPRESSION = {0: "none", 1: "BasisLZ", 2: "Zstandard", 3: "ZLIB"}


def container_of(head: bytes) -> str | None:
    """Return 'ktx2', 'ktx1', 'basis' or None for the first bytes of an image."""
    if head.startswith(KTX2_MAGIC):
        return "ktx2"
    if head.startswith(KTX1_MAGIC):
        return "ktx1"
    if head.startswith(BASIS_MAGIC):
        return "basis"
    return None


def _transcoder() -> Any:
    """Return the opengl_basisu module, or raise InputError-ready text when it is not installed."""
    try:
        import opengl_basisu
    except ImportError:  # pragma: no cover - a dependency of the package
        return None
    return opengl_basisu


def header_problem(head: bytes) -> str:
    """Return why an image whose first 80 bytes are `head` cannot be decoded here ('' when it can)."""
    kind = container_of(head)
    if kind == "ktx1":
        return "KTX (version 1) images are not read here"
    if kind is None:
        return f"not a KTX2 or Basis Universal image (starts {head[:12]!r})"
    basis = kind == "basis" or (len(head) >= 16 and struct.unpack_from("<I", head, 12)[0] == 0)
    if basis:
        return "" if _transcoder() is not None else ("its Basis Universal payload needs the transcoder: "
                                                      "`pip install opengl-basisu`")
    if len(head) < 48:
        return "truncated KTX2 header"
    vk, scheme = struct.unpack_from("<I", head, 12)[0], struct.unpack_from("<I", head, 44)[0]
    if vk not in PLAIN_FORMATS:
        return f"KTX2 vkFormat {vk} is neither a Basis Universal payload nor 8-bit RGB/RGBA pixels"
    if scheme not in (0, 2, 3):
        return f"KTX2 supercompression {SUPERCOMPRESSION.get(scheme, scheme)} on plain pixels"
    if scheme == 2:
        try:
            import zstandard  # noqa: F401
        except ImportError:
            return "its pixels are Zstandard-supercompressed and the zstandard package is not installed"
    return ""


ORIENTATION_KEY = b"KTXorientation"


def ktx2_key_values(data: bytes, where: str) -> dict[bytes, bytes]:
    """Return the key/value data of a KTX2 file: key -> value (bytes, a string value's NUL kept); raise InputError
    naming `where` when the block lies past the file's end."""
    if len(data) < 80:
        raise InputError(where, "truncated KTX2 header")
    offset, length = struct.unpack_from("<II", data, 56)
    if offset + length > len(data):
        raise InputError(where, "truncated KTX2 file: its key/value data lies past its end")
    out: dict[bytes, bytes] = {}
    pos, end = offset, offset + length
    while pos + 4 <= end:
        (n,) = struct.unpack_from("<I", data, pos)
        entry = data[pos + 4:pos + 4 + n]
        if len(entry) < n:
            raise InputError(where, "damaged KTX2 key/value data (an entry runs past the block)")
        key, _nul, value = entry.partition(b"\0")
        out[key] = value
        pos += 4 + n + (-n % 4)
    return out


def ktx2_flips(data: bytes, where: str) -> tuple[bool, bool]:
    """Return (flip rows, flip columns) that turn a KTX2 image into glTF's orientation (``rd``: x right, y down),
    from its ``KTXorientation`` key (absent: the default, ``rd``); raise InputError naming `where` for a value that
    is not an orientation (first letter r or l, then d or u; a third letter, o or i, is z's and does not matter to
    a 2D image)."""
    raw = ktx2_key_values(data, where).get(ORIENTATION_KEY)
    if raw is None:
        return False, False
    text = raw.split(b"\0", 1)[0].decode("ascii", "replace")
    if not (1 <= len(text) <= 3 and text[0] in "rl" and (len(text) < 2 or text[1] in "du")
            and (len(text) < 3 or text[2] in "oi")):
        raise InputError(where, f"KTXorientation {text!r} is not a KTX2 orientation (r or l, then d or u): the "
                                "image cannot be turned to glTF's 'rd'")
    return len(text) > 1 and text[1] == "u", text[0] == "l"


def decode(data: bytes, where: str) -> Any:
    """Return a GPU-encoded image (KTX2 or ``.basis``, level 0) as a PIL RGBA image, first row at the top (glTF's
    orientation: a ``.basis`` Y-flipped flag and a KTX2 ``KTXorientation`` honoured); raise InputError naming
    `where`."""
    from PIL import Image

    why = header_problem(data[:80])
    if why:
        raise InputError(where, why)
    kind = container_of(data)
    rows, cols = ktx2_flips(data, where) if kind == "ktx2" else (False, False)
    if kind == "ktx2" and struct.unpack_from("<I", data, 12)[0] in PLAIN_FORMATS:
        pixels = _plain_ktx2(data, where)
    else:
        basisu = _transcoder()
        try:
            tex = basisu.open(bytes(data))
            img = tex.transcode("rgba8", level=0)
        except Exception as e:  # noqa: BLE001 - the transcoder's refusal of a damaged file
            raise InputError(where, f"Basis Universal image cannot be transcoded: {type(e).__name__}: {e}") from None
        pixels = img.data[:, :, :4]
        rows = rows or (kind == "basis" and bool(tex.y_flipped))  # the encoder flipped it: flip it back
    if rows:
        pixels = pixels[::-1]
    if cols:
        pixels = pixels[:, ::-1]
    return Image.fromarray(np.ascontiguousarray(pixels, dtype=np.uint8))


def _plain_ktx2(data: bytes, where: str) -> np.ndarray:
    """Return level 0 of a KTX2 file of 8-bit RGB/RGBA pixels as an (H, W, C) uint8 array (rows top first)."""
    vk, _ts, w, h = struct.unpack_from("<IIII", data, 12)
    scheme = struct.unpack_from("<I", data, 44)[0]
    offset, length, raw_len = struct.unpack_from("<QQQ", data, 80)
    blob = data[offset:offset + length]
    if len(blob) != length:
        raise InputError(where, "truncated KTX2 file: level 0 lies past its end")
    if scheme == 3:
        blob = zlib.decompress(blob)
    elif scheme == 2:
        import zstandard

        blob = zstandard.ZstdDecompressor().decompress(blob, max_output_size=max(raw_len, 1))
    ch = PLAIN_FORMATS[vk]
    if len(blob) < w * h * ch:
        raise InputError(where, f"KTX2 level 0 holds {len(blob)} bytes, {w}x{h}x{ch} needed")
    return np.frombuffer(blob[: w * h * ch], dtype=np.uint8).reshape(h, w, ch)


def gpu_colour_images(doc: dict[str, Any]) -> dict[int, int]:
    """Return texture index -> image index of the base-colour textures whose image is GPU-encoded in a glTF document
    (named by a Basis texture extension, or an image whose MIME type or file suffix is KTX2 / Basis)."""
    textures, images = doc.get("textures", []), doc.get("images", [])
    out: dict[int, int] = {}
    for mat in doc.get("materials", []):
        idx = mat.get("pbrMetallicRoughness", {}).get("baseColorTexture", {}).get("index")
        if idx is None or not 0 <= idx < len(textures):
            continue
        tex = textures[idx]
        ext = next((tex.get("extensions", {})[e] for e in BASIS_EXTENSIONS if e in tex.get("extensions", {})), None)
        if ext is not None and isinstance(ext.get("source"), int) and 0 <= ext["source"] < len(images):
            out[idx] = int(ext["source"])
            continue
        src = tex.get("source")
        img = images[src] if isinstance(src, int) and 0 <= src < len(images) else {}
        if str(img.get("mimeType", "")).lower() in ("image/ktx2", "image/basis", "image/x-basis") \
                or str(img.get("uri", "")).lower().endswith((".ktx2", ".basis")):
            out[idx] = int(src)
    return out


def _glb_chunks(data: bytes, where: str) -> tuple[dict[str, Any], bytes]:
    """Return (JSON, BIN chunk) of a GLB."""
    clen = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + clen].decode("utf-8"))
    off = 20 + clen
    binary = b""
    if off + 8 <= len(data):
        blen, btype = struct.unpack_from("<II", data, off)
        if btype == 0x004E4942:
            binary = data[off + 8:off + 8 + blen]
    return doc, binary


def image_bytes(doc: dict[str, Any], binary: bytes, image: int, folder: Path, where: str, limit: int | None = None) -> bytes:
    """Return the bytes of a glTF image (its bufferView in `binary`, a data URI, or a file beside the model); with
    `limit`, at most that many leading bytes.

    Parameters
    ----------
    doc : dict
        The glTF JSON.
    binary : bytes
        The GLB's BIN chunk (b"" for a .gltf).
    image : int
        The image index.
    folder : Path
        The folder relative URIs start from.
    where : str
        The model file, named in errors.
    limit : int, optional
        Read only this many leading bytes (a header check).
    """
    from urllib.parse import unquote

    def read_uri(uri: str, what: str) -> bytes:
        if uri.startswith("data:"):
            return base64.b64decode(uri.split(",", 1)[1])
        p = folder / unquote(uri)
        if not p.is_file():
            raise InputError(where, f"{what} '{uri}' not found")
        return p.read_bytes()

    img = doc["images"][image]
    if "bufferView" in img:
        view = doc["bufferViews"][img["bufferView"]]
        buf = doc.get("buffers", [{}])[int(view.get("buffer", 0))]
        blob = read_uri(str(buf["uri"]), "buffer file") if "uri" in buf else binary
        start = int(view.get("byteOffset", 0))
        n = int(view["byteLength"]) if limit is None else min(limit, int(view["byteLength"]))
        return blob[start:start + n]
    uri = str(img.get("uri", ""))
    if not uri.startswith("data:") and limit is not None:
        p = folder / unquote(uri)
        if not p.is_file():
            raise InputError(where, f"texture file '{uri}' not found")
        with open(p, "rb") as fh:
            return fh.read(limit)
    return read_uri(uri, "texture file")[:limit]


def decoded_gltf(path: Path) -> tuple[io.BytesIO, str] | None:
    """Return (file object, trimesh file type) of a glTF/GLB with its GPU-encoded base-colour images decoded to PNG
    (the texture then names the PNG image as its plain ``source``, the Basis extension dropped), or None when the
    model has none. A GLB's PNGs go at the end of its BIN chunk; a .gltf's become data URIs."""
    where = os.fsencode(str(path)).decode("utf-8", "backslashreplace")  # as load.display_path writes it
    glb = path.suffix.lower() == ".glb"
    data = path.read_bytes()
    doc, binary = _glb_chunks(data, where) if glb else (json.loads(data.decode("utf-8")), b"")
    todo = gpu_colour_images(doc)
    if not todo:
        return None
    binary = bytearray(binary)
    done: dict[int, int] = {}
    for tex_idx, img_idx in sorted(todo.items()):
        if img_idx not in done:
            png = io.BytesIO()
            decode(image_bytes(doc, bytes(binary), img_idx, path.parent, where), where).save(png, format="PNG")
            pbytes = png.getvalue()
            if glb:
                while len(binary) % 4:
                    binary.append(0)
                doc.setdefault("bufferViews", []).append({"buffer": 0, "byteOffset": len(binary),
                                                          "byteLength": len(pbytes)})
                binary += pbytes
                doc["images"].append({"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/png"})
            else:
                doc["images"].append({"uri": "data:image/png;base64," + base64.b64encode(pbytes).decode("ascii")})
            done[img_idx] = len(doc["images"]) - 1
        tex = doc["textures"][tex_idx]
        tex["source"] = done[img_idx]
        for e in BASIS_EXTENSIONS:
            tex.get("extensions", {}).pop(e, None)
    for key in ("extensionsUsed", "extensionsRequired"):
        if key in doc:
            doc[key] = [e for e in doc[key] if e not in BASIS_EXTENSIONS]
    if not glb:
        return io.BytesIO(json.dumps(doc).encode("utf-8")), "gltf"
    while len(binary) % 4:
        binary.append(0)
    if doc.get("buffers"):
        doc["buffers"][0]["byteLength"] = len(binary)
    else:
        doc["buffers"] = [{"byteLength": len(binary)}]
    js = json.dumps(doc).encode("utf-8")
    js += b" " * (-len(js) % 4)
    out = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js) + 8 + len(binary))
    out += struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(binary), 0x004E4942) + bytes(binary)
    return io.BytesIO(out), "glb"


__all__ = ["container_of", "decode", "decoded_gltf", "gpu_colour_images", "header_problem", "image_bytes", "ktx2_flips",
           "ktx2_key_values"]
