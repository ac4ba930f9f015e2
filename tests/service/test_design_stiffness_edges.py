"""Issue 17 over HTTP: the undamped cable, zero damping, the input limits and the back-off of a design."""

import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from fastapi.testclient import TestClient

from service.app import create_app

UNDAMPED = {"preset": "lhifam", "cable": {"motor_damping": 0, "body_damping": 0, "damping": 0}}


@pytest.fixture(scope="module")
def client():
    return TestClient(create_app())


def test_undamped_cable_is_analysed(client):
    """Was a 422 "outside the numerically representable range (invalid value encountered in matmul)"."""
    r = client.post("/v1/analysis/stability",
                    json={"device": UNDAMPED, "controller": {"stiffness": 100, "damping": 0.5}})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["critical_stiffness"] == pytest.approx(861.5237197778189, rel=1e-9)
    assert body["stable"] is True and body["passive"] is False


def test_undamped_cable_is_designed(client):
    r = client.post("/v1/design/stiffness", json={"device": UNDAMPED})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["status"] == "optimal" and body["damping"] > 0 and body["back_off"] == 1e-8
    check = client.post("/v1/analysis/stability", json={"device": UNDAMPED, "controller": {
        "stiffness": body["stiffness"], "damping": body["damping"]}}).json()
    assert check["stable"] is True and check["gain_margin_db"] >= 6.0


def test_undamped_cable_with_passivity_is_infeasible_with_the_reason(client):
    body = client.post("/v1/design/stiffness", json={"device": UNDAMPED, "requirements": {"passivity": True}}).json()
    assert body["status"] == "infeasible" and "passivity is impossible" in body["reason"]


def test_zero_margin_design_is_analysed_stable(client):
    dev = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
    body = client.post("/v1/design/stiffness", json={"device": dev, "requirements": {"min_gain_margin_db": 0}}).json()
    assert body["status"] == "optimal" and body["stiffness"] < body["critical_stiffness"]
    check = client.post("/v1/analysis/stability", json={"device": dev, "controller": {
        "stiffness": body["stiffness"], "damping": body["damping"]}}).json()
    assert check["stable"] is True


def test_sample_time_limit_design_is_not_failed(client):
    dev = {"mass": 5.4, "damping": 3.5, "sample_time": 1.0}
    body = client.post("/v1/design/stiffness", json={"device": dev}).json()
    assert body["status"] == "optimal", body["reason"]
    assert "pydantic" not in (body["sensitivity_note"] or "") and len(body["sensitivities"]) == 4


@pytest.mark.parametrize("method", ["linear", "grid", "exact"])
def test_undamped_cable_on_every_cheap_rung(client, method):
    """The linear rung divided by Q = 0 (an undamped mode's peak): its estimate is now null (unbounded)."""
    r = client.post("/v1/analysis/stability", json={"device": UNDAMPED, "method": method,
                                                    "controller": {"stiffness": 100, "damping": 0.5}})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["critical_stiffness"] > 0
    if method != "exact":
        assert body["error_estimate"] is None       # unbounded: an undamped mode the rung cannot vouch for
