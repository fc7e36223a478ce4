"""Config, records, store and plugin lookup: the foundation every stage relies on."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj import config as C
from sdovon_mj import plugins, records as R
from sdovon_mj.store import Store, atomic_write_bytes, clean_temp_files, fingerprint


def test_config_defaults_match_paper_appendix_e():
    cfg = C.RunConfig()
    assert cfg.observe.h_map == 0.3
    assert cfg.observe.eps_p_obs == 0.5
    assert (cfg.perceive.k_sem, cfg.perceive.k_geo, cfg.perceive.phi_min) == (0.4, 1.6, 0.8)
    assert cfg.perceive.iou_min == 0.9
    assert cfg.place.h_spawn == 0.3
    assert cfg.agent.eta_gt == 1e-4
    assert cfg.nav.eps_nav == 0.5 and cfg.nav.d_next == 1.0
    rows = {r[0]: r for r in C.describe()}
    assert rows["observe.h_map"][2] == "m" and rows["observe.h_map"][3] == "h_map"
    assert all(r[4] for r in rows.values()), "every field documents its meaning"


def test_config_yaml_round_trip(tmp_path):
    cfg = C.apply_overrides(C.RunConfig(), ["place.k_v=5", "observe.pitch_angles=[-45, 0, 15]", "name=mine"])
    p = tmp_path / "c.yaml"
    C.save_config(cfg, p)
    back = C.load_config(p)
    assert back == cfg and back.place.k_v == 5 and back.observe.pitch_angles == (-45.0, 0.0, 15.0)


def test_config_misspelt_key_names_the_key_and_file(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("observe:\n  h_mapp: 0.4\n")
    with pytest.raises(C.ConfigError) as e:
        C.load_config(p)
    msg = str(e.value)
    assert "observe.h_mapp" in msg and str(p) in msg and "observe.h_map" in msg
    with pytest.raises(C.ConfigError, match="plcae"):
        C.load_config(None, ["plcae.k_v=3"])
    with pytest.raises(C.ConfigError, match="k_v"):
        C.load_config(None, ["place.k_v=abc"])


def test_fusion_presets():
    pc = C.with_fusion_preset(dataclasses.replace(C.PerceiveConfig(), fusion_preset="conceptgraphs"))
    assert (pc.k_sem, pc.k_geo, pc.phi_min) == (1.0, 1.0, 1.1)
    custom = dataclasses.replace(C.PerceiveConfig(), fusion_preset="custom", k_sem=2.0)
    assert C.with_fusion_preset(custom).k_sem == 2.0
    with pytest.raises(C.ConfigError):
        C.with_fusion_preset(dataclasses.replace(C.PerceiveConfig(), fusion_preset="nope"))


def test_fusion_preset_resolves_at_load_and_an_explicit_key_wins(tmp_path):
    """--set perceive.k_sem=... is no longer overwritten by the default preset; presets resolve when loading."""
    cfg = C.load_config(None, ["perceive.k_sem=0.7"])
    assert cfg.perceive.k_sem == 0.7 and cfg.perceive.fusion_preset == "custom"
    assert (cfg.perceive.k_geo, cfg.perceive.phi_min) == (1.6, 0.8)  # the rest of the preset it was given
    cfg = C.load_config(None, ["perceive.fusion_preset=conceptgraphs"])
    assert (cfg.perceive.k_sem, cfg.perceive.k_geo, cfg.perceive.phi_min) == (1.0, 1.0, 1.1)
    cfg = C.load_config(None, ["perceive.fusion_preset=conceptgraphs", "perceive.phi_min=1.3"])
    assert (cfg.perceive.k_sem, cfg.perceive.phi_min, cfg.perceive.fusion_preset) == (1.0, 1.3, "custom")
    p = tmp_path / "c.yaml"
    p.write_text("perceive:\n  fusion_preset: conceptgraphs\n  k_geo: 2.0\n")
    cfg = C.load_config(p)
    assert (cfg.perceive.k_sem, cfg.perceive.k_geo, cfg.perceive.fusion_preset) == (1.0, 2.0, "custom")
    # an explicit key equal to the preset changes nothing; the saved config loads back to itself
    assert C.load_config(None, ["perceive.k_sem=0.4"]).perceive == C.RunConfig().perceive
    C.save_config(cfg, tmp_path / "back.yaml")
    assert C.load_config(tmp_path / "back.yaml") == cfg
    # the fuser uses what the config says
    from sdovon_mj.perceive.fusion import InstanceFuser

    assert InstanceFuser(C.load_config(None, ["perceive.k_sem=0.7"]).perceive).cfg.k_sem == 0.7


def test_moved_keys_name_their_new_home(tmp_path):
    """Agent fields and eta_gt have one home (agent.*); old keys fail with an error naming the new key."""
    p = tmp_path / "old.yaml"
    p.write_text("episodes:\n  eta_gt: 0.001\n")
    with pytest.raises(C.ConfigError, match=r"episodes\.eta_gt.*agent\.eta_gt"):
        C.load_config(p)
    for old, new in (("perceive.gt_eta", "agent.eta_gt"), ("nav.eta_gt", "agent.eta_gt"), ("observe.agent_radius", "agent.radius"),
                     ("nav.obs_width", "agent.sensor_width"), ("episodes.hfov", "agent.hfov"), ("observe.agent_height", "agent.camera_height")):
        with pytest.raises(C.ConfigError, match=new.replace(".", r"\.")):
            C.load_config(None, [f"{old}=1"])
    cfg = C.load_config(None, ["agent.radius=0.2", "agent.eta_gt=0.001"])
    assert (cfg.agent.radius, cfg.agent.eta_gt) == (0.2, 0.001)


def _examples() -> list[R.Record]:
    rng = np.random.default_rng(0)
    poly = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    return [
        R.SceneAsset("apt", "scene/apt.xml", floors=[R.Floor(0, 0.0, 30.5)],
                     instances=[R.SemanticInstance(3, "table", ["inst_3"], room=1, kind="receptacle", bounds=rng.random((2, 3)))],
                     bounds=rng.random((2, 3)), rooms=[R.Room(1, "kitchen", 0, poly)],
                     support_surfaces=[R.SupportSurface(3, 0.75, poly)]),
        R.ObjectAsset("mug_0", "mug", "objects/mug_0/model.xml", rng.random((2, 3)), 0.3, 4),
        R.NavMap(0, 0.0, np.array([-1.0, -2.0]), 0.05, rng.random((7, 9)) > 0.5, rng.random((7, 9)) > 0.3),
        R.Observation((rng.random((4, 5, 3)) * 255).astype(np.uint8), rng.random((4, 5)).astype(np.float32),
                      np.eye(3), np.eye(4), segmentation=rng.integers(-1, 5, (4, 5)).astype(np.int32)),
        R.Instance(1, "sofa", rng.random((20, 3)).astype(np.float32), np.array([1.0, 2.0, 0.3]), [0.9, 0.8], [0, 3]),
        R.ReceptaclePlane(0, 1, "table", 0.75, poly, np.array([0, 0, 1.0]), region="kitchen"),
        R.RegionMap(0, np.zeros(2), 0.05, ["kitchen", "bedroom"], rng.integers(-1, 2, (3, 4)).astype(np.int16),
                    rng.random((3, 4, 2)).astype(np.float32)),
        R.Relevance(["mug"], ["kitchen"], ["table"], np.ones((1, 1)), np.ones((1, 1))),
        R.SceneVariant("apt", 2, 1234, [R.Placement("obj_000", "mug_0", "mug", 0, 1, "kitchen", np.zeros(3),
                                                    np.array([1.0, 0, 0, 0]), np.ones(3), np.array([1.0, 0, 0, 0]), "resting")],
                       qpos=rng.random(7)),
        R.Episode("ep0", "apt", "apt_v002", "mug", np.zeros(3), np.array([1.0, 0, 0, 0]),
                  [R.Goal("obj_000", "mug", np.ones(3), [R.ViewPoint(np.zeros(3), np.array([1.0, 0, 0, 0]), 0.01)])],
                  geodesic_distance=3.2, euclidean_distance=2.0 / 3.0),
    ]


@pytest.mark.parametrize("rec", _examples(), ids=lambda r: r.record_type())
def test_records_round_trip_json_exactly(rec, tmp_path):
    back = type(rec).from_json(rec.to_json())
    assert R.records_equal(rec, back)
    assert back.to_json() == rec.to_json()
    R.save_json(rec, tmp_path / "r.json")
    assert R.records_equal(R.load_json(tmp_path / "r.json"), rec)


def test_records_round_trip_npz_exactly(tmp_path):
    recs = _examples()
    R.save_npz(recs, tmp_path / "s.npz")
    back = R.load_npz(tmp_path / "s.npz")
    assert len(back) == len(recs)
    for a, b in zip(recs, back):
        assert R.records_equal(a, b), a.record_type()
    b1 = (tmp_path / "s.npz").read_bytes()
    R.save_npz(recs, tmp_path / "s2.npz")
    assert (tmp_path / "s2.npz").read_bytes() == b1, "npz shards are deterministic"


def test_renamed_record_keeps_its_file_tag(tmp_path):
    """A renamed record class keeps its on-disk tag: same bytes, and files written before still load."""
    vp = R.CoverageCamera(floor=1, position=np.array([1.0, 2.0, 0.88]))
    assert vp.record_type() == "Viewpoint" and vp.to_dict()[R.TAG] == "Viewpoint"
    R.save_json([vp], tmp_path / "viewpoints.json")
    assert '"__record__": "Viewpoint"' in (tmp_path / "viewpoints.json").read_text()
    assert R.records_equal(R.load_json(tmp_path / "viewpoints.json"), [vp])
    assert R.records_equal(R.load_json(tmp_path / "viewpoints.json", R.CoverageCamera), [vp])
    R.save_npz([vp], tmp_path / "v.npz")
    assert type(R.load_npz(tmp_path / "v.npz")[0]) is R.CoverageCamera
    with pytest.raises(R.RecordError, match="Viewpoint"):
        R.ViewPoint.from_dict(vp.to_dict())
    with pytest.raises(TypeError, match="Viewpoint"):
        type("Other", (R.Record,), {}, tag="Viewpoint")


def test_corrupt_record_file_is_a_clear_error(tmp_path):
    p = tmp_path / "x.json"
    p.write_text("{not json")
    with pytest.raises(R.RecordError, match="x.json"):
        R.load_json(p)
    p.write_text('{"__record__": "Nope"}')
    with pytest.raises(R.RecordError, match="Nope"):
        R.load_json(p)


def test_atomic_write_leaves_no_partial_file_when_killed(tmp_path):
    target = tmp_path / "big.bin"
    target.write_bytes(b"old")
    script = textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {str(Path(__file__).resolve().parents[1])!r})
        import sdovon_mj.store as s
        class Slow:
            def __init__(self): self.n = 0
        # write a large payload in many chunks by monkeypatching os.fsync to stall
        import os
        real = os.fsync
        def stall(fd):
            print("writing", flush=True); time.sleep(30)
        os.fsync = stall
        s.atomic_write_bytes(__import__("pathlib").Path({str(target)!r}), b"x" * 50_000_000)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE)
    assert proc.stdout.readline().strip() == b"writing"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert target.read_bytes() == b"old", "the target is the old file, never a partial new one"
    leftovers = [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert leftovers, "the killed writer left its temp file (and only that)"
    assert clean_temp_files(tmp_path) == len(leftovers)
    atomic_write_bytes(target, b"new")
    assert target.read_bytes() == b"new"


def test_dumps_is_json_dumps_byte_for_byte():
    """store.dumps' fast encoder writes json.dumps(sort_keys, indent=1, ensure_ascii=False) + newline exactly,
    and leaves what it does not handle to json (same text or the same error)."""
    import json

    from sdovon_mj.store import dumps

    def ref(d):
        return json.dumps(d, sort_keys=True, indent=1, ensure_ascii=False, allow_nan=False) + "\n"

    rng = np.random.default_rng(0)
    cases = [None, True, False, 0, -7, 2 ** 70, 0.1, -0.0, 1e-300, 1.7976931348623157e308, np.float64(0.3),
             "", "a\"b\\c\n\t\u0001é😀", [], {}, (), [[]], {"": {}}, [1, [2, [3, []]], {"z": 1, "a": [None]}],
             {"b": 1, "a": {"y": (1, 2.5), "x": "s"}, "é": [True, False]},
             [R._encode(r) for r in _examples()],
             {"k": [float(x) for x in rng.normal(size=50)], "n": [int(x) for x in rng.integers(-10**9, 10**9, 50)]},
             {1: "int key"}, {"a": 1, 2: "mixed"}, {(1, 2): "tuple key"}, {True: 1, None: 2, 1.5: 3}]
    for d in cases:
        try:
            want = ref(d)
        except (TypeError, ValueError) as e:
            with pytest.raises(type(e)):
                dumps(d)
            continue
        assert dumps(d) == want, d
    for bad in (float("nan"), [float("inf")], {"x": -float("inf")}, {"x": object()}, [np.int64(3)], {"x": {1, 2}}):
        with pytest.raises((ValueError, TypeError)) as got:
            dumps(bad)
        with pytest.raises(got.type):
            ref(bad)
    loop: list = []
    loop.append(loop)
    with pytest.raises(ValueError, match="Circular"):
        dumps(loop)


def test_store_stage_markers(tmp_path):
    st = Store(tmp_path)
    fp = fingerprint({"in": 1}, {"cfg": 2})
    assert fp == fingerprint({"in": 1}, {"cfg": 2}) and fp != fingerprint({"in": 2}, {"cfg": 2})
    assert not st.is_done("scenes/a/observe")
    st.write_json("scenes/a/observe/out.json", {"x": 1})
    st.mark_done("scenes/a/observe", fp, ["scenes/a/observe/out.json"], 1.5)
    assert st.is_done("scenes/a/observe", fp)
    assert not st.is_done("scenes/a/observe", "other")
    st.path("scenes/a/observe/out.json").unlink()
    assert not st.is_done("scenes/a/observe", fp), "a marker whose outputs vanished is not done"


def test_plugins_lookup_errors_name_the_plugin():
    assert "offline" in plugins.available("llm_backend")
    with pytest.raises(plugins.PluginError, match="nope"):
        plugins.load("exporter", "nope")
    plugins.register("exporter", "inline", dict)
    assert plugins.load("exporter", "inline") is dict


def test_cli_help_lists_subcommands():
    out = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "--help"], capture_output=True, text=True)
    assert out.returncode == 0
    for name in ("demo", "convert", "observe", "place", "episodes", "generate", "export", "eval", "show"):
        assert name in out.stdout
    bad = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", "frobnicate"], capture_output=True, text=True)
    assert bad.returncode == 2
