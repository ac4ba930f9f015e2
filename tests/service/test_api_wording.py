"""Wording of the API a newcomer reads (issue 29): the delay limit with its unit, /redoc without Sphinx roles, and
one kind of name for every operation in /docs."""

from __future__ import annotations

import json
import re

import pytest

from service.route_names import NAMES, plain_descriptions
from tests.service.conftest import make_client


@pytest.fixture(scope="module")
def client():
    with make_client() as c:
        yield c


@pytest.fixture(scope="module")
def openapi(client) -> dict:
    return client.get("/openapi.json").json()


@pytest.mark.parametrize(("device", "seconds"), [({"preset": "lhifam", "delay": 1e6}, "10 s"),
                                                  ({"mass": 1, "damping": 1, "sample_time": 1e-4, "delay": 2}, "1 s"),
                                                  ({"preset": "lhifam", "delay": 1e300}, "10 s")])
def test_the_delay_limit_says_samples_and_the_seconds_they_mean(client, device, seconds):
    r = client.post("/v1/analysis/stability", json={"device": device, "controller": {"stiffness": 1000}})
    assert r.status_code == 422
    (err,) = r.json()["detail"]
    assert err["loc"] == ["body", "device", "delay"]
    assert "delay/sample_time ≤ 10000 samples" in err["msg"] and f"delay ≤ {seconds} at sample_time" in err["msg"]
    assert "less than or equal to" not in err["msg"]


def test_a_delay_within_the_limit_is_accepted(client):
    r = client.post("/v1/analysis/stability", json={"device": {"preset": "lhifam", "delay": 0.002},
                                                     "controller": {"stiffness": 1000}})
    assert r.status_code == 200


def test_openapi_descriptions_have_no_sphinx_roles(openapi):
    text = json.dumps(openapi, ensure_ascii=False)
    assert not re.search(r":[a-z]+:`", text), re.search(r".{40}:[a-z]+:`.{20}", text)
    assert "``" not in text
    device = openapi["components"]["schemas"]["Device"]["description"]
    assert "`PRESETS`" in device


def test_plain_descriptions_rewrites_roles_as_code():
    doc = {"description": "see :data:`PRESETS`, :class:`~models.device.Device` and ``x``",
           "properties": {"a": {"description": ":py:func:`f`"}}, "example": ":data:`kept`"}
    assert plain_descriptions(doc) == {"description": "see `PRESETS`, `models.device.Device` and `x`",
                                       "properties": {"a": {"description": "`f`"}}, "example": ":data:`kept`"}


def test_every_operation_has_a_sentence_summary_and_a_chosen_operation_id(openapi):
    ids = []
    for path, item in openapi["paths"].items():
        for method, op in item.items():
            summary, op_id = op.get("summary", ""), op.get("operationId", "")
            where = f"{method.upper()} {path}"
            assert not op_id.endswith(re.sub(r"\W", "_", path) + "_" + method), f"{where}: FastAPI's generated id"
            assert re.fullmatch(r"[a-z]+(_[a-z]+)*", op_id), where
            assert not summary.endswith((" Route", " Plot")) and " " in summary, f"{where}: {summary!r}"
            assert summary[0].isupper() and summary != summary.title(), f"{where}: {summary!r} (title case)"
            ids.append(op_id)
    assert len(ids) == len(set(ids))


def test_every_named_route_exists(openapi):
    """A renamed or removed route leaves no stale name behind."""
    ops = {(m.upper(), p) for p, item in openapi["paths"].items() for m in item}
    assert set(NAMES) <= ops
