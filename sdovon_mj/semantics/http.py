"""Minimal JSON-over-HTTP client (standard library): timeouts, retries with exponential backoff."""

from __future__ import annotations

import json
import socket
import time
import urllib.error
import urllib.request
from typing import Any

from ..errors import SdovonError


class TransportError(SdovonError, ConnectionError):
    """A server that could not be reached or answered with an error after all retries."""

    def __init__(self, url: str, cause: str, status: int = 0) -> None:
        self.url = url
        self.cause = cause
        self.status = status
        super().__init__(f"{url}: {cause}")


def _retryable(status: int) -> bool:
    """Return whether an HTTP status is worth retrying (server errors, rate limits)."""
    return status >= 500 or status in (408, 429)


def request_json(url: str, payload: dict[str, Any] | None = None, *, timeout: float = 60.0, retries: int = 3,
                 backoff: float = 0.5, headers: dict[str, str] | None = None) -> dict[str, Any]:
    """POST (or GET when `payload` is None) JSON and return the decoded reply; raise TransportError.

    Parameters
    ----------
    url : str
        Endpoint URL.
    payload : dict, optional
        JSON body to POST (None: GET).
    timeout : float
        Seconds per attempt.
    retries : int
        Retries after the first attempt.
    backoff : float
        Seconds before the first retry (doubling each time).
    headers : dict of str to str, optional
        Extra HTTP headers.
    """
    data = None if payload is None else json.dumps(payload).encode("utf-8")
    hdrs = {"Accept": "application/json"}
    if data is not None:
        hdrs["Content-Type"] = "application/json"
    hdrs.update(headers or {})
    last = "no attempt"
    status = 0
    for attempt in range(max(0, retries) + 1):
        if attempt:
            time.sleep(backoff * (2 ** (attempt - 1)))
        req = urllib.request.Request(url, data=data, headers=hdrs, method="GET" if data is None else "POST")
        try:
            with urllib.request.urlopen(req, timeout=timeout) as resp:
                body = resp.read()
        except urllib.error.HTTPError as e:
            status = e.code
            try:
                detail = e.read().decode("utf-8", "replace")[:300]
            except Exception:  # noqa: BLE001 - the body is only for the message
                detail = ""
            last = f"HTTP {e.code} {e.reason}" + (f": {detail}" if detail else "")
            if _retryable(e.code):
                continue
            raise TransportError(url, last, status) from None
        except (urllib.error.URLError, socket.timeout, TimeoutError, ConnectionError, OSError) as e:
            reason = getattr(e, "reason", e)
            if isinstance(reason, (socket.timeout, TimeoutError)) or "timed out" in str(reason):
                last = f"no reply within {timeout:g} s (timed out)"
            else:
                last = f"cannot connect ({reason})"
            status = 0
            continue
        try:
            out = json.loads(body.decode("utf-8")) if body.strip() else {}
        except (UnicodeDecodeError, json.JSONDecodeError) as e:
            raise TransportError(url, f"reply body is not JSON ({e})", 200) from None
        if not isinstance(out, dict):
            raise TransportError(url, f"reply body is JSON {type(out).__name__}, expected an object", 200)
        return out
    raise TransportError(url, f"{last} (after {retries + 1} attempt(s))", status)
