"""The learned offline semantics against independent human judgements (Housekeep), and its measure.

Not circular: the model is trained on Housekeep's train split only (tools/train_semantics.py) and
judged on its val split, whose objects it never saw; the measure is checked against brute force.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest

from sdovon_mj.config import SemanticsConfig
from sdovon_mj.errors import InputError
from sdovon_mj.records import Relevance
from sdovon_mj.semantics import get_backend, relevance
from sdovon_mj.semantics.judgements import (average_precision, backend_scores, chance_average_precision,
                                            load_judgements, score_method)
from sdovon_mj.semantics.learned import default_model

DATA = Path(__file__).resolve().parents[2] / "shared" / "semantics" / "housekeep" / "housekeep_train_val.json"
needs_data = pytest.mark.skipif(not DATA.is_file(), reason=f"human-judgement file not here: {DATA}")


def test_average_precision_by_hand_and_ties():
    assert average_precision(np.array([3.0, 2.0, 1.0]), np.array([0, 1, 0])) == pytest.approx(0.5)
    assert average_precision(np.array([3.0, 2.0, 1.0]), np.array([1, 0, 1])) == pytest.approx((1 + 2 / 3) / 2)
    # a constant scorer gets the positive rate, never a lucky order
    assert average_precision(np.zeros(5), np.array([0, 0, 1, 0, 1])) == pytest.approx(2 / 5)
    with pytest.raises(ValueError):
        average_precision(np.zeros(3), np.zeros(3))


@pytest.mark.parametrize("n,r", [(1, 1), (4, 1), (5, 2), (6, 3), (7, 7)])
def test_chance_is_the_mean_over_every_order(n, r):
    pos = np.array([1] * r + [0] * (n - r))
    aps = [average_precision(-np.arange(n, dtype=float), pos[list(p)]) for p in itertools.permutations(range(n))]
    assert chance_average_precision(n, r) == pytest.approx(float(np.mean(aps)))


def _write(tmp_path, data) -> Path:
    p = tmp_path / "votes.json"
    p.write_text(json.dumps(data))
    return p


def test_bad_judgement_files_name_the_file_and_cause(tmp_path):
    good = {"room_receptacles": ["kitchen|sink", "bathroom|sink"], "objects": ["cup"], "splits": {"val": ["cup"]},
            "votes": {"cup": {"correct": [7, 1]}}, "annotators_per_pair": 10}
    j = load_judgements(_write(tmp_path, good))
    assert j.rooms == ["bathroom", "kitchen"] and j.split("val") == ["cup"]
    cases = [({**good, "votes": {"cup": {"correct": [7]}}}, "has 1 counts, expected 2"),
             ({**good, "room_receptacles": ["kitchen sink", "bathroom|sink"]}, "is not 'room|receptacle'"),
             ({**good, "votes": {"cup": {"correct": [11, 0]}}}, "outside 0..10"),
             ({k: v for k, v in good.items() if k != "votes"}, "missing key 'votes'"),
             ({**good, "splits": {"val": ["plate"]}}, "without votes: plate")]
    for data, cause in cases:
        with pytest.raises(InputError, match=cause) as e:
            load_judgements(_write(tmp_path, data))
        assert str(tmp_path / "votes.json") in str(e.value)
    with pytest.raises(InputError, match="no split 'test'"):
        j.split("test")
    (tmp_path / "votes.json").write_text("{not json")
    with pytest.raises(InputError, match="not JSON"):
        load_judgements(tmp_path / "votes.json")


@needs_data
def test_shipped_model_was_trained_on_train_only():
    j = load_judgements(DATA)
    info = default_model().info
    assert sorted(info["train_objects"]) == sorted(j.split("train"))
    assert not set(info["train_objects"]) & set(j.split("val"))


@needs_data
def test_offline_backend_ranks_like_people_on_unseen_val_objects():
    """The issue's bar: ORR mAP >= 0.80 and OR mAP >= 0.70 on objects the model never saw; above chance."""
    j = load_judgements(DATA)
    objs = j.split("val")
    s = score_method(j, objs, *backend_scores(get_backend(), j, objs))
    assert s.orr_map >= 0.80 and s.or_map >= 0.70
    assert s.orr_map > s.orr_chance and s.or_map > s.or_chance
    table = get_backend(SemanticsConfig(offline_model="table"))
    old = score_method(j, objs, *backend_scores(table, j, objs))
    assert s.orr_map > old.orr_map and s.or_map > old.or_map  # the curated table it replaces, as an ordering


def test_rooms_outside_every_table_get_plausible_calibrated_scores():
    """Rooms like 'nursery', 'laundry room', 'garage' with objects whose room is unambiguous: in the top 3 of 8."""
    rooms = ["garage", "kitchen", "bathroom", "bedroom", "nursery", "home office", "laundry room", "dining room"]
    expect = {"wrench": "garage", "screwdriver": "garage", "laptop": "home office", "teddy bear": "nursery",
              "towel": "bathroom", "shampoo bottle": "bathroom", "milk": "kitchen", "frozen pizza": "kitchen",
              "dirty plate": "kitchen"}
    m = default_model()
    for obj, room in expect.items():
        p = m.score_rooms(obj, rooms)
        assert ((p >= 0) & (p <= 1)).all()  # calibrated: a fraction of people, no per-object max rescaling
        top3 = [rooms[i] for i in np.argsort(-p, kind="stable")[:3]]
        assert room in top3, (obj, top3)


def test_relevance_records_both_directions_and_sources(tmp_path):
    objs, regs, recs = ["towel", "frying pan", "book"], ["kitchen", "bathroom"], ["shelf", "sink", "counter"]
    rel = relevance(objs, regs, recs, get_backend())
    assert rel.backend == "offline" and rel.model.startswith("learned-v") and rel.sources == ["learned"] * 3
    assert rel.p_pair is not None and rel.p_pair.shape == (3, 2, 3)
    assert ((rel.p_pair > 0) & (rel.p_pair <= 1)).all()
    j = rel.joint("bathroom", "sink")  # placement direction: a distribution over objects (Bayes over all 6 pairs)
    p_q_o = rel.p_pair[:, 1, 1] / rel.p_pair.sum(axis=(1, 2))
    assert j.sum() == pytest.approx(1.0) and j[0] == pytest.approx(p_q_o[0] / p_q_o.sum())
    scene = [("bathroom", "sink"), ("kitchen", "counter")]  # the pairs a scene offers: P(pair | obj) over them only
    p_q_o = rel.p_pair[:, 1, 1] / (rel.p_pair[:, 1, 1] + rel.p_pair[:, 0, 2])
    assert rel.joint("bathroom", "sink", scene) == pytest.approx(p_q_o / p_q_o.sum())
    ranked = rel.search("towel")  # search direction: every pair of one object, best first
    assert len(ranked) == 6 and [s for *_x, s in ranked] == sorted([s for *_x, s in ranked], reverse=True)
    assert ranked[0][2] == pytest.approx(float(rel.p_pair[0].max()))
    back = Relevance.from_json(rel.to_json())
    assert back.sources == rel.sources and np.array_equal(back.p_pair, rel.p_pair)
    assert relevance(objs, regs, recs, get_backend()).to_json() == rel.to_json()  # same input, same bytes


# Hand-picked before looking at the model's output: for each receptacle outside the vote file, three
# objects that belong there and nowhere else on the list (the other fifteen belong elsewhere).
UNSEEN_RECEPTACLES = {"wardrobe": {"shirt", "sweater", "coat"}, "bookshelf": {"book", "novel", "magazine"},
                      "shoe rack": {"shoe", "sneaker", "boot"}, "dish rack": {"plate", "bowl", "mug"},
                      "tool box": {"hammer", "screwdriver", "wrench"}, "toy box": {"toy car", "teddy bear", "doll"}}


def test_unseen_receptacles_rank_their_objects_first():
    """Placement direction on receptacles outside the training data: each one's expected objects rank top-3 of 18.

    Scores are calibrated fractions in [0, 1] (no per-object max rescaling). The bar: at least two of the
    three expected objects in the top 3 for every receptacle; a scorer blind to the receptacle (popularity)
    gives every receptacle the same top 3, so it can meet this for at most one of the six disjoint sets.
    """
    m = default_model()
    objs = sorted(set().union(*UNSEEN_RECEPTACLES.values()))
    recs = list(UNSEEN_RECEPTACLES)
    s = np.stack([m.score_receptacles(o, recs) for o in objs])
    assert ((s >= 0) & (s <= 1)).all()
    bad = {}
    for k, rec in enumerate(recs):
        top3 = {objs[i] for i in np.argsort(-s[:, k], kind="stable")[:3]}
        if len(top3 & UNSEEN_RECEPTACLES[rec]) < 2:
            bad[rec] = sorted(top3)
    assert not bad, bad
