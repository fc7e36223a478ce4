"""The stage contract: declarations, fingerprints from them, per-stage commands = generate, byte identity."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
import yaml

from sdovon_mj import stages
from sdovon_mj.cli import main
from sdovon_mj.config import RunConfig, load_config
from sdovon_mj.errors import StageError
from sdovon_mj.pipeline import generate
from sdovon_mj.store import Store

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
from run_digests import environment, run_digests  # noqa: E402

# A small default-world run: one apartment, two cheap object categories, small images, one variant.
SMALL = {
    "world": {"scene_seeds": [0], "floors": 1, "object_variants": 1, "object_categories": ["apple", "book"]},
    "observe": {"width": 160, "height": 120, "yaw_steps": 4, "pitch_angles": [-30.0]},
    "place": {"k_v": 1, "m": 1},
    "episodes": {"k_e": 1},
}


def test_every_declaration_is_consistent():
    cfg = RunConfig()
    keys = set()
    for name, st in stages.STAGES.items():
        assert st.name == name and st.scope in stages.SCOPES
        for need in st.needs + st.after:  # a stage needs only stages declared before it
            assert list(stages.STAGES).index(need) < list(stages.STAGES).index(name), (name, need)
        for sec in st.read_sections(cfg):
            stages.section_value(cfg, sec)  # raises AttributeError for a section that does not exist
        assert st.key not in keys
        keys.add(st.key)
    assert stages.closure(["episodes"]) == ["world:objects", "objects", "world:scene", "convert", "observe", "perceive",
                                            "semantics", "place", "episodes"]
    assert stages.closure(["observe"]) == ["world:scene", "convert", "observe"]  # world:scene via `after`
    with pytest.raises(StageError, match="unknown stage 'nope'"):
        stages.closure(["nope"])
    assert "perceive" in stages.describe()


def test_fingerprints_follow_the_declared_config(tmp_path):
    store = Store(tmp_path)
    store.write_json("inputs.json", {"scenes": [], "objects": []})
    base = RunConfig()

    def fp(stage: str, cfg: RunConfig) -> str:
        return stages.stage_fingerprint(stages.STAGES[stage], stages.StageContext(store, cfg, "apt_0000", 0))

    other_place = load_config(None, ["place.k_v=7"])
    other_observe = load_config(None, ["observe.yaw_steps=5"])
    other_seed = load_config(None, ["seed=3"])
    assert fp("observe", other_place) == fp("observe", base)  # observe does not read place
    assert fp("observe", other_observe) != fp("observe", base)
    assert fp("observe", other_seed) != fp("observe", base)  # the scene seed is an input
    assert fp("place", other_place) != fp("place", base)
    # perceive reads the semantics fields that decide the LLM's answers (it may ask the backend to name
    # receptacles), never the region-map window: a new window radius does not redo perception
    other_sem = load_config(None, ["semantics.window_radius=3.0"])
    assert fp("perceive", other_sem) == fp("perceive", base)
    assert fp("perceive", load_config(None, ["semantics.offline_model=table"])) != fp("perceive", base)
    never = load_config(None, ["receptacles.llm_share=0"])  # prespecified labels, never asks: no semantics field
    assert fp("perceive", load_config(None, ["receptacles.llm_share=0", "semantics.offline_model=table"])) == fp("perceive", never)
    llm = load_config(None, ["receptacles.labels=[]"])
    assert fp("perceive", load_config(None, ["receptacles.labels=[]", "semantics.backend=ollama"])) != fp("perceive", llm)


def test_semantics_fingerprint_follows_the_shipped_offline_model(tmp_path, monkeypatch):
    """A new learned model or priors file (a package upgrade) makes a resumed run compute its relevance again."""
    import sdovon_mj.semantics as sem

    store = Store(tmp_path)
    store.write_json("inputs.json", {"scenes": [], "objects": []})
    ctx = stages.StageContext(store, RunConfig(), "apt_0000", 0)
    before = stages.stage_fingerprint(stages.STAGES["semantics"], ctx)
    observe = stages.stage_fingerprint(stages.STAGES["observe"], ctx)
    monkeypatch.setattr(sem, "offline_data_digest", lambda: "another model")
    assert stages.stage_fingerprint(stages.STAGES["semantics"], ctx) != before
    assert stages.stage_fingerprint(stages.STAGES["observe"], ctx) == observe  # perception does not read it


@pytest.mark.slow
def test_stage_commands_write_the_same_bytes_as_generate(tmp_path):
    """`sdovon-mj observe/perceive/semantics/place/episodes` one after the other = `generate`'s stages."""
    cfg_file = tmp_path / "small.yaml"
    cfg_file.write_text(yaml.safe_dump(SMALL))
    a, b = tmp_path / "a", tmp_path / "b"
    generate(a, load_config(cfg_file), progress=False, exporters=[])
    assert main(["observe", str(b), "--config", str(cfg_file), "--quiet"]) == 0
    assert (b / "scenes" / "apt_0000" / "observe" / ".done.json").exists()
    assert not (b / "scenes" / "apt_0000" / "perceive").exists() and not (b / "objects").exists()
    for stage in ("perceive", "semantics", "place", "episodes"):
        assert main([stage, str(b), "--quiet"]) == 0, stage
    da, db = run_digests(a), run_digests(b)
    keep = lambda d: {k: v for k, v in d.items() if k.startswith(("scenes/", "objects/", "inputs/"))}  # noqa: E731
    assert keep(da) == keep(db)  # every record, MJCF, picture and stage marker (fingerprints included)
    assert any(k.endswith("episodes.json") for k in keep(da))
    # a rerun of a stage command finds everything done
    assert main(["place", str(b), "--quiet"]) == 0
    assert run_digests(b) == db


def test_stage_command_errors_name_the_input(tmp_path, capsys):
    missing = tmp_path / "nothere.glb"
    assert main(["observe", str(tmp_path / "run"), "--scenes", str(missing), "--quiet"]) == 2  # found before any work
    assert "nothere.glb" in capsys.readouterr().err and not (tmp_path / "run").exists()
    (tmp_path / "file").write_text("x")
    assert main(["perceive", str(tmp_path / "file")]) == 1
    # a --scene pattern that names no scene of the run is a usage error, found before any work
    assert main(["place", str(tmp_path / "run"), "--scene", "apt_9999", "--quiet"]) == 2
    assert "apt_9999" in capsys.readouterr().err


GOLDEN = ROOT / "tests" / "data" / "golden" / "demo_generate_digests.json"
GOLDEN_ENV = GOLDEN.with_name("demo_generate_environment.json")
# The digests of every output of the demo-config `generate` (tools/run_digests.py: timings and the installed
# package versions aside). First recorded before the one-shape redesign (issue 19), which kept every data output
# byte-identical (only the config-shaped files config.yaml, manifest.json and the stage markers changed, with the
# config's new shape); re-recorded after the intended behaviour changes that followed (dense view points and
# start filters, the learned semantics, the MJCF bundle's oracle/ folder, textured Habitat GLBs, deterministic
# scene part order, verified stage markers, run-relative sources), and once more when the bytes stopped depending
# on the machine (issue 35: float64 one-thread embeddings on a grid, exact axis-aligned ray casts, a CPU-time CoACD
# budget, the numerics profile). A refactor must keep them; a behaviour change re-records them in the same commit
# and says why.
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@pytest.fixture(scope="module")
def demo_runs(tmp_path_factory) -> dict[int, dict[str, str]]:
    """The demo-config `generate` run twice from cold (no cache), in fresh processes with 1 and 2 intra-op threads
    (torch, OpenMP and BLAS read these variables when they load): {threads: digests of every output}."""
    import os
    import subprocess

    from sdovon_mj.commands.demo import demo_config_path

    runs = {}
    for threads in (2, 1):  # side by side: each leaves a core idle in its one-scene stages (same bytes either way)
        folder = tmp_path_factory.mktemp(f"demo{threads}")
        env = {**os.environ, "SDOVON_CACHE": str(folder / "cache"), **{k: str(threads) for k in THREAD_VARS}}
        runs[threads] = folder, subprocess.Popen([sys.executable, "-m", "sdovon_mj.cli", "generate", "--out",
                                                  str(folder / "run"), "--config", str(demo_config_path()), "--jobs",
                                                  "2", "--quiet"], env=env, stdout=subprocess.PIPE,
                                                 stderr=subprocess.PIPE, text=True)
    out = {}
    for threads, (folder, proc) in runs.items():
        _, err = proc.communicate()
        assert proc.returncode == 0, err[-2000:]
        out[threads] = run_digests(folder / "run")
    return out


@pytest.mark.slow
def test_generate_writes_the_same_bytes_on_one_and_two_threads(demo_runs):
    one, two = demo_runs[1], demo_runs[2]
    differ = sorted(k for k in one.keys() | two.keys() if one.get(k) != two.get(k))
    assert len(one) > 500 and not differ, f"{len(differ)} of {len(one)} outputs differ between 1 and 2 threads: {differ[:20]}"


@pytest.mark.slow
def test_generate_outputs_match_the_recorded_digests(demo_runs):
    from sdovon_mj import numerics

    got = demo_runs[2]
    want = json.loads(GOLDEN.read_text())
    differ = sorted(k for k in want.keys() | got.keys() if want.get(k) != got.get(k))
    env = json.loads(GOLDEN_ENV.read_text()) if GOLDEN_ENV.is_file() else {}
    now = environment()
    changed = {k: f"{env.get(k)} -> {v}" for k, v in now.items() if env and env.get(k) != v}
    assert not differ, (f"{len(differ)} outputs differ from the recorded digests: {differ[:20]}; byte-shaping "
                        f"libraries or the numerics profile changed since the recording: {changed or 'none'} "
                        f"(this machine: {numerics.describe()['profile']}; tests/data/golden/README)")
