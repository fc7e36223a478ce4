"""Receptacle identification: instances whose label is a receptacle label (prespecified, or from an LLM)."""

from __future__ import annotations

import json
import re
from typing import Callable, Iterable

from ..records import Instance

# Paper appendix C.1, system prompt of the receptacle-identification query.
RECEPTACLE_PROMPT = (
    'The user will give you a list of objects {"objects": [object_1, object_2, ...]}, please find and return '
    'pieces of furnitures with surface to put daily objects on top of, such as "sofa", "bed", and "table", which '
    'we refer to as "receptacles". Return in JSON format {"receptacles": [receptacle_1, receptacle_2, ...]}. '
    "Do NOT reply any other information."
)


def normalize_label(label: str) -> str:
    """Return a label lower-cased with '_'/'-' as spaces and single spaces."""
    return " ".join(re.sub(r"[_\-]+", " ", str(label).lower()).split())


def is_receptacle(label: str, labels: Iterable[str]) -> bool:
    """Return whether a label names a receptacle (case, separators and spaces ignored)."""
    key = normalize_label(label)
    for lab in labels:
        n = normalize_label(lab)
        if key == n or key.replace(" ", "") == n.replace(" ", ""):
            return True
    return False


def receptacle_instances(instances: list[Instance], labels: Iterable[str]) -> list[Instance]:
    """Return the instances whose label is one of the receptacle labels."""
    labels = list(labels)
    return [inst for inst in instances if is_receptacle(inst.label, labels)]


def parse_receptacle_reply(reply: str, candidates: Iterable[str]) -> list[str]:
    """Return the receptacle labels named in an LLM reply that are among the candidates (sorted)."""
    m = re.search(r"\{.*\}", reply, flags=re.S)
    if not m:
        raise ValueError(f"no JSON object in reply: {reply[:120]!r}")
    data = json.loads(m.group(0))
    got = data.get("receptacles") if isinstance(data, dict) else None
    if not isinstance(got, list):
        raise ValueError(f"reply has no 'receptacles' list: {reply[:120]!r}")
    cands = sorted(set(candidates))
    return sorted({c for c in cands if any(normalize_label(c) == normalize_label(str(g)) for g in got)})


def llm_receptacle_labels(object_labels: Iterable[str], ask: Callable[[str, str], str], retries: int = 3) -> list[str]:
    """Ask an LLM (ask(system, user) -> reply text) which labels are receptacles (appendix C.1)."""
    cands = sorted({str(x) for x in object_labels})
    user = json.dumps({"objects": cands})
    last: Exception | None = None
    for _ in range(max(int(retries), 1)):
        try:
            return parse_receptacle_reply(ask(RECEPTACLE_PROMPT, user), cands)
        except (ValueError, json.JSONDecodeError) as e:  # re-ask on a malformed reply, as the paper does
            last = e
    raise ValueError(f"LLM gave no usable receptacle list after {retries} tries: {last}")
