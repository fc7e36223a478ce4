"""Train the offline backend's learned semantics model on human votes (run from the repo root).

    python tools/train_semantics.py [--data ../shared/semantics/housekeep/housekeep_train_val.json]
                                    [--out sdovon_mj/data/semantics/learned.json] [--check]

Fits every head (`sdovon_mj.semantics.learned`) on the **train** split for each (lambda, beta) of a
small grid and keeps the one with the best **val** figure (pair and receptacle heads: ORR mAP; room
head: OR mAP); the unseen-column temperature is chosen by leave-one-column-out on val. Nothing else
is looked at. Deterministic: closed-form ridge, fixed grids, ties to the first grid entry, single-label
embeddings; the same data give the same bytes. ``--check`` compares with the shipped file instead of
writing it (exit 1 when they differ). Prints train and val figures with chance beside.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from sdovon_mj.embeddings import embed_labels
from sdovon_mj.semantics.judgements import Judgements, load_judgements, score_method
from sdovon_mj.semantics.learned import HEADS, Head, LearnedModel, fit_head, head_targets, object_vectors

LAMBDAS = (0.3, 1.0, 3.0, 10.0)
BETAS = (0.0, 0.2, 0.4, 0.8, 1.2, 1.6)
TEMPERATURES = (0.02, 0.05, 0.1, 0.2)
VERSION = "1"
DEFAULT_DATA = "../shared/semantics/housekeep/housekeep_train_val.json"
DEFAULT_OUT = "sdovon_mj/data/semantics/learned.json"


def head_measure(j: Judgements, objects: list[str], head: str, pred: np.ndarray) -> float:
    """Return the figure a head is chosen by: ORR mAP (pair, receptacle heads) or OR mAP (room head)."""
    if head == "room":
        return score_method(j, objects, np.zeros((len(objects), len(j.pairs))), pred).or_map
    if head == "receptacle":
        ci = {c: i for i, c in enumerate(j.receptacles)}
        pred = pred[:, [ci[c] for _r, c in j.pairs]]
    return score_method(j, objects, pred, np.zeros((len(objects), len(j.rooms)))).orr_map


def loco_predict(h: Head, feats: np.ndarray, zs: np.ndarray, temperature: float) -> np.ndarray:
    """Return predictions with each training column treated as unseen (scored from the others)."""
    base = h.mean[None, :] + feats @ h.weights
    cv = h.column_vectors()
    sims = cv @ cv.T
    np.fill_diagonal(sims, -np.inf)
    z = (sims - sims.max(axis=1, keepdims=True)) / temperature
    w = np.exp(z)
    w /= w.sum(axis=1, keepdims=True)
    return np.clip(base @ w.T + h.beta * (zs @ cv.T), 0.0, 1.0)


def train(j: Judgements, log=print) -> LearnedModel:
    """Fit the heads on train, choose on val; return the model with its figures in `info`."""
    train_objs, val_objs = j.split("train"), j.split("val")
    f_tr, z_tr = object_vectors(train_objs)
    f_va, z_va = object_vectors(val_objs)
    heads: dict[str, Head] = {}
    chosen: dict[str, dict[str, float]] = {}
    for head in HEADS:
        cols, y_tr = head_targets(j, train_objs, head)
        embed_labels(cols)
        best: tuple[float, Head] | None = None
        for lam in LAMBDAS:
            for beta in BETAS:
                h = fit_head(f_tr, z_tr, cols, y_tr, lam, beta, TEMPERATURES[0])
                m = head_measure(j, val_objs, head, h.predict(f_va, z_va, cols))
                if best is None or m > best[0] + 1e-12:
                    best = (m, h)
        assert best is not None
        h = best[1]
        best_t: tuple[float, float] | None = None
        for t in TEMPERATURES:
            m = head_measure(j, val_objs, head, loco_predict(h, f_va, z_va, t))
            if best_t is None or m > best_t[0] + 1e-12:
                best_t = (m, t)
        assert best_t is not None
        h.temperature = best_t[1]
        heads[head] = h
        chosen[head] = {"lambda": h.lam, "beta": h.beta, "temperature": h.temperature,
                        "val": round(best[0], 4), "val_unseen_columns": round(best_t[0], 4),
                        "train": round(head_measure(j, train_objs, head, h.predict(f_tr, z_tr, cols)), 4)}
        log(f"{head:>10}: lambda {h.lam:g} beta {h.beta:g} T {h.temperature:g}  train {chosen[head]['train']:.3f}  "
            f"val {best[0]:.3f}  val with each column unseen {best_t[0]:.3f}")
    model = LearnedModel(heads, {"version": VERSION, "source": "Housekeep train split (Kant et al., ECCV 2022, MIT)",
                                 "train_objects": list(train_objs), "chosen_on": "Housekeep val split",
                                 "heads": chosen})
    scores = {}
    for split, objs in (("train", train_objs), ("val", val_objs)):
        pair, room = evaluate_model(model, j, objs)
        s = score_method(j, objs, pair, room)
        scores[split] = s.as_dict()
        log(f"{split:>10}: ORR mAP {s.orr_map:.3f} (chance {s.orr_chance:.3f})  OR mAP {s.or_map:.3f} "
            f"(chance {s.or_chance:.3f})  [{len(objs)} objects]")
    model.info["scores"] = scores
    return model


def evaluate_model(model: LearnedModel, j: Judgements, objects: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Return the model's pair scores (O, P) and room scores (O, R) on the file's vocabulary."""
    pi = {p: k for k, p in enumerate(j.pairs)}
    pair = np.zeros((len(objects), len(j.pairs)))
    room = np.zeros((len(objects), len(j.rooms)))
    for i, o in enumerate(objects):
        t = model.score_pairs(o, j.rooms, j.receptacles)
        for a, r in enumerate(j.rooms):
            for b, c in enumerate(j.receptacles):
                if (r, c) in pi:
                    pair[i, pi[(r, c)]] = t[a, b]
        room[i] = model.score_rooms(o, j.rooms)
    return pair, room


def main(argv: list[str] | None = None) -> int:
    """Train, print the figures, write (or --check) the model file."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=DEFAULT_DATA, help="human-judgement file (Housekeep layout)")
    ap.add_argument("--out", default=DEFAULT_OUT, help="model file to write")
    ap.add_argument("--check", action="store_true", help="compare with --out instead of writing it")
    args = ap.parse_args(argv)
    model = train(load_judgements(args.data))
    text = model.to_json()
    out = Path(args.out)
    if args.check:
        same = out.is_file() and out.read_text(encoding="utf-8") == text
        print("model file is up to date" if same else f"{out} differs from a fresh training run")
        return 0 if same else 1
    out.write_text(text, encoding="utf-8")
    print(f"wrote {out} ({len(text)} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
