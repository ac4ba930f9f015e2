"""A structural fuzzer of our own, beside schemathesis (test_fuzz_api.py): every node of every route's example
body (each leaf, each object, each list, and a new unknown key in each object) is replaced in turn by each
hostile value below (deep nesting, long strings, lone surrogates, huge and tiny numbers, wrong shapes), and
every query and path parameter of the GET routes likewise.  0 × 5xx: each answer is 2xx or a 4xx whose body
is JSON naming where the problem is (the documented 503 of the time budget is allowed, as in test_fuzz_api).
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Any, Iterator

import pytest

from service.app import create_app
from service.settings import Settings

from .test_input_abuse import body_operations

pytestmark = pytest.mark.slow

_STORE = Path(tempfile.mkdtemp(prefix="zwidth-structural-")) / "studies.db"
_BUDGET_MESSAGES = ("the computation did not finish within the request time budget",
                    "no compute worker became free within the request time budget")


def _nested(depth: int) -> Any:
    leaf: Any = 1.0
    for i in range(depth):
        leaf = {"a": leaf} if i % 2 else [leaf]
    return leaf


#: Refused by service.body_guard wherever they are: tried at one place per route only.
ANYWHERE = {"deep-70", "deep-5000", "surrogate", "surrogate-in-key"}
#: (name, JSON text) of each hostile value; text, because "\ud800" must reach the server as its escape.
HOSTILE: list[tuple[str, str]] = [
    ("deep-70", json.dumps(_nested(70))),
    ("deep-60", json.dumps(_nested(60))),
    ("deep-5000", "[" * 5000 + "]" * 5000),
    ("long-string", json.dumps("x" * 100_000)),
    ("long-key", json.dumps({"k" * 50_000: 1})),
    ("surrogate", '"\\ud800"'),
    ("surrogate-in-key", '{"\\udc00": 1}'),
    ("int-2^63", str(2**63)),
    ("int-38-digits", "9" * 38),
    ("int-minus-38-digits", "-" + "9" * 38),
    ("int-400-digits", "1" * 400),
    ("float-max", "1.7976931348623157e308"),
    ("float-tiny", "5e-324"),
    ("float-minus-zero", "-0.0"),
    ("null", "null"),
    ("true", "true"),
    ("empty-string", '""'),
    ("empty-list", "[]"),
    ("empty-object", "{}"),
    ("list-of-10k", json.dumps([1.0] * 10_000)),
]

_MARK = "\x00HOSTILE\x00"


def _paths(node: Any, at: tuple = ()) -> Iterator[tuple]:
    """Every node of a JSON document (the root excluded), and a new key in every object."""
    if isinstance(node, dict):
        yield at + ("zz_new",)
        for k, v in node.items():
            yield at + (k,)
            yield from _paths(v, at + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node[:1]):
            yield at + (i,)
            yield from _paths(v, at + (i,))


def _hostile_body(example: dict, path: tuple, text: str) -> bytes:
    doc = json.loads(json.dumps(example))
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = _MARK
    return json.dumps(doc).replace(json.dumps(_MARK), text).encode()


@pytest.fixture(scope="module")
def client():
    from fastapi.testclient import TestClient

    app = create_app(Settings(prestart_workers=False, access_log=False, request_timeout=2.0,
                              database_url=f"sqlite:///{_STORE}"))
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c
        # The studies the fuzzer created are not the subject: cancel them so the shutdown does not wait.
        for st in c.get("/v1/studies?limit=1000").json()["studies"]:
            c.delete(f"/v1/studies/{st['id']}")


def _check(r, what: str, stats: dict) -> None:
    stats[r.status_code] = stats.get(r.status_code, 0) + 1
    if r.status_code == 503:
        detail = r.json().get("detail", "")
        assert isinstance(detail, str) and detail.startswith(_BUDGET_MESSAGES), (what, r.text[:300])
        return
    assert r.status_code < 500, (what, r.status_code, r.text[:300])
    body = r.json() if r.headers.get("content-type", "").startswith("application/json") else None
    if 400 <= r.status_code < 500:
        assert body is not None and "detail" in body, (what, r.text[:300])
        assert len(r.content) < 20_000, (what, len(r.content))  # the echo is capped
    if r.status_code == 422 and isinstance(body["detail"], list):
        assert all(e["loc"] and e["loc"][0] in ("body", "query", "path", "header") for e in body["detail"]), what


def test_every_node_of_every_body_with_every_hostile_value(client):
    spec = client.get("/openapi.json").json()
    stats: dict[int, int] = {}
    n, t0 = 0, time.monotonic()
    for route, _, example in body_operations(spec):
        for i, path in enumerate(_paths(example)):
            for name, text in HOSTILE:
                if name in ANYWHERE and i > 0:
                    continue
                r = client.post(route, content=_hostile_body(example, path, text),
                                headers={"content-type": "application/json"})
                _check(r, f"{route} {'.'.join(map(str, path))} = {name}", stats)
                n += 1
    print(f"structural fuzz: {n} requests in {time.monotonic() - t0:.1f} s, by status {stats}")
    assert n >= 1500
    assert stats.get(503, 0) <= 0.02 * n, stats


_QUERY_VALUES = ["9" * 38, "-" + "9" * 38, str(2**63), "1e400", "nan", "-0", "x" * 10_000, "%ED%A0%80", "%00",
                 "%FF%FE", "true", ""]


def test_every_query_and_path_parameter_with_hostile_values(client):
    from .conftest import LHIFAM_RIGID

    sid = client.post("/v1/studies", json={"problem": "stability", "base": {"device": LHIFAM_RIGID},
                                           "sweep": {"device.delay": [0.0, 0.001]}}).json()["id"]
    spec = client.get("/openapi.json").json()
    stats: dict[int, int] = {}
    n, slow = 0, []
    for path, ops in spec["paths"].items():
        for method, op in ops.items():
            params = op.get("parameters", [])
            if not params:
                continue
            for p in params:
                for value in _QUERY_VALUES:
                    url = path.replace("{study_id}", value if p["in"] == "path" else sid)
                    query = f"?{p['name']}={value}" if p["in"] == "query" else ""
                    if method == "delete":
                        continue  # cancelling and purging are not input-parsing paths; keep the study
                    t = time.monotonic()
                    r = client.request(method.upper(), url + query,
                                       **({"json": {"device": LHIFAM_RIGID}} if method == "post" else {}))
                    _check(r, f"{method} {path} {p['name']}={value[:20]}", stats)
                    slow.append((time.monotonic() - t, f"{method} {path} {p['name']}={value[:20]}"))
                    n += 1
    print(f"parameter fuzz: {n} requests, by status {stats}", sorted(slow)[-5:])
    assert n >= 100
