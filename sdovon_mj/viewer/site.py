"""The viewer's files: the page (package data under ``viewer/static/``) and its data files, served or written out.

One set of files for both uses: ``sdovon-mj view RUN_DIR`` serves them from a local HTTP server that builds each data
file when the page first asks for it; ``--export DIR`` writes every one of them, and the folder opens from
``file://`` (no fetch: the page loads its data as classic ``<script>`` files, which browsers allow there) or from any
static web host. Data file ``data/<key>.js`` is one line, ``SDOVON_DATA("<key>", <JSON payload>);``.
"""

from __future__ import annotations

import http.server
import threading
from importlib.resources import files
from pathlib import Path
from typing import Any, Callable

from ..errors import InputError
from ..runview import RunView
from ..store import atomic_write_bytes
from . import data

STATIC_FILES = ("index.html", "viewer.css", "viewer.js", "three.min.js", "THREE_LICENSE.txt")
CONTENT_TYPES = {".html": "text/html; charset=utf-8", ".css": "text/css; charset=utf-8",
                 ".js": "text/javascript; charset=utf-8", ".txt": "text/plain; charset=utf-8"}


def static_file(name: str) -> bytes:
    """Return one of the page's packaged files (`STATIC_FILES`)."""
    return (files("sdovon_mj.viewer") / "static" / name).read_bytes()


class Site:
    """The viewer's files for one run (and its evaluation results): names and contents, each data file built once.

    Parameters
    ----------
    run_dir
        The run folder (read through `RunView`).
    eval_dirs
        Output folders of `sdovon-mj eval --out` (or agent folders inside them) whose trajectories to show.
    scene_faces
        Triangle budget of a scene's mesh.
    object_faces
        Triangle budget of one object asset's mesh.
    """

    def __init__(self, run_dir: str | Path, eval_dirs: list[str | Path] | None = None,
                 scene_faces: int = data.SCENE_FACES, object_faces: int = data.OBJECT_FACES) -> None:
        self.view = RunView(run_dir)
        self.evals = data.read_evaluations(list(eval_dirs)) if eval_dirs else None
        self.scene_faces, self.object_faces = int(scene_faces), int(object_faces)
        self._scenes = self.view.scene_names()
        if not self._scenes:
            raise InputError(self.view.root, "run folder holds no converted scene (scenes/<scene>/scene.json)")
        self._variants = {s: self.view.variants(s) for s in self._scenes}
        self._models = data.SceneModels(self.view)
        self._objects: dict[str, data.Triangles] = {}
        self._built: dict[str, bytes] = {}
        self._lock = threading.Lock()

    def unmatched_results(self) -> dict[str, tuple[int, int]]:
        """Return agent -> (results naming no episode of this run, results) for agents with such results."""
        if self.evals is None:
            return {}
        known = {(v.name, e.episode_id) for vs in self._variants.values() for v in vs for e in self.view.episodes(v)}
        out = {}
        for agent, rows in self.evals.agents.items():
            n = sum(1 for k in rows if k not in known)
            if n:
                out[agent] = (n, len(rows))
        return out

    def data_keys(self) -> list[str]:
        """Return the keys of every data file: ``index``, ``scene_<i>``, ``variant_<i>_<j>`` (indices in the index)."""
        keys = ["index"]
        for i, s in enumerate(self._scenes):
            keys.append(f"scene_{i}")
            keys += [f"variant_{i}_{j}" for j in range(len(self._variants[s]))]
        return keys

    def names(self) -> list[str]:
        """Return every file of the site, relative to its root."""
        return list(STATIC_FILES) + [f"data/{k}.js" for k in self.data_keys()]

    def payload(self, key: str) -> dict[str, Any]:
        """Return the payload of a data key (KeyError for an unknown one)."""
        if key == "index":
            return data.index_payload(self.view, self.evals)
        kind, _, rest = key.partition("_")
        idx = [int(x) for x in rest.split("_")] if rest and all(x.isdigit() for x in rest.split("_")) else []
        if kind == "scene" and len(idx) == 1 and idx[0] < len(self._scenes):
            return data.scene_payload(self.view, self._scenes[idx[0]], self._models, self.scene_faces)
        if kind == "variant" and len(idx) == 2 and idx[0] < len(self._scenes) and idx[1] < len(self._variants[self._scenes[idx[0]]]):
            v = self._variants[self._scenes[idx[0]]][idx[1]]
            return data.variant_payload(self.view, v, self.evals, self._models, self._objects, self.object_faces)
        raise KeyError(key)

    def data_file(self, key: str) -> bytes:
        """Return the bytes of ``data/<key>.js`` (built on first use)."""
        with self._lock:
            if key not in self._built:
                self._built[key] = f'SDOVON_DATA("{key}",{data.to_json(self.payload(key))});\n'.encode("ascii")
            return self._built[key]

    def get(self, name: str) -> bytes:
        """Return a file of the site by its relative name (KeyError when it is none)."""
        if name in STATIC_FILES:
            return static_file(name)
        if name.startswith("data/") and name.endswith(".js"):
            return self.data_file(name[len("data/"):-len(".js")])
        raise KeyError(name)


def export_site(site: Site, out: str | Path, progress: Callable[[str], None] | None = None) -> list[Path]:
    """Write every file of the site under `out` (created); return the paths written."""
    out = Path(out)
    written = []
    for name in site.names():
        if progress:
            progress(name)
        p = out / name
        atomic_write_bytes(p, site.get(name))
        p.chmod(0o644)  # a published folder: readable by the web server
        written.append(p)
    return written


def make_server(site: Site, host: str = "127.0.0.1", port: int = 8000) -> http.server.ThreadingHTTPServer:
    """Return an HTTP server of the site (not started: call ``serve_forever``); port 0 picks a free one."""

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802 - http.server's name
            name = self.path.split("?", 1)[0].split("#", 1)[0].lstrip("/") or "index.html"
            try:
                body = site.get(name)
            except KeyError:
                self.send_error(404, "not a file of this viewer")
                return
            except Exception as e:  # a data file that cannot be built: say why on the page's console
                self.send_error(500, f"{type(e).__name__}: {e}"[:200])
                raise
            self.send_response(200)
            self.send_header("Content-Type", CONTENT_TYPES.get(Path(name).suffix, "application/octet-stream"))
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - http.server's signature
            return  # quiet: the command prints its own lines

    server = http.server.ThreadingHTTPServer((host, int(port)), Handler)
    server.daemon_threads = True
    return server
