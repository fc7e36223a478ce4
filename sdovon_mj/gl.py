"""Which OpenGL renderer a process draws with: Mesa's llvmpipe (the CPU renderer that defines a dataset's bytes) or a
GPU, chosen once per process, read back from the driver and recorded.

Offscreen rendering goes through EGL (``MUJOCO_GL=egl``). With glvnd, ``libEGL`` loads the vendor libraries that
the ICD files name (``__EGL_VENDOR_LIBRARY_FILENAMES``, else the ``*.json`` of ``__EGL_VENDOR_LIBRARY_DIRS`` or of
``/etc/glvnd/egl_vendor.d`` and ``/usr/share/glvnd/egl_vendor.d``, in name order: NVIDIA's ``10_nvidia.json`` before
Mesa's ``50_mesa.json``), and it loads them when ``mujoco`` is imported. MuJoCo then draws on the first EGL device
(``EGL_EXT_device_enumeration``, all vendors' devices in vendor order) that initialises, or on
``MUJOCO_EGL_DEVICE_ID``: on a GPU machine, the GPU, whose pixels differ from llvmpipe's. So:

- `prepare` (run by ``sdovon_mj/__init__.py`` before anything imports mujoco; stdlib only) lists Mesa's vendor file
  first in ``__EGL_VENDOR_LIBRARY_FILENAMES``, the others after it, so Mesa is always loaded and a GPU vendor too;
- `use` chooses, before the process's first GL context (MuJoCo keeps one EGL display per process): ``cpu`` the
  device with ``EGL_MESA_device_software`` and Mesa's software driver (``LIBGL_ALWAYS_SOFTWARE=1``,
  ``GALLIUM_DRIVER=llvmpipe``, no ``MESA_LOADER_DRIVER_OVERRIDE``), ``gpu`` another device (NVIDIA's first),
  ``auto`` a GPU when one is there, else the CPU; ``any`` is the explicit override (the CPU preferred, whatever comes
  is used). It
  then reads ``GL_RENDERER`` / ``GL_VENDOR`` / ``GL_VERSION`` back through a tiny MuJoCo GL context and refuses
  (`RendererError`) what it did not ask for; ``SDOVON_RENDER`` carries the choice to child processes;
- `ensure` is what every `SceneRenderer` calls: the choice made, else ``SDOVON_RENDER`` (unset: ``cpu``), so dataset
  generation (its workers too) draws with llvmpipe or stops; `manifest_record` is what a run's manifest records.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from .errors import RendererError

RENDERS = ("auto", "cpu", "gpu")  # what evaluation and the Gymnasium environment offer
CHOICES = RENDERS + ("any",)  # `any`: generation's explicit override (recorded)
DEFAULT_VENDOR_DIRS = ("/etc/glvnd/egl_vendor.d", "/usr/share/glvnd/egl_vendor.d")
SOFTWARE_DEVICE = "EGL_MESA_device_software"
NVIDIA = "EGL_NV_device_cuda"  # in the extensions of NVIDIA's EGL devices
RENDER_ENV = "SDOVON_RENDER"  # the renderer choice a process hands to its children (workers, evaluation jobs)
OURS = "SDOVON_EGL_DEVICE_ID"  # the MUJOCO_EGL_DEVICE_ID this package set (children re-choose; a user's value stays)
# GL_RENDERER prefixes of CPU rasterisers (Mesa's llvmpipe and softpipe, OpenSWR, Mesa's classic swrast)
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swr", "software rasterizer")
CPU_ENV = {"LIBGL_ALWAYS_SOFTWARE": "1", "GALLIUM_DRIVER": "llvmpipe"}  # Mesa's driver choice, read at eglInitialize
_STATE: dict[str, Any] = {}


def vendor_files(environ: dict[str, str] | None = None) -> list[str]:
    """Return the EGL vendor ICD files glvnd loads under `environ` (default: this process's), in load order."""
    env = os.environ if environ is None else environ
    if env.get("__EGL_VENDOR_LIBRARY_FILENAMES"):
        return [f for f in env["__EGL_VENDOR_LIBRARY_FILENAMES"].split(":") if f]
    dirs = [d for d in env.get("__EGL_VENDOR_LIBRARY_DIRS", "").split(":") if d] or list(DEFAULT_VENDOR_DIRS)
    out: list[str] = []
    for d in dirs:
        try:
            out += sorted(str(p) for p in Path(d).glob("*.json"))
        except OSError:
            continue
    return out


def vendor_library(path: str) -> str:
    """Return the library an EGL vendor ICD file names ('' when the file cannot be read)."""
    try:
        return str(json.loads(Path(path).read_text(encoding="utf-8"))["ICD"]["library_path"])
    except (OSError, ValueError, KeyError, TypeError):
        return ""


def is_mesa(path: str) -> bool:
    """Return whether an EGL vendor ICD file names Mesa's vendor library (``libEGL_mesa.so.0``)."""
    return Path(vendor_library(path)).name.startswith("libEGL_mesa")


def prepare(environ: dict[str, str] | None = None) -> list[str]:
    """List Mesa's EGL vendor file first in ``__EGL_VENDOR_LIBRARY_FILENAMES`` (the others after it, in their order);
    return the list. Run before anything loads EGL (`sdovon_mj/__init__.py`); a later call changes nothing there.

    Mesa's file comes from the list glvnd would load, else from the default folders (a list that leaves Mesa out
    still gets it: generation needs it). No Mesa file anywhere: the variables stay as they are, and `use` says so.
    """
    env = os.environ if environ is None else environ
    files = vendor_files(env)
    mesa = [f for f in files if is_mesa(f)] or [f for f in vendor_files({}) if is_mesa(f)][:1]
    if not mesa:
        return files
    ordered = mesa + [f for f in files if f not in mesa]
    env["__EGL_VENDOR_LIBRARY_FILENAMES"] = ":".join(ordered)
    return ordered


def _egl_devices() -> list[str]:
    """Return the extension string of every EGL device, in MuJoCo's order (empty when EGL offers no devices)."""
    import ctypes

    try:
        from mujoco.egl import egl_ext as EGL

        devices = EGL.eglQueryDevicesEXT()
        query = ctypes.CFUNCTYPE(ctypes.c_char_p, EGL.EGLDeviceEXT, EGL.EGLint)(
            EGL.eglGetProcAddress("eglQueryDeviceStringEXT"))
    except Exception:  # no EGL library, no device enumeration: MuJoCo's own context creation reports it
        return []
    EGL_EXTENSIONS = 0x3055
    return [(query(d, EGL_EXTENSIONS) or b"").decode("ascii", "replace") for d in devices]


def _egl_display_made() -> bool:
    """Return whether MuJoCo has made its (one, per-process) EGL display already."""
    import sys

    egl = sys.modules.get("mujoco.egl")
    return egl is not None and getattr(egl, "EGL_DISPLAY", None) is not None


def is_software(renderer: str) -> bool:
    """Return whether a GL_RENDERER string names a CPU rasteriser (llvmpipe, softpipe, ...)."""
    return renderer.strip().lower().startswith(SOFTWARE_RENDERERS)


def read_back() -> dict[str, str]:
    """Return GL_RENDERER, GL_VENDOR and GL_VERSION of this process's renderer, read through a 1x1 MuJoCo context."""
    import mujoco

    try:
        ctx = mujoco.GLContext(1, 1)
        try:
            ctx.make_current()
            from OpenGL import GL

            strings = {k: (GL.glGetString(getattr(GL, f"GL_{k.upper()}")) or b"").decode("ascii", "replace")
                       for k in ("renderer", "vendor", "version")}
        finally:
            ctx.free()
    except Exception as e:  # no display, no driver: the cause in one line
        raise RendererError(f"cannot make an OpenGL context (MUJOCO_GL={os.environ.get('MUJOCO_GL')}): "
                            f"{type(e).__name__}: {e}") from None
    return strings


def _offered(devices: list[str]) -> str:
    """Describe the EGL vendor files and devices on offer, for error messages."""
    files = ", ".join(f"{f} ({Path(vendor_library(f)).name or 'unreadable'})" for f in vendor_files()) or "none"
    devs = ", ".join(f"{i}: {'software (Mesa)' if SOFTWARE_DEVICE in e else (e.split() or ['?'])[0]}"
                     for i, e in enumerate(devices)) or "none"
    return f"EGL vendor files {files}; EGL devices {devs}"


def _pick_device(render: str) -> tuple[str | None, str | None, str]:
    """Set the EGL device and Mesa variables for `render` before the first context; return (device id or None,
    fallback note or None, the render tried: cpu or gpu)."""
    if os.environ.get("MUJOCO_GL", "egl").lower() != "egl":
        return None, None, "gpu" if render == "gpu" else "cpu"  # OSMesa / GLFW: no device to choose
    devices = _egl_devices()
    soft = [i for i, e in enumerate(devices) if SOFTWARE_DEVICE in e]
    # NVIDIA's devices first: Mesa also lists an NVIDIA card's DRM render node, which it cannot drive
    hard = sorted((i for i, e in enumerate(devices) if SOFTWARE_DEVICE not in e), key=lambda i: NVIDIA not in devices[i])
    user = os.environ.get("MUJOCO_EGL_DEVICE_ID")
    if user is not None and user == os.environ.get(OURS):  # a parent process's choice, not the user's: chosen again
        user = None
        os.environ.pop("MUJOCO_EGL_DEVICE_ID")
    note = None
    want = render
    if render in ("gpu", "auto"):
        if user is not None:  # the user's device, where it is no software one
            hard = [int(user)] if user.isdigit() and int(user) < len(devices) and int(user) not in soft else []
        if hard:
            want = "gpu"
        elif render == "gpu":
            raise RendererError(f"render='gpu' but this machine offers no GPU EGL device ({_offered(devices)}); "
                                "use render='cpu' or 'auto'")
        else:
            want, note = "cpu", f"auto: no GPU EGL device ({_offered(devices)}), rendering on the CPU"
    if want == "gpu":
        for k, v in CPU_ENV.items():  # a parent's CPU pin must not hold a Mesa GPU driver back
            if os.environ.get(k) == v:
                os.environ.pop(k)
        os.environ["MUJOCO_EGL_DEVICE_ID"] = os.environ[OURS] = str(hard[0])
        return str(hard[0]), note, "gpu"
    os.environ.update(CPU_ENV)
    os.environ.pop("MESA_LOADER_DRIVER_OVERRIDE", None)
    if soft:
        os.environ["MUJOCO_EGL_DEVICE_ID"] = os.environ[OURS] = str(soft[0])
        return str(soft[0]), note, "cpu"
    if render == "cpu":
        raise RendererError(f"the CPU renderer (Mesa llvmpipe through EGL) is not available: {_offered(devices)}; "
                            "install Mesa's EGL (Debian/Ubuntu: libegl-mesa0 libgl1-mesa-dri), or, to generate "
                            "with this machine's renderer anyway (other pixels, recorded in the manifest), "
                            "`sdovon-mj generate --any-renderer` (SDOVON_RENDER=any)")
    return None, note, "cpu"


def use(render: str = "cpu") -> dict[str, Any]:
    """Choose this process's renderer (see the module docstring), read it back, record it; return the record.

    Parameters
    ----------
    render : str
        ``cpu`` (Mesa llvmpipe or `RendererError`), ``gpu`` (a GPU EGL device whose renderer is no CPU rasteriser,
        or `RendererError`), ``auto`` (the GPU when there is one, else the CPU; the record says why), ``any``
        (the CPU preferred, whatever renders is used: generation's override).

    Returns
    -------
    dict
        ``requested``, ``render`` (``cpu`` / ``gpu``: what draws), ``renderer``, ``vendor``, ``version`` (the GL
        strings), ``egl_device`` (MuJoCo's EGL device index, None when not chosen here) and, for ``auto`` on the
        CPU, ``fallback`` (why).
    """
    if render not in CHOICES:
        raise ValueError(f"render {render!r}: one of {', '.join(CHOICES)}")
    if "record" not in _STATE:
        device, note, tried = (None, "this process made its EGL display before a renderer was chosen", "cpu") \
            if _egl_display_made() else _pick_device(render)
        strings = read_back()
        got = "cpu" if is_software(strings["renderer"]) else "gpu"
        first = {"requested": render, "render": got, **strings, "egl_device": device}
        if got != tried:
            note = f"{render}: EGL device {device} renders with {strings['renderer']!r}"
        if note and got == "cpu":
            first["fallback"] = note
        _STATE["record"] = first
        os.environ[RENDER_ENV] = render  # spawned children (workers, evaluation jobs) choose alike
    rec = dict(_STATE["record"], requested=render)
    if render != "auto":  # a fallback is auto's: cpu and any got what they asked for
        rec.pop("fallback", None)
    renderer = str(rec["renderer"])
    if render == "cpu" and not renderer.lower().startswith("llvmpipe"):
        why = _STATE["record"].get("fallback") or f"chosen first ({_STATE['record']['requested']})"
        raise RendererError(f"render='cpu' needs Mesa llvmpipe (datasets are defined by its pixels), but this process "
                            f"renders with {renderer!r} ({rec.get('vendor')}): {why}; a process keeps the renderer it "
                            "made first. To generate anyway (recorded in the manifest): `sdovon-mj generate "
                            "--any-renderer` (SDOVON_RENDER=any)")
    if render == "gpu" and rec["render"] != "gpu":
        devices = _egl_devices() if os.environ.get("MUJOCO_GL", "egl").lower() == "egl" else []
        if not any(SOFTWARE_DEVICE not in e for e in devices):
            raise RendererError(f"render='gpu' but this machine offers no GPU EGL device ({_offered(devices)}); "
                                "use render='cpu' or 'auto'")
        raise RendererError(f"render='gpu' but this process renders with {renderer!r} on the CPU, chosen first "
                            f"({_STATE['record']['requested']}): a process keeps the renderer it made first; choose "
                            "the GPU in a fresh process")
    if render == "auto" and rec["render"] == "cpu" and "fallback" not in rec:
        rec["fallback"] = f"auto: this process renders on the CPU already ({_STATE['record']['requested']} chosen first)"
    return rec


def ensure() -> dict[str, Any]:
    """Return this process's renderer record, choosing it first when nothing has (``SDOVON_RENDER``, default ``cpu``).

    Every `SceneRenderer` calls it before making its context: a process that chose nothing (dataset generation and
    its workers) renders with llvmpipe, or stops with `RendererError` naming what the machine offers.
    """
    if "record" in _STATE:
        return dict(_STATE["record"])
    want = os.environ.get(RENDER_ENV, "").strip().lower() or "cpu"
    return use(want if want in CHOICES else "cpu")


def generation_renderer() -> dict[str, Any]:
    """Pin the CPU renderer for dataset generation (``SDOVON_RENDER=any``: the recorded override) and return the
    record; `RendererError` when llvmpipe is not what this process renders with."""
    rec = use("any" if os.environ.get(RENDER_ENV, "").strip().lower() == "any" else "cpu")
    os.environ[RENDER_ENV] = rec["requested"]  # the workers: the same pin (or override)
    return rec


def manifest_record() -> dict[str, Any]:
    """Return what a run's manifest records of the renderer: the GL strings, and whether llvmpipe drew the pixels
    or the override let another renderer draw them (``override``)."""
    rec = generation_renderer()
    return {"renderer": rec["renderer"], "vendor": rec["vendor"], "version": rec["version"],
            "llvmpipe": str(rec["renderer"]).lower().startswith("llvmpipe"), "override": rec["requested"] == "any"}
