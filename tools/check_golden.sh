#!/usr/bin/env bash
# Maintainer check during refactors: run the demo-config generate into a fresh folder and diff its digests
# against a digest file recorded before the change.   tools/check_golden.sh BEFORE.json [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
before="$1"; out="${2:-$(mktemp -d /tmp/golden-after-XXXX)}"; mkdir -p "$out"; rm -rf "$out/run"
export MUJOCO_GL=egl PYOPENGL_PLATFORM=egl HF_HUB_OFFLINE=1 TRANSFORMERS_OFFLINE=1 SDOVON_CACHE="${SDOVON_CACHE:-/tmp/sdcache}"
.venv/bin/sdovon-mj generate --out "$out/run" --config sdovon_mj/presets/demo.yaml --jobs "${JOBS:-1}" --quiet > "$out/log.txt" 2>&1 || { tail -20 "$out/log.txt"; exit 1; }
.venv/bin/python tools/run_digests.py "$out/run" --out "$out/after.json"
.venv/bin/python - "$before" "$out/after.json" <<'PY'
import json, sys
sys.path.insert(0, "tools")
from run_digests import digest_diff
a, b = (json.load(open(p)) for p in sys.argv[1:3])
differ, new, missing = digest_diff(a, b)
diff = sorted(differ + new + missing)
for k in diff:
    print("DIFF", k, "(missing after)" if k in missing else "(new)" if k in new else "")
print(f"{len(a)} files before, {len(b)} after, {len(diff)} differ")
sys.exit(1 if diff else 0)
PY
