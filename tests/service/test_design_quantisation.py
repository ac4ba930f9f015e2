"""POST /v1/design/hardware with free = encoder_resolution | coulomb_friction (issue 31): the answer in closed form
by hand, its exact check by the nonlinear analysis, the counts over the travel, and the refusals."""

from __future__ import annotations

import math

import pytest

from .conftest import make_client

DEV = {"mass": 0.2, "damping": 25.0, "sample_time": 0.001}      # 2b/T = 50 kN/m


@pytest.fixture(scope="module")
def client():
    with make_client() as c:
        yield c


def _design(client, device, free, target=None, **extra):
    body = {"device": device, "target": target or {"stiffness": 20000}, "free": free, **extra}
    return client.post("/v1/design/hardware", json=body)


def test_what_encoder_for_20_kn_per_m(client):
    r = _design(client, {**DEV, "coulomb_friction": 0.1, "travel": 0.1}, "encoder_resolution")
    assert r.status_code == 200, r.text
    body = r.json()
    q = body["quantisation"]
    # Abbott & Okamura by hand: q* = 2f_c/K_t = 2·0.1/20000 = 10 µm; 0.1 m of travel / 10 µm = 10,000 counts
    assert body["status"] == "optimal" and body["direction"] == "max"
    assert math.isclose(body["value"], 1e-5, rel_tol=1e-12)
    assert math.isclose(q["counts_over_travel"], 1e4, rel_tol=1e-12)
    assert q["covered"] is True and "Abbott & Okamura" in q["source"]
    # the exact check: passive at q* with the limit K_t, not passive 1 % coarser
    assert q["confirmed"] is True
    assert q["at_value"]["regime"] == "passive"
    assert math.isclose(q["at_value"]["passive_stiffness_limit"], 20000, rel_tol=1e-12)
    assert q["looser"]["regime"] != "passive"


def test_the_friction_a_wall_needs(client):
    r = _design(client, {**DEV, "encoder_resolution": 2e-5}, "coulomb_friction")
    body = r.json()
    assert r.status_code == 200 and body["status"] == "optimal" and body["direction"] == "min"
    assert math.isclose(body["value"], 20000 * 2e-5 / 2, rel_tol=1e-12)    # K_t·q/2 = 0.2 N
    assert body["quantisation"]["confirmed"] is True
    assert body["quantisation"]["counts_over_travel"] is None


def test_out_of_reach_of_every_encoder(client):
    # the sampling term 2b/T = 10 kN/m < K_t: no encoder makes the spring passive
    r = _design(client, {**DEV, "damping": 5.0, "coulomb_friction": 0.1}, "encoder_resolution")
    body = r.json()
    assert r.status_code == 200 and body["status"] == "infeasible" and body["value"] is None
    assert "sampling term" in body["reason"]


def test_without_friction_no_encoder_answers(client):
    body = _design(client, DEV, "encoder_resolution").json()
    assert body["status"] == "infeasible" and "friction" in body["reason"]


@pytest.mark.parametrize("device, free, extra, field", [
    ({**DEV, "encoder_resolution": 0.0}, "coulomb_friction", {}, "encoder_resolution"),
    ({**DEV, "encoder_resolution": -1e-5}, "coulomb_friction", {}, "encoder_resolution"),
    ({**DEV, "encoder_resolution": 0.5, "travel": 0.1}, "coulomb_friction", {}, "encoder_resolution"),
    ({**DEV, "coulomb_friction": -0.1}, "encoder_resolution", {}, "coulomb_friction"),
    (DEV, "coulomb_friction", {}, "encoder_resolution"),
    ({**DEV, "coulomb_friction": 0.1}, "encoder_resolution", {"range": {"min": 1e-6, "max": 1e-4}}, "range"),
    ({**DEV, "coulomb_friction": 0.1}, "encoder_resolution", {"target": {"apparent_mass": 0.1}}, "target"),
])
def test_bad_input_answers_422_naming_the_field(client, device, free, extra, field):
    target = extra.pop("target", None)
    r = _design(client, device, free, target, **extra)
    assert r.status_code == 422, r.text
    assert field in r.text


def test_nan_is_refused(client):
    r = client.post("/v1/design/hardware", content='{"device": {"mass": 0.2, "damping": 25, "coulomb_friction": NaN}, '
                    '"target": {"stiffness": 20000}, "free": "encoder_resolution"}',
                    headers={"content-type": "application/json"})
    assert r.status_code == 422 and "coulomb_friction" in r.text


def test_an_encoder_coarser_than_the_travel_is_capped_at_it(client):
    # 2f_c/K_t = 100 µm > the 1 µm travel: any encoder with a count within the travel keeps the wall passive
    body = _design(client, {**DEV, "coulomb_friction": 0.1, "travel": 1e-6}, "encoder_resolution", {"stiffness": 2000}).json()
    assert body["status"] == "optimal" and body["value"] == 1e-6
    assert body["quantisation"]["counts_over_travel"] == 1.0 and body["quantisation"]["confirmed"] is True
    assert body["quantisation"]["looser"] is None and "travel" in body["reason"]
