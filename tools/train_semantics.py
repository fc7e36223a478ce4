"""Train the offline backend's learned semantics model on human votes (run from the repo root).

    python tools/train_semantics.py [--data ../shared/semantics/housekeep/housekeep_train_val.json]
                                    [--out sdovon_mj/data/semantics/learned.json] [--check]

Fits every head (`sdovon_mj.semantics.learned`) on the **train** split for each (lambda,
column-kernel temperature, zero-shot scale) of a small fixed grid and keeps the one with the best
**val** figure. The zero-shot weight beta is the least-squares slope on train (`zero_shot_weight`)
times a scale of ``BETA_SCALES``: the cosine of two MiniLM embeddings is a noisy proxy of where
people put things, and the least-squares slope on a noisy regressor is attenuated towards 0; columns
outside the vote file rest on this term alone, so its scale is chosen where that is measured (val,
with columns held out). The figure: a quarter the val figure with the training
columns, a quarter the val figure with each column group refitted out and scored as unseen (a
receptacle type for the pair and receptacle heads, a room for the room head) -- ORR mAP for the pair
and receptacle heads, OR mAP for the room head -- and half the placement direction, the val objects
ranked for each column (`placement_measure`), seen and unseen. Nothing else is looked
at. Deterministic: closed-form ridge, fixed grids, ties to the first grid entry, grid-rounded
embeddings; the same data give the same bytes. ``--check`` compares with the shipped file instead of
writing it (exit 1 when they differ). Prints train and val figures with chance beside.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

from sdovon_mj.embeddings import embed_labels
from sdovon_mj.semantics.judgements import Judgements, average_precision, load_judgements, score_method
from sdovon_mj.semantics.learned import HEADS, Head, LearnedModel, fit_head, head_targets, object_vectors

LAMBDAS = (0.3, 1.0, 3.0)
TEMPERATURES = (0.05, 0.1, 0.2, 0.3)
BETA_SCALES = (1.0, 2.0, 4.0)  # zero-shot weight = scale * least-squares slope on train (geometric grid)
VERSION = "4"  # 4: fitted on the float64, 2**-20-grid embeddings (issue 35)
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


def placement_measure(j: Judgements, objects: list[str], head: str, pred: np.ndarray) -> float:
    """Return the placement-direction figure: mean over columns of the AP of objects ranked by score.

    A column's positives are the objects at least 6 of 10 annotators put there (room and receptacle
    heads: anywhere in that room / on that receptacle); columns without a positive are skipped.
    """
    _cols, y = head_targets(j, objects, head)
    pos = y >= 0.6 - 1e-9
    aps = [average_precision(pred[:, k], pos[:, k].astype(int)) for k in range(y.shape[1]) if pos[:, k].any()]
    return float(np.mean(aps)) if aps else 0.0


def zero_shot_weight(zs: np.ndarray, col_vecs: np.ndarray, targets: np.ndarray) -> float:
    """Return beta fitted on the training votes: the least-squares slope of the targets on the zero-shot
    similarity, both centred per column (how much better than the average object an object fits a
    column, explained by meaning; not the column's popularity). `train` multiplies it by a scale of
    ``BETA_SCALES`` chosen on val (the slope of a noisy regressor is attenuated towards 0).

    Parameters
    ----------
    zs : ndarray, shape (N, 384)
        Zero-shot vectors of the training objects.
    col_vecs : ndarray, shape (K, 384)
        Column embeddings.
    targets : ndarray, shape (N, K)
        Training targets (fractions).
    """
    c = zs @ col_vecs.T
    c = c - c.mean(axis=0)
    y = targets - targets.mean(axis=0)
    return round(float(max(0.0, (c * y).sum() / max((c * c).sum(), 1e-12))), 4)


def column_groups(j: Judgements, head: str) -> list[list[int]]:
    """Return the column groups held out together when judging unseen columns.

    Receptacle and pair heads: every column of one receptacle type (a pair head never sees the
    receptacle in any room); room head: each room.
    """
    if head == "room":
        return [[k] for k in range(len(j.rooms))]
    if head == "receptacle":
        return [[k] for k in range(len(j.receptacles))]
    return [[k for k, (_r, c) in enumerate(j.pairs) if c == rec] for rec in j.receptacles]


def unseen_predict(j: Judgements, head: str, f_tr: np.ndarray, z_tr: np.ndarray, y_tr: np.ndarray, cols: list[str],
                   cv: np.ndarray, f_va: np.ndarray, z_va: np.ndarray, lam: float, beta: float,
                   temperature: float) -> np.ndarray:
    """Return val predictions with each column group refitted out of training and scored as unseen.

    Parameters
    ----------
    j : Judgements
        The vote file (column groups).
    head : str
        Head name (`HEADS`).
    f_tr, z_tr : ndarray, shape (N, 384)
        Training objects' ridge features and zero-shot vectors.
    y_tr : ndarray, shape (N, K)
        Training targets.
    cols : list of str
        Column phrases (K); ``cv`` (K, 384) their embeddings.
    cv : ndarray, shape (K, 384)
        Embeddings of `cols`.
    f_va, z_va : ndarray, shape (M, 384)
        Validation objects' ridge features and zero-shot vectors.
    lam, beta, temperature : float
        Hyper-parameters (`fit_head`).
    """
    out = np.zeros((len(f_va), len(cols)))
    for g in column_groups(j, head):
        keep = [k for k in range(len(cols)) if k not in set(g)]
        h = fit_head(f_tr, z_tr, [cols[k] for k in keep], y_tr[:, keep], lam, beta, temperature, cv[keep])
        h._col_vecs = cv[keep]
        out[:, g] = h.predict(f_va, z_va, [cols[k] for k in g])
    return out


def train(j: Judgements, log=print) -> LearnedModel:
    """Fit the heads on train, choose on val; return the model with its figures in `info`."""
    train_objs, val_objs = j.split("train"), j.split("val")
    f_tr, z_tr = object_vectors(train_objs)
    f_va, z_va = object_vectors(val_objs)
    heads: dict[str, Head] = {}
    chosen: dict[str, dict[str, float]] = {}
    for head in HEADS:
        cols, y_tr = head_targets(j, train_objs, head)
        cv = embed_labels(cols)
        beta_ls = zero_shot_weight(z_tr, cv, y_tr)
        best: tuple[float, float, float, Head, float] | None = None
        for lam, t, scale in itertools.product(LAMBDAS, TEMPERATURES, BETA_SCALES):
            beta = round(beta_ls * scale, 4)
            h = fit_head(f_tr, z_tr, cols, y_tr, lam, beta, t, cv)
            p_seen = h.predict(f_va, z_va, cols)
            p_unseen = unseen_predict(j, head, f_tr, z_tr, y_tr, cols, cv, f_va, z_va, lam, beta, t)
            seen, unseen = head_measure(j, val_objs, head, p_seen), head_measure(j, val_objs, head, p_unseen)
            place = (placement_measure(j, val_objs, head, p_seen)
                     + placement_measure(j, val_objs, head, p_unseen)) / 2.0
            m = (seen + unseen) / 4.0 + place / 2.0
            if best is None or m > best[2] + 1e-12:
                best = (seen, unseen, m, h, place)
        assert best is not None
        h = best[3]
        heads[head] = h
        chosen[head] = {"lambda": h.lam, "beta": h.beta, "beta_least_squares": beta_ls, "temperature": h.temperature,
                        "val": round(best[0], 4), "val_unseen_columns": round(best[1], 4),
                        "val_placement": round(best[4], 4),
                        "train": round(head_measure(j, train_objs, head, h.predict(f_tr, z_tr, cols)), 4)}
        log(f"{head:>10}: lambda {h.lam:g} beta {h.beta:g} T {h.temperature:g}  train {chosen[head]['train']:.3f}  "
            f"val {best[0]:.3f}  val with each column group unseen {best[1]:.3f}  val placement AP {best[4]:.3f}")
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
