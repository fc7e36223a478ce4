"""Observation shards: compressed npz files of N frames each (records.save_npz), written in order."""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Iterable, Iterator

from ..errors import InputError
from ..records import Observation, RecordError, load_npz, save_npz


def shard_name(index: int) -> str:
    """Return the file name of shard `index`."""
    return f"obs_{index:05d}.npz"


def save_shards(observations: Iterable[Observation], out_dir: str | Path, frames_per_shard: int = 24) -> list[Path]:
    """Write observations as numbered compressed shards (compressing while the next frames render)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    n = max(1, int(frames_per_shard))
    paths: list[Path] = []
    pending: list[Future] = []
    batch: list[Observation] = []
    # zlib releases the GIL: one writer thread overlaps compression with rendering
    with ThreadPoolExecutor(max_workers=1) as pool:
        for obs in observations:
            batch.append(obs)
            if len(batch) == n:
                p = out / shard_name(len(paths))
                pending.append(pool.submit(save_npz, batch, p))
                paths.append(p)
                batch = []
                if len(pending) > 2:  # bound memory: at most ~3 shards in flight
                    pending.pop(0).result()
        if batch:
            p = out / shard_name(len(paths))
            pending.append(pool.submit(save_npz, batch, p))
            paths.append(p)
        for f in pending:
            f.result()
    return paths


def load_shards(paths: Iterable[str | Path]) -> Iterator[Observation]:
    """Yield the observations of shards in order (InputError naming a bad shard)."""
    for p in paths:
        try:
            recs = load_npz(p)
        except FileNotFoundError:
            raise InputError(p, "observation shard not found") from None
        except RecordError as e:
            raise InputError(p, f"not an observation shard ({e})") from None
        for r in recs:
            if not isinstance(r, Observation):
                raise InputError(p, f"shard holds a {type(r).__name__}, not Observation records")
            yield r
