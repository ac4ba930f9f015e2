"""POST /v1/design/stiffness with a rendered wall (issue 30): the fixed filter, the designed cutoff's bad input
(422 naming the field); today's answers without the new block are tests/service/test_recorded_answers.py's."""

from __future__ import annotations

import pytest

from tests.service.conftest import make_client

DEV = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
PATH = "/v1/design/stiffness"


@pytest.fixture(scope="module")
def client():
    # a rendered design runs in a worker for seconds; a loaded machine (the suite beside other work) needs the room
    with make_client(request_timeout=300.0) as c:
        yield c


def _design(lo=5, hi=400, **kw):
    return {"kind": "low_pass", "design": True, "order": 1, "min_cutoff_hz": lo, "max_cutoff_hz": hi, **kw}


@pytest.mark.parametrize(("body", "loc"), [
    ({"requirements": {"velocity_filter": _design(hi=500)}}, ["requirements", "velocity_filter", "max_cutoff_hz"]),
    ({"requirements": {"velocity_filter": _design(hi=800)}}, ["requirements", "velocity_filter", "max_cutoff_hz"]),
    ({"requirements": {"velocity_filter": _design(lo=600, hi=None)}},
     ["requirements", "velocity_filter", "min_cutoff_hz"]),
    ({"requirements": {"velocity_filter": _design(lo=50, hi=5)}}, ["max_cutoff_hz"]),
    ({"requirements": {"velocity_filter": _design(lo=50, hi=50)}}, ["max_cutoff_hz"]),
    ({"requirements": {"velocity_filter": {"kind": "low_pass", "cutoff_hz": 500}}},
     ["requirements", "velocity_filter", "cutoff_hz"]),
    ({"controller": {"velocity_filter": {"kind": "low_pass", "cutoff_hz": 600}}},
     ["controller", "velocity_filter", "cutoff_hz"]),
    ({"controller": {"velocity_filter": {"kind": "moving_average", "samples": 0}}}, ["samples"]),
    ({"controller": {"velocity_filter": {"kind": "low_pass", "cutoff_hz": 50}},
      "requirements": {"velocity_filter": _design()}}, ["requirements", "velocity_filter"]),
    ({"requirements": {"max_force_noise_rms": 0.1}}, ["requirements", "quantization"]),
    ({"requirements": {"velocity_filter": _design(), "quantization": 1e-5, "max_force_noise": 0.5},
      "method": "grid"}, ["method"]),
])
def test_bad_input_is_a_422_naming_the_field(client, body, loc):
    r = client.post(PATH, json={"device": DEV, **body})
    assert r.status_code == 422, r.text
    got = r.json()["detail"][0]["loc"]
    assert got[-len(loc):] == loc, got


@pytest.mark.parametrize("text", ['"min_cutoff_hz": NaN', '"max_cutoff_hz": Infinity', '"order": 3'])
def test_non_numbers_in_the_cutoff_range(client, text):
    body = ('{"device": {"mass": 5.4, "damping": 3.5}, "requirements": {"velocity_filter": {"kind": "low_pass", '
            f'"design": true, {text}}}}}}}')
    r = client.post(PATH, content=body, headers={"content-type": "application/json"})
    assert r.status_code == 422, r.text
    assert "velocity_filter" in r.json()["detail"][0]["loc"]


def test_fixed_filter_design_with_its_noise(client):
    body = {"device": DEV, "controller": {"velocity_filter": {"kind": "low_pass", "cutoff_hz": 50, "order": 1}},
            "requirements": {"quantization": 1e-5, "max_force_noise": 0.5}, "verify": True}
    r = client.post(PATH, json=body)
    assert r.status_code == 200, r.text
    j = r.json()
    assert j["status"] == "optimal" and j["exact_check"]["statement"].startswith("safe")
    assert j["verification"]["verdict"] == "confirmed"
    assert j["rendered"]["kind"] == "low_pass" and not j["rendered"]["designed"]
    assert j["rendered"]["force_step"] == pytest.approx(0.5, rel=1e-9)
    assert "max_force_noise" in j["active_constraints"]
