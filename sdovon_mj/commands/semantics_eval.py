"""`sdovon-mj semantics-eval` (also `sdovon-mj semantics eval`): a semantics backend against human judgements.

Prints ORR mAP (rank a room's receptacles for an object) and OR mAP (rank the rooms) on a file in
the layout of Housekeep's ``housekeep_train_val.json`` (val split by default, else the file's only split), chance beside and, for
the offline backend's learned model, its figures on the split it was trained on. The measure is
`semantics.judgements.score_method`; the scores are the backend's own answers
(`semantics.judgements.backend_scores`), so a server backend is asked exactly what the pipeline asks.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

DEFAULT_DATA_ENV = "SDOVON_JUDGEMENTS"  # where the human-judgement file is when --data is not given


def default_data() -> str:
    """Return the default judgement file: $SDOVON_JUDGEMENTS, else ../shared/semantics/housekeep/ from the cwd."""
    return os.environ.get(DEFAULT_DATA_ENV) or str(Path("..") / "shared" / "semantics" / "housekeep"
                                                   / "housekeep_train_val.json")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare semantics-eval's options."""
    p.add_argument("--backend", default=None, help="semantics backend plugin (offline, ollama, openai, ...); "
                                                   "default: the config's")
    p.add_argument("--data", default=None, help=f"human-judgement file (Housekeep layout; default ${DEFAULT_DATA_ENV} "
                                                "or ../shared/semantics/housekeep/housekeep_train_val.json)")
    p.add_argument("--split", default=None, help="split of the file to score (train, val, test, all); default: val, "
                                                 "or the file's only split")
    p.add_argument("--config", default=None, help="run config YAML (its semantics section is used)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="config override, e.g. semantics.model=llama3.1:8b")
    p.add_argument("--json", default=None, help="also write the figures to this JSON file")


def evaluate(backend, data: str | Path, split: str | None = None) -> dict:
    """Return the figures of one backend on one split of a judgement file (plus the learned model's train figures).

    ``split``: the split to score; None: `Judgements.default_split` (val, or the file's only split)."""
    from ..semantics.judgements import backend_scores, load_judgements, score_method

    j = load_judgements(data)
    split = j.default_split() if split is None else split
    objs = j.split(split)
    pair, room = backend_scores(backend, j, objs)
    s = score_method(j, objs, pair, room)
    out = {"backend": backend.name, "model": backend.model, "data": str(data), "split": split,
           "objects": len(objs), **s.as_dict(), "fallbacks": len(backend.fallbacks)}
    if getattr(backend, "mode", "") == "learned":
        from ..semantics.learned import default_model

        info = default_model().info
        out["trained_on"] = info.get("source", "")
        out["train_scores"] = (info.get("scores") or {}).get("train", {})
    return out


def run(args: argparse.Namespace) -> int:
    """Score the backend and print the figures."""
    import dataclasses

    from ..config import load_config
    from ..errors import UsageError
    from ..semantics import get_backend

    data = args.data or default_data()
    if not Path(data).is_file():
        raise UsageError(f"{data}: no such judgement file (give --data FILE or set ${DEFAULT_DATA_ENV})")
    cfg = load_config(args.config, args.overrides).semantics
    if args.backend:
        cfg = dataclasses.replace(cfg, backend=args.backend)
    backend = get_backend(cfg, None)
    res = evaluate(backend, data, args.split)
    print(f"backend {res['backend']} ({res['model'] or '-'}) on {res['data']} [{res['split']}: {res['objects']} objects]")
    print(f"  ORR mAP {res['orr_map']:.3f}  (chance {res['orr_chance']:.3f}; {res['n_orr']} object-room rankings)")
    print(f"  OR  mAP {res['or_map']:.3f}  (chance {res['or_chance']:.3f}; {res['n_or']} objects)")
    if res["fallbacks"]:
        print(f"  {res['fallbacks']} answers fell back to {cfg.fallback}: these figures are partly the fallback's")
    if res.get("train_scores"):
        t = res["train_scores"]
        print(f"  learned model on its training split: ORR mAP {t['orr_map']:.3f}  OR mAP {t['or_map']:.3f} "
              f"({res['trained_on']})")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return 0
