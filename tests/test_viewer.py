"""The browser viewer (`sdovon-mj view`): its data follows the run and the evaluation's per-episode results, and real
headless Chromium (Debian's chromium + chromium-driver, driven by selenium) shows the page, served and exported.

The data tests use the small synthetic run (support.run_folder) evaluated by the real `eval` command; the
browser test uses the tiny default-world run of tests/conftest.py (`articulated_closed_run`), evaluated the same way.
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from exporters.mjcf_bundle import MjcfBundleExporter
from sdovon_mj.cli import main
from sdovon_mj.export import ExportOptions, RunView, run_export
from support.run_folder import build_sample_run
from sdovon_mj.viewer import data as D
from sdovon_mj.viewer.geometry import Triangles, cluster_decimate
from sdovon_mj.viewer.site import STATIC_FILES, Site, export_site

REPO = Path(__file__).resolve().parents[1]
BACKGROUND = (0x1E, 0x21, 0x27)  # the page's scene background (viewer.js)


def _decode(a: dict) -> np.ndarray:
    import base64

    return np.frombuffer(base64.b64decode(a["b64"]), dtype="<" + a["dtype"]).reshape(a["shape"])


def _eval(dataset: Path, out: Path, episodes: int) -> Path:
    """Run the real `sdovon-mj eval` (the oracle agent, small images) and return its output folder."""
    rc = main(["eval", str(dataset), "--agent", "oracle", "--episodes", str(episodes), "--width", "64", "--height", "48",
               "--pictures", "0", "--out", str(out)])
    assert rc == 0
    return out


@pytest.fixture(scope="module")
def sample(tmp_path_factory) -> tuple[Path, Path]:
    """The synthetic run with episodes, exported as MJCF bundles and evaluated (2 episodes): (run, eval folder)."""
    root = tmp_path_factory.mktemp("viewer_sample")
    run = build_sample_run(root / "run", episodes=True, seed=0)
    run_export(MjcfBundleExporter(), RunView(run), root / "mjcf", ExportOptions(name="sample"))
    return run, _eval(root / "mjcf", root / "eval", 2)


def test_payloads_follow_the_run_and_its_evaluation(sample) -> None:
    run, ev = sample
    view = RunView(run)
    site = Site(run, [ev])
    index = site.payload("index")
    assert [s["name"] for s in index["scenes"]] == view.scene_names()
    variants = view.variants("room")
    assert [v["name"] for v in index["scenes"][0]["variants"]] == [v.name for v in variants]
    assert set(index["categories"]) == {p.category for v in variants for p in v.placements}
    assert index["agents"] == ["oracle"]
    assert site.names() == list(STATIC_FILES) + ["data/index.js", "data/scene_0.js", "data/variant_0_0.js", "data/variant_0_1.js"]

    scene = site.payload("scene_0")
    pos = _decode(scene["mesh"]["positions"])
    faces = _decode(scene["mesh"]["indices"])
    lo, hi = np.asarray(scene["bounds"])
    assert len(faces) > 0 and faces.max() < len(pos)
    assert np.all(pos >= lo - 0.11) and np.all(pos <= hi + 0.11)  # the floor slab overhangs the room by 0.1 m
    assert _decode(scene["ceiling"]["indices"]).shape[0] > 0  # the ceiling (group 1) apart, hidden by default
    assert [f["floor"] for f in scene["floors"]] == [nm.floor for nm in view.navmaps("room")]
    nav = _decode(scene["floors"][0]["navmap"]["cells"])
    assert np.array_equal(nav == 2, view.navmaps("room")[0].navigable)

    v0 = site.payload("variant_0_0")
    placed = {p.object_id: p for p in variants[0].placements}
    assert {o["id"] for o in v0["objects"]} == set(placed)
    for o in v0["objects"]:
        assert o["category"] == placed[o["id"]].category and np.allclose(o["position"], placed[o["id"]].settled_pos)
        assert o["asset"] in v0["assets"]
    episodes = view.episodes(variants[0])
    assert [e["id"] for e in v0["episodes"]] == [e.episode_id for e in episodes]
    for e in episodes:
        for g in e.goals:
            assert _decode(v0["goals"][g.object_id]["view_points"]).shape == (len(g.view_points), 3)
    # the oracle's two episodes, with their trajectories as eval wrote them
    results = v0["results"]["oracle"]
    assert len(results) == 2
    for eid, r in results.items():
        wrote = json.loads((ev / "episodes" / "oracle" / f"{eid}.json").read_text())
        assert np.allclose(r["trajectory"], wrote["trajectory"]) and r["metrics"]["success"] == wrote["success"]
    assert site.payload("variant_0_1")["results"] == {}  # the oracle ran no episode of v001


def test_evaluation_reader_keeps_growing_fields_and_skips_what_is_no_result(sample, tmp_path) -> None:
    run, ev = sample
    copy = tmp_path / "eval"
    shutil.copytree(ev, copy)
    first = sorted((copy / "episodes" / "oracle").glob("*.json"))[0]
    r = json.loads(first.read_text())
    r["future_field"] = {"nested": [1, 2]}
    r["poses"] = [[0.0, 0.0, 0.0]]
    r["video"] = "videos/x.mp4"
    first.write_text(json.dumps(r))
    (copy / "episodes" / "oracle" / "notes.json").write_text('{"hello": 1}')
    (copy / "episodes" / "oracle" / "broken.json").write_text("{")
    evals = D.read_evaluations([copy])
    got = evals.agents["oracle"][(r["variant"], r["episode_id"])]
    assert got["future_field"] == {"nested": [1, 2]} and got["video"] == "videos/x.mp4"
    assert len(evals.agents["oracle"]) == 2 and len(evals.skipped) == 2
    payload = Site(run, [copy]).payload("variant_0_0")
    assert payload["results"]["oracle"][r["episode_id"]]["metrics"]["video"] == "videos/x.mp4"
    # one agent's folder alone reads the same
    assert D.read_evaluations([copy / "episodes" / "oracle"]).agents.keys() == {"oracle"}


def test_bad_input_is_a_usage_error_naming_it(sample, tmp_path, capsys) -> None:
    run, ev = sample
    assert main(["view", str(tmp_path / "nope"), "--export", str(tmp_path / "o")]) == 2
    assert "nope" in capsys.readouterr().err
    empty = tmp_path / "empty_eval"
    empty.mkdir()
    assert main(["view", str(run), "--eval", str(empty), "--export", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "empty_eval" in err and "per-episode result" in err
    assert main(["view", str(run), "--port", "70000"]) == 2
    assert not (tmp_path / "o").exists()  # nothing written before the inputs were checked


def test_export_writes_every_file_of_the_site(sample, tmp_path) -> None:
    run, ev = sample
    out = tmp_path / "site"
    assert main(["view", str(run), "--eval", str(ev), "--export", str(out)]) == 0
    site = Site(run, [ev])
    for name in site.names():
        assert (out / name).read_bytes() == site.get(name), name
    text = (out / "data" / "variant_0_0.js").read_text()
    assert text.startswith('SDOVON_DATA("variant_0_0",') and text.endswith(");\n")
    assert "MIT" in (out / "THREE_LICENSE.txt").read_text()
    assert (out / "three.min.js").read_bytes().startswith(b"/* three.js 0.187.0")


def test_server_serves_the_site_and_nothing_else(sample) -> None:
    import threading
    import urllib.error
    import urllib.request

    from sdovon_mj.viewer.site import make_server

    run, ev = sample
    site = Site(run, [ev])
    server = make_server(site, port=0)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    base = "http://127.0.0.1:%d/" % server.server_address[1]
    try:
        with urllib.request.urlopen(base) as r:
            assert r.read() == site.get("index.html") and r.headers["Content-Type"].startswith("text/html")
        with urllib.request.urlopen(base + "data/scene_0.js") as r:
            assert r.read() == site.get("data/scene_0.js")
        for bad in ("data/scene_9.js", "../pyproject.toml", "data/../../config.yaml", "viewer.py"):
            with pytest.raises(urllib.error.HTTPError) as e:
                urllib.request.urlopen(base + bad)
            assert e.value.code == 404, bad
    finally:
        server.shutdown()
        server.server_close()


def test_the_page_uses_only_what_the_bundled_three_js_holds() -> None:
    """viewer.js takes from THREE exactly the names tools/build_viewer_js.py bundles (a missing one is undefined on
    the page), and the committed bundle names the pinned version."""
    sys.path.insert(0, str(REPO / "tools"))
    try:
        import build_viewer_js as B
    finally:
        sys.path.remove(str(REPO / "tools"))
    js = (REPO / "sdovon_mj" / "viewer" / "static" / "viewer.js").read_text()
    used = set(re.findall(r"\bT\.([A-Z][A-Za-z0-9]+)", js)) - {"OrbitControls"}
    assert used == set(B.NAMES)
    bundle = (REPO / "sdovon_mj" / "viewer" / "static" / "three.min.js").read_text()
    assert bundle.startswith(f"/* three.js {B.PINS['three'][0]} ")
    for name in B.NAMES + ["OrbitControls"]:
        assert re.search(rf"\b{name}:\s*\(\)\s*=>", bundle), name  # esbuild's export table of the IIFE


def test_decimation_keeps_the_budget_and_each_instance_its_own_colour() -> None:
    import trimesh

    parts = []
    for k, (centre, rgb) in enumerate([((0, 0, 0), (200, 10, 10)), ((0.5, 0, 0), (10, 200, 10))]):
        m = trimesh.creation.icosphere(subdivisions=5, radius=0.3)  # 20480 faces each, overlapping spheres
        parts.append(Triangles(np.asarray(m.vertices + centre, np.float32), np.asarray(m.faces, np.int64),
                               np.tile(np.array(rgb, np.uint8), (len(m.vertices), 1)), np.full(len(m.faces), k)))
    mesh = Triangles.concat(parts)
    small = cluster_decimate(mesh, 4000)
    assert 0 < small.face_count <= 4000
    assert set(np.unique(small.face_id)) == {0, 1}
    for k, rgb in enumerate([(200, 10, 10), (10, 200, 10)]):
        corners = np.unique(small.faces[small.face_id == k])
        assert np.all(small.colors[corners] == rgb)
    assert cluster_decimate(mesh, mesh.face_count) is mesh


# -- real headless Chromium ------------------------------------------------------------------------------------------

CHROME_FLAGS = ["--headless", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu", "--disable-quic",
                "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync",
                # WebGL without a GPU: ANGLE on SwiftShader (software), which Chromium no longer picks by itself
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--window-size=1200,800"]


def _browser(user_data: Path):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    chromium, driver = shutil.which("chromium"), shutil.which("chromedriver")
    assert chromium and driver, "Debian's chromium and chromium-driver are needed (./run.sh test installs them as root)"
    opts = webdriver.ChromeOptions()
    opts.binary_location = chromium
    for f in CHROME_FLAGS + [f"--user-data-dir={user_data}"]:
        opts.add_argument(f)
    return webdriver.Chrome(options=opts, service=Service(driver))


def _wait(driver, predicate: str, timeout: float = 120.0) -> None:
    """Wait until a JavaScript expression is true on the page (fails with the page's status when it errs)."""
    t0 = time.time()
    while time.time() - t0 < timeout:
        if driver.execute_script(f"return !!({predicate})"):
            return
        if driver.execute_script("return document.body.dataset.state") == "error":
            pytest.fail("viewer error: " + driver.execute_script("return document.getElementById('status').textContent"))
        time.sleep(0.1)
    pytest.fail(f"timed out waiting for {predicate}")


def _canvas(driver) -> np.ndarray:
    from PIL import Image

    png = driver.find_element("css selector", "#view canvas").screenshot_as_png
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def _drawn(img: np.ndarray) -> np.ndarray:
    """Pixels that are not the page's background."""
    return np.any(np.abs(img.astype(int) - np.array(BACKGROUND)) > 3, axis=2)


def _set_layer(driver, key: str, on: bool) -> None:
    box = driver.find_element("id", f"layer-{key}")
    if box.is_selected() != on:
        frames = driver.execute_script("return +document.body.dataset.frames")
        box.click()
        _wait(driver, f"+document.body.dataset.frames > {frames}")
        driver.execute_script("return new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")


def _check_page(driver, url: str, expect: dict) -> dict[str, np.ndarray]:
    """Open the viewer at `url` and check what it shows; return screenshots by name."""
    driver.get(url)
    _wait(driver, "document.body.dataset.state === 'ready'")
    shots = {"first": _canvas(driver)}
    stats = driver.execute_script("return window.sdovonViewer.stats()")
    assert stats["triangles"] >= expect["scene_faces"]  # the whole scene mesh is drawn (and objects, markers)
    # placed objects coloured by category and labelled: one label per placed object, named by its category
    labels = driver.execute_script("return [...document.querySelectorAll('#labels div')].map(d => d.textContent)")
    assert sorted(labels) == expect["categories"]
    legend = driver.find_element("id", "legend-categories").text
    assert all(c in legend for c in set(expect["categories"]))
    # not blank: the camera frames the scene's bounding sphere, so the scene fills a large part of the view; a
    # tenth of the canvas is far below what a framed room covers and far above a blank (or a marker alone)
    drawn = _drawn(shots["first"])
    assert drawn.mean() > 0.1 and len(np.unique(shots["first"].reshape(-1, 3), axis=0)) > 50
    # the scene shows: with every layer off the canvas is the background alone; the scene layer alone fills it again
    keys = driver.execute_script("return [...document.querySelectorAll('#layers input')].map(b => b.id.slice(6))")
    for k in keys:
        _set_layer(driver, k, False)
    assert not _drawn(_canvas(driver)).any()
    _set_layer(driver, "scene", True)
    shots["scene"] = _canvas(driver)
    assert _drawn(shots["scene"]).mean() > 0.1
    for k in ("objects", "labels", "regions", "planes", "starts", "goals", "trajectory"):
        _set_layer(driver, k, True)
    assert np.array_equal(_canvas(driver), shots["first"])  # the same view again: rendering is deterministic
    # the region map lies on the floor: hiding it changes the picture
    _set_layer(driver, "regions", False)
    assert not np.array_equal(_canvas(driver), shots["first"])
    _set_layer(driver, "regions", True)
    # the selected episode's trajectory is drawn
    if expect.get("trajectory"):
        _set_layer(driver, "trajectory", False)
        assert not np.array_equal(_canvas(driver), shots["first"])
        _set_layer(driver, "trajectory", True)
    # picking another episode (a click on its row) changes the picture
    first = driver.execute_script("return document.body.dataset.episode")
    rows = driver.find_elements("css selector", "#episodes tbody tr")
    other = next(r for r in rows if r.get_attribute("data-episode") == expect["other_episode"])
    other.click()
    _wait(driver, f"document.body.dataset.episode === {json.dumps(expect['other_episode'])} && "
                  "document.body.dataset.state === 'ready'")
    assert first != expect["other_episode"]
    shots["other"] = _canvas(driver)
    assert not np.array_equal(shots["other"], shots["first"])
    assert expect["other_episode"] in driver.find_element("id", "episode-info").text
    return shots


@pytest.fixture(scope="module")
def demo_eval(articulated_closed_run: Path, tmp_path_factory) -> Path:
    """The oracle evaluated on 2 episodes of the tiny default-world run's MJCF export."""
    return _eval(articulated_closed_run / "mjcf", tmp_path_factory.mktemp("viewer_eval"), 2)


@pytest.mark.slow
def test_chromium_shows_the_run_served_and_exported(articulated_closed_run: Path, demo_eval: Path, tmp_path) -> None:
    run = articulated_closed_run / "run"
    view = RunView(run)
    variant = view.variants(view.scene_names()[0])[0]
    episodes = view.episodes(variant)
    evaluated = sorted(p.stem for p in (demo_eval / "episodes" / "oracle").glob("*.json"))
    assert len(episodes) >= 2 and len(evaluated) == 2
    site = Site(run, [demo_eval])
    scene = site.payload("scene_0")
    expect = {"scene_faces": len(_decode(scene["mesh"]["indices"])),
              "categories": sorted(p.category for p in variant.placements if p.settled_pos is not None),
              "other_episode": next(e.episode_id for e in episodes if e.episode_id != episodes[0].episode_id),
              "trajectory": episodes[0].episode_id in evaluated}
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    server = subprocess.Popen([sys.executable, "-m", "sdovon_mj.cli", "view", str(run), "--eval", str(demo_eval),
                               "--port", "0"], cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    driver = None
    try:
        line = server.stdout.readline()
        m = re.search(r"http://[\d.]+:\d+/", line)
        assert m, line + server.stderr.read()
        driver = _browser(tmp_path / "chromium-served")
        served = _check_page(driver, m.group(0), expect)
        out = tmp_path / "site"
        assert main(["view", str(run), "--eval", str(demo_eval), "--export", str(out)]) == 0
        driver.quit()
        driver = _browser(tmp_path / "chromium-file")
        exported = _check_page(driver, (out / "index.html").as_uri(), expect)
        # the same page: served and opened from disk, the same pixels
        for k in ("first", "other"):
            assert np.array_equal(served[k], exported[k]), k
    finally:
        if driver is not None:
            driver.quit()
        server.terminate()
        server.wait(timeout=30)
