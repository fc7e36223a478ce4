"""Parse and validate LLM replies against the candidate list; errors are worded for re-asking.

Documented behaviour (paper appendix C, "restricted output formatting", made robust):
- code fences (```json ... ```) and text around the first balanced ``{...}`` are ignored;
- a reply that is not valid JSON but holds the required key's value as valid JSON (the paper's
  own example reply, whose "reason" is unquoted) is salvaged from that value alone;
- names are matched case/space/underscore/plural-insensitively; unknown keys are dropped,
  missing candidates score 0, numbers are coerced and clipped to 0-10;
- an empty reply, no JSON at all, a missing key, a wrong type or all-zero scores raise
  `ReplyError` whose message tells the model what to fix.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any, Iterable

from ..errors import SdovonError

_FENCE = re.compile(r"```[a-zA-Z0-9_-]*\s*\n?(.*?)```", re.DOTALL)


class ReplyError(SdovonError, ValueError):
    """A reply that fails validation; the message is sent back to the model when re-asking."""


def normalise(name: Any) -> str:
    """Return a label in canonical form: lower case, single spaces, no underscores or dashes."""
    s = str(name).strip().lower().replace("_", " ").replace("-", " ")
    s = re.sub(r"[^\w\s&'/]", " ", s)
    return re.sub(r"\s+", " ", s).strip()


def _singular(s: str) -> str:
    """Return a naive singular of the last word (tables -> table, shelves -> shelf, boxes -> box)."""
    words = s.split(" ")
    w = words[-1]
    if len(w) > 4 and w.endswith("ves"):
        w = w[:-3] + "f"
    elif len(w) > 4 and w.endswith(("ches", "shes", "xes", "sses")):
        w = w[:-2]
    elif len(w) > 3 and w.endswith("ies"):
        w = w[:-3] + "y"
    elif len(w) > 3 and w.endswith("s") and not w.endswith(("ss", "us", "is")):
        w = w[:-1]
    words[-1] = w
    return " ".join(words)


def match_name(name: Any, candidates: Iterable[str]) -> str | None:
    """Return the candidate a reply's name refers to, or None when it is unknown."""
    cands = list(candidates)
    n = normalise(name)
    if not n:
        return None
    forms = [(normalise(c), c) for c in cands]
    for key in (lambda s: s, lambda s: s.replace(" ", ""), lambda s: _singular(s).replace(" ", "")):
        target = key(n)
        for nc, c in forms:
            if key(nc) == target:
                return c
    return None


def strip_fences(text: str) -> str:
    """Return the content of the first fenced code block, or the text unchanged."""
    m = _FENCE.search(text)
    return m.group(1) if m else text


def _balanced(text: str, start: int) -> str | None:
    """Return the balanced {...} (or [...]) substring starting at `start`, string-aware."""
    open_ch = text[start]
    close_ch = "}" if open_ch == "{" else "]"
    depth = 0
    in_str = False
    esc = False
    for i in range(start, len(text)):
        ch = text[i]
        if in_str:
            if esc:
                esc = False
            elif ch == "\\":
                esc = True
            elif ch == '"':
                in_str = False
            continue
        if ch == '"':
            in_str = True
        elif ch == open_ch:
            depth += 1
        elif ch == close_ch:
            depth -= 1
            if depth == 0:
                return text[start : i + 1]
    return None


def _salvage(text: str, key: str) -> Any:
    """Find `"key": <json value>` in text that is not JSON as a whole; return the value or raise."""
    for m in re.finditer(r'["\']?' + re.escape(key) + r'["\']?\s*:\s*', text):
        j = m.end()
        if j < len(text) and text[j] in "{[":
            frag = _balanced(text, j)
            if frag is not None:
                try:
                    return json.loads(frag)
                except json.JSONDecodeError:
                    continue
    raise KeyError(key)


def parse_reply(text: str | None, key: str) -> tuple[Any, bool]:
    """Return (value of `key`, salvaged?) from a reply text; raise ReplyError saying what is wrong."""
    if text is None or not str(text).strip():
        raise ReplyError(f'the reply was empty. Reply with one JSON object with the key "{key}".')
    body = strip_fences(str(text)).strip()
    start = body.find("{")
    obj: Any = None
    if start >= 0:
        frag = _balanced(body, start)
        if frag is not None:
            try:
                obj = json.loads(frag)
            except json.JSONDecodeError:
                obj = None
    if isinstance(obj, dict):
        for k, v in obj.items():
            if normalise(k) == normalise(key):
                return v, False
        raise ReplyError(f'the reply has no "{key}" key (keys: {sorted(map(str, obj))}). '
                         f'Reply with one JSON object with the key "{key}".')
    try:
        return _salvage(body, key), True
    except KeyError:
        pass
    if start < 0:
        raise ReplyError(f'the reply holds no JSON object. Reply with JSON only: one object with the key "{key}".')
    raise ReplyError(f'the reply is not valid JSON (quote every string). '
                     f'Reply with one valid JSON object with the key "{key}".')


def _number(v: Any) -> float | None:
    """Coerce a score (number, numeric string, {"score": n}) to float, or None."""
    if isinstance(v, bool):
        return None
    if isinstance(v, (int, float)):
        f = float(v)
    elif isinstance(v, str):
        m = re.search(r"-?\d+(\.\d+)?", v)
        if not m:
            return None
        f = float(m.group(0))
    elif isinstance(v, dict) and len(v) == 1:
        return _number(next(iter(v.values())))
    else:
        return None
    return f if math.isfinite(f) else None


def validate_scores(value: Any, candidates: list[str], key: str = "relevances") -> tuple[dict[str, float], list[str]]:
    """Return ({candidate: score 0-10}, notes) from a reply's score mapping; raise ReplyError."""
    if isinstance(value, list):  # [{"name": .., "score": ..}] or [[name, score]]
        pairs: dict[str, Any] = {}
        for item in value:
            if isinstance(item, dict) and len(item) >= 2:
                vals = list(item.values())
                pairs[str(vals[0])] = vals[1]
            elif isinstance(item, (list, tuple)) and len(item) == 2:
                pairs[str(item[0])] = item[1]
        value = pairs or value
    if not isinstance(value, dict):
        raise ReplyError(f'"{key}" must be an object mapping each name to a score from 0 to 10, '
                         f'got {type(value).__name__}.')
    out = {c: 0.0 for c in candidates}
    notes: list[str] = []
    seen: set[str] = set()
    for k, v in value.items():
        c = match_name(k, candidates)
        if c is None:
            notes.append(f"dropped unknown key {k!r}")
            continue
        f = _number(v)
        if f is None:
            notes.append(f"score of {k!r} is not a number ({v!r}): 0")
            f = 0.0
        if f < 0 or f > 10:
            notes.append(f"score of {k!r} clipped to 0-10 ({f})")
        out[c] = float(min(10.0, max(0.0, f)))
        seen.add(c)
    missing = [c for c in candidates if c not in seen]
    if missing:
        notes.append(f"missing keys scored 0: {missing}")
    if not seen:
        raise ReplyError(f'"{key}" names none of the given names. Use exactly these keys: '
                         + json.dumps(candidates) + ".")
    if all(v == 0.0 for v in out.values()):
        raise ReplyError(f'all scores in "{key}" are 0. Give every name a score from 0 to 10; '
                         "at least one must be above 0.")
    return out, notes


def validate_names(value: Any, key: str, allowed: list[str] | None = None, min_items: int = 0) -> tuple[list[str], list[str]]:
    """Return (names, notes) from a reply's list; names outside `allowed` are dropped."""
    if isinstance(value, str):
        value = [v for v in re.split(r"[,;\n]", value) if v.strip()]
    if isinstance(value, dict):
        value = list(value)
    if not isinstance(value, list):
        raise ReplyError(f'"{key}" must be a list of names, got {type(value).__name__}.')
    out: list[str] = []
    notes: list[str] = []
    for v in value:
        if not isinstance(v, (str, int, float)) or not normalise(v):
            notes.append(f"dropped non-name item {v!r}")
            continue
        if allowed is not None:
            c = match_name(v, allowed)
            if c is None:
                notes.append(f"dropped unknown name {v!r}")
                continue
        else:
            c = normalise(v)
        if c not in out:
            out.append(c)
    if len(out) < min_items:
        hint = f" Choose only from: {json.dumps(allowed)}." if allowed is not None else ""
        raise ReplyError(f'"{key}" must list at least {min_items} name(s); got {len(out)}.{hint}')
    return out, notes
