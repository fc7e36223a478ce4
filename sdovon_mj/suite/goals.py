"""Episodes with their goals written once (MJCF bundle v4): a goal table plus episodes that refer to it.

Like habitat-lab's ObjectNav ``goals_by_category``, every goal object of a bundle (its position, bounds and
view points) is stored once, in ``goals.npz``; ``episodes.json`` holds the episodes without their goals, each
with ``goal_refs`` (indices into the table) and the record tag ``EpisodeRef`` (so a reader that does not know
the layout fails loudly instead of reading episodes without goals).

``goals.npz`` (written with fixed zip timestamps: same goals, same bytes), arrays:

- ``__meta__``: uint8 JSON ``{"format": "sdovon-goals-1", "goals": [{"object_id", "category", "n_view_points",
  "bounds"}]}`` (``bounds``: whether the goal has bounds; ``history``, only on a day of a chain of days: the goal's
  `Goal.history`);
- ``position`` (G, 3) float64, ``bounds`` (G, 2, 3) float64 (zeros where a goal has none);
- ``vp_position`` (V, 3), ``vp_rotation`` (V, 4) wxyz, ``vp_visible_fraction`` (V,): every goal's view points
  in table order, float64.

`pack_episodes` checks that the table reads back to the very same records; goals that do not fit the array
encoding (another dtype or shape) are written as a JSON list of Goal records (``goals.json``) instead.
`unpack_episodes` returns Episode records equal (`records.records_equal`) to the ones exported.
"""

from __future__ import annotations

import copy
import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..records import TAG, Episode, Goal, RecordError, ViewPoint, _savez_deterministic, load_json
from ..store import dumps

GOALS_FORMAT = "sdovon-goals-1"
EPISODE_REF = "EpisodeRef"  # record tag of an episode whose goals live in the goal table


def goal_key(data: Any) -> str:
    """Return a goal's `to_dict` data as compact JSON text: equal texts exactly where `store.dumps` gives equal texts.

    Both write the same scalars the same way (``float.__repr__``, ``int.__repr__``, json's string escaper) in the
    same sorted structure; only the whitespace differs, so the keys compare like the files would, and json's C
    encoder writes them several times faster than the indented encoder. Never written to a file.
    """
    return json.dumps(data, sort_keys=True, ensure_ascii=False, allow_nan=False, separators=(",", ":"))


def goal_table(episodes: list[Episode], encoded: list[list[dict[str, Any]]] | None = None,
               ) -> tuple[list[Goal], list[list[int]], list[str]]:
    """Return the distinct goals of episodes (first-seen order, equal records once), each episode's indices and each
    table goal's key (`goal_key` of its `to_dict` data: equal keys, equal records).

    ``encoded``: each episode's goals as `to_dict` data (``Episode.to_dict()["goals"]``), when the caller has them
    (they are not encoded again).
    """
    table: list[Goal] = []
    texts: list[str] = []
    index: dict[str, int] = {}
    refs: list[list[int]] = []
    for i, e in enumerate(episodes):
        row = []
        data = encoded[i] if encoded is not None else [g.to_dict() for g in e.goals]
        for g, d in zip(e.goals, data):
            key = goal_key(d)
            k = index.get(key)
            if k is None:
                k = index[key] = len(table)
                table.append(g)
                texts.append(key)
            row.append(k)
        refs.append(row)
    return table, refs, texts


def goals_npz_bytes(goals: list[Goal]) -> bytes:
    """Return the ``goals.npz`` bytes of a goal table (deterministic; ValueError when a goal does not fit)."""
    meta: list[dict[str, Any]] = []
    pos, bounds, vpp, vpr, vpv = [], [], [], [], []
    for g in goals:
        meta.append({"object_id": g.object_id, "category": g.category, "n_view_points": len(g.view_points),
                     "bounds": g.bounds is not None, **({"history": g.history} if g.history is not None else {})})
        pos.append(np.asarray(g.position, dtype=np.float64).reshape(3))
        bounds.append(np.zeros((2, 3)) if g.bounds is None else np.asarray(g.bounds, dtype=np.float64).reshape(2, 3))
        for vp in g.view_points:
            vpp.append(np.asarray(vp.position, dtype=np.float64).reshape(3))
            vpr.append(np.asarray(vp.rotation, dtype=np.float64).reshape(4))
            vpv.append(float(vp.visible_fraction))
    arrays = {
        "__meta__": np.frombuffer(dumps({"format": GOALS_FORMAT, "goals": meta}).encode("utf-8"), dtype=np.uint8),
        "position": np.array(pos, dtype=np.float64).reshape(-1, 3),
        "bounds": np.array(bounds, dtype=np.float64).reshape(-1, 2, 3),
        "vp_position": np.array(vpp, dtype=np.float64).reshape(-1, 3),
        "vp_rotation": np.array(vpr, dtype=np.float64).reshape(-1, 4),
        "vp_visible_fraction": np.array(vpv, dtype=np.float64).reshape(-1),
    }
    buf = io.BytesIO()
    _savez_deterministic(buf, arrays)
    return buf.getvalue()


def read_goals_npz(data: bytes | str | Path) -> list[Goal]:
    """Read a goal table from ``goals.npz`` bytes or a file (RecordError when malformed)."""
    src = io.BytesIO(data) if isinstance(data, (bytes, bytearray)) else Path(data)
    try:
        with np.load(src, allow_pickle=False) as z:
            meta = json.loads(bytes(z["__meta__"]).decode("utf-8"))
            if meta.get("format") != GOALS_FORMAT:
                raise RecordError(f"goal table format {meta.get('format')!r}, expected {GOALS_FORMAT!r}")
            pos, bnd = z["position"], z["bounds"]
            vpp, vpr, vpv = z["vp_position"], z["vp_rotation"], z["vp_visible_fraction"]
    except (OSError, KeyError, ValueError, UnicodeDecodeError) as e:
        raise RecordError(f"not a valid goal table ({e})") from None
    goals: list[Goal] = []
    k = 0
    try:
        for i, m in enumerate(meta["goals"]):
            n = int(m["n_view_points"])
            if k + n > len(vpp):
                raise RecordError(f"goal {i} claims {n} view points beyond the {len(vpp)} stored")
            vps = [ViewPoint(vpp[j].copy(), vpr[j].copy(), float(vpv[j])) for j in range(k, k + n)]
            k += n
            goals.append(Goal(str(m["object_id"]), str(m["category"]), pos[i].copy(), vps,
                              bnd[i].copy() if m["bounds"] else None,
                              history=str(m["history"]) if m.get("history") is not None else None))
    except (KeyError, IndexError, TypeError) as e:
        raise RecordError(f"goal table does not match its arrays ({e})") from None
    return goals


def pack_episodes(episodes: list[Episode]) -> tuple[str, bytes, str]:
    """Return (episodes.json text, goal table bytes, goal table file name) for a bundle's episodes.

    The goal table is ``goals.npz`` when it reads back to the same records (each goal's JSON text the same), else
    ``goals.json``. Every goal is encoded once for the episodes' rows and the table, and each goal read back once.
    """
    rows, encoded = [], []
    for e in episodes:
        d = e.to_dict()
        encoded.append(d.pop("goals"))
        d[TAG] = EPISODE_REF
        rows.append(d)
    table, refs, texts = goal_table(episodes, encoded)
    for d, r in zip(rows, refs):
        d["goal_refs"] = r
    try:
        data = goals_npz_bytes(table)
        back = read_goals_npz(data)
        if len(back) == len(table) and all(goal_key(b.to_dict()) == t for b, t in zip(back, texts)):
            return dumps(rows), data, "goals.npz"
    except (ValueError, RecordError):
        pass
    return dumps(rows), dumps([g.to_dict() for g in table]).encode("utf-8"), "goals.json"


def unpack_episodes(episodes_path: Path, goals_path: Path | None) -> list[Episode]:
    """Read a bundle's episodes.json, resolving ``EpisodeRef`` rows against the goal table file.

    Rows that are whole Episode records (older bundles, hand-edited files) are read as they are. Raises
    InputError naming the file that is missing or malformed.
    """
    try:
        rows = json.loads(episodes_path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as e:
        raise InputError(episodes_path, f"not a valid Episode file ({e})") from None
    if not isinstance(rows, list):
        raise InputError(episodes_path, "expected a list of Episode records")
    table: list[Goal] | None = None
    out: list[Episode] = []
    for i, row in enumerate(rows):
        try:
            if isinstance(row, dict) and row.get(TAG) == EPISODE_REF:
                if table is None:
                    table = _read_table(episodes_path, goals_path)
                d = {k: v for k, v in row.items() if k != "goal_refs"}
                d[TAG] = Episode.record_type()
                ep = Episode.from_dict(d)
                refs = [int(j) for j in row.get("goal_refs", [])]
                if any(j < 0 for j in refs):
                    raise IndexError
                ep.goals = [copy.deepcopy(table[j]) for j in refs]
            else:
                ep = Episode.from_dict(row)
        except (RecordError, KeyError, TypeError, ValueError) as e:
            raise InputError(episodes_path, f"episode {i}: not a valid Episode record ({e})") from None
        except IndexError:
            raise InputError(episodes_path, f"episode {i}: goal_refs {row.get('goal_refs')} beyond the "
                                            f"{len(table or [])} goals of {goals_path}") from None
        out.append(ep)
    return out


def _read_table(episodes_path: Path, goals_path: Path | None) -> list[Goal]:
    """Read the goal table an episodes file refers to."""
    if goals_path is None:
        raise InputError(episodes_path, "episodes refer to a goal table (goal_refs) but the bundle names none "
                                        "(bundle.json 'goals')")
    if not goals_path.is_file():
        raise InputError(goals_path, f"goal table of {episodes_path} not found")
    try:
        if goals_path.suffix == ".npz":
            return read_goals_npz(goals_path)
        table = load_json(goals_path, Goal)
    except RecordError as e:
        raise InputError(goals_path, f"not a valid goal table ({e})") from None
    if not isinstance(table, list):
        raise InputError(goals_path, "expected a list of Goal records")
    return table
