"""Build the viewer's three.js bundle from the npm registry (maintainer script; its output is committed package data).

    python tools/build_viewer_js.py            # writes sdovon_mj/viewer/static/three.min.js and THREE_LICENSE.txt
    python tools/build_viewer_js.py --check    # rebuilds in a scratch folder and fails when the committed files differ

Installs the pinned three.js and esbuild with npm into a scratch folder (no install scripts run), checks the
tarballs' integrity against the pins below, and bundles only the classes `viewer.js` uses into one minified classic
script that defines ``window.THREE`` (a classic script, not an ES module: browsers refuse module imports from
``file://``, and the exported viewer must open from disk). The page never downloads anything at run time.
Needs `npm` (Debian package `npm`) and the npm registry; users and CI never run this.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
STATIC = REPO / "sdovon_mj" / "viewer" / "static"
PINS = {  # package -> (version, the npm registry's dist.integrity of its tarball)
    "three": ("0.187.0", "sha512-Qiu7R+Cmh8CstZsY1uJOSWnVlfo7ZtNLV7mF8Jltk3LB3AtDu9cRZlcnRKkAk8Y4z6KKw35z7Y7Urd7jWY8etA=="),
    "esbuild": ("0.28.2", "sha512-HKVLS8dvII+xoKW9kmqxbRKrnWEXfJJr/FZhhJmiqIB0e053QNYFqOBouTMO/k5sID4MvCiUCvv8b9M4h32wIA=="),
}
# What viewer.js takes from THREE (keep in step with it: a name missing here is undefined on the page).
NAMES = ["Box3", "Box3Helper", "BufferAttribute", "BufferGeometry", "Color", "ConeGeometry", "DataTexture",
         "DirectionalLight", "DoubleSide", "Group", "HemisphereLight", "LineBasicMaterial", "LineLoop", "Mesh",
         "MeshBasicMaterial", "MeshLambertMaterial", "NearestFilter", "PerspectiveCamera", "Plane", "PlaneGeometry",
         "Points", "PointsMaterial", "RGBAFormat", "Raycaster", "SRGBColorSpace", "Scene", "Shape", "ShapeGeometry",
         "SphereGeometry", "Vector2", "Vector3", "WebGLRenderer"]


def build(out_dir: Path) -> None:
    """Install the pins with npm in a scratch folder and write three.min.js and THREE_LICENSE.txt into `out_dir`."""
    npm = shutil.which("npm")
    if npm is None:
        sys.exit("build_viewer_js: npm not found (apt-get install npm)")
    with tempfile.TemporaryDirectory(prefix="sdovon-viewer-js-") as tmp:
        work = Path(tmp)
        (work / "package.json").write_text(json.dumps({"name": "sdovon-viewer-js", "private": True}), encoding="utf-8")
        subprocess.run([npm, "install", "--ignore-scripts", "--no-audit", "--no-fund", "--save-exact",
                        *[f"{k}@{v}" for k, (v, _) in PINS.items()]], cwd=work, check=True, stdout=subprocess.DEVNULL)
        lock = json.loads((work / "node_modules" / ".package-lock.json").read_text(encoding="utf-8"))["packages"]
        for name, (version, integrity) in PINS.items():
            got = lock.get(f"node_modules/{name}", {})
            if got.get("version") != version or got.get("integrity") != integrity:
                sys.exit(f"build_viewer_js: {name} installed as {got.get('version')} {got.get('integrity')}, "
                         f"pinned {version} {integrity}")
        (work / "entry.js").write_text(
            f"export {{ {', '.join(NAMES)} }} from 'three';\n"
            "export { OrbitControls } from 'three/addons/controls/OrbitControls.js';\n", encoding="utf-8")
        version = PINS["three"][0]
        banner = (f"/* three.js {version} (https://threejs.org, MIT licence: THREE_LICENSE.txt), bundled for sdovon-mj's "
                  f"viewer by tools/build_viewer_js.py with esbuild {PINS['esbuild'][0]}: window.THREE */")
        subprocess.run([str(work / "node_modules" / ".bin" / "esbuild"), "entry.js", "--bundle", "--format=iife",
                        "--global-name=THREE", "--minify", "--legal-comments=none", f"--banner:js={banner}",
                        "--target=es2020", "--outfile=three.min.js", "--log-level=warning"], cwd=work, check=True)
        out_dir.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(work / "three.min.js", out_dir / "three.min.js")
        shutil.copyfile(work / "node_modules" / "three" / "LICENSE", out_dir / "THREE_LICENSE.txt")


def main() -> int:
    """Build (or check) the committed bundle."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="rebuild in a scratch folder and compare with the committed files")
    args = ap.parse_args()
    if not args.check:
        build(STATIC)
        print(f"wrote {STATIC / 'three.min.js'} ({(STATIC / 'three.min.js').stat().st_size} bytes) and THREE_LICENSE.txt")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        build(Path(tmp))
        differ = [n for n in ("three.min.js", "THREE_LICENSE.txt") if (Path(tmp) / n).read_bytes() != (STATIC / n).read_bytes()]
    print("differ: " + ", ".join(differ) if differ else "the committed bundle is what the pins build")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
