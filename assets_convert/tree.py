"""convert_tree: batch conversion in a process pool with a per-item timeout, progress and a JSON report.

Workers are spawned processes (CoACD's threads do not survive fork); a worker past its timeout is
killed and replaced, a crashed worker is reported, and the batch goes on. The report
``<out_dir>/convert_report.json`` lists per input: file, status, error, faces, hulls, volume ratio,
mass, seconds, cache hit; for a scene its articulated pieces and what the input held that was not used (``unused``).
"""

from __future__ import annotations

import functools
import multiprocessing as mp
import os
import time
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any, Iterable

from sdovon_mj.config import ConvertConfig
from sdovon_mj.progress import Progress
from sdovon_mj.records import dumps
from sdovon_mj.store import atomic_write_text

from . import habitat, scannet
from .load import SUPPORTED, display_path
from .metadata import meta_for

URDF_SUFFIX = ".urdf"  # articulated objects (assets_convert.urdf); their meshes are not objects of their own
SKIP_PREFIXES = ("receptacle_mesh",)  # habitat receptacle annotations, not models
# 3D model formats we do not read: a folder search lists them as skipped instead of passing over them silently
OTHER_MODEL_SUFFIXES = (".dae", ".fbx", ".3ds", ".blend", ".usd", ".usda", ".usdc", ".usdz", ".x3d", ".wrl", ".off",
                        ".3mf", ".dxf", ".ifc", ".max", ".ma", ".mb", ".c4d", ".skp")


def _in_habitat_dataset(f: Path, top: Path) -> bool:
    """Return whether a file lies in a Habitat scene dataset's folder under `top` (a config beside it or above it, up
    to `top`): its scenes are the dataset's members (`habitat.dataset_members`), its other files are their assets."""
    for anc in f.parents:
        if _holds_config(anc):
            return True
        if anc == top:
            break
    return False


@functools.lru_cache(maxsize=4096)
def _holds_config(folder: Path) -> bool:
    """Return whether a folder holds a scene dataset config (memoised: a dataset's folders are asked once each)."""
    return any(folder.glob(f"*{habitat.DATASET_CONFIG}"))


def dataset_scenes(folder: Path) -> list[Path]:
    """Return the scenes of the Habitat scene dataset configs in a folder tree (each scene once, sorted)."""
    found: set[Path] = set()
    for cfg in sorted(folder.rglob(f"*{habitat.DATASET_CONFIG}")):
        if not any(part.startswith(".") for part in cfg.relative_to(folder).parts):
            found.update(habitat.dataset_members(cfg))
    return sorted(found, key=lambda f: os.fsencode(str(f)))


def known_suffixes(kind: str = "object") -> tuple[str, ...]:
    """Return the file suffixes a conversion of `kind` ("object" or "scene") reads (objects also take URDFs)."""
    return SUPPORTED + ((URDF_SUFFIX,) if kind == "object" else ())


def skipped_reason(path: Path, kind: str = "object") -> str:
    """Return why a model file of another format is skipped (for reports and warnings)."""
    return (f"unsupported format '{Path(path).suffix.lower()}' (supported: {', '.join(known_suffixes(kind))}); "
            "export it to one of them")


def _scan(inputs: str | Path | Iterable[str | Path], kind: str) -> tuple[list[Path], list[Path], dict[Path, Path]]:
    """Walk the inputs once: return (the files to convert, `find_inputs`; the model files of other formats in the
    input folders, `unsupported_models`), each sorted, and the input folder each file to convert was found in."""
    items = [inputs] if isinstance(inputs, (str, Path)) else list(inputs)
    out: list[Path] = []
    other: list[Path] = []
    folder_urdfs: list[Path] = []
    roots: dict[Path, Path] = {}
    for item in items:
        p = Path(item)
        if kind == "scene" and p.is_file() and p.name.lower().endswith(habitat.DATASET_CONFIG):
            out.extend(habitat.dataset_members(p))  # a scene dataset: each of its scenes
            continue
        if p.is_dir():
            if kind == "scene":
                members = dataset_scenes(p)
                out.extend(members)
                roots.update({f: p for f in members})
            for f in sorted(p.rglob("*")):
                if not f.is_file() or any(part.startswith(".") for part in f.relative_to(p).parts):
                    continue
                suffix = f.suffix.lower()
                if suffix == URDF_SUFFIX:
                    folder_urdfs.append(f)
                elif suffix in OTHER_MODEL_SUFFIXES:
                    other.append(f)
                scene_cfg = kind == "scene" and f.name.lower().endswith(habitat.SCENE_INSTANCE) \
                    and not _in_habitat_dataset(f, p)  # a dataset's scene instances: its members, above
                urdf = kind == "object" and suffix == URDF_SUFFIX
                if (suffix in SUPPORTED or scene_cfg or urdf) and not f.name.startswith(SKIP_PREFIXES):
                    if kind == "scene" and (_placed_by_sibling(f) or habitat.is_companion(f) or scannet.is_companion(f)
                                            or _in_habitat_dataset(f, p)):
                        continue
                    out.append(f)
                    roots.setdefault(f, p)
        else:
            out.append(p)
    meshes: dict[Path, set[str]] = {}

    def links(u: Path) -> set[str]:
        if u not in meshes:
            meshes[u] = {os.path.realpath(m) for m in _urdf_meshes(u)}
        return meshes[u]

    # the meshes a URDF among the inputs references are its links, not objects of their own
    linked = set().union(*(links(f) for f in out if f.suffix.lower() == URDF_SUFFIX))
    out = [f for f in out if f.suffix.lower() == URDF_SUFFIX or os.path.realpath(f) not in linked]
    seen: set[str] = set()
    uniq = []
    for f in out:
        k = os.fsencode(str(f))
        if k not in seen:
            seen.add(k)  # type: ignore[arg-type]
            uniq.append(f)
    # a URDF's link meshes (e.g. .dae) are not skipped models
    linked_other = set().union(*(links(u) for u in folder_urdfs))
    other = sorted({f for f in other if os.path.realpath(f) not in linked_other}, key=lambda f: os.fsencode(str(f)))
    return sorted(uniq, key=lambda f: os.fsencode(str(f))), other, roots


def find_inputs(inputs: str | Path | Iterable[str | Path], kind: str = "object") -> list[Path]:
    """Expand files and folders into a sorted list of mesh files to convert."""
    return _scan(inputs, kind)[0]


def unsupported_models(inputs: str | Path | Iterable[str | Path], kind: str = "object") -> list[Path]:
    """Return the model files in the input folders that `find_inputs` passes over: formats we do not read.

    Files a URDF in the input folders references (its links' meshes, e.g. ``.dae``) are not listed. Named files
    (not folders) are not listed: they are converted and fail with the format named.
    """
    return _scan(inputs, kind)[1]


def _urdf_meshes(f: Path) -> list[Path]:
    """Return the mesh files a URDF references ([] when it cannot be read: its conversion reports why)."""
    from .urdf import urdf_mesh_files

    return urdf_mesh_files(f)


def _placed_by_sibling(f: Path) -> bool:
    """Return whether a file is a non-room asset of a placements.json in its folder (e.g. curtains)."""
    import json

    pj = f.parent / "placements.json"
    if not pj.is_file():
        return False
    try:
        items = json.loads(pj.read_text(encoding="utf-8")).get("instances", [])
    except (OSError, ValueError, AttributeError):
        return False
    return any(Path(it.get("asset", "")).name == f.name for it in items[1:])


def _tell_apart(tasks: list[dict[str, Any]]) -> None:
    """Give object tasks that would share a name (one output folder) distinct ones: the first in input order keeps
    it, the others get ``_2``, ``_3``, ... (a free name), and a ``renamed`` note for their report row."""
    from .naming import object_name

    taken: dict[str, str] = {}
    names = [object_name(t["path"], t.get("name")) for t in tasks]
    used = set(names)
    for t, name in zip(tasks, names):
        if name not in taken:
            taken[name] = t["display"]
            continue
        k = 2
        while f"{name}_{k}" in used:
            k += 1
        new = f"{name}_{k}"
        used.add(new)
        taken[new] = t["display"]
        t["name"] = new
        t["renamed"] = f"named '{new}': '{name}' is the name of {taken[name]} in this batch"


def _work(task: dict[str, Any]) -> dict[str, Any]:
    """Convert one input (runs in a worker process); return its report row."""
    t0 = time.perf_counter()
    row: dict[str, Any] = {"file": task["display"], "status": "ok", "error": ""}
    try:
        if task["kind"] == "scene":
            from .scene import convert_scene

            a = convert_scene(task["path"], task["out_dir"], name=task["name"], units=task["config"].units,
                              up=task["config"].up, cache_dir=task["cache_dir"],
                              texture_max_size=task["config"].texture_max_size, add_floor=task["config"].add_floor)
            row.update(name=a.name, mjcf=a.mjcf, instances=len(a.instances), cache_hit=False)
            if a.articulated:  # only then: rows of scenes without articulated pieces keep their bytes
                row["articulated"] = [f"{fx.instance_id} {fx.label} ({len(fx.parts)} joints)" for fx in a.articulated]
            if a.unused:  # what the input held that the conversion did not use (SceneAsset.unused)
                row["unused"] = list(a.unused)
        elif task.get("parts"):
            import tempfile

            from .metadata import combine_parts
            from .object import convert_object_report

            cfg = task["config"]
            with tempfile.TemporaryDirectory(prefix="sdovon-parts-") as tmp:
                glb = combine_parts([Path(p) for p in task["parts"]], Path(tmp) / "parts.glb", cfg.units, cfg.up)
                a, info = convert_object_report(glb, task["out_dir"], category=task["category"], units="m", up="+Z",
                                                name=task["name"], config=cfg, cache_dir=task["cache_dir"],
                                                source=task["display"])
            row.update(name=a.name, category=a.category, mjcf=a.mjcf, faces=info.get("faces"), hulls=a.hull_count,
                       volume_ratio=round(a.volume_ratio, 4), mass=round(a.mass, 6), cache_hit=info.get("cache_hit"),
                       warnings=info.get("warnings", []) + ([task["renamed"]] if task.get("renamed") else []),
                       parts=[display_path(p) for p in task["parts"]])
        else:
            from .object import convert_object_report

            a, info = convert_object_report(task["path"], task["out_dir"], category=task.get("category"),
                                            name=task.get("name"), config=task["config"], cache_dir=task["cache_dir"])
            row.update(name=a.name, category=a.category, mjcf=a.mjcf, faces=info.get("faces"), hulls=a.hull_count,
                       volume_ratio=round(a.volume_ratio, 4), mass=round(a.mass, 6), cache_hit=info.get("cache_hit"),
                       warnings=info.get("warnings", []) + ([task["renamed"]] if task.get("renamed") else []))
    except Exception as e:  # noqa: BLE001 - every failure becomes a report row, the batch goes on
        from sdovon_mj.errors import InputError

        row["status"] = "error"
        row["error"] = e.cause if isinstance(e, InputError) else f"{type(e).__name__}: {e}"
    row["seconds"] = round(time.perf_counter() - t0, 3)
    return row


STARTED = "started"
STARTUP_GRACE_S = 120.0  # a fresh worker may take this long to import before its first task's clock starts


def _worker_main(conn: Any) -> None:
    """Worker loop: receive tasks, send rows, until None."""
    # import the converters before the first task, so a task's timeout does not count start-up
    import coacd  # noqa: F401
    import mujoco  # noqa: F401
    import scipy.ndimage  # noqa: F401
    import trimesh  # noqa: F401

    from . import object as _object, scene as _scene  # noqa: F401

    while True:
        try:
            task = conn.recv()
        except EOFError:
            return
        if task is None:
            return
        conn.send(STARTED)  # the parent's per-task clock starts here
        conn.send(_work(task))


class _Worker:
    """One spawned worker process and the task it is running."""

    def __init__(self, ctx: Any) -> None:
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker_main, args=(child,), daemon=True)
        self.proc.start()
        child.close()
        self.task: dict[str, Any] | None = None
        self.started = False
        self.t0 = 0.0

    def submit(self, task: dict[str, Any]) -> None:
        self.task = task
        self.started = False
        self.t0 = time.perf_counter()
        self.conn.send(task)

    def stop(self) -> None:
        try:
            self.conn.send(None)
        except (OSError, BrokenPipeError):
            pass
        self.proc.join(timeout=2)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()

    def kill(self) -> None:
        self.proc.kill()
        self.proc.join()


def convert_tree(inputs: str | Path | Iterable[str | Path], out_dir: str | Path, kind: str = "object",
                 jobs: int = 0, timeout: float | None = None, progress: bool | None = True,
                 config: ConvertConfig | None = None, cache_dir: str | Path | None = None,
                 categories: dict[str, str] | None = None) -> dict[str, Any]:
    """Convert every mesh under `inputs` in a process pool; write and return the batch report.

    Parameters
    ----------
    inputs : str or Path or iterable of str or Path
        Mesh files and folders (folders are searched for mesh files).
    out_dir : str or Path
        Output root (also holds the batch report).
    kind : str
        "object" or "scene".
    jobs : int
        Worker processes (0: the config's, else the CPU count).
    timeout : float, optional
        Seconds allowed per item (default: the config's).
    progress : bool, optional
        Show progress (`sdovon_mj.progress.Progress`: a bar on a terminal, else a line per ~10 % with the items done
        of total and an ETA) and each failure as it happens; None: progress only, unless an enclosing bar is quiet
        (``generate --quiet``); False: nothing.
    config : ConvertConfig, optional
        Conversion settings (default: ``ConvertConfig()``).
    cache_dir : str or Path, optional
        Conversion cache folder (default: the user cache).
    categories : dict of str to str, optional
        Input file path -> object category (default: guessed per file).
    """
    if kind not in ("object", "scene"):
        raise ValueError(f"kind must be 'object' or 'scene', got {kind!r}")
    cfg = config or ConvertConfig()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    from .naming import library_category

    files, skipped, roots = _scan(inputs, kind)
    timeout = float(timeout if timeout is not None else cfg.timeout_s)
    jobs = int(jobs or cfg.jobs or os.cpu_count() or 1)
    jobs = max(1, min(jobs, len(files) or 1))
    cache = None if cache_dir is None else str(cache_dir)
    tasks = []
    groups: dict[Path, dict[str, Any]] = {}
    for f in files:
        meta = meta_for(f) if kind == "object" else None
        cat = (categories or {}).get(str(f))
        if cat is None and meta is not None and f in roots:
            # found in an input folder: the category guess knows the library folder (`object.library_category`)
            cat = library_category(f, roots[f], meta)
        if meta is not None and meta.multipart is not None:  # one object of several part files (assets.yaml)
            g = groups.get(meta.multipart)
            if g is None:
                g = groups[meta.multipart] = {"path": str(meta.multipart), "display": display_path(meta.multipart),
                                              "out_dir": str(out_dir), "kind": kind, "config": cfg, "cache_dir": cache,
                                              "category": cat or meta.category or meta.multipart.name,
                                              "name": meta.name, "parts": []}
                tasks.append(g)
            g["parts"].append(str(f))
            continue
        tasks.append({"path": str(f), "display": display_path(f), "out_dir": str(out_dir), "kind": kind, "config": cfg,
                      "cache_dir": cache, "category": cat})
    if kind == "object":
        _tell_apart(tasks)
    else:  # scenes: the names a run gives them (`naming.name_scenes`), so two room.ply get two folders
        from sdovon_mj.naming import name_scenes

        for name, t in zip(name_scenes([t["path"] for t in tasks]), tasks):
            t["name"] = name
    rows: dict[int, dict[str, Any]] = {}
    t_start = time.perf_counter()
    with Progress(total=len(tasks), desc=f"convert {kind}s", enabled=progress) as bar:
        ctx = mp.get_context("spawn")
        workers = [_Worker(ctx) for _ in range(min(jobs, len(tasks)))]
        pending = list(enumerate(tasks))
        busy: dict[int, tuple[_Worker, int]] = {}
        try:
            while pending or busy:
                for w in workers:
                    if w.task is None and pending:
                        idx, task = pending.pop(0)
                        w.submit(task)
                        busy[id(w)] = (w, idx)
                ready = wait([w.conn for w, _ in busy.values()], timeout=0.2)
                now = time.perf_counter()
                for wid, (w, idx) in list(busy.items()):
                    row = None
                    if w.conn in ready:
                        try:
                            row = w.conn.recv()
                            if row == STARTED:
                                w.t0, w.started = now, True
                                continue
                        except (EOFError, OSError):
                            row = {"file": tasks[idx]["display"], "status": "error",
                                   "error": f"worker crashed (exit code {w.proc.exitcode})", "seconds": round(now - w.t0, 3)}
                    elif now - w.t0 > timeout + (0.0 if w.started else STARTUP_GRACE_S):
                        row = {"file": tasks[idx]["display"], "status": "error",
                               "error": f"timeout: conversion took longer than {timeout:g} s", "seconds": round(now - w.t0, 3)}
                    if row is None:
                        continue
                    rows[idx] = row
                    del busy[wid]
                    if row["status"] == "error" and (not w.proc.is_alive() or row["error"].startswith(("timeout", "worker crashed"))):
                        w.kill()
                        workers[workers.index(w)] = _Worker(ctx)
                    else:
                        w.task = None
                    bar.update(1, "/".join(Path(row["file"]).parts[-2:]))  # e.g. mug_0/model.obj
                    if row["status"] == "error" and progress:  # None: the caller reports failures itself
                        bar.write(f"convert: {row['file']}: {row['error']}")
        finally:
            for w in workers:
                w.stop()
    items = [rows[i] for i in range(len(tasks))]
    report = {"kind": kind, "out_dir": str(out_dir), "count": len(items),
              "ok": sum(r["status"] == "ok" for r in items), "failed": sum(r["status"] != "ok" for r in items),
              "seconds": round(time.perf_counter() - t_start, 3), "items": items}
    if skipped:  # only then: a report without skipped files keeps its bytes
        report["skipped"] = sorted(({"file": display_path(f), "reason": skipped_reason(f, kind)} for f in skipped),
                                   key=lambda r: r["file"])
    atomic_write_text(out_dir / "convert_report.json", dumps(report))
    return report
