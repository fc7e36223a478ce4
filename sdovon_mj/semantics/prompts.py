"""The four LLM prompts of the paper's appendix C, versioned, with their JSON schemas and validators.

System texts are the paper's, verbatim, plus one versioned sentence that pins the candidate names
(a model that renames candidates is the commonest failure). The paper's worked examples are given
as one few-shot exchange each; two of them are not valid JSON in the paper (C.1 writes the object
list as a set, C.3 leaves "reason" unquoted), so the few-shot copies are corrected.
Bump a prompt's ``version`` whenever its text changes: the version is part of the cache key.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Callable

from . import validate

RECEPTACLES = "receptacles"
REGION_PROPOSALS = "region_proposals"
RECEPTACLE_RELEVANCE = "receptacle_relevance"
REGION_RELEVANCE = "region_relevance"


@dataclass(frozen=True)
class Prompt:
    """One appendix C prompt: system text, worked example, reply key, schema and validator."""

    id: str
    version: str
    system: str
    example_input: dict[str, Any]
    example_output: dict[str, Any]
    key: str
    schema_fn: Callable[[dict[str, Any]], dict[str, Any]]
    check_fn: Callable[[Any, dict[str, Any]], tuple[Any, list[str]]]
    suffix_fn: Callable[[dict[str, Any]], str]

    def messages(self, payload: dict[str, Any]) -> list[dict[str, str]]:
        """Return the chat messages (system, few-shot pair, user) for one question."""
        system = self.system + self.suffix_fn(payload)
        user = {k: v for k, v in payload.items() if not k.startswith("_")}
        return [
            {"role": "system", "content": system},
            {"role": "user", "content": json.dumps(self.example_input)},
            {"role": "assistant", "content": json.dumps(self.example_output)},
            {"role": "user", "content": json.dumps(user)},
        ]

    def schema(self, payload: dict[str, Any]) -> dict[str, Any]:
        """Return the JSON schema a reply to `payload` must follow."""
        return self.schema_fn(payload)

    def check(self, text: str | None, payload: dict[str, Any]) -> tuple[Any, list[str]]:
        """Return (validated result, notes) for a reply text; raise validate.ReplyError."""
        value, salvaged = validate.parse_reply(text, self.key)
        result, notes = self.check_fn(value, payload)
        if salvaged:
            notes = ["salvaged the required key from a reply that is not valid JSON", *notes]
        return result, notes

    @property
    def tag(self) -> str:
        """Return the prompt's cache tag, e.g. ``region_relevance@1``."""
        return f"{self.id}@{self.version}"


def _list_schema(key: str) -> Callable[[dict[str, Any]], dict[str, Any]]:
    def fn(_payload: dict[str, Any]) -> dict[str, Any]:
        return {"type": "object", "properties": {key: {"type": "array", "items": {"type": "string"}}},
                "required": [key]}
    return fn


def _scores_schema(cand_key: str) -> Callable[[dict[str, Any]], dict[str, Any]]:
    def fn(payload: dict[str, Any]) -> dict[str, Any]:
        names = list(payload[cand_key])
        return {
            "type": "object",
            "properties": {
                "reason": {"type": "string"},
                "relevances": {
                    "type": "object",
                    "properties": {n: {"type": "integer", "minimum": 0, "maximum": 10} for n in names},
                    "required": names,
                },
            },
            "required": ["reason", "relevances"],
        }
    return fn


def _check_receptacles(value: Any, payload: dict[str, Any]) -> tuple[Any, list[str]]:
    return validate.validate_names(value, "receptacles", allowed=list(payload["objects"]), min_items=0)


def _check_regions(value: Any, payload: dict[str, Any]) -> tuple[Any, list[str]]:
    return validate.validate_names(value, "regions", allowed=None, min_items=1)


def _check_scores(cand_key: str) -> Callable[[Any, dict[str, Any]], tuple[Any, list[str]]]:
    def fn(value: Any, payload: dict[str, Any]) -> tuple[Any, list[str]]:
        return validate.validate_scores(value, list(payload[cand_key]), "relevances")
    return fn


def _no_suffix(_payload: dict[str, Any]) -> str:
    return ""


def _names_suffix(cand_key: str) -> Callable[[dict[str, Any]], str]:
    def fn(payload: dict[str, Any]) -> str:
        return (f" Use exactly the {cand_key} names given by the user as the keys of \"relevances\", "
                "each with an integer score.")
    return fn


def _regions_suffix(payload: dict[str, Any]) -> str:
    vocab = payload.get("_vocabulary") or []
    if not vocab:
        return ""
    return " Where they fit, use these region names: " + json.dumps(list(vocab)) + "."


PROMPTS: dict[str, Prompt] = {
    RECEPTACLES: Prompt(
        id=RECEPTACLES,
        version="1",
        system=('The user will give you a list of objects {"objects": [object_1, object_2, ...]}, please find and '
                'return pieces of furnitures with surface to put daily objects on top of, such as "sofa", "bed", '
                'and "table", which we refer to as "receptacles". Return in JSON format {"receptacles": '
                '[receptacle_1, receptacle_2, ...]}. Do NOT reply any other information.'),
        example_input={"objects": ["curtain", "bed", "stool", "pillow", "desk", "shelf", "book shelf", "dresser",
                                   "chair", "pen", "laptop", "lamp"]},
        example_output={"receptacles": ["bed", "desk", "shelf", "book shelf", "dresser", "chair"]},
        key="receptacles",
        schema_fn=_list_schema("receptacles"),
        check_fn=_check_receptacles,
        suffix_fn=_no_suffix,
    ),
    REGION_PROPOSALS: Prompt(
        id=REGION_PROPOSALS,
        version="1",
        system=('The user will give you a list of objects {"objects": [object_1, object_2, ...]} in a region inside '
                'a house or a public indoor space, please suggest what this region may be. Propose at least five '
                'candidates, only return JSON format {"regions": [region_1, region_2, ...]}. Do NOT reply other '
                'information.'),
        example_input={"objects": ["headboard", "bed", "stool", "carpet", "pillow", "curtain"]},
        example_output={"regions": ["Bedroom", "Living Room", "Dining Room", "Home Office", "Guest Bedroom"]},
        key="regions",
        schema_fn=_list_schema("regions"),
        check_fn=_check_regions,
        suffix_fn=_regions_suffix,
    ),
    RECEPTACLE_RELEVANCE: Prompt(
        id=RECEPTACLE_RELEVANCE,
        version="1",
        system=('The user will give you a list of pieces of furniture and an object. Give a relevance score from 0 '
                '(low) to 10 (high) for each piece of furniture indicating how likely the given object may be '
                'placed on it in daily situations, and tell your reason in details. Return in JSON format only: '
                '{"reason": reason, "relevances": {furniture_name: score, ...}}. Do NOT reply other information.'),
        example_input={"furniture": ["table", "desk", "dresser", "bookshelf", "shelf", "bed", "sofa", "couch"],
                       "object": "dumbbell"},
        example_output={"reason": "The dumbbell is likely to be placed on a surface where it can be easily "
                                  "accessed and used.",
                        "relevances": {"table": 8, "desk": 9, "dresser": 1, "bookshelf": 0, "shelf": 4, "bed": 2,
                                       "sofa": 5, "couch": 6}},
        key="relevances",
        schema_fn=_scores_schema("furniture"),
        check_fn=_check_scores("furniture"),
        suffix_fn=_names_suffix("furniture"),
    ),
    REGION_RELEVANCE: Prompt(
        id=REGION_RELEVANCE,
        version="1",
        system=('The user will give you a list of regions and an object. Give a score from 0 (low) to 10 (high) for '
                'each region indicating the relevance between this region and the given object, after telling your '
                'reason in details. Return in JSON format only: {"reason": reason, "relevances": {region_name: '
                'score, ...}}. Do NOT reply other information.'),
        example_input={"regions": ["living room", "living room and kitchen combination", "bedroom", "bathroom",
                                   "kitchen"], "object": "dumbbell"},
        example_output={"reason": "The score is based on the likelihood of finding the object in a specific region, "
                                  "considering its typical uses and associations.",
                        "relevances": {"bedroom": 8, "living room": 6, "living room and kitchen combination": 7,
                                       "bathroom": 1, "kitchen": 2}},
        key="relevances",
        schema_fn=_scores_schema("regions"),
        check_fn=_check_scores("regions"),
        suffix_fn=_names_suffix("regions"),
    ),
}

# The paper's own example reply to C.3, byte for byte in spirit: "reason" is not quoted.
PAPER_EXAMPLE_REPLY = ('{"reason": The dumbbell is likely to be placed on a surface where it can be easily accessed '
                       'and used. "relevances": {"table": 8, "desk": 9, "dresser": 1, "bookshelf": 0, "shelf": 4, '
                       '"bed": 2, "sofa": 5, "couch": 6}}')


def get_prompt(prompt_id: str) -> Prompt:
    """Return the prompt with this id."""
    return PROMPTS[prompt_id]
