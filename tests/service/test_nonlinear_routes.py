"""Issue 31 over HTTP: device.encoder_resolution / coulomb_friction / travel, the ``nonlinear`` block of
/v1/analysis/stability, and the refusals (422 naming the field)."""

from __future__ import annotations

import math

import pytest

from .conftest import make_client

SMALL = {"mass": 0.2, "damping": 0.5, "sample_time": 0.001}


@pytest.fixture(scope="module")
def client():
    with make_client() as c:
        yield c


def _post(client, path, body):
    return client.post(path, json=body)


def test_without_the_fields_the_answer_has_no_nonlinear_block(client):
    r = _post(client, "/v1/analysis/stability", {"device": SMALL, "controller": {"stiffness": 500}})
    assert r.status_code == 200
    assert "nonlinear" not in r.json()


def test_the_abbott_okamura_limit_in_the_theorems_case(client):
    dev = {**SMALL, "encoder_resolution": 1e-5, "coulomb_friction": 0.004}
    r = _post(client, "/v1/analysis/stability", {"device": dev, "controller": {"stiffness": 500}})
    assert r.status_code == 200, r.text
    nl = r.json()["nonlinear"]
    # min(2b/T, 2f_c/q) = min(1000, 800) by hand
    assert math.isclose(nl["passive_stiffness_limit"], 800.0, rel_tol=1e-12)
    assert nl["binding"] == "quantization" and nl["covered"] is True
    assert "Abbott & Okamura" in nl["source"]
    assert nl["regime"] == "passive"


def test_outside_the_theorem_covered_is_false(client):
    dev = {**SMALL, "encoder_resolution": 1e-5, "coulomb_friction": 0.004, "delay": 0.001}
    r = _post(client, "/v1/analysis/stability", {"device": dev, "controller": {"stiffness": 300, "damping": 0.1}})
    assert r.status_code == 200, r.text
    nl = r.json()["nonlinear"]
    assert nl["covered"] is False and "extension" in nl["source"]


def test_above_k_cr_the_regime_is_unstable(client):
    dev = {**SMALL, "coulomb_friction": 0.004}
    r = _post(client, "/v1/analysis/stability", {"device": dev, "controller": {"stiffness": 1500}})
    body = r.json()
    assert body["stable"] is False and body["nonlinear"]["regime"] == "unstable"
    assert body["nonlinear"]["quantization_term"] is None   # no encoder: 2f_c/q is infinite


@pytest.mark.parametrize("device, field", [
    ({**SMALL, "encoder_resolution": 0.0}, "encoder_resolution"),
    ({**SMALL, "encoder_resolution": -1e-5}, "encoder_resolution"),
    ({**SMALL, "encoder_resolution": 0.2, "travel": 0.1}, "encoder_resolution"),
    ({**SMALL, "coulomb_friction": -0.1}, "coulomb_friction"),
    ({**SMALL, "travel": 0.0}, "travel"),
])
def test_bad_fields_answer_422_naming_them(client, device, field):
    r = _post(client, "/v1/analysis/stability", {"device": device})
    assert r.status_code == 422, r.text
    assert field in r.text


def test_nan_is_refused(client):
    r = client.post("/v1/analysis/stability", content='{"device": {"mass": 0.2, "damping": 0.5, '
                    '"coulomb_friction": NaN}}', headers={"content-type": "application/json"})
    assert r.status_code == 422
    assert "coulomb_friction" in r.text


def test_a_quantization_effect_without_a_resolution_is_refused(client):
    scene = {"experiment": "release", "duration": 0.1, "controller": {"stiffness": 500},
             "initial": {"position": 1e-3}, "effects": {"quantization": {}}}
    r = _post(client, "/v1/simulate", {"device": SMALL, "scene": scene})
    assert r.status_code == 422, r.text
    assert r.json()["detail"][0]["loc"] == ["body", "scene", "effects", "quantization"]
    r = _post(client, "/v1/simulate", {"device": {**SMALL, "encoder_resolution": 1e-5}, "scene": scene})
    assert r.status_code == 200, r.text
    assert "quantization" in r.json()["effects_simulated"]


def test_the_simulator_reads_the_devices_friction(client):
    scene = {"experiment": "release", "duration": 0.2, "controller": {"stiffness": 500},
             "initial": {"position": 1e-3}, "effects": {"coulomb_friction": {}}}
    r = _post(client, "/v1/simulate", {"device": SMALL, "scene": scene})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "scene", "effects", "coulomb_friction"]
    named = _post(client, "/v1/simulate", {"device": SMALL, "scene": {**scene, "effects": {"coulomb_friction":
                                                                                            {"force": 0.05}}}})
    from_device = _post(client, "/v1/simulate", {"device": {**SMALL, "coulomb_friction": 0.05}, "scene": scene})
    assert named.status_code == from_device.status_code == 200
    assert named.json()["trajectory"]["motor_position"] == from_device.json()["trajectory"]["motor_position"]


@pytest.mark.slow
def test_verify_runs_the_audit_and_the_release(client):
    dev = {**SMALL, "encoder_resolution": 1e-5, "coulomb_friction": 0.004}
    r = _post(client, "/v1/analysis/stability", {"device": dev, "controller": {"stiffness": 500}, "verify": True})
    assert r.status_code == 200, r.text
    v = r.json()["nonlinear"]["verification"]
    assert v["verdict"] == "confirmed", v
    assert v["chatter_probe"]["mode"] == "none" and v["instability_probe"]["mode"] == "none"
    assert v["chatter_probe"]["net_energy"] <= 0.0
    assert v["measured_state"] == "settled"


def test_passive_with_quantization_caps_the_designed_stiffness(client):
    dev = {**SMALL, "encoder_resolution": 1e-5, "coulomb_friction": 0.004}
    req = {"passivity": True, "passive_with_quantization": True, "min_gain_margin_db": 0}
    r = _post(client, "/v1/design/stiffness", {"device": dev, "requirements": req})
    assert r.status_code == 200, r.text
    body = r.json()
    # 2f_c/q = 800 N/m binds below the linear limits (2b/T = 1000): met as K ≤ cap
    assert body["stiffness"] <= 800.0 and math.isclose(body["stiffness"], 800.0, rel_tol=1e-9)
    assert "passive_with_quantization" in body["active_constraints"]


@pytest.mark.parametrize("device, req, loc", [
    ({**SMALL, "encoder_resolution": 1e-5}, {"passive_with_quantization": True},
     ["body", "requirements", "passive_with_quantization"]),
    (SMALL, {"passivity": True, "passive_with_quantization": True},
     ["body", "requirements", "passive_with_quantization"]),
])
def test_passive_with_quantization_refusals(client, device, req, loc):
    r = _post(client, "/v1/design/stiffness", {"device": device, "requirements": req})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == loc, r.text


def test_without_friction_no_quantised_wall_is_passive(client):
    dev = {**SMALL, "encoder_resolution": 1e-5}
    r = _post(client, "/v1/design/stiffness", {"device": dev, "requirements": {"passivity": True,
                                                                               "passive_with_quantization": True}})
    assert r.status_code == 200 and r.json()["status"] == "infeasible"


def test_without_a_wall_only_the_limit_is_answered(client):
    dev = {**SMALL, "encoder_resolution": 1e-5, "coulomb_friction": 0.004}
    nl = _post(client, "/v1/analysis/stability", {"device": dev}).json()["nonlinear"]
    assert nl["regime"] is None and nl["limit_cycle"]["exists"] is False
    assert math.isclose(nl["passive_stiffness_limit"], 800.0, rel_tol=1e-12)


def test_presets_list_no_issue31_nulls(client):
    body = client.get("/v1/presets").json()
    assert all("encoder_resolution" not in d and "travel" not in d for d in body.values())


def test_the_velocity_filter_is_in_the_nonlinear_block(client):
    dev = {**SMALL, "encoder_resolution": 1e-5, "coulomb_friction": 0.004}
    ctl = {"stiffness": 300, "damping": 0.2, "velocity_filter": {"kind": "low_pass", "cutoff_hz": 50}}
    r = _post(client, "/v1/analysis/stability", {"device": dev, "controller": ctl})
    assert r.status_code == 200, r.text
    nl = r.json()["nonlinear"]
    assert nl["covered"] is False and "velocity filter" in nl["reason"] + nl["source"]
    plain = _post(client, "/v1/analysis/stability", {"device": dev, "controller": {"stiffness": 300, "damping": 0.2}})
    # the filtered wall's passive limit is its own (optim.stability.passivity_rendered), not the backward difference's
    assert nl["sampling_term"] != plain.json()["nonlinear"]["sampling_term"]
