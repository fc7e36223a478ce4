"""Relevance out of the box: the offline backend against a hand-labelled table; normalisation; joint."""

from __future__ import annotations

import numpy as np
import pytest

from sdovon_mj.config import ReceptacleConfig, SemanticsConfig
from sdovon_mj.records import Relevance, records_equal
from sdovon_mj.semantics import get_backend, identify_receptacles, relevance
from sdovon_mj.semantics.relevance import normalise_columns, rank_pairs

# Hand-labelled by us (where would you look first?): object -> (region, receptacle). Written
# independently of the priors table, over the default region vocabulary and receptacle labels.
HAND = {
    "pillow": ("bedroom", "bed"),
    "toothbrush": ("bathroom", "counter"),
    "mug": ("kitchen", "counter"),
    "book": ("office", "bookshelf"),
    "laptop": ("office", "desk"),
    "remote control": ("living room", "coffee table"),
    "towel": ("bathroom", "shelf"),
    "plate": ("dining room", "table"),
    "wine glass": ("dining room", "table"),
    "fork": ("dining room", "table"),
    "frying pan": ("kitchen", "counter"),
    "cereal box": ("kitchen", "cabinet"),
    "alarm clock": ("bedroom", "nightstand"),
    "teddy bear": ("bedroom", "bed"),
    "keyboard": ("office", "desk"),
    "soap dispenser": ("bathroom", "counter"),
    "vase": ("living room", "table"),
    "potted plant": ("living room", "shelf"),
    "candle": ("living room", "coffee table"),
    "banana": ("kitchen", "counter"),
    "apple": ("kitchen", "table"),
    "stapler": ("office", "desk"),
    "cushion": ("living room", "sofa"),
    "magazine": ("living room", "coffee table"),
    "watch": ("bedroom", "nightstand"),
    "shampoo": ("bathroom", "shelf"),
    "teapot": ("kitchen", "counter"),
    "hair dryer": ("bathroom", "counter"),
    "spoon": ("kitchen", "counter"),
    "headphones": ("office", "desk"),
}

REGIONS = list(SemanticsConfig().region_labels)
RECEPTACLES = list(ReceptacleConfig().labels)


@pytest.fixture(scope="module")
def rel() -> Relevance:
    return relevance(sorted(HAND), REGIONS, RECEPTACLES, get_backend(SemanticsConfig()))


TABLE = SemanticsConfig(offline_model="table")  # the curated table (the learned default: test_semantics_learned.py)


def _top2_raw(obj: str, kind: str, want: str) -> bool:
    """Whether `want` is among the object's two best candidates by the table backend's 0-10 scores."""
    b = get_backend(TABLE)
    s = b.score_regions(obj, REGIONS) if kind == "regions" else b.score_receptacles(obj, RECEPTACLES)
    order = sorted(s, key=lambda k: (-s[k], k))
    return want in order[:2]


def test_top2_agreement_with_hand_table():
    """Table mode: an object's top-2 regions and receptacles hold the hand-labelled answer for >= 85 % of objects."""
    miss_r = [o for o, (r, _c) in HAND.items() if not _top2_raw(o, "regions", r)]
    miss_c = [o for o, (_r, c) in HAND.items() if not _top2_raw(o, "receptacles", c)]
    n = len(HAND)
    assert (n - len(miss_r)) / n >= 0.85, miss_r
    assert (n - len(miss_c)) / n >= 0.85, miss_c


def test_normalised_and_floored(rel):
    assert np.allclose(rel.p_obj_region.sum(axis=0), 1.0)
    assert np.allclose(rel.p_obj_receptacle.sum(axis=0), 1.0)
    assert (rel.p_obj_region > 0).all() and (rel.p_obj_receptacle > 0).all()  # floor: nothing is impossible
    assert rel.backend == "offline" and rel.fallbacks == []


def test_joint_is_product_and_ranks_pairs():
    """Table mode (no pair model of its own): both directions use P(obj|rgn) * P(obj|rec)."""
    rel = relevance(sorted(HAND), REGIONS, RECEPTACLES, get_backend(TABLE))
    i = rel.objects.index("pillow")
    j = rel.joint("bedroom", "bed")
    r, c = rel.regions.index("bedroom"), rel.receptacles.index("bed")
    prod = rel.p_obj_region[:, r] * rel.p_obj_receptacle[:, c]
    assert j[i] == pytest.approx(prod[i] / prod.sum())  # the placement direction: a distribution over objects
    assert rank_pairs(rel, "pillow")[0][:2] == ("bedroom", "bed")
    assert rank_pairs(rel, "toothbrush")[0][0] == "bathroom"


def test_normalise_columns_zero_column_uniform():
    s = np.array([[0.0, 2.0], [0.0, 6.0]])
    p = normalise_columns(s)
    assert np.allclose(p[:, 0], 0.5) and np.allclose(p[:, 1], [0.25, 0.75])


def test_same_inputs_same_record(rel):
    again = relevance(sorted(HAND), REGIONS, RECEPTACLES, get_backend(SemanticsConfig()))
    assert records_equal(rel, again)
    assert Relevance.from_json(rel.to_json()).objects == rel.objects


def test_offline_receptacles_paper_example():
    labels = ["curtain", "bed", "stool", "pillow", "desk", "shelf", "book shelf", "dresser", "chair", "pen",
              "laptop", "lamp"]
    got = identify_receptacles(labels, get_backend(SemanticsConfig()))
    assert {"bed", "desk", "shelf", "book shelf", "dresser", "chair"} <= set(got)
    assert not {"curtain", "pillow", "pen", "laptop", "lamp"} & set(got)


def test_offline_region_proposals_from_furniture():
    b = get_backend(SemanticsConfig())
    cases = {
        ("bed", "nightstand", "dresser", "wardrobe"): "bedroom",
        ("toilet", "bathtub", "sink"): "bathroom",
        ("fridge", "counter", "stove"): "kitchen",
        ("desk", "office chair", "bookshelf"): "office",
        ("dining table", "chair"): "dining room",
        ("sofa", "coffee table", "tv"): "living room",
        ("headboard", "bed", "stool", "carpet", "pillow", "curtain"): "bedroom",  # the paper's C.2 example
    }
    for labels, want in cases.items():
        props = b.propose_regions(list(labels), REGIONS)
        assert props[0] == want, (labels, props)
        assert len(props) >= 5
    # a lone table is ambiguous: dining room, kitchen and living room all rank high
    assert set(b.propose_regions(["table"], REGIONS)[:3]) == {"dining room", "kitchen", "living room"}
    assert b.propose_regions(["wall", "door"], REGIONS) == []  # nothing informative: no proposal
