"""POST /v1/analysis/stability and /boundary with a velocity filter and a virtual mass (ARCHITECTURE.md, "The
rendered virtual environment"): answers verified by the closed loop with the filter's states, today's requests
unchanged, and every bad input a 422 naming its field."""

from __future__ import annotations

import pytest

from .conftest import LHIFAM_RIGID

STABILITY = "/v1/analysis/stability"
BOUNDARY = "/v1/analysis/boundary"
LOW_PASS_50 = {"kind": "low_pass", "cutoff_hz": 50, "order": 1}


def test_filtered_wall_is_verified(client):
    r = client.post(STABILITY, json={"device": LHIFAM_RIGID, "verify": True,
                                     "controller": {"stiffness": 3000, "damping": 5, "velocity_filter": LOW_PASS_50}})
    assert r.status_code == 200, r.text
    j = r.json()
    assert j["verification"]["verdict"] == "confirmed", j["verification"]
    assert j["verification"]["passivity"]["verdict"] == "confirmed"
    assert j["stable"] is True and j["mass_range"]["min"] < 0 < j["mass_range"]["max"]
    assert j["method"] == "exact"


def test_virtual_mass_without_stiffness(client):
    r = client.post(STABILITY, json={"device": {**LHIFAM_RIGID, "delay": 0.0015}, "verify": True,
                                     "controller": {"damping": 5, "mass": -1.0,
                                                    "velocity_filter": {"kind": "moving_average", "samples": 3}}})
    assert r.status_code == 200, r.text
    j = r.json()
    assert j["critical_stiffness"] > 0 and j["verification"]["verdict"] == "confirmed"
    assert j["mass_range"] is None   # no stiffness: no wall to take the range at


def test_todays_request_has_no_new_field(client):
    j = client.post(STABILITY, json={"device": LHIFAM_RIGID, "controller": {"stiffness": 3000, "damping": 5}}).json()
    assert "mass_range" not in j
    # naming the default rendering answers the same K_cr (the general path agrees with the fast one) and its range
    k = client.post(STABILITY, json={"device": LHIFAM_RIGID,
                                      "controller": {"stiffness": 3000, "damping": 5, "mass": 0}}).json()
    assert k["critical_stiffness"] == pytest.approx(j["critical_stiffness"], rel=1e-12)
    assert k["mass_range"]["min"] < 0 < k["mass_range"]["max"]


def test_boundary_with_a_filter(client):
    r = client.post(BOUNDARY, json={"device": LHIFAM_RIGID, "points": 8, "verify": True,
                                    "controller": {"velocity_filter": LOW_PASS_50}})
    assert r.status_code == 200, r.text
    j = r.json()
    assert j["verification"]["verdict"] == "confirmed", j["verification"]["reason"]
    plain = client.post(BOUNDARY, json={"device": LHIFAM_RIGID, "points": 8}).json()
    assert j["max_stable_damping"] != plain["max_stable_damping"]


@pytest.mark.parametrize("controller,loc", [
    ({"stiffness": 1000, "velocity_filter": {"kind": "low_pass", "cutoff_hz": 500}},
     ["body", "controller", "velocity_filter", "cutoff_hz"]),
    ({"stiffness": 1000, "velocity_filter": {"kind": "moving_average", "samples": 0}},
     ["body", "controller", "velocity_filter", "moving_average", "samples"]),
    ({"stiffness": 1000, "velocity_filter": {"kind": "transfer_function", "numerator": [1000, -999]}},
     ["body", "controller", "velocity_filter", "numerator"]),
    ({"stiffness": 1000, "velocity_filter": {"kind": "transfer_function", "numerator": [2000, -2000]}},
     ["body", "controller", "velocity_filter", "numerator"]),
    ({"stiffness": 1000, "velocity_filter": {"kind": "transfer_function", "numerator": [500, -500],
                                             "denominator": [1, -1.5]}},
     ["body", "controller", "velocity_filter", "denominator"]),
    ({"stiffness": 1000, "mass": 1e13}, ["body", "controller", "mass"]),
    ({"damping": 5}, ["body", "controller", "stiffness"]),
])
def test_bad_filters_are_refused_naming_the_field(client, controller, loc):
    r = client.post(STABILITY, json={"device": LHIFAM_RIGID, "controller": controller})
    assert r.status_code == 422, r.text
    assert loc in [e["loc"] for e in r.json()["detail"]]


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_numbers_are_refused(client, literal):
    for body in ('{"device": {"mass": 5.4, "damping": 3.5}, "controller": {"stiffness": 1, "mass": %s}}',
                 '{"device": {"mass": 5.4, "damping": 3.5}, "controller": {"stiffness": 1, "velocity_filter": '
                 '{"kind": "low_pass", "cutoff_hz": %s}}}'):
        r = client.post(STABILITY, content=body % literal, headers={"content-type": "application/json"})
        assert r.status_code == 422, r.text


def test_other_rungs_refuse_a_filter_naming_method(client):
    for method in ("linear", "grid", "reference"):
        r = client.post(STABILITY, json={"device": LHIFAM_RIGID, "method": method,
                                         "controller": {"stiffness": 1000, "velocity_filter": LOW_PASS_50}})
        assert r.status_code == 422
        assert r.json()["detail"][0]["loc"] == ["body", "method"]


def test_rendered_stable_band_past_b_max_reaches_the_answer_and_verify_confirms_it(client):
    """Issue 34 on the rendered wall: a moving average and a virtual mass past the rendered B_max; the band comes
    from the closed loop with the filter's states, and verify (that closed loop at K) confirms the wall's label."""
    import math

    from tests.optim.stability.test_rendered_band import BANDS

    raw, spec, mass, b, (lo, hi) = BANDS[0]
    k = math.sqrt(lo * hi)
    r = client.post(STABILITY, json={
        "device": raw, "verify": True,
        "controller": {"stiffness": k, "damping": b, "mass": mass, "velocity_filter": spec.model_dump()}})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["critical_stiffness"] == 0.0 and body["stable"] is True
    assert body["stable_band"][0] < k < body["stable_band"][1]
    assert body["verification"]["verdict"] == "confirmed", body["verification"]
