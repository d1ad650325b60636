"""The control API under hostile or sloppy input (issue 12, items 15-17): strict angles,
every settings error at once, auth and size bounds before a body is parsed, bounded pass
searches, the live feed's Origin/Host rules, the OpenAPI description, offline /docs."""

from __future__ import annotations

import asyncio
import json
import re
import threading

import httpx
import pytest
from starlette.websockets import WebSocketDisconnect

from urc.web.security import MAX_BODY_BYTES

from .fake_tracker import FakeTracker
from .test_api import next_status

TOKEN = "s3cret-token"
JSON = {"content-type": "application/json"}


# ----------------------------------------------------------------------- item 15: strict input
@pytest.mark.parametrize("path,body,field", [
    ("/api/goto", '{"az_deg": NaN, "el_deg": 10}', "az_deg"),
    ("/api/goto", '{"az_deg": 10, "el_deg": Infinity}', "el_deg"),
    ("/api/goto", '{"az_deg": -Infinity, "el_deg": 10}', "az_deg"),
    # (1e999 is a JSON number that parses to inf: the 422 echoing it could not be written, a 500)
    ("/api/goto", '{"az_deg": 1e999, "el_deg": 10}', "az_deg"),
    ("/api/goto", '{"az_deg": 10, "el_deg": -1e999}', "el_deg"),
    ("/api/set-position", '{"az_deg": 1e999}', "az_deg"),
    ("/api/track", '{"kind": "azel", "az_deg": 1e999, "el_deg": 10}', "az_deg"),
    ("/api/goto", '{"az_deg": "45", "el_deg": 10}', "az_deg"),
    ("/api/goto", '{"az_deg": true, "el_deg": 10}', "az_deg"),
    ("/api/goto", '{"az_deg": 45, "el_deg": 10, "speed": 2}', "speed"),
    ("/api/goto", '{"az_deg": 45, "el_dge": 10}', "el_dge"),
    ("/api/goto", '{"az_deg": 1e300, "el_deg": 10}', "az_deg"),
    ("/api/set-position", '{"az_deg": "12"}', "az_deg"),
    ("/api/calibration/zero", '{"el_deg": false}', "el_deg"),
    ("/api/track", '{"kind": "azel", "az_deg": 1e300, "el_deg": 10}', "az_deg"),
    ("/api/track", '{"kind": "azel", "az_deg": "10", "el_deg": 10}', "az_deg"),
    ("/api/jog", '{"axis": "az", "direction": 1, "speed": "1"}', "speed"),
    ("/api/stop", '{"axis": "az", "now": true}', "now"),
    ("/api/settings", '{"offsets": {"az_deg": NaN}}', "az_deg"),
    ("/api/settings/validate", '{"offsets": {"az_deg": 1e999}}', "az_deg"),
])
def test_angles_are_finite_numbers_in_range_and_unknown_fields_refused(make_client, path, body, field):
    c = make_client(tracker=FakeTracker())
    before = c.get("/api/status").json()["target_az_deg"]
    r = c.post(path, content=body, headers=JSON)
    assert r.status_code == 422, (path, body, r.status_code, r.text)
    locs = [d["loc"][-1] for d in r.json()["detail"]]
    assert field in locs, r.json()
    assert c.get("/api/status").json()["target_az_deg"] == before   # nothing moved


def test_every_settings_error_is_reported_at_once(make_client):
    c = make_client()
    doc = c.get("/api/settings").json()["config"]
    doc["limits"]["az"]["max_deg"] = 999                           # checked against the profile
    doc["park"]["az_deg"] = 1e9                                     # checked against the limits
    doc["keepout"] = [{"name": "mast", "az_min_deg": 10, "az_max_deg": 20, "el_min_deg": 0,
                       "el_max_deg": "x"}]                          # a type error
    doc["offsets"]["el_deg"] = True
    r = c.post("/api/settings/validate", json=doc)
    assert r.status_code == 422
    keys = {e["key"] for e in r.json()["errors"]}
    assert {"limits.az.max_deg", "park.az_deg", "keepout[0].el_max_deg", "offsets.el_deg"} <= keys, keys
    assert c.post("/api/settings", json=doc).status_code == 422


# ----------------------------------------------------------------------- item 16: auth and size first
def _asgi_post(app, path: str, headers: dict, body: bytes) -> tuple[int, bool]:
    """POST through the raw ASGI interface; returns (status, whether the body was read)."""
    read = []
    sent = []

    async def receive():
        read.append(True)
        return {"type": "http.request", "body": body, "more_body": False}

    async def send(message):
        sent.append(message)

    scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "POST",
             "scheme": "http", "path": path, "raw_path": path.encode(), "query_string": b"",
             "root_path": "", "server": ("127.0.0.1", 8080), "client": ("127.0.0.1", 5000),
             "headers": [(k.lower().encode(), v.encode()) for k, v in headers.items()]}
    asyncio.run(app(scope, receive, send))
    return next(m["status"] for m in sent if m["type"] == "http.response.start"), bool(read)


def test_token_and_origin_are_checked_before_the_body_is_read(make_client):
    c = make_client(api={"host": "0.0.0.0", "token": TOKEN})
    body = b'{"az_deg": 10, "el_deg": 10}'
    big = {"content-type": "application/json", "content-length": str(40 * 2**20), "host": "127.0.0.1:8080"}
    assert _asgi_post(c.app, "/api/goto", big, body) == (401, False)
    foreign = big | {"origin": "http://evil.example", "authorization": f"Bearer {TOKEN}"}
    assert _asgi_post(c.app, "/api/goto", foreign, body) == (403, False)
    ok = {"content-type": "application/json", "content-length": str(len(body)), "host": "127.0.0.1:8080",
          "authorization": f"Bearer {TOKEN}"}
    assert _asgi_post(c.app, "/api/goto", ok, body) == (200, True)


def test_request_bodies_are_bounded(make_client):
    c = make_client()
    doc = c.get("/api/settings").json()["config"]
    doc["padding"] = "x" * (MAX_BODY_BYTES + 10)
    for path in ("/api/settings", "/api/settings/validate", "/api/goto"):
        assert c.post(path, json=doc).status_code == 413, path
    # without a Content-Length (chunked): counted while read
    def chunks():
        for _ in range(MAX_BODY_BYTES // 1000 + 2):
            yield b" " * 1000
    assert c.post("/api/goto", content=chunks(), headers=JSON).status_code == 413


class SlowTracker(FakeTracker):
    """A pass search that runs until the test releases it, and records how many run at once."""

    def __init__(self):
        super().__init__()
        self.release = threading.Event()
        self.running = 0
        self.max_running = 0
        self.lock = threading.Lock()

    def passes(self, hours, min_el_deg):
        with self.lock:
            self.running += 1
            self.max_running = max(self.max_running, self.running)
        self.release.wait(30.0)
        with self.lock:
            self.running -= 1
        return super().passes(hours, min_el_deg)


def test_pass_searches_are_bounded_and_keep_the_api_responsive(make_client):
    trk = SlowTracker()
    c = make_client(tracker=trk)

    async def scenario():
        transport = httpx.ASGITransport(app=c.app)
        async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1:8080") as http:
            # a flood of different (unauthenticated) searches, plus the same one many times
            asks = [http.get(f"/api/passes?hours={h}&min_el={e}") for h in (24, 48, 72) for e in (0, 5, 30)]
            asks += [http.get("/api/passes?hours=24&min_el=10") for _ in range(20)]
            flood = asyncio.gather(*asks)
            for _ in range(500):                      # until a search is under way
                if trk.running:
                    break
                await asyncio.sleep(0.01)
            # answered while that search still runs: the event loop is not the searcher's
            status = await asyncio.wait_for(http.get("/api/status"), 10.0)
            searching = trk.running
            trk.release.set()
            answers = await flood
        return status, searching, answers
    status, searching, answers = asyncio.run(scenario())
    codes = [a.status_code for a in answers]
    assert all(a.headers["retry-after"] == "30" for a in answers if a.status_code == 503)
    assert status.status_code == 200 and searching == 1       # the event loop was not blocked
    assert trk.max_running == 1                                  # one search at a time
    assert set(codes) <= {200, 503} and 503 in codes             # the excess is refused at once
    same = codes[9:]
    assert all(code == same[0] for code in same)                 # the same question shares one search
    calls = [call for call in trk.calls if call[0] == "passes"]
    assert len(calls) <= 4, calls
    assert c.get("/api/passes?hours=500").status_code == 422     # the size of a search is bounded


# ----------------------------------------------------------------------- item 17: live feed, OpenAPI, docs
@pytest.mark.parametrize("origin,host,ok", [
    ("http://evil.example", "127.0.0.1:8080", False),
    ("http://rebound.example:8080", "rebound.example:8080", False),
    ("null", "127.0.0.1:8080", False),
    ("http://127.0.0.1:8080", "127.0.0.1:8080", True),
    (None, "127.0.0.1:8080", True),                                # not a browser
])
def test_live_feed_applies_the_origin_and_host_rules(make_client, origin, host, ok):
    c = make_client()
    headers = {"host": host} | ({"origin": origin} if origin else {})
    if ok:
        with c.websocket_connect("/api/ws", headers=headers) as ws:
            assert next_status(ws)["type"] == "status"
    else:
        with pytest.raises(WebSocketDisconnect) as exc:
            with c.websocket_connect("/api/ws", headers=headers) as ws:
                ws.receive_json()
        assert exc.value.code == 1008


def test_openapi_declares_the_token_and_the_refusals(make_client):
    c = make_client(tracker=FakeTracker())
    spec = c.get("/openapi.json").json()
    schemes = spec["components"]["securitySchemes"]
    assert any(s["type"] == "http" and s["scheme"] == "bearer" for s in schemes.values())
    for path in ("/api/goto", "/api/stop", "/api/jog", "/api/settings", "/api/calibration/zero",
                 "/api/track", "/api/sim/fault"):
        op = spec["paths"][path]["post"]
        assert op.get("security"), path
        for code in ("401", "403", "409", "422"):
            assert "$ref" in json.dumps(op["responses"][code]["content"]), (path, code)
        ok = op["responses"]["200"]["content"]["application/json"]["schema"]
        assert ok != {} and ok.get("type") != "object" or ok.get("properties"), (path, ok)
    assert "security" not in spec["paths"]["/api/status"]["get"]
    # the views' answers are described, and the descriptions name every key they have
    for path, doc in (("/api/status", "StatusDoc"), ("/api/info", "InfoDoc"), ("/api/history", "HistoryDoc")):
        schema = spec["paths"][path]["get"]["responses"]["200"]["content"]["application/json"]["schema"]
        assert schema == {"$ref": f"#/components/schemas/{doc}"}, (path, schema)
        described = set(spec["components"]["schemas"][doc]["properties"])
        assert set(c.get(path).json()) == described, path
    assert "security" not in spec["paths"]["/api/settings/validate"]["post"]


def test_docs_are_served_without_the_internet(make_client):
    c = make_client()
    for page in ("/docs", "/redoc"):
        html = c.get(page).text
        refs = re.findall(r"""(?:src|href|url)\s*[=:]\s*['"]([^'"]+)['"]""", html)
        assert refs, page
        for ref in refs:
            assert not re.match(r"(https?:)?//", ref), (page, ref)
            assert c.get(ref).status_code == 200, (page, ref)


# ----------------------------------------------------------------------- issue 22: reads, token scheme
@pytest.mark.parametrize("path", ["/", "/api/status", "/api/info", "/api/settings", "/api/history",
                                  "/openapi.json", "/docs", "/redoc", "/static/js/main.js"])
def test_a_loopback_api_answers_no_read_under_a_foreign_host_name(make_client, path):
    """DNS rebinding: a page of evil.example whose name was re-pointed at 127.0.0.1 asks
    under its own name (same origin, so no Origin header on a GET): nothing is answered.
    Asked under a loopback name, the same read works."""
    c = make_client(tracker=FakeTracker(), station={"lat_deg": 58.4, "lon_deg": 26.7})
    for host in ("evil.example:8080", "rebound.example", "127.0.0.1.evil.example:8080", "10.0.0.5:8080"):
        r = c.get(path, headers={"host": host})
        assert r.status_code == 403, (path, host, r.status_code)
        assert "58.4" not in r.text and "loopback only" in r.json()["detail"]
        assert r.headers["x-frame-options"] == "DENY"           # still a response of this API
    for host in ("127.0.0.1:8080", "localhost:8080", "[::1]:8080", "station.localhost"):
        assert c.get(path, headers={"host": host}).status_code == 200, (path, host)


def test_a_remote_listener_answers_reads_under_any_name(make_client):
    """Listening beyond loopback, the station's own name is unknown: reads are answered
    under any name (with a token: issue 36.8)."""
    c = make_client(api={"host": "0.0.0.0", "token": TOKEN})
    auth = {"authorization": f"Bearer {TOKEN}"}
    assert c.get("/api/status", headers={"host": "station.example:8080", **auth}).status_code == 200


@pytest.mark.parametrize("authorization,ok", [
    (f"Bearer {TOKEN}", True),
    (f"bearer {TOKEN}", True),                  # the scheme's name is case-insensitive (RFC 7235)
    (f"BEARER  {TOKEN} ", True),
    (TOKEN, False),                             # a bare token is not a bearer token
    (f"Basic {TOKEN}", False),
    (f"Bearer{TOKEN}", False),
    ("Bearer ", False),
    (f"Bearer {TOKEN}x", False),
])
def test_the_token_is_a_bearer_token(make_client, authorization, ok):
    c = make_client(api={"host": "0.0.0.0", "token": TOKEN})
    r = c.post("/api/stop", json={}, headers={"authorization": authorization})
    assert r.status_code == (200 if ok else 401), (authorization, r.text)
