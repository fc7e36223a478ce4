"""OpenAI-compatible backend: POST /v1/chat/completions (vLLM, llama.cpp server, LM Studio, ...).

``response_format`` is a JSON schema first; a server that refuses it (HTTP 400) is asked with
``json_object``, then with no response_format at all (the validator still checks every reply).
"""

from __future__ import annotations

import os
from typing import Any

from ..http import TransportError, request_json
from . import ServerBackend

_MODES = ("json_schema", "json_object", "none")


class OpenAIBackend(ServerBackend):
    """Any server speaking the OpenAI chat completions protocol (default http://localhost:8000)."""

    name = "openai"
    default_url = "http://localhost:8000"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.mode = 0  # index into _MODES
        base = self.url
        self.endpoint = base + ("/chat/completions" if base.endswith("/v1") else "/v1/chat/completions")

    def _headers(self) -> dict[str, str]:
        key = os.environ.get("OPENAI_API_KEY", "")
        return {"Authorization": f"Bearer {key}"} if key else {}

    def chat(self, messages: list[dict[str, str]], schema: dict[str, Any]) -> str:
        """Send one chat completion request and return the first choice's content."""
        while True:
            body: dict[str, Any] = {"model": self.model, "messages": messages, "stream": False,
                                    "temperature": self.cfg.temperature, "seed": self.cfg.seed}
            mode = _MODES[self.mode]
            if mode == "json_schema":
                body["response_format"] = {"type": "json_schema",
                                           "json_schema": {"name": "reply", "schema": schema, "strict": False}}
            elif mode == "json_object":
                body["response_format"] = {"type": "json_object"}
            try:
                reply = request_json(self.endpoint, body, headers=self._headers(), **self.http_kwargs())
                break
            except TransportError as e:
                if e.status == 400 and self.mode < len(_MODES) - 1:
                    self.mode += 1
                    continue
                raise
        choices = reply.get("choices")
        if not isinstance(choices, list) or not choices or not isinstance(choices[0], dict):
            raise TransportError(self.endpoint, "reply has no 'choices' (not an OpenAI-compatible server?)", 200)
        msg = choices[0].get("message") or {}
        return str(msg.get("content") or "")
