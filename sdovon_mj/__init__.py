"""sdovon-mj: MuJoCo-native SD-OVON dynamic scene and open-vocabulary ObjectNav generation."""

import os

# The one place the GL backend is chosen: offscreen EGL unless the user set MUJOCO_GL. It must be set
# before anything imports mujoco (or dm_control), which picks its backend at import time; every module
# of this package, and `exporters` / `assets_convert` through their `sdovon_mj` imports, runs this first.
os.environ.setdefault("MUJOCO_GL", "egl")

# The numerics profile (`numerics`): the CPU paths of numpy, OpenBLAS, torch and llvmpipe pinned so outputs are the
# same bytes on any x86-64 CPU. Set here, before anything imports numpy; pool workers inherit the variables.
from . import numerics as _numerics  # noqa: E402  (stdlib only)

_numerics.apply()

# The renderer (`gl`): Mesa's EGL vendor listed first, before anything imports mujoco (which loads the EGL
# vendors), so the CPU renderer llvmpipe can always be chosen; which device draws is chosen at the first context.
from . import gl as _gl  # noqa: E402  (stdlib only until a renderer is chosen)

_gl.prepare()

__version__ = "0.1.0"
