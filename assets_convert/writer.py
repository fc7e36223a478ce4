"""Writing MJCF assets: OBJ meshes, PNG textures, materials, and filling the XML templates."""

from __future__ import annotations

import io
from pathlib import Path
from string import Template
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np

from mjcf_templates import template_path
from sdovon_mj.store import atomic_write_bytes, atomic_write_text

from .load import Material, Part
from .textures import to_png_bytes


def obj_bytes(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray | None = None) -> bytes:
    """Return Wavefront OBJ text of a triangle mesh (with texture coordinates when given)."""
    # one %-format over all rows (the text np.savetxt wrote, row by row, several times slower on a scan's faces)
    v = np.asarray(vertices, dtype=np.float64)
    f1 = np.asarray(faces, dtype=np.int64) + 1
    parts = ["# sdovon-mj assets_convert\n", _rows("v %.6f %.6f %.6f\n", v)]
    if uv is not None:
        parts.append(_rows("vt %.6f %.6f\n", np.asarray(uv, dtype=np.float64)))
        parts.append(_rows("f %d/%d %d/%d %d/%d\n", np.repeat(f1, 2, axis=1)))
    else:
        parts.append(_rows("f %d %d %d\n", f1))
    return "".join(parts).encode("ascii")


def _rows(fmt: str, rows: np.ndarray, chunk: int = 65536) -> str:
    """Return `fmt` (one row's format) applied to every row of a 2-D array, as one string."""
    out = []
    for k in range(0, len(rows), chunk):
        block = rows[k:k + chunk]
        out.append((fmt * len(block)) % tuple(block.ravel().tolist()))
    return "".join(out)


def fmt(values: np.ndarray | list[float] | tuple[float, ...], digits: int = 6) -> str:
    """Return space-separated numbers for an XML attribute."""
    return " ".join(f"{float(x):.{digits}g}" for x in np.ravel(values))


def merge_parts(parts: list[Part]) -> list[Part]:
    """Merge parts that share a material into one part each (order of first appearance)."""
    groups: dict[str, list[Part]] = {}
    for p in parts:
        groups.setdefault(p.material.key, []).append(p)
    out = []
    for items in groups.values():
        if len(items) == 1:
            out.append(items[0])
            continue
        offs = np.cumsum([0] + [len(p.vertices) for p in items[:-1]])
        v = np.concatenate([p.vertices for p in items])
        f = np.concatenate([p.faces + o for p, o in zip(items, offs)])
        uv = None
        if all(p.uv is not None for p in items):
            uv = np.concatenate([p.uv for p in items])  # type: ignore[misc]
        colors = None
        if all(p.colors is not None for p in items):
            colors = np.concatenate([p.colors for p in items])  # type: ignore[misc]
        out.append(Part(v, f, items[0].material, uv, colors, items[0].node))
    return out


def clean_part(part: Part) -> Part | None:
    """Drop zero-area faces and unused vertices; None when nothing is left."""
    v, f = part.vertices, part.faces
    tri = v[f]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    keep = area2 > 1e-14
    f = f[keep]
    if len(f) == 0:
        return None
    used = np.unique(f)
    if len(used) < 3:
        return None
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    uv = part.uv[used] if part.uv is not None else None
    colors = part.colors[used] if part.colors is not None else None
    return Part(v[used], remap[f], part.material, uv, colors, part.node)


class AssetWriter:
    """Collects meshes, textures and materials for one MJCF file and writes them under assets/."""

    def __init__(self, assets_dir: Path, texture_max_size: int = 1024, texture_cache: Path | None = None) -> None:
        self.assets_dir = Path(assets_dir)
        self.texture_max_size = texture_max_size
        self.texture_cache = texture_cache  # PNGs by image content (`png_file`): a texture shared by scenes is encoded once
        self.lines: list[str] = []
        self._textures: dict[int, str] = {}
        self._materials: dict[str, str] = {}

    def mesh(self, name: str, vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray | None = None,
             extra: str = "") -> str:
        """Write a mesh file and register its <mesh> asset; return its name.

        Parameters
        ----------
        name : str
            Mesh asset name (also the OBJ file stem).
        vertices : (N, 3) float
            Vertices, metres.
        faces : (M, 3) int
            Triangle vertex indices.
        uv : (N, 2) float, optional
            Texture coordinates per vertex.
        extra : str
            Further XML attributes of the ``<mesh>`` element (with a leading space).
        """
        atomic_write_bytes(self.assets_dir / f"{name}.obj", obj_bytes(vertices, faces, uv))
        self.lines.append(f'    <mesh name="{name}" file="{name}.obj"{extra}/>')
        return name

    def material(self, mat: Material, textured: bool) -> str:
        """Register a material (and its PNG texture) once per appearance (texture and colour as written); return
        its name. Parts of one look share one MJCF material: a scan split into hundreds of instances would otherwise
        pass MuJoCo's renderer limit of 1000 materials."""
        rgba = fmt(mat.rgba, 4)
        tex = None
        if textured and mat.image is not None:
            tex = self._textures.get(id(mat.image))
            if tex is None:
                tex = f"texture_{len(self._textures)}"
                png_file(mat.image, self.assets_dir / f"{tex}.png", self.texture_max_size, self.texture_cache)
                self.lines.append(f'    <texture name="{tex}" type="2d" file="{tex}.png"/>')
                self._textures[id(mat.image)] = tex
        key = f"{tex}|{rgba}"
        if key in self._materials:
            return self._materials[key]
        name = f"material_{len(self._materials)}"
        texture = f' texture="{tex}"' if tex else ""
        self.lines.append(f'    <material name="{name}"{texture} rgba="{rgba}" specular="0.2" shininess="0.2"/>')
        self._materials[key] = name
        return name

    @property
    def xml(self) -> str:
        """Return the <asset> children as XML lines."""
        return "\n".join(self.lines)


def png_file(image: Any, dst: Path, max_size: int, cache: Path | None = None) -> Path:
    """Write a texture image as PNG at `dst` (`to_png_bytes`); with a cache folder, through it: the PNG of an image
    (keyed by its decoded pixels and `max_size`) is encoded once and hard-linked (else copied) to each `dst`."""
    if cache is None:
        atomic_write_bytes(dst, to_png_bytes(image, max_size))
        return dst
    import hashlib
    import os
    import shutil

    h = hashlib.sha256(f"{image.mode}|{image.size}|{max_size}|".encode())
    h.update(image.tobytes())
    cached = cache / f"{h.hexdigest()[:32]}.png"
    if not cached.is_file():
        atomic_write_bytes(cached, to_png_bytes(image, max_size))
    dst.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.link(cached, dst)
    except OSError:
        shutil.copy2(cached, dst)
    return dst


def render_template(template: str, out: Path, **values: str) -> str:
    """Fill an mjcf_templates/ template, write it atomically to `out`, return the text."""
    text = Template(template_path(template).read_text(encoding="utf-8")).substitute(**values)
    atomic_write_text(out, text)
    return text


def xml_attr(value: str) -> str:
    """Return an XML-quoted attribute value."""
    return quoteattr(value)
