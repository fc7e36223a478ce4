"""The numerics profile: one instruction path for the libraries that shape output bytes, on every x86-64 CPU.

Same seed, same bytes needs more than seeds: numpy, OpenBLAS, torch and Mesa's llvmpipe each pick code by the
CPU they run on (AVX2 or AVX-512 kernels, fused multiply-adds or not), and the kernels sum and round in other
orders. Measured on one scene's inputs (`docs/reproducibility.md`): an AVX-512 Xeon and an AVX2 EPYC gave other
matrix products (OpenBLAS SkylakeX against Haswell kernels), other orders of equal keys from ``np.argsort``
(numpy's AVX-512 sort), other ``np.exp`` / ``np.log`` bits, and llvmpipe renders other pixels when its JIT
targets another instruction set. With the variables below set before those libraries load, both machines
gave the same bits in every one of these. CoACD, MuJoCo's physics and the element-wise numpy arithmetic were
the same without them; ray casts no longer go through Embree (`raycast`).

The profile caps every library at the x86-64-v3 level (AVX2 + FMA), which any x86-64 server of the last ten
years has: ``x86-64-v3``. A CPU without AVX2 gets ``x86-64-v2`` (the SSE4.2 paths: other bytes than v3 machines,
the same among themselves), other architectures run natively (their name is the profile). The package entry
(`sdovon_mj/__init__.py`) calls `apply` before anything imports numpy; a variable the user set wins, and
``SDOVON_NUMERICS=native`` turns the profile off. `active` says whether it holds in this process (numpy or
torch imported before `sdovon_mj` cannot be pinned any more); the pipeline then runs its work in fresh worker
processes, which inherit the variables. Stdlib only: this module runs before numpy is imported.
"""

from __future__ import annotations

import os
import platform
import sys

# x86-64-v3 (AVX2 + FMA): the variables, each for the library named beside it
V3_ENV = {
    "OPENBLAS_CORETYPE": "Haswell",  # numpy's and scipy's OpenBLAS: the AVX2 kernels on every CPU (SkylakeX, Zen, ...)
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",  # numpy's own loops: no AVX-512 targets
    "GALLIUM_OVERRIDE_CPU_CAPS": "avx",  # Mesa llvmpipe: JIT for AVX, without AVX2/FMA/AVX-512
    "ATEN_CPU_CAPABILITY": "avx2",  # torch's vectorised kernels: the AVX2 build even on AVX-512 CPUs
}
V2_ENV = {
    "OPENBLAS_CORETYPE": "Nehalem",
    "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR",
    "GALLIUM_OVERRIDE_CPU_CAPS": "sse4.1",
    "ATEN_CPU_CAPABILITY": "default",
}
_APPLIED: dict[str, object] = {}


def cpu_flags() -> set[str]:
    """Return the CPU's feature flags as Linux reports them (an empty set elsewhere)."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def profile(flags: set[str] | None = None, machine: str | None = None) -> tuple[str, dict[str, str]]:
    """Return the profile's name and variables for a CPU (default: this one)."""
    machine = (machine or platform.machine()).lower()
    if machine not in ("x86_64", "amd64"):
        return machine or "unknown", {}
    flags = cpu_flags() if flags is None else flags
    if {"avx", "avx2", "fma"} <= flags:
        return "x86-64-v3", dict(V3_ENV)
    return "x86-64-v2", dict(V2_ENV)


def apply() -> str:
    """Set the profile's variables (those the user left unset) for this process and its children; return its name.

    Idempotent. ``SDOVON_NUMERICS=native`` leaves every variable alone (profile ``native``).
    """
    if _APPLIED:
        return str(_APPLIED["name"])
    if os.environ.get("SDOVON_NUMERICS", "").strip().lower() == "native":
        name, env = "native", {}
    else:
        name, env = profile()
    for k, v in env.items():
        os.environ.setdefault(k, v)
    _APPLIED.update(name=name, env={k: os.environ[k] for k in env},
                    late=sorted(m for m in ("numpy", "torch") if m in sys.modules and env))
    return name


def active() -> bool:
    """Return whether the profile holds in this process: applied before numpy and torch were imported."""
    apply()
    return not _APPLIED["late"]


def describe() -> dict[str, object]:
    """Return the profile for records: its name and the variables as set (manifest, golden environment)."""
    apply()
    return {"profile": _APPLIED["name"], "env": dict(sorted(_APPLIED["env"].items()))}  # type: ignore[arg-type]
