"""LLM backend interface: a JSON chat call with a schema, plus the validate / re-ask / fallback / cache logic.

A backend subclass implements one method, ``chat(messages, schema) -> str`` (one request, the
reply's text). ``Backend.ask(prompt_id, payload)`` does the rest, the same for every server:

1. cache: an answer cached under (backend, model, prompt version, canonical inputs, options) is
   returned without any request;
2. the reply is validated (``semantics.validate``); an invalid reply is re-asked with the
   validation error appended, up to ``cfg.retries`` times;
3. when the replies stay invalid, or the transport fails (after its own retries with backoff),
   the question goes to the ``cfg.fallback`` backend (``offline`` by default) and the fallback is
   recorded in ``backend.fallbacks``; with ``fallback = ''`` a StageError says what failed;
4. after a transport failure the backend is marked down and later questions go straight to the
   fallback (also recorded), so a dead or hung server costs one timeout, not one per question.

Fallback answers are never cached: a later run with the server up asks it again.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np

from ...config import SemanticsConfig
from ...errors import StageError
from .. import prompts
from ..cache import DiskCache, cache_key
from ..http import TransportError
from ..validate import ReplyError


class Backend:
    """Base LLM backend: subclasses implement `chat`; `ask` validates, re-asks, caches, falls back."""

    name = "base"

    def __init__(self, cfg: SemanticsConfig | None = None, cache_dir: str | Path | None = None) -> None:
        self.cfg = cfg or SemanticsConfig()
        self.model = self.cfg.model
        self.cache = DiskCache(Path(cache_dir) / self.name) if (cache_dir and self.cfg.cache) else None
        self.fallbacks: list[str] = []
        self.requests = 0  # chat requests sent (cache hits send none)
        self.down: str = ""  # transport failure that marked the server down
        self._fallback: Backend | None = None

    # -- to implement -------------------------------------------------------------------------------

    def chat(self, messages: list[dict[str, str]], schema: dict[str, Any]) -> str:
        """Send one chat request and return the reply text; raise TransportError."""
        raise NotImplementedError

    def options(self) -> dict[str, Any]:
        """Return the decoding options that belong in the cache key."""
        return {"temperature": self.cfg.temperature, "seed": self.cfg.seed}

    @property
    def label(self) -> str:
        """Return 'name' or 'name:model' for records."""
        return f"{self.name}:{self.model}" if self.model else self.name

    # -- shared logic -------------------------------------------------------------------------------

    def fallback_backend(self) -> "Backend":
        """Return the configured fallback backend (built once)."""
        if self._fallback is None:
            sub = dataclasses.replace(self.cfg, backend=self.cfg.fallback, fallback="")
            self._fallback = get_backend(sub, None)
        return self._fallback

    def ask(self, prompt_id: str, payload: dict[str, Any]) -> Any:
        """Return the validated answer to one appendix C question (cached, re-asked, or fallen back)."""
        prompt = prompts.get_prompt(prompt_id)
        key = cache_key(self.name, self.model, prompt.tag, payload, self.options())
        if self.cache is not None:
            entry = self.cache.get(key)
            if entry is not None:
                return entry["result"]
        if self.down:
            return self._fail(prompt, payload, f"server marked down earlier ({self.down})")
        messages = prompt.messages(payload)
        schema = prompt.schema(payload)
        raws: list[str] = []
        last = ""
        for _attempt in range(max(0, self.cfg.retries) + 1):
            try:
                self.requests += 1
                text = self.chat(messages, schema)
            except TransportError as e:
                self.down = str(e)
                return self._fail(prompt, payload, str(e))
            raws.append(text)
            try:
                result, notes = prompt.check(text, payload)
            except ReplyError as e:
                last = str(e)
                messages = messages + [
                    {"role": "assistant", "content": text or ""},
                    {"role": "user", "content": f"Your reply was invalid: {e} Answer the last question again, "
                                                "JSON only."},
                ]
                continue
            if self.cache is not None:
                self.cache.put(key, {"backend": self.name, "model": self.model, "prompt": prompt.tag,
                                     "inputs": payload, "options": self.options(), "result": result,
                                     "notes": notes, "raw": raws})
            return result
        return self._fail(prompt, payload, f"{len(raws)} invalid repl{'y' if len(raws) == 1 else 'ies'}; last: {last}")

    def _fail(self, prompt: prompts.Prompt, payload: dict[str, Any], reason: str) -> Any:
        """Fall back to the configured backend (recorded) or raise a StageError."""
        what = json.dumps({k: v for k, v in payload.items() if not k.startswith("_")}, sort_keys=True)
        if len(what) > 160:
            what = what[:157] + "..."
        if not self.cfg.fallback or self.cfg.fallback == self.name:
            raise StageError(f"{self.label} backend failed on {prompt.id} {what}: {reason} "
                             "(no fallback: semantics.fallback is empty)")
        fb = self.fallback_backend()
        self.fallbacks.append(f"{prompt.id} {what}: {reason} -> {fb.name}")
        return fb.ask(prompt.id, payload)

    # -- the four questions -------------------------------------------------------------------------

    def receptacles(self, labels: list[str]) -> list[str]:
        """Return which of `labels` are receptacles (prompt C.1)."""
        return list(self.ask(prompts.RECEPTACLES, {"objects": list(labels)}))

    def propose_regions(self, labels: list[str], vocabulary: list[str] | tuple[str, ...] = ()) -> list[str]:
        """Return region proposals, most likely first, for the labels seen in one area (prompt C.2)."""
        payload: dict[str, Any] = {"objects": list(labels)}
        if vocabulary:
            payload["_vocabulary"] = list(vocabulary)
        return list(self.ask(prompts.REGION_PROPOSALS, payload))

    def score_receptacles(self, obj: str, furniture: list[str]) -> dict[str, float]:
        """Return 0-10 scores of how likely `obj` is put on each piece of furniture (prompt C.3)."""
        return dict(self.ask(prompts.RECEPTACLE_RELEVANCE, {"furniture": list(furniture), "object": obj}))

    def score_regions(self, obj: str, regions: list[str]) -> dict[str, float]:
        """Return 0-10 relevance scores between `obj` and each region (prompt C.4)."""
        return dict(self.ask(prompts.REGION_RELEVANCE, {"regions": list(regions), "object": obj}))

    def pair_scores(self, obj: str, regions: list[str], receptacles: list[str], region_scores: np.ndarray,
                    receptacle_scores: np.ndarray) -> np.ndarray:
        """Return 0-1 scores (R, C) of each (region, receptacle) as a place for `obj` (search direction).

        The base rule asks nothing more: the product of the object's 0-10 region and receptacle
        answers (given), divided by 100. A backend with its own pair model overrides this.

        Parameters
        ----------
        obj : str
            Object category.
        regions : list of str
            Region names (R).
        receptacles : list of str
            Receptacle names (C).
        region_scores : ndarray, shape (R,)
            The object's 0-10 region answers (`score_regions`), same order.
        receptacle_scores : ndarray, shape (C,)
            The object's 0-10 receptacle answers (`score_receptacles`), same order.
        """
        return np.outer(np.asarray(region_scores, dtype=float), np.asarray(receptacle_scores, dtype=float)) / 100.0

    def answer_pairs(self, obj: str, regions: list[str], receptacles: list[str], region_scores: np.ndarray,
                     receptacle_scores: np.ndarray, fell_back: bool = False) -> np.ndarray:
        """Return `pair_scores` from whoever answered this object's questions: the fallback's model when `fell_back`.

        Parameters
        ----------
        obj : str
            Object category.
        regions, receptacles : list of str
            Region names (R) and receptacle names (C).
        region_scores, receptacle_scores : ndarray, shapes (R,) and (C,)
            The object's 0-10 answers, same order.
        fell_back : bool
            Whether some of this object's answers came from the fallback backend.
        """
        who = self.fallback_backend() if (fell_back and self.cfg.fallback and self.cfg.fallback != self.name) else self
        return who.pair_scores(obj, regions, receptacles, region_scores, receptacle_scores)

    def row_source(self, obj: str) -> str:
        """Return what produces this backend's answers about `obj` (recorded per Relevance row)."""
        return self.name


class ServerBackend(Backend):
    """Base of HTTP backends: base URL, model name required, timeouts and retries from the config."""

    default_url = ""

    def __init__(self, cfg: SemanticsConfig | None = None, cache_dir: str | Path | None = None) -> None:
        super().__init__(cfg, cache_dir)
        self.url = (self.cfg.url or self.default_url).rstrip("/")
        if not self.model:
            raise StageError(f"{self.name} backend needs a model name: set semantics.model (e.g. llama3.1:8b)")

    def http_kwargs(self) -> dict[str, Any]:
        """Return timeout / retries / backoff for `http.request_json`."""
        return {"timeout": self.cfg.timeout_s, "retries": self.cfg.retries, "backoff": self.cfg.backoff_s}

    @property
    def label(self) -> str:
        return f"{self.name}:{self.model}@{self.url}"


def get_backend(cfg: SemanticsConfig | None = None, cache_dir: str | Path | None = None) -> Backend:
    """Return the configured LLM backend (cache under `cache_dir` when given and enabled).

    The backend class comes from the plugin group ``sdovon_mj.llm_backends`` (offline, ollama, openai, or any
    installed plugin); `sdovon_mj.semantics` re-exports this function.
    """
    from ... import plugins

    cfg = cfg or SemanticsConfig()
    cls = plugins.load("llm_backend", cfg.backend)
    backend = cls(cfg, cache_dir=cache_dir)
    if not isinstance(backend, Backend):
        raise StageError(f"llm_backend plugin '{cfg.backend}' did not build a semantics Backend")
    return backend
