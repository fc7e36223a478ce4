"""Ollama backend: POST /api/chat, stream off; `format` = the JSON schema on servers >= 0.5, else "json"."""

from __future__ import annotations

import re
from typing import Any

from ..http import TransportError, request_json
from . import ServerBackend

SCHEMA_MIN_VERSION = (0, 5, 0)  # Ollama accepts a JSON schema in "format" from 0.5 on


def _version(text: str) -> tuple[int, ...]:
    """Return the numeric version tuple of '0.5.7' / 'v0.6.0-rc1' (empty if none)."""
    m = re.search(r"(\d+)\.(\d+)(?:\.(\d+))?", str(text))
    return tuple(int(g or 0) for g in m.groups()) if m else ()


class OllamaBackend(ServerBackend):
    """An Ollama server (default http://localhost:11434), schema-constrained when it supports it."""

    name = "ollama"
    default_url = "http://localhost:11434"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.schema_mode: bool | None = None  # None: not probed yet

    def _probe(self) -> bool:
        """Return whether the server takes a JSON schema as `format` (GET /api/version)."""
        if self.schema_mode is None:
            try:
                reply = request_json(self.url + "/api/version", None, timeout=min(self.cfg.timeout_s, 10.0), retries=0)
                self.schema_mode = _version(str(reply.get("version", ""))) >= SCHEMA_MIN_VERSION
            except TransportError:
                self.schema_mode = False  # old server or no /api/version: plain JSON mode
        return self.schema_mode

    def chat(self, messages: list[dict[str, str]], schema: dict[str, Any]) -> str:
        """Send one /api/chat request and return the assistant message's content."""
        fmt: Any = schema if self._probe() else "json"
        body = {"model": self.model, "messages": messages, "stream": False, "format": fmt,
                "options": {"temperature": self.cfg.temperature, "seed": self.cfg.seed}}
        try:
            reply = request_json(self.url + "/api/chat", body, **self.http_kwargs())
        except TransportError as e:
            if e.status == 400 and fmt != "json":  # schema refused: plain JSON mode from now on
                self.schema_mode = False
                body["format"] = "json"
                reply = request_json(self.url + "/api/chat", body, **self.http_kwargs())
            else:
                raise
        if "error" in reply and "message" not in reply:
            raise TransportError(self.url + "/api/chat", f"server error: {reply['error']}")
        msg = reply.get("message")
        if not isinstance(msg, dict):
            raise TransportError(self.url + "/api/chat", "reply has no 'message' object (not an Ollama server?)", 200)
        return str(msg.get("content") or "")
