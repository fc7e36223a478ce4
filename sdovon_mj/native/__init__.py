"""Compiled inner loops of the agents (`kernels.c`), built on first use with the system C compiler and loaded by ctypes.

Each kernel has a pure-Python reference beside its caller (the lattice planner in `nav/control.py`, the ray carving
in `nav/frontier.py`, the free-segment test in `grid.py`, fusion's overlap test and voxel union in
`perceive/fusion.py`, the grid Dijkstra of `gridgraph.py`) and computes exactly what it computes: same results, bit for bit (tests/test_native.py compares
both). Where no compiler is found or the build fails, the callers run their Python form: slower, never different.
One kernel has no Python form: the renderer's occlusion test (`sim/occlusion.py`) only decides what need not be drawn,
and without it everything in view is drawn: the same images.
`status()` says which one runs and why.

The library is built once per source text and compiler flags into the shared cache (``$SDOVON_CACHE/native/<digest>``,
else ``~/.cache/sdovon-mj/native``; a per-user temporary folder with SDOVON_CACHE=off), written under a temporary
name and renamed, so parallel workers never load a half-written file. ``SDOVON_NATIVE=off`` turns the kernels off.
A sealed agent process may not write there: the evaluator builds the library before it starts the agent and lets
it read the folder (`library_dir`).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

SOURCE = Path(__file__).with_name("kernels.c")
# -ffp-contract=off: no fused multiply-add (on arm64 GCC would fuse by default, changing the last bit of sums that
# Python computes unfused); -fno-builtin-pow: `pow` is the C library's, the function Python's ``x ** 2`` calls
# (GCC would otherwise fold pow(x, 2.0) into x * x); no -march: the build runs on any CPU of its architecture.
FLAGS = ("-O2", "-std=c99", "-shared", "-fPIC", "-ffp-contract=off", "-fno-builtin-pow", "-fno-fast-math")
_STATE: dict[str, object] = {}


def _cache_root() -> Path:
    from ..store import user_cache_dir

    root = user_cache_dir("native")
    if root is None:
        root = Path(tempfile.gettempdir()) / f"sdovon-mj-native-{os.getuid() if hasattr(os, 'getuid') else 'user'}"
    return root


def _compiler() -> str | None:
    cc = os.environ.get("CC", "cc")
    return shutil.which(cc) or shutil.which("gcc") or shutil.which("clang")


def library_dir() -> Path:
    """Return the folder the library of this source text and these flags is built into (it may not exist yet)."""
    digest = hashlib.sha256(SOURCE.read_bytes() + " ".join(FLAGS).encode() + sys.platform.encode()).hexdigest()[:16]
    return _cache_root() / digest


def _build(target: Path) -> str:
    """Compile `kernels.c` into `target`; return "" or why not."""
    cc = _compiler()
    if cc is None:
        return "no C compiler found (set CC, or install gcc)"
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".build-", suffix=".so", dir=target.parent)
    os.close(fd)
    try:
        run = subprocess.run([cc, *FLAGS, "-o", tmp, str(SOURCE), "-lm"], capture_output=True, text=True, timeout=300)
        if run.returncode != 0:
            return f"{Path(cc).name} failed on {SOURCE.name}: {(run.stderr or run.stdout).strip()[-400:]}"
        os.replace(tmp, target)
        return ""
    except (OSError, subprocess.SubprocessError) as e:
        return f"building {SOURCE.name} failed: {e}"
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def library() -> ctypes.CDLL | None:
    """Return the loaded kernels (built first if needed), or None: the callers then run their Python forms."""
    if "lib" in _STATE:
        return _STATE["lib"]  # type: ignore[return-value]
    lib, why = None, ""
    if os.environ.get("SDOVON_NATIVE", "").lower() in ("off", "0", "no", "false"):
        why = "turned off (SDOVON_NATIVE=off)"
    else:
        target = library_dir() / "libsdovon_kernels.so"
        if not target.exists():
            try:
                why = _build(target)
            except OSError as e:  # the cache folder cannot be written (e.g. a sealed agent process)
                why = f"cannot build into {target.parent}: {e}"
        if not why:
            try:
                lib = _declare(ctypes.CDLL(str(target)))
            except (OSError, AttributeError) as e:
                lib, why = None, f"cannot load {target}: {e}"
    _STATE["lib"], _STATE["why"] = lib, why or f"compiled ({library_dir() / 'libsdovon_kernels.so'})"
    return lib


def status() -> str:
    """Return which form the agents' inner loops run in: "compiled (path)" or "python: why"."""
    lib = library()
    return str(_STATE["why"]) if lib is not None else f"python: {_STATE['why']}"


def _declare(lib: ctypes.CDLL) -> ctypes.CDLL:
    """Declare the kernels' C signatures (ctypes then converts and checks every argument)."""
    d, i64, i32, p = ctypes.c_double, ctypes.c_int64, ctypes.c_int32, ctypes.c_void_p
    lib.sdv_carve.restype = None
    lib.sdv_carve.argtypes = [p, i64, i64, p, p, p, i64, p, d, d, d, d, d]
    lib.sdv_segment_free.restype = i32
    lib.sdv_segment_free.argtypes = [p, i64, i64, d, d, d, d, d, d, d, i64]
    lib.sdv_lattice.restype = i64
    lib.sdv_lattice.argtypes = [p, p, i64, i64, i64, i64, d, d, d, d, d, d, d, d, i64, p, p, i64, d, i64, i32, i32,
                                i32, p]
    lib.sdv_near_any.restype = i64
    lib.sdv_near_any.argtypes = [p, i64, p, p, p, p, i64, d, d, d, d, i64, i64, i64, d, d]
    lib.sdv_union.restype = i64
    lib.sdv_union.argtypes = [p, p, p, p, i64, p, p, p, i64, p, p, p, p, p]
    lib.sdv_grid_dijkstra.restype = i32
    lib.sdv_grid_dijkstra.argtypes = [p, i64, i64, p, p, i64, d, p]
    lib.sdv_grid_reach.restype = i64
    lib.sdv_grid_reach.argtypes = [p, i64, i64, i64, d, p, p, p]
    lib.sdv_category.restype = None
    lib.sdv_category.argtypes = [p, i64, i64, i64, p, i64, p]
    lib.sdv_voxel_stats.restype = i64
    lib.sdv_voxel_stats.argtypes = [p, i64, d, p, p, p, p, p]
    lib.sdv_cells.restype = i32
    lib.sdv_cells.argtypes = [p, i64, d, d, d, d, p, p, p]
    lib.sdv_codes_seen.restype = None
    lib.sdv_codes_seen.argtypes = [p, i64, i64, p]
    lib.sdv_occlusion_cull.restype = i32
    lib.sdv_occlusion_cull.argtypes = [p, p, p, p, p, p, p, p, p, i64, p, i64, p, p, i64, i64, p, p]
    lib.sdv_code_lookup.restype = None
    lib.sdv_code_lookup.argtypes = [p, i64, i64, i64, i32, p, p]
    lib.sdv_frustum_out.restype = None
    lib.sdv_frustum_out.argtypes = [p, p, i64, p, p, p]
    return lib
