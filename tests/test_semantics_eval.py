"""`sdovon-mj semantics eval` against the local fake Ollama / OpenAI servers: the same figures as the backend called directly."""

from __future__ import annotations

import json

import numpy as np

from sdovon_mj.cli import main
from sdovon_mj.commands.semantics_eval import evaluate
from sdovon_mj.semantics import get_backend, relevance
from sdovon_mj.semantics.judgements import backend_scores, load_judgements, score_method
from test_semantics_backends import _patch_500, cfg_for, protocol, serve  # noqa: F401 (fixtures)

VOTES = {"room_receptacles": ["kitchen|sink", "kitchen|shelf", "kitchen|counter", "bathroom|sink", "bathroom|shelf",
                              "bedroom|bed", "bedroom|shelf"],
         "objects": ["cup", "towel", "pillow"], "splits": {"train": ["cup"], "val": ["towel", "pillow"]},
         "votes": {"cup": {"correct": [8, 9, 6, 1, 0, 0, 1]}, "towel": {"correct": [0, 2, 1, 3, 9, 1, 4]},
                   "pillow": {"correct": [0, 0, 0, 0, 1, 10, 3]}},
         "annotators_per_pair": 10}


def test_eval_command_matches_the_backend(serve, protocol, tmp_path, capsys):  # noqa: F811
    fake = serve("good")
    data = tmp_path / "votes.json"
    data.write_text(json.dumps(VOTES))
    out = tmp_path / "figures.json"
    rc = main(["semantics", "eval", "--backend", protocol, "--data", str(data), "--set", f"semantics.url={fake.url}",
               "--set", "semantics.model=test-model", "--set", "semantics.cache=false", "--json", str(out)])
    assert rc == 0
    printed = capsys.readouterr().out
    res = json.loads(out.read_text())
    assert res["backend"] == protocol and res["fallbacks"] == 0 and res["objects"] == 2
    j = load_judgements(data)
    direct = score_method(j, j.split("val"), *backend_scores(get_backend(cfg_for(protocol, fake.url)), j, j.split("val")))
    assert res["orr_map"] == round(direct.orr_map, 4) and res["or_map"] == round(direct.or_map, 4)
    assert f"ORR mAP {direct.orr_map:.3f}" in printed and f"chance {direct.orr_chance:.3f}" in printed


def test_eval_command_offline_prints_train_figures(tmp_path, capsys):
    data = tmp_path / "votes.json"
    data.write_text(json.dumps(VOTES))
    assert main(["semantics-eval", "--data", str(data), "--split", "all"]) == 0
    text = capsys.readouterr().out
    assert "learned model on its training split" in text and "[all: 3 objects]" in text
    assert main(["semantics-eval", "--data", str(tmp_path / "missing.json")]) == 2


def test_failed_server_is_visible_in_relevance(serve, protocol):  # noqa: F811
    fake = serve("good")
    _patch_500(fake)
    b = get_backend(cfg_for(protocol, fake.url, retries=0))
    rel = relevance(["towel", "cup"], ["kitchen"], ["sink", "shelf"], b)
    assert rel.backend == "offline" and rel.sources == ["fallback:offline", "fallback:offline"]
    assert len(rel.fallbacks) >= 2
    off = relevance(["towel", "cup"], ["kitchen"], ["sink", "shelf"], get_backend())
    assert np.array_equal(rel.p_pair, off.p_pair)  # the fallback's own pair model answered


def test_eval_default_split_of_a_held_out_file(tmp_path, capsys):
    """A file of held-out objects with one split (Housekeep's test objects as ``test``) is scored without --split;
    a file with several splits and no ``val`` asks for one, naming the file and its splits."""
    test_only = dict(VOTES, splits={"test": ["towel", "pillow"]})
    data = tmp_path / "test_votes.json"
    data.write_text(json.dumps(test_only))
    assert main(["semantics-eval", "--data", str(data)]) == 0
    assert "[test: 2 objects]" in capsys.readouterr().out
    no_splits = {k: v for k, v in VOTES.items() if k != "splits"}
    data.write_text(json.dumps(no_splits))
    assert main(["semantics-eval", "--data", str(data)]) == 0
    assert "[all: 3 objects]" in capsys.readouterr().out
    data.write_text(json.dumps(dict(VOTES, splits={"train": ["cup"], "test": ["towel"]})))
    assert main(["semantics-eval", "--data", str(data)]) == 1  # an input error (exit code 1), named
    err = capsys.readouterr().err
    assert str(data) in err and "test, train" in err and "--split" in err
