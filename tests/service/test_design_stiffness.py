"""POST /v1/design/stiffness over HTTP."""

import math
import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from fastapi.testclient import TestClient

from service.app import create_app


@pytest.fixture(scope="module")
def client():
    return TestClient(create_app())


URL = "/v1/design/stiffness"
LH_RIGID = {"preset": "lhifam", "cable": None}


def test_lhifam_rigid_at_6_db(client):
    r = client.post(URL, json={"device": LH_RIGID, "requirements": {"min_gain_margin_db": 6}})
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "optimal"
    assert body["gain_margin_db"] >= 6 - 1e-6
    assert body["gain_margin_db"] == pytest.approx(20 * math.log10(body["critical_stiffness"] / body["stiffness"]),
                                                   abs=1e-6)
    for key in ("stiffness", "damping", "critical_stiffness", "active_constraints", "solver", "elapsed_ms",
                "crossover_frequency", "linear_estimate", "linear_estimate_error", "sensitivities"):
        assert key in body
    assert body["active_constraints"] == ["min_gain_margin_db"]
    assert {s["parameter"] for s in body["sensitivities"]} == {"damping", "delay", "sample_time", "mass"}
    assert body["solver"]["return_status"] == "Solve_Succeeded"


def test_default_requirements(client):
    r = client.post(URL, json={"device": {"mass": 1.0, "damping": 2.0, "delay": 0.0015}})
    assert r.status_code == 200 and r.json()["status"] == "optimal"
    assert r.json()["gain_margin_db"] >= 6 - 1e-6


def test_infeasible_is_a_200_with_a_reason(client):
    r = client.post(URL, json={"device": {"mass": 1.0, "damping": 0.0, "delay": 0.002},
                               "requirements": {"passivity": True}})
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "infeasible" and body["reason"] and body["stiffness"] is None


@pytest.mark.parametrize("requirements,field", [
    ({"min_gain_margin_db": -1}, "min_gain_margin_db"),
    ({"min_gain_margin_db": 500}, "min_gain_margin_db"),
    ({"max_damping": 0}, "max_damping"),
    ({"max_stiffness": -5}, "max_stiffness"),
    ({"max_force": 3}, "max_penetration"),
    ({"max_penetration": 0.001}, "max_force"),
    ({"quantization": 1e-5}, "max_force_noise"),
    ({"max_force_noise": 0.1}, "quantization"),
    ({"bogus": 1}, "bogus"),
    ({"passivity": "maybe"}, "passivity"),
])
def test_bad_requirements_answer_422_naming_the_field(client, requirements, field):
    r = client.post(URL, json={"device": LH_RIGID, "requirements": requirements})
    assert r.status_code == 422
    assert field in str(r.json()["detail"])


def test_bad_device_answers_422(client):
    r = client.post(URL, json={"device": {"mass": -1, "damping": 1}})
    assert r.status_code == 422 and "mass" in str(r.json()["detail"])


@pytest.mark.parametrize("token", [b"NaN", b"Infinity", b"-Infinity", b"1e400"])
def test_non_finite_input_is_422_not_500(client, token):
    r = client.post(URL, content=b'{"device": {"preset": "lhifam"}, "requirements": {"max_damping": ' + token + b'}}',
               headers={"content-type": "application/json"})
    assert r.status_code == 422
    assert "max_damping" in str(r.json()["detail"])
