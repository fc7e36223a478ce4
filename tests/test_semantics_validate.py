"""Reply validation, prompts, priors table, embedding fallback, cache, CLI."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from sdovon_mj.config import SemanticsConfig
from sdovon_mj.semantics import get_backend
from sdovon_mj.semantics import prompts as P
from sdovon_mj.semantics.cache import DiskCache, cache_key
from sdovon_mj.semantics.priors import FLOOR, default_priors, load_table
from sdovon_mj.semantics.validate import (ReplyError, match_name, normalise, parse_reply, validate_names,
                                          validate_scores)

REPO = Path(__file__).resolve().parents[1]


def test_parse_reply_forms():
    assert parse_reply('{"regions": ["Kitchen"]}', "regions") == (["Kitchen"], False)
    assert parse_reply('```json\n{"regions": ["a"]}\n```', "regions") == (["a"], False)
    assert parse_reply('Sure: {"Regions": ["a"]} bye', "regions") == (["a"], False)
    assert parse_reply(P.PAPER_EXAMPLE_REPLY, "relevances")[1] is True
    assert parse_reply('{"reason": "a {brace} in a string", "relevances": {"x": 1}}', "relevances") == ({"x": 1}, False)
    for bad, why in [("", "empty"), ("   ", "empty"), ("no json here", "no JSON"), ('{"regions": [1, 2}', "not valid"),
                     ('{"other": 1}', 'no "regions"')]:
        with pytest.raises(ReplyError, match=why):
            parse_reply(bad, "regions")


def test_validate_scores():
    cands = ["living room", "book shelf", "tables"]
    got, notes = validate_scores({"Living_Room": 7, "bookshelf": "8/10", "table": 12.5, "garage": 3}, cands)
    assert got == {"living room": 7.0, "book shelf": 8.0, "tables": 10.0}
    assert any("garage" in n for n in notes) and any("clipped" in n for n in notes)
    got, notes = validate_scores({"living room": 3}, cands)
    assert got == {"living room": 3.0, "book shelf": 0.0, "tables": 0.0} and any("missing" in n for n in notes)
    assert validate_scores([{"name": "tables", "score": 4}], cands)[0]["tables"] == 4.0
    with pytest.raises(ReplyError, match="all scores"):
        validate_scores({"living room": 0, "tables": -3}, cands)
    with pytest.raises(ReplyError, match="none of the given names"):
        validate_scores({"garage": 5}, cands)
    with pytest.raises(ReplyError, match="must be an object"):
        validate_scores("8", cands)


def test_validate_names_and_matching():
    assert validate_names(["Bed", "bed", "sofa", "pen"], "receptacles", allowed=["bed", "sofa"])[0] == ["bed", "sofa"]
    assert validate_names("Bedroom, Living Room", "regions")[0] == ["bedroom", "living room"]
    with pytest.raises(ReplyError, match="at least 1"):
        validate_names([], "regions", min_items=1)
    assert match_name("Shelves", ["shelf"]) == "shelf" and match_name("boxes", ["box"]) == "box"
    assert match_name("garage", ["shelf"]) is None and normalise("  Living_Room ") == "living room"


def test_prompts_are_the_papers_and_versioned():
    tex = (REPO.parent / "shared" / "paper" / "sd-ovon.tex")
    assert set(P.PROMPTS) == {P.RECEPTACLES, P.REGION_PROPOSALS, P.RECEPTACLE_RELEVANCE, P.REGION_RELEVANCE}
    for p in P.PROMPTS.values():
        assert p.version and p.tag.startswith(p.id + "@")
        msgs = p.messages({"objects": ["bed"], "furniture": ["bed"], "regions": ["bedroom"], "object": "pillow"})
        assert [m["role"] for m in msgs] == ["system", "user", "assistant", "user"]
        json.loads(msgs[2]["content"])  # the few-shot example reply is valid JSON (the paper's is not)
        if tex.exists():
            text = tex.read_text().replace("\\_", "_").replace("\\{", "{").replace("\\}", "}")
            assert p.system[:120] in " ".join(text.split()), p.id


def test_priors_table_complete_and_regenerable(tmp_path):
    t = load_table()
    assert "curated" in t["source"].lower()
    for k, v in t["labels"].items():
        for r, s in v.get("regions", {}).items():
            assert r in t["regions"] and 0 <= s <= 10, (k, r)
        for c, s in v.get("receptacles", {}).items():
            assert c in t["receptacles"] and 0 <= s <= 10, (k, c)
    objs = [k for k, v in t["labels"].items() if v["kind"] == "object"]
    assert len(objs) >= 100 and all(t["labels"][o]["receptacles"] for o in objs)
    for must in ("mug", "cup", "bowl", "plate", "book", "bottle", "can", "cereal box", "laptop", "remote", "pillow",
                 "stuffed toy", "vase", "potted plant", "lamp", "shoe", "toothbrush", "soap dispenser", "towel",
                 "spoon", "knife", "apple", "banana", "keyboard", "phone", "alarm clock", "candle", "wine glass",
                 "teapot", "bed", "toilet", "fridge", "sofa", "desk", "counter", "nightstand", "wardrobe"):
        assert default_priors().resolve(must, embed=False) is not None, must
    out = tmp_path / "priors.json"
    subprocess.run([sys.executable, str(REPO / "tools/make_priors.py"), str(out)], check=True,
                   capture_output=True)
    assert out.read_bytes() == (REPO / "sdovon_mj/data/semantics/priors.json").read_bytes()


def test_resolution_without_embeddings():
    pri = default_priors()
    assert pri.resolve("Refrigerator", embed=False) == "fridge"
    assert pri.resolve("small wooden tables", embed=False) == "table"
    assert pri.resolve("bedside table", embed=False) == "nightstand"
    assert pri.resolve_region("Guest Bedroom") == "bedroom" and pri.resolve_region("Home Office") == "office"
    assert pri.resolve_region("restroom") == "bathroom" and pri.resolve_region("spaceship") is None
    assert pri.resolve_receptacle("kitchen counter") == "counter" and pri.resolve_receptacle("book case") == "bookshelf"


def test_unknown_labels_use_embeddings_with_floor():
    """The default offline model on labels outside every table: plausible best candidate, none below the floor."""
    b = get_backend(SemanticsConfig())
    s = b.score_regions("shower gel", ["kitchen", "bathroom", "bedroom", "office"])
    assert max(s, key=s.get) == "bathroom" and min(s.values()) >= FLOOR
    s = b.score_receptacles("espresso cup", ["bed", "counter", "sofa", "bookshelf"])
    assert max(s, key=s.get) == "counter" and min(s.values()) >= FLOOR
    s = b.score_regions("toothbrush", ["bathroom", "garage", "kitchen"])
    assert max(s, key=s.get) == "bathroom" and min(s.values()) >= FLOOR


def test_table_embedding_temperatures_calibrated():
    """The table backend's embedding fallback: calibrated temperatures in (0, 1)."""
    get_backend(SemanticsConfig(offline_model="table")).score_regions("toothbrush", ["bathroom", "garage", "kitchen"])
    t = default_priors()._temps
    assert set(t) >= {"regions"} and all(0 < v < 1 for v in t.values())


def test_disk_cache_roundtrip(tmp_path):
    c = DiskCache(tmp_path)
    k1 = cache_key("ollama", "m", "p@1", {"a": [1, 2]})
    assert k1 == cache_key("ollama", "m", "p@1", {"a": [1, 2]})
    assert k1 != cache_key("ollama", "m", "p@2", {"a": [1, 2]}) != cache_key("openai", "m", "p@1", {"a": [1, 2]})
    assert c.get(k1) is None
    c.put(k1, {"result": {"x": 1.0}, "raw": ["{}"]})
    assert c.get(k1)["result"] == {"x": 1.0} and len(c) == 1
    p = next(tmp_path.rglob("*.json"))
    p.write_text("{broken")
    assert c.get(k1) is None  # a corrupt entry is a miss, never a crash


def test_unknown_backend_is_a_clear_error():
    from sdovon_mj.plugins import PluginError

    with pytest.raises(PluginError, match="no llm_backend plugin named 'nope'"):
        get_backend(SemanticsConfig(backend="nope"))


def test_default_world_labels_are_all_in_the_table():
    """Every default-world object category and furniture label has table rows (no embedding fallback needed)."""
    world = pytest.importorskip("sdovon_mj.world")
    pri = default_priors()
    for cat in world.OBJECT_CATEGORIES:
        key = pri.resolve(cat, embed=False)
        assert key is not None and pri.labels[key]["regions"] and pri.labels[key]["receptacles"], cat
    labels = {i.label for s in range(3) for i in world.generate_apartment(s).instances if i.kind != "structure"}
    for lab in sorted(labels):
        key = pri.resolve(lab, embed=False)
        assert key is not None and pri.labels[key]["regions"], lab
    # structure labels resolve too (region maps and agents look every detected label up; no embedding needed)
    from sdovon_mj.world import STRUCTURE_LABELS

    for lab in STRUCTURE_LABELS:
        assert pri.resolve(lab, embed=False) is not None, lab
