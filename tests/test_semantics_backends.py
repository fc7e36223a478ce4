"""Ollama and OpenAI-compatible backends against a local HTTP server that speaks each protocol."""

from __future__ import annotations

import json
import socket
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

from sdovon_mj.config import SemanticsConfig
from sdovon_mj.errors import StageError
from sdovon_mj.records import records_equal
from sdovon_mj.semantics import get_backend, identify_receptacles, relevance
from sdovon_mj.semantics.prompts import PAPER_EXAMPLE_REPLY

PAPER_FURNITURE = ["table", "desk", "dresser", "bookshelf", "shelf", "bed", "sofa", "couch"]
PAPER_SCORES = {"table": 8, "desk": 9, "dresser": 1, "bookshelf": 0, "shelf": 4, "bed": 2, "sofa": 5, "couch": 6}


def score(name: str, obj: str) -> float:
    """The fake model's deterministic relevance score."""
    return float((len(name) + len(obj)) % 10 + 1)


def good_answer(system: str, question: dict) -> dict:
    """A valid, deterministic answer to any of the four questions."""
    if "object" in question:
        names = question.get("furniture") or question.get("regions")
        return {"reason": "test", "relevances": {n: int(score(n, question["object"])) for n in names}}
    if '"receptacles"' in system:
        return {"receptacles": [o for o in question["objects"] if o in ("bed", "desk", "table", "shelf")]}
    return {"regions": ["Kitchen", "Dining Room", "Living Room", "Office", "Bedroom"]}


class FakeLLM:
    """A threaded HTTP server speaking Ollama (/api/chat, /api/version) or OpenAI (/v1/chat/completions)."""

    def __init__(self, protocol: str, mode: str = "good", version: str | None = "0.6.2", sleep: float = 1.0,
                 refuse_schema: bool = False) -> None:
        self.protocol = protocol
        self.mode = mode
        self.version = version
        self.sleep = sleep
        self.refuse_schema = refuse_schema
        self.requests: list[dict] = []
        self.lock = threading.Lock()
        fake = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *a):  # quiet
                pass

            def _send(self, code: int, body: dict | str) -> None:
                data = (json.dumps(body) if isinstance(body, dict) else body).encode()
                self.send_response(code)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                try:
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass

            def do_GET(self):
                if fake.protocol == "ollama" and self.path == "/api/version" and fake.version:
                    return self._send(200, {"version": fake.version})
                return self._send(404, "404 page not found")

            def do_POST(self):
                n = int(self.headers.get("Content-Length", 0))
                body = json.loads(self.rfile.read(n))
                assert self.headers.get("Content-Type") == "application/json"
                with fake.lock:
                    fake.requests.append({"path": self.path, "body": body})
                want = "/api/chat" if fake.protocol == "ollama" else "/v1/chat/completions"
                if self.path != want:
                    return self._send(404, {"error": f"no route {self.path}"})
                assert body["stream"] is False and body["model"] == "test-model"
                if fake.protocol == "openai" and fake.refuse_schema and \
                        body.get("response_format", {}).get("type") == "json_schema":
                    return self._send(400, {"error": {"message": "response_format json_schema not supported"}})
                content = fake.content(body)
                if fake.protocol == "ollama":
                    return self._send(200, {"model": body["model"], "created_at": "2024-01-01T00:00:00Z",
                                            "message": {"role": "assistant", "content": content},
                                            "done_reason": "stop", "done": True})
                return self._send(200, {"id": "chatcmpl-1", "object": "chat.completion", "created": 0,
                                        "model": body["model"],
                                        "choices": [{"index": 0, "finish_reason": "stop",
                                                     "message": {"role": "assistant", "content": content}}],
                                        "usage": {"prompt_tokens": 1, "completion_tokens": 1, "total_tokens": 2}})

        self.handler = Handler
        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}"

    def content(self, body: dict) -> str:
        """Reply text for the current mode."""
        msgs = body["messages"]
        system, question = msgs[0]["content"], json.loads(msgs[3]["content"])  # [3]: the question, also on re-asks
        mode = self.mode
        if mode == "empty_then_good":
            mode = "empty" if len(self.chat_requests) == 1 else "good"
        if mode == "good":
            return json.dumps(good_answer(system, question))
        if mode == "fenced":
            return "Sure! Here you go:\n```json\n" + json.dumps(good_answer(system, question)) + "\n```\nHope it helps."
        if mode == "paper":
            return PAPER_EXAMPLE_REPLY
        if mode == "unknown_keys":
            ans = good_answer(system, question)
            rel = ans["relevances"]
            del rel[sorted(rel)[0]]
            rel["Garage"] = 7
            rel[next(iter(rel)).upper()] = 11  # matched case-insensitively, clipped to 10
            ans["mood"] = "cheerful"
            return json.dumps(ans)
        if mode == "empty":
            return ""
        if mode == "prose":
            return "I think the pillow goes on the bed."
        if mode == "slow":
            time.sleep(self.sleep)
            return json.dumps(good_answer(system, question))
        raise AssertionError(mode)

    @property
    def chat_requests(self) -> list[dict]:
        return [r for r in self.requests if r["path"] != "/api/version"]

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


@pytest.fixture(params=["ollama", "openai"])
def protocol(request):
    return request.param


@pytest.fixture
def serve(protocol):
    servers = []

    def make(mode="good", **kw):
        s = FakeLLM(protocol, mode, **kw)
        servers.append(s)
        return s

    yield make
    for s in servers:
        s.close()


def _patch_500(fake: FakeLLM) -> None:
    """Make the server answer HTTP 500 to every chat request."""
    def do_post(self):
        n = int(self.headers.get("Content-Length", 0))
        body = json.loads(self.rfile.read(n))
        with fake.lock:
            fake.requests.append({"path": self.path, "body": body})
        return self._send(500, {"error": "model runner crashed"})

    fake.handler.do_POST = do_post  # type: ignore[method-assign]


def cfg_for(protocol: str, url: str, **kw) -> SemanticsConfig:
    base = dict(backend=protocol, model="test-model", url=url, timeout_s=2.0, retries=2, backoff_s=0.01)
    base.update(kw)
    return SemanticsConfig(**base)


def test_good_reply_and_request_shape(serve, protocol):
    fake = serve("good")
    b = get_backend(cfg_for(protocol, fake.url))
    scores = b.score_receptacles("mug", PAPER_FURNITURE)
    assert scores == {n: score(n, "mug") for n in PAPER_FURNITURE}
    assert b.fallbacks == [] and len(fake.chat_requests) == 1
    body = fake.chat_requests[0]["body"]
    assert body["messages"][0]["role"] == "system" and "relevance score from 0" in body["messages"][0]["content"]
    assert json.loads(body["messages"][-1]["content"]) == {"furniture": PAPER_FURNITURE, "object": "mug"}
    if protocol == "ollama":  # 0.6.2 takes a JSON schema as format
        assert isinstance(body["format"], dict)
        assert body["format"]["properties"]["relevances"]["required"] == PAPER_FURNITURE
        assert body["options"]["temperature"] == 0.0
    else:
        assert body["response_format"]["type"] == "json_schema"
        assert body["response_format"]["json_schema"]["schema"]["required"] == ["reason", "relevances"]


def test_fenced_reply_is_accepted(serve, protocol):
    fake = serve("fenced")
    b = get_backend(cfg_for(protocol, fake.url))
    assert identify_receptacles(["curtain", "bed", "pen", "desk"], b) == ["bed", "desk"]
    assert len(fake.chat_requests) == 1 and b.fallbacks == []


def test_paper_example_reply_is_salvaged(serve, protocol):
    """The paper's own C.3 reply (unquoted reason) is not JSON; its relevances are salvaged, no re-ask."""
    with pytest.raises(json.JSONDecodeError):
        json.loads(PAPER_EXAMPLE_REPLY)
    fake = serve("paper")
    b = get_backend(cfg_for(protocol, fake.url))
    assert b.score_receptacles("dumbbell", PAPER_FURNITURE) == {k: float(v) for k, v in PAPER_SCORES.items()}
    assert len(fake.chat_requests) == 1 and b.fallbacks == []


def test_unknown_keys_dropped_missing_zero_clipped(serve, protocol, tmp_path):
    fake = serve("unknown_keys")
    b = get_backend(cfg_for(protocol, fake.url), cache_dir=tmp_path)
    cands = ["kitchen", "bedroom", "bathroom"]
    got = b.score_regions("towel", cands)
    assert set(got) == set(cands)
    assert got["bathroom"] == 0.0  # the key the server left out
    assert all(0.0 <= v <= 10.0 for v in got.values())
    assert len(fake.chat_requests) == 1 and b.fallbacks == []
    entry = json.loads(next(Path(tmp_path).rglob("*.json")).read_text())
    assert "Garage" in entry["raw"][0]  # the raw reply is kept for audit
    assert any("dropped unknown key 'Garage'" in n for n in entry["notes"])


def test_empty_reply_then_good_is_reasked(serve, protocol):
    fake = serve("empty_then_good")
    b = get_backend(cfg_for(protocol, fake.url))
    assert b.score_regions("towel", ["kitchen", "bathroom"]) == {"kitchen": score("kitchen", "towel"), "bathroom": score("bathroom", "towel")}
    assert len(fake.chat_requests) == 2 and b.fallbacks == []
    reask = fake.chat_requests[1]["body"]["messages"][-1]["content"]
    assert "invalid" in reask and "empty" in reask


@pytest.mark.parametrize("mode", ["empty", "prose"])
def test_invalid_replies_fall_back_recorded(serve, protocol, mode):
    fake = serve(mode)
    cfg = cfg_for(protocol, fake.url, retries=2)
    b = get_backend(cfg)
    offline = get_backend(SemanticsConfig())
    got = b.score_regions("toothbrush", ["kitchen", "bathroom", "bedroom"])
    assert got == offline.score_regions("toothbrush", ["kitchen", "bathroom", "bedroom"])
    assert len(fake.chat_requests) == 3  # first ask + 2 re-asks
    assert len(b.fallbacks) == 1 and "3 invalid replies" in b.fallbacks[0] and b.fallbacks[0].endswith("-> offline")
    # no fallback configured: a clear error
    b2 = get_backend(cfg_for(protocol, fake.url, retries=1, fallback=""))
    with pytest.raises(StageError, match="invalid repl.*no fallback"):
        b2.score_regions("toothbrush", ["kitchen", "bathroom"])


def test_slow_reply_times_out(serve, protocol):
    fake = serve("slow", sleep=1.5)
    b = get_backend(cfg_for(protocol, fake.url, timeout_s=0.2, retries=1, fallback=""))
    t0 = time.perf_counter()
    with pytest.raises(StageError, match="timed out"):
        b.score_regions("mug", ["kitchen", "bedroom"])
    assert time.perf_counter() - t0 < 6.0
    # with the default fallback: recorded, and the server is marked down (no second wait)
    b = get_backend(cfg_for(protocol, fake.url, timeout_s=0.2, retries=1))
    t0 = time.perf_counter()
    rel = relevance(["mug", "pillow"], ["kitchen", "bedroom"], ["table", "bed"], b)
    assert time.perf_counter() - t0 < 6.0
    assert len(rel.fallbacks) == 4 and "timed out" in rel.fallbacks[0] and "marked down" in rel.fallbacks[1]
    assert rel.objects == ["mug", "pillow"] and rel.p_obj_region.shape == (2, 2)


def test_server_error_500(serve, protocol):
    fake = serve("good")
    _patch_500(fake)
    b = get_backend(cfg_for(protocol, fake.url, retries=2, fallback=""))
    with pytest.raises(StageError, match="HTTP 500"):
        b.score_regions("mug", ["kitchen", "bedroom"])
    assert len(fake.chat_requests) == 3  # retried with backoff
    b = get_backend(cfg_for(protocol, fake.url, retries=0))
    assert b.score_regions("mug", ["kitchen", "bedroom"])["kitchen"] > 5
    assert "HTTP 500" in b.fallbacks[0]


def test_refused_connection(protocol):
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    url = f"http://127.0.0.1:{port}"
    b = get_backend(cfg_for(protocol, url, retries=1, fallback=""))
    t0 = time.perf_counter()
    with pytest.raises(StageError, match="cannot connect"):
        b.score_regions("mug", ["kitchen", "bedroom"])
    b = get_backend(cfg_for(protocol, url, retries=1))
    assert identify_receptacles(["bed", "pillow"], b) == ["bed"]
    assert "cannot connect" in b.fallbacks[0]
    assert time.perf_counter() - t0 < 5.0


def test_second_run_is_cached_and_identical(serve, protocol, tmp_path):
    fake = serve("good")
    objs, regs, recs = ["mug", "pillow", "towel"], ["kitchen", "bedroom", "bathroom"], ["table", "bed", "shelf"]
    r1 = relevance(objs, regs, recs, get_backend(cfg_for(protocol, fake.url), cache_dir=tmp_path))
    n = len(fake.chat_requests)
    assert n == 6
    b2 = get_backend(cfg_for(protocol, fake.url), cache_dir=tmp_path)
    r2 = relevance(objs, regs, recs, b2)
    assert len(fake.chat_requests) == n and b2.requests == 0 and b2.cache.hits == 6
    assert records_equal(r1, r2)
    # another model is another cache key
    b3 = get_backend(cfg_for(protocol, fake.url, model="test-model"), cache_dir=tmp_path / "other")
    relevance(objs[:1], regs, recs, b3)
    assert len(fake.chat_requests) == n + 2


def test_corrupt_cache_entries_are_asked_again_and_rewritten(serve, protocol, tmp_path):
    """A truncated entry and one that is not UTF-8 JSON count as misses: those prompts are asked again, the
    answers equal the first run's, and the entries are written anew (issue 20: faults tried on purpose)."""
    fake = serve("good")
    objs, regs, recs = ["mug", "pillow"], ["kitchen", "bedroom"], ["table", "bed"]
    r1 = relevance(objs, regs, recs, get_backend(cfg_for(protocol, fake.url), cache_dir=tmp_path))
    n = len(fake.chat_requests)
    entries = sorted(tmp_path.glob("*/*/*.json"))  # <backend>/<key[:2]>/<key>.json
    assert len(entries) == n >= 2
    entries[0].write_bytes(entries[0].read_bytes()[:20])
    entries[1].write_bytes(b"\xff\xfe\x00garbage")
    b2 = get_backend(cfg_for(protocol, fake.url), cache_dir=tmp_path)
    r2 = relevance(objs, regs, recs, b2)
    assert len(fake.chat_requests) == n + 2 and b2.cache.misses == 2 and b2.cache.hits == n - 2
    assert records_equal(r1, r2)
    assert all(json.loads(p.read_text(encoding="utf-8"))["result"] for p in entries[:2])


def test_ollama_plain_json_mode_on_old_server():
    fake = FakeLLM("ollama", "good", version=None)  # no /api/version: pre-0.5 server
    try:
        b = get_backend(cfg_for("ollama", fake.url))
        b.score_regions("mug", ["kitchen"])
        assert fake.chat_requests[0]["body"]["format"] == "json"
    finally:
        fake.close()


def test_openai_falls_back_to_json_object_mode():
    fake = FakeLLM("openai", "good", refuse_schema=True)
    try:
        b = get_backend(cfg_for("openai", fake.url))
        assert b.score_regions("mug", ["kitchen"]) == {"kitchen": score("kitchen", "mug")}
        modes = [r["body"].get("response_format", {}).get("type") for r in fake.chat_requests]
        assert modes == ["json_schema", "json_object"]
    finally:
        fake.close()


def test_server_backend_needs_model():
    with pytest.raises(StageError, match="semantics.model"):
        get_backend(SemanticsConfig(backend="ollama"))
