"""ScanNet v2 scans as they ship: the mesh ``<scene>_vh_clean_2.ply`` and the files beside it that give instances.

Instances, first found wins: the over-segmentation ``<mesh stem>*.segs.json`` (``segIndices`` per vertex) with
``<scene>*aggregation.json`` (``segGroups``: object id, label, segments), as the full release has them; else the
labels mesh ``<mesh stem>.labels.ply`` (the same mesh, an NYU40 class id per vertex in its ``label`` property, as
many public samples ship): classes only, so an instance is a connected component of one class's faces on the mesh,
its category from the one NYU40 table (`nyu40`). ``<scene>.txt``'s ``axisAlignment`` (a row-major 4x4 matrix that
aligns the scan with the axes) is applied when present. A scan with none of these gets one line in
`SceneAsset.unused` naming the files looked for.
"""

from __future__ import annotations

import glob
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sdovon_mj.errors import InputError
from sdovon_mj.naming import scene_stem

from . import habitat, nyu40
from .load import LoadedMesh, Material, Part, display_path, read_json, up_rotation

LABELS_SUFFIX = ".labels.ply"
# A class's connected component smaller than this (m^2 of surface) is not an object of its own: annotators labelled
# ScanNet's over-segmentation segment by segment, and where two classes meet, the faces whose vertices are
# mostly of one class leave fringes of a few triangles (the decimated mesh's edges are some 2-5 cm, so 0.01 m^2,
# a 10 cm square, is a handful of faces) that are no objects; the smallest objects NYU40 names on their own (a
# book, a towel, a pillow) have faces of several times that. Such specks join the unannotated instance.
SPECK_AREA = 0.01


@dataclass(frozen=True)
class ScanFiles:
    """The files beside a ScanNet mesh that its conversion reads (None: not there)."""

    segs: Path | None = None
    aggregation: Path | None = None
    labels: Path | None = None
    meta: Path | None = None  # <scene>.txt (axisAlignment)

    @property
    def segments(self) -> tuple[Path, Path] | None:
        """Return (segs.json, aggregation.json) when both are there."""
        return (self.segs, self.aggregation) if self.segs is not None and self.aggregation is not None else None

    def inputs(self) -> list[Path]:
        """Return the files a conversion reads (cache keys, stage fingerprints): a labels mesh only without the
        segments that win over it."""
        segs = list(self.segments or ())
        return segs + ([self.labels] if self.labels is not None and not segs else []) + \
            ([self.meta] if self.meta is not None else [])


def scan_files(path: str | Path) -> ScanFiles:
    """Return the ScanNet files beside a PLY scan (all None for another file)."""
    path = Path(path)
    if path.suffix.lower() != ".ply" or path.name.lower().endswith(LABELS_SUFFIX):
        return ScanFiles()
    stem = scene_stem(path)
    segs = sorted(path.parent.glob(f"{glob.escape(path.stem)}*.segs.json")) or \
        sorted(path.parent.glob(f"{glob.escape(stem)}*.segs.json"))
    aggs = sorted(path.parent.glob(f"{glob.escape(stem)}*aggregation.json"))
    labels = path.parent / f"{path.stem}{LABELS_SUFFIX}"
    meta = path.parent / f"{stem}.txt"
    return ScanFiles(segs[0] if segs else None, aggs[0] if aggs else None, labels if labels.is_file() else None,
                     meta if meta.is_file() and _alignment_line(meta) is not None else None)


def looked_for(path: str | Path) -> str:
    """Return the line naming the instance files looked for beside a PLY scan that has none of them."""
    path = Path(path)
    stem = scene_stem(path)
    return (f"{display_path(path)}: no instance labels beside it (looked for {stem}.semantics.json, "
            f"{path.stem}{LABELS_SUFFIX}, and {path.stem}*.segs.json with {stem}*aggregation.json): its instances are "
            "its mesh nodes, labelled from their names")


def is_companion(path: str | Path) -> bool:
    """Return whether a file is a companion of a ScanNet mesh, not a scene of its own: a ``.labels.ply``, or the
    full ``_vh_clean.ply`` beside the decimated ``_vh_clean_2.ply`` (the one converted)."""
    path = Path(path)
    name = path.name.lower()
    if name.endswith(LABELS_SUFFIX):
        return True
    return name.endswith("_vh_clean.ply") and (path.parent / f"{path.name[:-4]}_2.ply").is_file()


def check(files: ScanFiles) -> None:
    """Check a scan's files before any work (InputError naming the file): the segments and aggregation parse, the
    labels mesh is a PLY whose vertices have a ``label`` property, the axisAlignment is a rigid 4x4 matrix."""
    for f in files.segments or ():
        read_json(f)
    if files.labels is not None and files.segments is None:
        with open(files.labels, "rb") as fh:
            head = fh.read(4096)
        end = head.find(b"end_header")
        text = head[:end].decode("ascii", "replace") if end >= 0 else ""
        vertex = text.split("element vertex", 1)[-1].split("element", 1)[0] if "element vertex" in text else ""
        if not text.startswith("ply") or not re.search(r"property\s+\w+\s+label\b", vertex):
            raise InputError(display_path(files.labels), "not a ScanNet labels mesh: a PLY whose vertices have a "
                                                         "'label' property (NYU40 class) expected")
    if files.meta is not None:
        read_alignment(files.meta)


def _alignment_line(meta: Path) -> str | None:
    """Return the text after ``axisAlignment =`` in a ScanNet ``<scene>.txt``, or None."""
    try:
        text = meta.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    m = re.search(r"^\s*axisAlignment\s*=\s*(.*)$", text, flags=re.MULTILINE)
    return m.group(1) if m else None


def read_alignment(meta: Path) -> np.ndarray:
    """Return ``<scene>.txt``'s axisAlignment as a 4x4 matrix (row-major in the file); InputError naming the file
    when it is not 16 numbers or not a rigid motion (a rotation and a translation)."""
    text = _alignment_line(meta) or ""
    try:
        vals = [float(x) for x in text.split()]
    except ValueError:
        vals = []
    if len(vals) != 16:
        raise InputError(display_path(meta), f"axisAlignment must be 16 numbers (a 4x4 matrix), not {text.strip()!r}")
    m = np.asarray(vals, dtype=np.float64).reshape(4, 4)
    r = m[:3, :3]
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-3) or np.linalg.det(r) < 0 or not np.allclose(m[3], (0, 0, 0, 1)):
        raise InputError(display_path(meta), "axisAlignment is not a rotation and a translation")
    return m


def align(mesh: LoadedMesh, matrix: np.ndarray) -> None:
    """Apply a ScanNet axisAlignment (in the file's frame and units) to a loaded mesh's parts, in place: loading
    scaled by ``mesh.scale`` and turned by the up axis' rotation U, so a loaded point p becomes
    U A U^T p + scale U t."""
    u = up_rotation(mesh.up, mesh.path)[0]
    rot = u @ matrix[:3, :3] @ u.T
    t = mesh.scale * (u @ matrix[:3, 3])
    for p in mesh.parts:
        p.vertices = p.vertices @ rot.T + t


def _single_part(parts: list[Part], where: Path) -> Part:
    """Return a scan's one part; InputError naming `where` (the labels file) otherwise."""
    if len(parts) != 1:
        raise InputError(display_path(where), "ScanNet labels need a single-mesh PLY")
    return parts[0]


def segment_pairs(parts: list[Part], files: tuple[Path, Path]) -> tuple[list[tuple[Part, int]], dict[int, dict]]:
    """Split a PLY scan by ScanNet segments + aggregation into (part, instance id) pairs and instance records."""
    segs_path, agg_path = files
    segs = read_json(segs_path)
    agg = read_json(agg_path)
    seg_idx = np.asarray(segs.get("segIndices", []), dtype=np.int64)
    part = _single_part(parts, segs_path)
    if len(seg_idx) != len(part.vertices):
        raise InputError(display_path(segs_path), f"has {len(seg_idx)} segment indices for {len(part.vertices)} vertices")
    seg_to_inst: dict[int, int] = {}
    meta: dict[int, dict] = {}
    for g in agg.get("segGroups", []):
        iid = int(g.get("objectId", g.get("id")))
        meta[iid] = {"id": iid, "label": str(g.get("label", "object")), "kind": ""}
        for s in g.get("segments", []):
            seg_to_inst[int(s)] = iid
    lut_keys = np.array(sorted(seg_to_inst), dtype=np.int64)
    lut_vals = np.array([seg_to_inst[k] for k in lut_keys], dtype=np.int64)
    pos = np.searchsorted(lut_keys, seg_idx) if len(lut_keys) else np.zeros(len(seg_idx), dtype=np.int64)
    pos = np.clip(pos, 0, max(len(lut_keys) - 1, 0))
    ok = (lut_keys[pos] == seg_idx) if len(lut_keys) else np.zeros(len(seg_idx), dtype=bool)
    unl = (max(meta) + 1) if meta else 0
    vinst = np.where(ok, lut_vals[pos] if len(lut_vals) else 0, unl)
    if (~ok).any():
        meta[unl] = {"id": unl, "label": "unlabeled", "kind": ""}
    return split_coloured(part, vinst[part.faces[:, 0]]), meta


def read_labels(labels: Path) -> np.ndarray:
    """Return the per-vertex ``label`` (NYU40 class id) of a ScanNet labels PLY; InputError naming the file."""
    import trimesh

    try:
        ply = trimesh.load(str(labels), process=False)
        vals = ply.metadata["_ply_raw"]["vertex"]["data"]["label"]
    except (KeyError, ValueError, TypeError) as e:
        raise InputError(display_path(labels), f"no per-vertex 'label' property ({type(e).__name__})") from None
    except Exception as e:  # noqa: BLE001 - any parser failure is a bad input
        raise InputError(display_path(labels), f"cannot parse PLY file: {type(e).__name__}: {e}") from None
    return np.asarray(vals, dtype=np.int64).reshape(-1)


def label_pairs(parts: list[Part], labels: Path) -> tuple[list[tuple[Part, int]], dict[int, dict]]:
    """Split a PLY scan by its labels mesh's NYU40 classes: each connected component of one class's faces is an
    instance (ids by class, then by first face), specks under `SPECK_AREA` join the unannotated instance."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    part = _single_part(parts, labels)
    vlab = read_labels(labels)
    if len(vlab) != len(part.vertices):
        raise InputError(display_path(labels), f"has {len(vlab)} labelled vertices for the mesh's {len(part.vertices)}")
    f = part.faces
    a, b, c = vlab[f[:, 0]], vlab[f[:, 1]], vlab[f[:, 2]]
    flab = np.where((a == b) | (a == c), a, np.where(b == c, b, a))  # a face's class: its vertices' majority
    flab = np.where((flab >= 1) & (flab <= len(nyu40.NYU40_NAMES)), flab, nyu40.UNANNOTATED)
    tri = part.vertices[f]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    finst = np.full(len(f), -1, dtype=np.int64)
    meta: dict[int, dict] = {}
    nv = len(part.vertices)
    for cls in np.unique(flab).tolist():
        if cls == nyu40.UNANNOTATED:
            continue
        sel = np.flatnonzero(flab == cls)
        fs = f[sel]
        rows = np.concatenate([fs[:, 0], fs[:, 1]])
        cols = np.concatenate([fs[:, 1], fs[:, 2]])
        graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(nv, nv))
        _n, comp = connected_components(graph, directed=False)
        fcomp = comp[fs[:, 0]]
        comp_area = np.bincount(fcomp, weights=area[sel])
        ids, first = np.unique(fcomp, return_index=True)  # `sel` ascends: a component's first face is its first
        for cc in ids[np.argsort(first, kind="stable")].tolist():  # ids in face order, not scipy's numbering
            if comp_area[cc] < SPECK_AREA:
                continue
            iid = len(meta)
            meta[iid] = {"id": iid, "label": nyu40.category(int(cls)), "kind": "",
                         "name": f"{nyu40.nyu40_name(int(cls))} {iid}"}
            finst[sel[fcomp == cc]] = iid
    if (finst < 0).any():
        unl = len(meta)
        meta[unl] = {"id": unl, "label": "unlabeled", "kind": "", "name": "unannotated"}
        finst[finst < 0] = unl
    return split_coloured(part, finst), meta


def split_coloured(part: Part, finst: np.ndarray) -> list[tuple[Part, int]]:
    """Split a vertex-coloured scan part by per-face instance ids; each piece one material of its mean colour."""
    out = []
    for piece, iid in habitat.split_by_face_instance(part, finst):
        colors = piece.colors
        rgba = tuple(float(x) for x in (colors[:, :4].mean(axis=0) / 255.0)) if colors is not None else part.material.rgba
        piece.material, piece.uv = Material(f"inst_{iid}", rgba, None, f"scan|{iid}"), None  # type: ignore[arg-type]
        out.append((piece, iid))
    return out


def read_scan(mesh: LoadedMesh, files: ScanFiles) -> tuple[list[tuple[Part, int]] | None, dict[int, dict], list[str]]:
    """Return a loaded ScanNet mesh's (part, instance id) pairs (None: the files give no instances), instance
    records and the lines for `SceneAsset.unused`; the mesh is aligned first when ``<scene>.txt`` says how."""
    if files.meta is not None:
        align(mesh, read_alignment(files.meta))
    unused: list[str] = []
    if files.segments is not None:
        if files.labels is not None:
            unused.append(f"{display_path(files.labels)}: not read (the segments and aggregation beside it give "
                          "the instances)")
        pairs, meta = segment_pairs(mesh.parts, files.segments)
        return pairs, meta, unused
    if files.labels is not None:
        pairs, meta = label_pairs(mesh.parts, files.labels)
        return pairs, meta, unused
    return None, {}, unused


__all__ = ["LABELS_SUFFIX", "SPECK_AREA", "ScanFiles", "align", "check", "is_companion", "label_pairs", "looked_for",
           "read_alignment", "read_labels", "read_scan", "scan_files", "segment_pairs", "split_coloured"]
