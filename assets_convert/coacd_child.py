"""Run CoACD on one mesh in its own interpreter (used by hulls.decompose to survive CoACD crashes and stalls).

    python -m assets_convert.coacd_child IN.npz OUT.npz KWARGS_JSON [CPU_SECONDS]

IN.npz holds ``vertices`` and ``faces``; OUT.npz gets ``count`` and ``v<k>`` / ``f<k>`` per part. With
CPU_SECONDS the child limits its own processor time (RLIMIT_CPU: the kernel ends it past the limit).
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np


def main(argv: list[str]) -> int:
    """Decompose IN.npz with the given run_coacd keyword arguments and write the parts to OUT.npz."""
    from .hulls import _run_coacd

    src, dst, kwargs = argv[0], argv[1], json.loads(argv[2])
    if len(argv) > 3:
        import resource

        cpu = max(1, int(float(argv[3]) + 0.5))
        resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 5))
    with np.load(src) as z:
        vertices, faces = np.array(z["vertices"]), np.array(z["faces"])
    parts = _run_coacd(vertices, faces, kwargs)
    arrays = {"count": np.array(len(parts))}
    for k, (v, f) in enumerate(parts):
        arrays[f"v{k}"], arrays[f"f{k}"] = np.asarray(v, np.float64), np.asarray(f, np.int64)
    tmp = dst + ".tmp.npz"
    np.savez(tmp, **arrays)
    os.replace(tmp, dst)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
